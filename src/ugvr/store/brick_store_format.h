// The on-disk layout of a brick store (.ugvr), as structs: these are the source of truth for every byte offset, the
// writer and reader (store/brick_store.cpp) and the block codec (store/brick_codec.cpp) copy records to and from them
// and use no offset of their own. docs/brick-store.md has the same layout as tables, with the reasons; what the values
// mean for the octree (coordinates, child order, ranges) is in store/brick_store.h, how a block's payload is coded in
// store/brick_codec.h.
//
//   [HeaderRecord] [TfErrorHeaderRecord] [BoundaryHeaderRecord] [CellsHeaderRecord] [FieldRecord, name, padding] × F
//                                                        the header, header_size bytes (version 2 stores have none
//                                                        of the three middle records, version 3 only the first,
//                                                        version 4 the first two)
//   [BlockRecord, payload] × (F per node with a brick)  the blocks, in the order the writer appended them, and
//   [cell block]                                        the nodes' cell blocks among them, if any (version 5)
//   [TfErrorEntry × F] × N                              the transfer-function error table, if any (version 3)
//   [BoundaryNodeEntry × N, uint32 × R, BoundaryTriangleRecord × T]  the boundary faces, if any (version 4)
//   [CellBlockRecord × N]                               where each node's cells are, if any (version 5)
//   [steps section]                                     the time steps after the first, if any (version 6)
//   [provenance text, crc32]                            if any
//   [NodeRecord, NodeFieldRecord × F] × N               the node table, in node id order, ending the file
//
// Little-endian, written and read by copying a record's bytes (std::memcpy), so the host must be little-endian too
// (asserted below; a big-endian port would byte-swap in read_record / write_record). No struct has padding inside
// (the offsetof asserts leave no gap, and each ends at its last member), so a copied record has no indeterminate
// bytes, and every member is at a multiple of its own size, so the structs need no packing; FieldRecord alone is
// packed, because the name follows its 20 bytes directly. Reserved members are written as 0 and not checked.
// Changing any of this changes the format: bump kBrickStoreVersion, and the reader must still refuse old files
// clearly.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace ugvr {

static_assert(std::endian::native == std::endian::little, "the brick store is read and written as little-endian");

// Version 3 adds the transfer-function error table (TfErrorHeaderRecord, TfErrorEntry); version 2 stores, which
// lack it, are still read (a renderer then falls back to the stored error_max). Version 4 adds the mesh's boundary
// faces per node (BoundaryHeaderRecord); version 2 and 3 stores, which lack them, are still read (the renderer then
// takes the boundary from the validity stencil alone, as before). Version 5 adds the cells of the nodes that keep them
// (CellsHeaderRecord: the [hybrid] issue's exact cells per node); version 2 to 4 stores have none. Version 6 adds time
// steps (StepsHeaderRecord: one store for every step of a series with static geometry, each step after the first adding
// its own bricks, node ranges, errors and transfer-function errors); version 2 to 5 stores hold one step.
inline constexpr uint32_t kBrickStoreVersion = 6;
inline constexpr uint32_t kOldestReadableBrickStoreVersion = 2;

namespace store_format {

// "\x89UBS\r\n\x1a\n": a binary tag that a text-mode (newline-translating) or 7-bit transfer, or a truncation at an
// EOF character, breaks (the PNG trick).
inline constexpr uint8_t kMagic[8] = {0x89, 'U', 'B', 'S', '\r', '\n', 0x1a, '\n'};

// The file's first bytes; the field records follow it.
struct HeaderRecord {
  uint8_t magic[8] = {};           //   0  kMagic; all zeros in the temporary file of a build not yet committed
  uint32_t version = 0;            //   8  format version, kBrickStoreVersion (version 1 quantized each brick on a
                                   //      grid of its own and is refused)
  uint32_t header_size = 0;        //  12  bytes of this record and the field records, a multiple of 8; the
                                   //      blocks start here
  uint32_t resolution = 0;         //  16  brick resolution R, samples per axis, 2..512
  uint32_t field_count = 0;        //  20  F, 1..1024: the field records, and the entries of each node record
  uint32_t node_record_size = 0;   //  24  bytes per node: sizeof(NodeRecord) + F × sizeof(NodeFieldRecord)
  uint8_t samples = 0;             //  28  SampleEncoding the writer was set to: 1 quant16, 2 float32 (each block
                                   //      states its own in its BlockRecord; these five are the writer's settings)
  uint8_t predictor = 0;           //  29  Predictor: 0 none, 1 delta-x, 2 lorenzo
  uint8_t codec = 0;               //  30  BrickCodec: 0 stored, 1 lz4, 2 zstd
  uint8_t shuffle = 0;             //  31  byte shuffle of the residuals, 0 or 1
  int32_t codec_level = 0;         //  32  BrickEncoding::level as given (<= 0: the codec's default)
  uint32_t provenance_size = 0;    //  36  bytes of the provenance record, which ends where the node table starts:
                                   //      JSON text (how the store was built: ugvr version, input, options),
                                   //      then the crc32 (zlib) of that text; 0: none (stores before it, raw
                                   //      writers)
  double tolerance = 0;            //  40  quant16 samples lie within tolerance × (field max - min) of the exact
                                   //      ones; 0 for float32 (exact) and for "each brick's own range over 65535
                                   //      codes"
  double root_lo[3] = {};          //  48  the octree's root cell, the box node 0 covers: lower corner x, y, z
  double root_hi[3] = {};          //  72  its upper corner
  double data_lo[3] = {};          //  96  the dataset's bounds (inside the root cell): lower corner
  double data_hi[3] = {};          // 120  upper corner
  uint64_t node_count = 0;         // 144  N >= 1
  uint64_t node_table_offset = 0;  // 152  file offset of node 0's record; the table runs to the end of the file
  uint64_t file_size = 0;          // 160  node_table_offset + N × node_record_size: shows a truncated copy
  uint32_t node_table_crc = 0;     // 168  crc32 (zlib) of the whole node table
  uint32_t header_crc = 0;         // 172  crc32 (zlib) of bytes [0, header_size), these 4 bytes read as 0
};

// Version 3: follows the HeaderRecord (so the field records start at byte 200, not 176 as in version 2); covered by
// header_crc. Where the transfer-function error table lies (LaMar et al., "Efficient error calculation for
// multiresolution texture-based volume visualization", ch. 7): per node and field a TfErrorEntry, node-major, F entries
// per node.
struct TfErrorHeaderRecord {
  uint64_t table_offset = 0;  //  0  file offset of node 0's first entry; 0: the store has no table
  uint64_t table_size = 0;    //  8  bytes: node_count × field_count × entry_size (0 without a table)
  uint32_t entry_size = 0;    // 16  sizeof(TfErrorEntry), 44 (0 without a table)
  uint32_t table_crc = 0;     // 20  crc32 (zlib) of the table's bytes
};

// Groups of a TfErrorEntry.
inline constexpr int kTfErrorGroups = 8;

// How far a node's brick is from the finest data under it, kept so that the error under any transfer function can be
// computed later without the data (render/lod/tf_error.h). The builder pairs each point where it measures error_max
// (octree/node_error.h) with the node's trilinear value there (coarse c, finest f), sorts the pairs by f into
// kTfErrorGroups groups of about equal count, and keeps per group the range of f and the rms of (c - f). Values are
// 16-bit codes over the field's global range [min, max] (FieldRecord): value = min + code / 65535 × (max - min).
struct TfErrorEntry {
  uint16_t bound[kTfErrorGroups + 1] = {};  //  0  group g holds the pairs with f in [bound[g], bound[g + 1]]:
                                            //     ascending codes, rounded outward (bound[0] down, the others up)
  uint16_t spread[kTfErrorGroups] = {};     // 18  per group, rms |c - f| in codes, rounded up (0: exact)
  uint8_t weight[kTfErrorGroups] = {};      // 34  per group, its share of the pairs in 1/255 (all 0: no pair was
                                            //     measured; the error is then unknown)
  uint16_t reserved = 0;                    // 42  0
};

// Version 4: follows the TfErrorHeaderRecord (the field records start at byte 240); covered by header_crc. Where the
// mesh's boundary faces lie, per node (Muigg 2008, section 5.1.2: the boundary of a resampled brick taken from the
// mesh, so that it is the same at every level). One section, three arrays back to back:
//   BoundaryNodeEntry × (N + V)  per node (id order), then V virtual nodes: each node's triangle references
//   uint32 × R                   triangle indices, each node's run ascending
//   BoundaryTriangleRecord × T   the boundary's triangles, each once
// A node lists every boundary triangle that overlaps its cell (closed box), unless there are more than the builder's
// cap: it then lists none (count kBoundaryOverflow) and its children do: an interior node's children in the tree
// (first 0), a leaf's in 8 virtual nodes from entry `first` (>= N; octant order as for children, a virtual node that
// no triangle reaches lists none), which may be divided again likewise. Nodes the boundary does not cross list none
// (count 0). octree/boundary_faces.h builds it.
struct BoundaryHeaderRecord {
  uint64_t section_offset = 0;   //  0  file offset of node 0's entry; 0: the store has no boundary faces
  uint64_t section_size = 0;     //  8  bytes: (N + V) × 8 + R × 4 + T × 36 (0 without)
  uint32_t triangle_count = 0;   // 16  T
  uint32_t reference_count = 0;  // 20  R, the sum of the listed counts
  uint32_t max_per_node = 0;     // 24  the largest count a node lists (the builder's cap, or more where a virtual
                                 //     node at the deepest division still has more)
  uint32_t section_crc = 0;      // 28  crc32 (zlib) of the section's bytes
  uint32_t virtual_nodes = 0;    // 32  V, a multiple of 8
  uint32_t reserved = 0;         // 36  0
};

// A node's run of references: triangles refs[first .. first + count). count kBoundaryOverflow: over the cap, none
// listed; first is 0 (an interior node: see its children) or its first virtual child's entry.
struct BoundaryNodeEntry {
  uint32_t first = 0;  // 0
  uint32_t count = 0;  // 4
};
inline constexpr uint32_t kBoundaryOverflow = 0xFFFFFFFFu;

// One triangle of the mesh boundary, corners in the root cell's normalised coordinates ((x - root.lo) / root.size(),
// float32), ordered so that the right-hand normal (p1 - p0) × (p2 - p0) points out of the mesh (the cells are
// positively oriented, README "How cells are brought in"). Quadrilateral faces are split along the diagonal through
// their lexicographically smallest corner (the exact engine's rule, render/exact/walk_mesh.h).
struct BoundaryTriangleRecord {
  float p[9] = {};  // 0  x0 y0 z0 x1 y1 z1 x2 y2 z2
};

// Version 5: follows the BoundaryHeaderRecord (the field records start at byte 272); covered by header_crc. Where the
// cells of the nodes that keep them lie (Muigg 2007: exact cells where they matter, resampled bricks elsewhere; the
// builder keeps them for the leaves, octree/node_cells.h): an index of one CellBlockRecord per node, in node id order,
// written with the node table's other sections; the blocks themselves are appended among the brick blocks as the
// builder makes them.
struct CellsHeaderRecord {
  uint64_t index_offset = 0;  //  0  file offset of node 0's CellBlockRecord; 0: the store keeps no cells
  uint64_t index_size = 0;    //  8  bytes: N × 16 (0 without)
  uint64_t total_cells = 0;   // 16  the blocks' cell counts summed (a cell in several nodes counts once in each)
  uint32_t index_crc = 0;     // 24  crc32 (zlib) of the index's bytes
  uint32_t block_count = 0;   // 28  nodes with a cell block
};

// Where one node's cells are. A block is one zstd frame (whatever the store's brick codec) whose content is a
// CellBlockHeader and then, back to back, with no padding:
//   uint64 × C            each cell's id in the input mesh (ascending)
//   uint8 × C             each cell's type (VTK id: 10 tetra, 12 hexahedron, 13 wedge, 14 pyramid), then zeros to a
//                         multiple of 4 bytes
//   uint32 × K            the cells' vertices, as indices into this block's points, each cell's in its type's order
//                         (K = the sum of the types' vertex counts)
//   uint32 × S            per cell face, in cell_info(type).faces order (S = the sum of the face counts): the cell
//                         across as an index into this block's cells, kCellAcrossBoundary (the face is on the mesh's
//                         boundary) or kCellAcrossOutside (the cell across is not in this node)
//   float32 × 3V          the points' positions (x, y, z), world coordinates as in the input
//   float32 × ...         per store field in field order: V values for a vertex field, C for a cell field
struct CellBlockRecord {
  uint64_t offset = 0;  //  0  file offset of the block; 0: the node keeps no cells
  uint32_t size = 0;    //  8  bytes of the block (compressed)
  uint32_t crc = 0;     // 12  crc32 (zlib) of the block's bytes
};
struct CellBlockHeader {
  uint32_t cell_count = 0;         //  0  C >= 1
  uint32_t point_count = 0;        //  4  V >= 1
  uint32_t vertex_references = 0;  //  8  K
  uint32_t face_slots = 0;         // 12  S
  uint32_t field_count = 0;        // 16  the store's F
  uint32_t reserved = 0;           // 20  0
};
inline constexpr uint32_t kCellAcrossBoundary = 0xFFFFFFFFu;
inline constexpr uint32_t kCellAcrossOutside = 0xFFFFFFFEu;

// Version 6: follows the CellsHeaderRecord (the field records start at byte 304); covered by header_crc. A store of
// several time steps (`ugvr build SERIES --time ...`, static geometry): the octree, the validity masks (so each node's
// valid fraction and whether it has a brick), the boundary faces and the cells are shared; step 0 is what the node
// table and the transfer-function error table hold, as in a store of one step, and the section adds the others. Its
// arrays, back to back (S steps, N nodes, F fields):
//   float64 × S                                 each step's time (finite, not decreasing)
//   StepFieldRange × F × S                      each step's range per field (step-major): what its bricks are
//                                               quantized over (origin min, step 2 × tolerance × (max - min)) and what
//                                               a renderer normalises them with; inside the FieldRecord's range, which
//                                               is the union over the steps
//   (StepNodeRecord, NodeFieldRecord × F) × N × (S - 1)
//                                               steps 1 .. S-1: per node (id order) where its blocks are and its
//                                               ranges, errors, block sizes and checksums for that step, with the
//                                               node table's meaning; brick_offset is 0 exactly where the node table's
//                                               is (the mask is shared)
//   TfErrorEntry × F × N × (S - 1)              steps 1 .. S-1: the transfer-function error entries (only with
//                                               kStepsHaveTfErrors), codes over the FieldRecord's range as in the
//                                               node table's (the union of the steps')
//   CellBlockRecord × N × (S - 1)               steps 1 .. S-1: per node (id order) where its cells' values for that
//                                               step are (only with kStepsHaveCells, which a store keeping cells and
//                                               more than one step must have); offset 0 exactly where the cell index's
//                                               is. A values block is one zstd frame holding, per store field in field
//                                               order, float32 × V (vertex field) or × C (cell field) in the node's
//                                               cell block's point / cell order: the block's last array, for that
//                                               step. The cell blocks themselves (geometry, and step 0's values) are
//                                               shared.
// The blocks of every step (and the values blocks) lie among the brick blocks, appended step after step.
struct StepsHeaderRecord {
  uint64_t section_offset = 0;  //  0  file offset of the section (the first time); 0: the store holds one step
  uint64_t section_size = 0;    //  8  bytes: 8 S + 16 F S + (S - 1) N (8 + 24 F) [+ (S - 1) N F 44]
                                //     [+ (S - 1) N 16] (0 without)
  uint32_t step_count = 0;      // 16  S >= 1 (0 without a section)
  uint32_t section_crc = 0;     // 20  crc32 (zlib) of the section's bytes
  uint32_t flags = 0;           // 24  kStepsHaveTfErrors | kStepsHaveCells
  uint32_t reserved = 0;        // 28  0
};
inline constexpr uint32_t kStepsHaveTfErrors = 1;  // the section holds the later steps' transfer-function error tables
inline constexpr uint32_t kStepsHaveCells = 2;     // the section holds the later steps' cell values blocks' records
// A step's range of one field.
struct StepFieldRange {
  double min = 0;  // 0
  double max = 0;  // 8
};
// Where a node's blocks are in a step after the first; its F NodeFieldRecords follow.
struct StepNodeRecord {
  uint64_t brick_offset = 0;  // 0  file offset of the node's first block for this step (0: no brick)
};

// Bytes of the records before the field records, by format version.
constexpr uint32_t header_records_size(uint32_t version) {
  return uint32_t(version >= 6 ? 176 + sizeof(TfErrorHeaderRecord) + sizeof(BoundaryHeaderRecord) +
                                     sizeof(CellsHeaderRecord) + sizeof(StepsHeaderRecord)
                  : version >= 5
                      ? 176 + sizeof(TfErrorHeaderRecord) + sizeof(BoundaryHeaderRecord) + sizeof(CellsHeaderRecord)
                  : version >= 4 ? 176 + sizeof(TfErrorHeaderRecord) + sizeof(BoundaryHeaderRecord)
                  : version >= 3 ? 176 + sizeof(TfErrorHeaderRecord)
                                 : 176);
}

// One per field, in field order, after the header record; each followed by its name (name_length bytes, UTF-8, not
// terminated) and zeros up to a multiple of 8 bytes (field_record_size).
struct [[gnu::packed]] FieldRecord {
  double min = 0;            //  0  global minimum of the field over the dataset: what tolerances are relative to,
                             //     and the origin of the field's quant16 grid
  double max = 0;            //  8  global maximum
  uint8_t association = 0;   // 16  where the source mesh had it: 0 vertex, 1 cell (Association)
  uint8_t reserved = 0;      // 17  0
  uint16_t name_length = 0;  // 18  L, 1..1024; the name follows at byte 20
};

// One per node, in node id order, from node_table_offset; followed by field_count NodeFieldRecords.
struct NodeRecord {
  uint64_t parent = 0;        //  0  parent's id; kNoNode (2^64 - 1) for the root, node 0
  uint64_t first_child = 0;   //  8  id of the first child, the others following in octant order; kNoNode: a leaf
  uint64_t brick_offset = 0;  // 16  file offset of the node's first block (field 0), the others back to back;
                              //     0: the node's cell holds no data and it has no brick
  uint32_t i = 0;             // 24  integer coordinates of the node's cell at its level, each < 2^level
  uint32_t j = 0;             // 28
  uint32_t k = 0;             // 32
  uint8_t level = 0;          // 36  0..31, root 0
  uint8_t child_mask = 0;     // 37  bit o set: the child in octant o = dx | dy << 1 | dz << 2 exists
  uint16_t reserved0 = 0;     // 38  0
  float valid_fraction = 0;   // 40  valid samples / R³ in the node's brick (0 exactly when there is no brick)
  uint32_t reserved1 = 0;     // 44  0
};

// Per field of a node, in field order, after its NodeRecord.
struct NodeFieldRecord {
  float min = 0;            //  0  smallest sample of the node's brick and of all its descendants', over the samples
                            //     as given and as decoded (quant16 may decode step / 2 beyond); +inf: no data
  float max = 0;            //  4  largest, likewise; -inf: no data. Culling a node by value range culls its subtree
  float error_max = 0;      //  8  max |sample - finest data| over the node's cell, in field units (the builder's)
  float error_rms = 0;      // 12  root mean square of the same
  uint32_t block_size = 0;  // 16  bytes of this field's block (0: no brick); it starts at brick_offset plus the
                            //     sizes of the fields before it
  uint32_t block_crc = 0;   // 20  crc32 (zlib) of the block's bytes
};

// The first bytes of every block (one field of one node's brick); the payload, compressed by `codec`, follows.
struct BlockRecord {
  uint8_t samples = 0;    //  0  SampleEncoding: 1 quant16, 2 float32
  uint8_t predictor = 0;  //  1  Predictor: 0 none, 1 delta-x, 2 lorenzo
  uint8_t codec = 0;      //  2  BrickCodec: 0 stored, 1 lz4, 2 zstd (stored when compressing would not shrink it)
  uint8_t flags = 0;      //  3  kBlockFlagMask | kBlockFlagShuffled
  uint32_t raw_size = 0;  //  4  bytes of the payload once decompressed
  uint32_t valid = 0;     //  8  valid samples, 1..R³ (R³ without a mask)
  float lo = 0;           // 12  smallest valid sample, as given to the encoder
  float hi = 0;           // 16  largest valid sample
  uint32_t qmax = 0;      // 20  quant16: the largest code, 0..65535; float32: 0
  int64_t base = 0;       // 24  quant16: grid index of code 0, -2^52 <= base, base + qmax <= 2^52; float32: 0
  double origin = 0;      // 32  quant16: value of grid index 0 (a store writes the field's min); float32: 0
  double step = 0;        // 40  quant16: grid step, > 0 unless qmax = 0 (a store writes 2 × tolerance × field
                          //     range); float32: 0
};

inline constexpr uint8_t kBlockFlagMask = 1;      // the payload starts with the validity mask, else all is valid
inline constexpr uint8_t kBlockFlagShuffled = 2;  // the residuals are split into byte planes

// Bytes a field record takes with its name and padding.
constexpr uint32_t field_record_size(uint64_t name_length) {
  return uint32_t((sizeof(FieldRecord) + name_length + 7) / 8 * 8);
}
// Bytes of one node's record with its per-field entries.
constexpr uint32_t node_record_size(uint64_t field_count) {
  return uint32_t(sizeof(NodeRecord) + sizeof(NodeFieldRecord) * field_count);
}

// A record from the bytes at p, and back. memcpy: p need not be aligned.
template <class Record>
Record read_record(const void* p) {
  static_assert(std::is_trivially_copyable_v<Record>);
  Record r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
template <class Record>
void write_record(void* p, const Record& r) {
  static_assert(std::is_trivially_copyable_v<Record>);
  std::memcpy(p, &r, sizeof r);
}

// The layout, checked member by member: reordering, resizing or inserting a member fails to compile here (and
// tests/test_brick_store_format.cpp finds each value at its documented offset in a written file).
#define UGVR_RECORD_AT(Record, member, offset) static_assert(offsetof(Record, member) == (offset), #Record "::" #member)

static_assert(std::is_trivially_copyable_v<HeaderRecord> && std::is_standard_layout_v<HeaderRecord>);
static_assert(sizeof(HeaderRecord) == 176);
UGVR_RECORD_AT(HeaderRecord, magic, 0);
UGVR_RECORD_AT(HeaderRecord, version, 8);
UGVR_RECORD_AT(HeaderRecord, header_size, 12);
UGVR_RECORD_AT(HeaderRecord, resolution, 16);
UGVR_RECORD_AT(HeaderRecord, field_count, 20);
UGVR_RECORD_AT(HeaderRecord, node_record_size, 24);
UGVR_RECORD_AT(HeaderRecord, samples, 28);
UGVR_RECORD_AT(HeaderRecord, predictor, 29);
UGVR_RECORD_AT(HeaderRecord, codec, 30);
UGVR_RECORD_AT(HeaderRecord, shuffle, 31);
UGVR_RECORD_AT(HeaderRecord, codec_level, 32);
UGVR_RECORD_AT(HeaderRecord, provenance_size, 36);
UGVR_RECORD_AT(HeaderRecord, tolerance, 40);
UGVR_RECORD_AT(HeaderRecord, root_lo, 48);
UGVR_RECORD_AT(HeaderRecord, root_hi, 72);
UGVR_RECORD_AT(HeaderRecord, data_lo, 96);
UGVR_RECORD_AT(HeaderRecord, data_hi, 120);
UGVR_RECORD_AT(HeaderRecord, node_count, 144);
UGVR_RECORD_AT(HeaderRecord, node_table_offset, 152);
UGVR_RECORD_AT(HeaderRecord, file_size, 160);
UGVR_RECORD_AT(HeaderRecord, node_table_crc, 168);
UGVR_RECORD_AT(HeaderRecord, header_crc, 172);
static_assert(offsetof(HeaderRecord, header_crc) + 4 == sizeof(HeaderRecord));
static_assert(sizeof(HeaderRecord) % 8 == 0, "the field records start 8-byte aligned");

static_assert(std::is_trivially_copyable_v<FieldRecord> && std::is_standard_layout_v<FieldRecord>);
static_assert(sizeof(FieldRecord) == 20);
UGVR_RECORD_AT(FieldRecord, min, 0);
UGVR_RECORD_AT(FieldRecord, max, 8);
UGVR_RECORD_AT(FieldRecord, association, 16);
UGVR_RECORD_AT(FieldRecord, reserved, 17);
UGVR_RECORD_AT(FieldRecord, name_length, 18);

static_assert(std::is_trivially_copyable_v<NodeRecord> && std::is_standard_layout_v<NodeRecord>);
static_assert(sizeof(NodeRecord) == 48);
UGVR_RECORD_AT(NodeRecord, parent, 0);
UGVR_RECORD_AT(NodeRecord, first_child, 8);
UGVR_RECORD_AT(NodeRecord, brick_offset, 16);
UGVR_RECORD_AT(NodeRecord, i, 24);
UGVR_RECORD_AT(NodeRecord, j, 28);
UGVR_RECORD_AT(NodeRecord, k, 32);
UGVR_RECORD_AT(NodeRecord, level, 36);
UGVR_RECORD_AT(NodeRecord, child_mask, 37);
UGVR_RECORD_AT(NodeRecord, reserved0, 38);
UGVR_RECORD_AT(NodeRecord, valid_fraction, 40);
UGVR_RECORD_AT(NodeRecord, reserved1, 44);
static_assert(offsetof(NodeRecord, reserved1) + 4 == sizeof(NodeRecord));

static_assert(std::is_trivially_copyable_v<NodeFieldRecord> && std::is_standard_layout_v<NodeFieldRecord>);
static_assert(sizeof(NodeFieldRecord) == 24);
UGVR_RECORD_AT(NodeFieldRecord, min, 0);
UGVR_RECORD_AT(NodeFieldRecord, max, 4);
UGVR_RECORD_AT(NodeFieldRecord, error_max, 8);
UGVR_RECORD_AT(NodeFieldRecord, error_rms, 12);
UGVR_RECORD_AT(NodeFieldRecord, block_size, 16);
UGVR_RECORD_AT(NodeFieldRecord, block_crc, 20);
static_assert(offsetof(NodeFieldRecord, block_crc) + 4 == sizeof(NodeFieldRecord));

static_assert(std::is_trivially_copyable_v<BlockRecord> && std::is_standard_layout_v<BlockRecord>);
static_assert(sizeof(BlockRecord) == 48);
UGVR_RECORD_AT(BlockRecord, samples, 0);
UGVR_RECORD_AT(BlockRecord, predictor, 1);
UGVR_RECORD_AT(BlockRecord, codec, 2);
UGVR_RECORD_AT(BlockRecord, flags, 3);
UGVR_RECORD_AT(BlockRecord, raw_size, 4);
UGVR_RECORD_AT(BlockRecord, valid, 8);
UGVR_RECORD_AT(BlockRecord, lo, 12);
UGVR_RECORD_AT(BlockRecord, hi, 16);
UGVR_RECORD_AT(BlockRecord, qmax, 20);
UGVR_RECORD_AT(BlockRecord, base, 24);
UGVR_RECORD_AT(BlockRecord, origin, 32);
UGVR_RECORD_AT(BlockRecord, step, 40);
static_assert(offsetof(BlockRecord, step) + 8 == sizeof(BlockRecord));

static_assert(std::is_trivially_copyable_v<TfErrorHeaderRecord> && std::is_standard_layout_v<TfErrorHeaderRecord>);
static_assert(sizeof(TfErrorHeaderRecord) == 24);
UGVR_RECORD_AT(TfErrorHeaderRecord, table_offset, 0);
UGVR_RECORD_AT(TfErrorHeaderRecord, table_size, 8);
UGVR_RECORD_AT(TfErrorHeaderRecord, entry_size, 16);
UGVR_RECORD_AT(TfErrorHeaderRecord, table_crc, 20);
static_assert(header_records_size(3) % 8 == 0 && header_records_size(2) == sizeof(HeaderRecord));

static_assert(std::is_trivially_copyable_v<BoundaryHeaderRecord> && sizeof(BoundaryHeaderRecord) == 40);
UGVR_RECORD_AT(BoundaryHeaderRecord, section_offset, 0);
UGVR_RECORD_AT(BoundaryHeaderRecord, section_size, 8);
UGVR_RECORD_AT(BoundaryHeaderRecord, triangle_count, 16);
UGVR_RECORD_AT(BoundaryHeaderRecord, reference_count, 20);
UGVR_RECORD_AT(BoundaryHeaderRecord, max_per_node, 24);
UGVR_RECORD_AT(BoundaryHeaderRecord, section_crc, 28);
UGVR_RECORD_AT(BoundaryHeaderRecord, virtual_nodes, 32);
UGVR_RECORD_AT(BoundaryHeaderRecord, reserved, 36);
static_assert(header_records_size(4) == 240 && header_records_size(4) % 8 == 0);
static_assert(sizeof(BoundaryNodeEntry) == 8 && sizeof(BoundaryTriangleRecord) == 36);
static_assert(std::is_trivially_copyable_v<BoundaryTriangleRecord> && std::is_trivially_copyable_v<BoundaryNodeEntry>);

static_assert(std::is_trivially_copyable_v<CellsHeaderRecord> && sizeof(CellsHeaderRecord) == 32);
UGVR_RECORD_AT(CellsHeaderRecord, index_offset, 0);
UGVR_RECORD_AT(CellsHeaderRecord, index_size, 8);
UGVR_RECORD_AT(CellsHeaderRecord, total_cells, 16);
UGVR_RECORD_AT(CellsHeaderRecord, index_crc, 24);
UGVR_RECORD_AT(CellsHeaderRecord, block_count, 28);
static_assert(header_records_size(5) == 272);
static_assert(std::is_trivially_copyable_v<CellBlockRecord> && sizeof(CellBlockRecord) == 16);
UGVR_RECORD_AT(CellBlockRecord, offset, 0);
UGVR_RECORD_AT(CellBlockRecord, size, 8);
UGVR_RECORD_AT(CellBlockRecord, crc, 12);
static_assert(std::is_trivially_copyable_v<CellBlockHeader> && sizeof(CellBlockHeader) == 24);
UGVR_RECORD_AT(CellBlockHeader, cell_count, 0);
UGVR_RECORD_AT(CellBlockHeader, point_count, 4);
UGVR_RECORD_AT(CellBlockHeader, vertex_references, 8);
UGVR_RECORD_AT(CellBlockHeader, face_slots, 12);
UGVR_RECORD_AT(CellBlockHeader, field_count, 16);
UGVR_RECORD_AT(CellBlockHeader, reserved, 20);

static_assert(std::is_trivially_copyable_v<StepsHeaderRecord> && sizeof(StepsHeaderRecord) == 32);
UGVR_RECORD_AT(StepsHeaderRecord, section_offset, 0);
UGVR_RECORD_AT(StepsHeaderRecord, section_size, 8);
UGVR_RECORD_AT(StepsHeaderRecord, step_count, 16);
UGVR_RECORD_AT(StepsHeaderRecord, section_crc, 20);
UGVR_RECORD_AT(StepsHeaderRecord, flags, 24);
UGVR_RECORD_AT(StepsHeaderRecord, reserved, 28);
static_assert(header_records_size(6) == 304);
static_assert(std::is_trivially_copyable_v<StepFieldRange> && sizeof(StepFieldRange) == 16);
UGVR_RECORD_AT(StepFieldRange, min, 0);
UGVR_RECORD_AT(StepFieldRange, max, 8);
static_assert(std::is_trivially_copyable_v<StepNodeRecord> && sizeof(StepNodeRecord) == 8);
UGVR_RECORD_AT(StepNodeRecord, brick_offset, 0);

static_assert(std::is_trivially_copyable_v<TfErrorEntry> && std::is_standard_layout_v<TfErrorEntry>);
static_assert(sizeof(TfErrorEntry) == 44);
UGVR_RECORD_AT(TfErrorEntry, bound, 0);
UGVR_RECORD_AT(TfErrorEntry, spread, 18);
UGVR_RECORD_AT(TfErrorEntry, weight, 34);
UGVR_RECORD_AT(TfErrorEntry, reserved, 42);

#undef UGVR_RECORD_AT

}  // namespace store_format
}  // namespace ugvr
