// The brick store: one file holding a sparse, adaptive octree of fixed-resolution bricks (Leven et al. 2002, sections
// 3-4) over a dataset, for one or more fields. Written once by the builder (streaming: bricks in any order from any
// number of threads, the node table at the end), read by the renderers and their caches (any brick by id, one pread,
// from any number of threads). docs/brick-store.md explains the choices and gives the measurements.
//
// Octree conventions. Node 0 is the root and covers `root` (a box; the builder usually makes it a cube). A node at
// level L with integer coordinates (i, j, k), 0 <= i, j, k < 2^L, covers the cell
//   lo = root.lo + (i, j, k) · root.size() / 2^L,  hi = lo + root.size() / 2^L,
// and its brick holds R³ samples at lo + (x, y, z) / (R - 1) · (hi - lo), x, y, z in [0, R): the border samples lie
// on the cell faces, so neighbouring bricks of one level share them (paper, figure 3). A node's children are stored
// contiguously from first_child, in increasing octant order, octant o = dx | dy << 1 | dz << 2 (child coordinates
// 2i + dx, ...), bit o of child_mask telling whether that child exists; children always come after their parent.
// A node whose cell holds no data at all has no brick (brick_offset 0, every block size 0, valid_fraction 0).
//
// File layout: [header record, field records] [blocks, appended as built] [node table], little-endian. A node's
// brick is its F blocks back to back (field 0 first) from brick_offset, each self-describing and compressed on its
// own (store/brick_codec.h), with its size and crc32 in the node's record. The structs of store/brick_store_format.h
// define every byte, each member with its offset and meaning; docs/brick-store.md has the same as tables, with the
// reasons.
//
// With tolerance > 0, every Quant16 block of field f lies on one grid, origin = field min, step = 2 × tolerance ×
// (field max - field min) (both stored in each block), so samples that neighbouring bricks share decode to
// bit-identical values (the renderer's seams stay closed). Only a brick whose values exceed the field's declared range
// so far that 16 bits cannot cover it on that grid gets a grid of its own. With tolerance 0 (or a field of range 0)
// each brick has its own grid, and shared samples may differ by up to a step of either brick.
//
// Atomicity: the writer works on a temporary next to the path (core/file.h) whose header stays all zeros until
// commit() writes it, then renames; an interrupted or failed build leaves no file at the path, and a temporary left
// by a killed process has no magic. The reader checks magic, version, sizes against the file size, both checksums
// and the tree's structure at open, and each block's checksum before decoding it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/field.h"
#include "ugvr/store/brick_codec.h"
#include "ugvr/store/brick_store_format.h"

namespace ugvr {

inline constexpr uint64_t kNoNode = ~uint64_t(0);
inline constexpr int kMaxOctreeLevel = 31;
inline constexpr uint32_t kMaxStoreFields = 1024;
// The finest tolerance 16 bits can honour for any brick: a brick spanning the whole field range needs all 65536 codes.
inline constexpr double kQuant16Tolerance = 1.0 / 131070.0;

struct BrickStoreField {
  std::string name;
  Association association = Association::Vertex;
  double min = 0, max = 0;  // global range over the dataset
};

// What a store holds besides its nodes. The writer takes it; the reader gives it back as read from the header.
struct BrickStoreLayout {
  uint32_t resolution = 32;
  std::vector<BrickStoreField> fields;
  Bounds root;  // the octree's root cell
  Bounds data;  // the dataset's bounds
  BrickEncoding encoding;
  // Quant16: max sample error relative to each field's range, >= kQuant16Tolerance; 0: each brick uses its own
  // range over 65535 codes (more precise in small-range bricks, larger). Ignored (stored 0) for Float32.
  double tolerance = kQuant16Tolerance;
  // How the store was made, as one JSON object (the builder's: ugvr version, input, options); empty: not recorded.
  // Written just before the node table (store_format::HeaderRecord::provenance_size).
  std::string provenance;
  // A store of several time steps (format version 6, store_format::StepsHeaderRecord): each step's time, in order;
  // empty: a store of one step without a time (written as version 5). `fields` then hold the union of the steps'
  // ranges; the writer takes each step's own with begin_step().
  std::vector<double> times;
};

// The tree as the builder describes it.
struct OctreeNode {
  uint64_t parent = kNoNode;
  uint64_t first_child = kNoNode;  // children at first_child + (rank of their octant among child_mask's bits)
  uint32_t i = 0, j = 0, k = 0;
  uint8_t level = 0;
  uint8_t child_mask = 0;  // bit o: the child in octant o = dx | dy << 1 | dz << 2 exists

  bool is_leaf() const { return child_mask == 0; }
  // The child in `octant`, or kNoNode.
  uint64_t child(int octant) const;
};

// A node as stored: the writer adds what it measured.
struct BrickNode : OctreeNode {
  float valid_fraction = 0;
  uint64_t brick_offset = 0;  // 0: no brick

  bool has_brick() const { return brick_offset != 0; }
};

// The builder's error figures for one field of one node, in the field's units.
struct FieldError {
  float max = 0, rms = 0;
};

struct FieldStats {
  // Conservative over the subtree, for the samples as given and as decoded; +inf / -inf where it has no data.
  float min = 0, max = 0;
  float error_max = 0, error_rms = 0;
};

// Where one block lies.
struct BlockRef {
  uint64_t offset = 0;
  uint32_t size = 0;
  uint32_t crc32 = 0;
};

// The cell a node covers.
Bounds node_bounds(const Bounds& root, const OctreeNode& node);

// The mesh's boundary faces per node (format version 4, store_format::BoundaryHeaderRecord has the layout and the
// rules): nodes[id] is node id's run in refs, refs index triangles. Empty (no nodes): the store has none.
struct StoreBoundary {
  std::vector<store_format::BoundaryNodeEntry> nodes;
  std::vector<uint32_t> refs;
  std::vector<store_format::BoundaryTriangleRecord> triangles;
  uint32_t max_per_node = 0;

  bool empty() const { return nodes.empty(); }
  uint64_t bytes() const {
    return nodes.size() * sizeof(nodes[0]) + refs.size() * 4 + triangles.size() * sizeof(triangles[0]);
  }
};

// The cells a node keeps (format version 5, store_format::CellBlockRecord has the layout): small mesh of its own, the
// cells overlapping the node with their vertices renumbered into `points`, each face saying what lies across it, and
// the store's fields at those points or cells. Built by octree/node_cells.h, for the [hybrid] issue's exact cells.
struct NodeCells {
  std::vector<uint64_t> ids;           // per cell: its id in the input mesh, ascending
  std::vector<CellType> types;         // per cell
  std::vector<uint32_t> connectivity;  // per cell its type's vertex count, indices into points
  std::vector<uint32_t> across;        // per cell face (cell_info(type).faces order): a cell index here,
                                       // store_format::kCellAcrossBoundary or kCellAcrossOutside
  std::vector<Vec3f> points;
  std::vector<float> values;  // per store field in order: points.size() values (vertex field) or ids.size() (cell)

  size_t cell_count() const { return ids.size(); }
  bool operator==(const NodeCells&) const = default;
};

// A node's cell block, encoded (BrickStoreWriter::encode_cells, on any thread) and ready to append.
struct EncodedCells {
  std::vector<std::byte> bytes;  // one zstd frame
  uint32_t crc = 0;
  uint32_t cells = 0;   // 0 for a values block (encode_cell_values)
  uint64_t values = 0;  // the values it holds (every field's)
};

// One node's bricks, encoded (by BrickStoreWriter::encode, on any thread) and ready to append.
struct EncodedBrick {
  std::vector<std::byte> bytes;  // the F blocks back to back; empty: the node has no valid sample, so no brick
  std::vector<uint32_t> sizes, crcs;
  std::vector<float> lo, hi;  // per field: range of the valid samples, exact and decoded
  uint32_t valid = 0;         // valid samples

  bool empty() const { return bytes.empty(); }
};

class BrickStoreWriter {
 public:
  // Creates the temporary file; throws ugvr::Error for an invalid layout.
  BrickStoreWriter(std::string path, BrickStoreLayout layout);
  // Without commit(), removes the temporary: nothing is left at the path.
  ~BrickStoreWriter();
  BrickStoreWriter(const BrickStoreWriter&) = delete;
  BrickStoreWriter& operator=(const BrickStoreWriter&) = delete;

  const BrickStoreLayout& layout() const { return layout_; }

  // Encodes one node's bricks: fields[f] points to R³ samples (x fastest) of field f, mask to R³ bytes (nonzero =
  // data; nullptr = all data). Thread-safe and I/O-free: the expensive part, to run on the builder's threads.
  EncodedBrick encode(std::span<const float* const> fields, const uint8_t* mask) const;
  // Appends node `node`'s bricks at the end of the file. Thread-safe (an internal mutex orders the writes); an empty
  // brick records "no brick". A node gets at most one brick.
  void append(uint64_t node, const EncodedBrick& brick);
  // encode() then append().
  void add_brick(uint64_t node, std::span<const float* const> fields, const uint8_t* mask);

  // Encodes a node's cells (checked against the store's fields). Thread-safe and I/O-free.
  EncodedCells encode_cells(const NodeCells& cells) const;
  // Appends node `node`'s cell block. Thread-safe; a node gets at most one.
  void append_cells(uint64_t node, const EncodedCells& cells);
  // A time store's cells (store_format::kStepsHaveCells): a later step's values of a node's cells, every field's in
  // its cell block's order (as NodeCells::values), encoded as one zstd frame. Thread-safe and I/O-free.
  EncodedCells encode_cell_values(std::span<const float> values) const;
  // Appends them for the step begun (1 or later) to node `node`, whose cell block must be appended already with as
  // many values. Thread-safe; a node gets one per step. commit() refuses a store of several steps in which a node
  // with cells lacks a step's values.
  void append_cell_values(uint64_t node, const EncodedCells& values);

  // Writes the node table and the header, syncs and renames the file into place. `nodes` is the whole tree (node 0
  // the root); `errors` has nodes.size() × F entries, node-major (empty: all zero). Validates the tree and that every
  // appended brick belongs to a node of it; on error nothing is committed and the writer is unusable.
  // `tf_errors` (optional): nodes.size() × F transfer-function error entries, node-major (store_format::TfErrorEntry);
  // empty: the store has no table.
  // `boundary` (optional, may be null or empty): the boundary faces, one entry per node of `nodes`.
  void commit(std::span<const OctreeNode> nodes, std::span<const FieldError> errors = {},
              std::span<const store_format::TfErrorEntry> tf_errors = {}, const StoreBoundary* boundary = nullptr);

  // Bytes of blocks appended so far.
  uint64_t block_bytes() const;

  // Time stores (layout.times not empty): the steps are written in order, each between begin_step(s, ranges) (its
  // fields' ranges, inside the layout's: its bricks are quantized over them) and end_step(errors, tf_errors) (as
  // commit() takes them, for this step); then commit(nodes, {}, {}, boundary). Every step must have a brick exactly
  // where step 0 has one (the geometry, hence each node's mask, is shared). Not thread-safe against encode().
  void begin_step(uint32_t step, std::span<const store_format::StepFieldRange> ranges);
  void end_step(std::span<const FieldError> errors, std::span<const store_format::TfErrorEntry> tf_errors = {});

 private:
  struct Placed {
    uint64_t offset = 0;  // 0: no brick
    uint32_t valid = 0;
  };

  std::string path_;
  BrickStoreLayout layout_;
  std::vector<double> steps_;    // per field, for encode_brick: the Quant16 grid's step (0: per brick)
  std::vector<double> origins_;  // per field, for encode_brick: the grid's origin (the field's, or the step's, min)
  uint32_t header_size_ = 0;
  std::unique_ptr<AtomicOutputFile> out_;
  mutable std::mutex mutex_;
  std::vector<Placed> placed_;                              // by node id
  std::vector<uint32_t> sizes_, crcs_;                      // node × F
  std::vector<float> lo_, hi_;                              // node × F
  std::vector<store_format::CellBlockRecord> cell_blocks_;  // by node id; offset 0: none
  std::vector<uint64_t> cell_value_counts_;                 // by node id: the values its cell block holds
  uint64_t total_cells_ = 0;
  uint64_t block_bytes_ = 0;
  bool done_ = false;  // committed, or failed: no more writes
  // Time stores: the step being written (-1: none begun) and what the finished ones left (step 0's go to the node
  // table at commit()).
  struct StepTables {
    std::vector<Placed> placed;
    std::vector<uint32_t> sizes, crcs;
    std::vector<float> lo, hi;
    std::vector<FieldError> errors;
    std::vector<store_format::TfErrorEntry> tf_errors;
    std::vector<store_format::StepFieldRange> ranges;
    std::vector<store_format::CellBlockRecord> cell_values;  // by node id: its values block (offset 0: none)
  };
  int64_t step_ = -1;
  bool step_open_ = false;
  std::vector<StepTables> done_steps_;
};

class BrickStoreReader {
 public:
  // Opens and validates the store; throws ugvr::Error naming the file, the byte offset and what is wrong.
  explicit BrickStoreReader(std::string path);

  const std::string& path() const { return file_.path(); }
  uint64_t file_size() const { return file_.size(); }
  // The header record as stored (checksum verified); layout() is the same, decoded.
  const store_format::HeaderRecord& header() const { return header_; }
  // File offset of node `node`'s record in the node table (it need not exist: for messages).
  uint64_t record_offset(uint64_t node) const;
  const BrickStoreLayout& layout() const { return layout_; }
  uint32_t resolution() const { return layout_.resolution; }
  uint32_t field_count() const { return uint32_t(layout_.fields.size()); }
  // Index of the field called `name`, or -1.
  int field_index(std::string_view name) const;

  uint64_t node_count() const { return nodes_.size(); }
  std::span<const BrickNode> nodes() const { return nodes_; }
  const BrickNode& node(uint64_t id) const;
  // `step`: a time store's step (0 .. step_count() - 1); a store of one step has only step 0. Without it: the step
  // set_step() selected (0 by default).
  const FieldStats& stats(uint64_t node, uint32_t field, uint32_t step) const;
  BlockRef block(uint64_t node, uint32_t field, uint32_t step) const;
  const FieldStats& stats(uint64_t node, uint32_t field) const { return stats(node, field, step_); }
  BlockRef block(uint64_t node, uint32_t field) const { return block(node, field, step_); }
  Bounds bounds(uint64_t node) const { return node_bounds(layout_.root, this->node(node)); }

  // The transfer-function error table (store_format::TfErrorEntry; version 3 stores written with one), checksum
  // verified at open: entries node-major, F per node. Empty when the store has none (older stores, raw writers).
  bool has_tf_errors() const { return !tf_errors_.empty(); }
  std::span<const store_format::TfErrorEntry> tf_errors(uint32_t step) const;
  std::span<const store_format::TfErrorEntry> tf_errors() const { return tf_errors(step_); }
  const store_format::TfErrorHeaderRecord& tf_error_header() const { return tf_error_header_; }

  // The boundary faces (version 4 stores built with them), checksum and references verified at open; empty when the
  // store has none.
  bool has_boundary() const { return !boundary_.empty(); }
  const StoreBoundary& boundary() const { return boundary_; }
  const store_format::BoundaryHeaderRecord& boundary_header() const { return boundary_header_; }

  // The cells kept per node (version 5 stores built with them): the index is verified at open, each block when read.
  bool has_cells() const { return !cell_blocks_.empty(); }
  const store_format::CellsHeaderRecord& cells_header() const { return cells_header_; }
  // Where node `node`'s block is (offset 0: the node keeps no cells, or the store none).
  store_format::CellBlockRecord cell_block(uint64_t node) const;
  // Reads and checks node `node`'s cells: checksum, sizes, every index in range, positions and values finite. Throws
  // ugvr::Error naming the file, node and offset. Thread-safe. `step`: a time store's step, whose values the cells
  // then hold (a later step's from its values block, checked likewise, the error naming the step too); without it,
  // the step set_step() selected.
  NodeCells read_cells(uint64_t node, uint32_t step) const;
  NodeCells read_cells(uint64_t node) const { return read_cells(node, step_); }
  // Only the values of node `node`'s cells in step `step` (NodeCells::values): for a later step its values block and
  // the counts from its cell block's header, without decoding the geometry; for step 0 the whole cell block. Checked
  // and thread-safe as read_cells.
  std::vector<float> read_cell_values(uint64_t node, uint32_t step) const;
  // Where node `node`'s values of step `step` >= 1 are (store_format::kStepsHaveCells; offset 0: none).
  store_format::CellBlockRecord cell_values_block(uint64_t node, uint32_t step) const;
  // The counts of node `node`'s cells (its block's header), decoded from the first bytes of the block alone: what a
  // cell budget needs to know before it decides to read a block of millions of cells. As stored: the checksum and
  // the arrays are checked when read_cells reads the block. Throws ugvr::Error naming the file, node and offset for a
  // node without cells or a header that does not decode.
  store_format::CellBlockHeader cell_block_header(uint64_t node) const;

  // Time steps (format version 6; docs/time-series.md, "Stores with time"). A store of one step: step_count() 1,
  // has_steps() false, its time 0 and its fields' ranges those of the layout.
  bool has_steps() const { return !times_.empty(); }
  uint32_t step_count() const { return times_.empty() ? 1 : uint32_t(times_.size()); }
  double step_time(uint32_t step) const;
  // Field `field`'s range in step `step`: what its bricks were quantized over (inside layout().fields[field]'s).
  store_format::StepFieldRange step_range(uint32_t step, uint32_t field) const;
  const store_format::StepsHeaderRecord& steps_header() const { return steps_header_; }
  // The step that the accessors without a step argument present, so that code written for a store of one step (the
  // cut, the transfer-function errors, the residency) draws any step. Not thread-safe: change it while no other thread
  // reads through those accessors (the LOD engine does between frames; its RAM caches read with explicit steps).
  void set_step(uint32_t step);
  uint32_t step() const { return step_; }

  // Decodes field `field` of node `node` into samples (R³ floats, x fastest) and, unless null, mask (R³ bytes, 1 =
  // data). One pread of the block, checksum verified. Thread-safe: per-thread scratch, no shared mutable state.
  // Throws ugvr::Error for a node without brick or a corrupt block (naming the file, node, field and offset).
  void read_brick(uint64_t node, uint32_t field, float* samples, uint8_t* mask, uint32_t step) const;
  void read_brick(uint64_t node, uint32_t field, float* samples, uint8_t* mask) const {
    read_brick(node, field, samples, mask, step_);
  }

  // For a cache of compressed bricks: read_block fills dst (block(node, field).size bytes) with the block, checksum
  // verified; decode_block decodes such bytes (not re-verified).
  void read_block(uint64_t node, uint32_t field, std::byte* dst, uint32_t step) const;
  void decode_block(uint64_t node, uint32_t field, std::span<const std::byte> block, float* samples, uint8_t* mask,
                    uint32_t step) const;
  void read_block(uint64_t node, uint32_t field, std::byte* dst) const { read_block(node, field, dst, step_); }
  void decode_block(uint64_t node, uint32_t field, std::span<const std::byte> block, float* samples,
                    uint8_t* mask) const {
    decode_block(node, field, block, samples, mask, step_);
  }

 private:
  // The steps of opening, in order; each throws ugvr::Error naming the file and offset.
  std::vector<std::byte> read_header();
  void read_field_records(std::span<const std::byte> header_bytes);
  void read_node_table();
  void read_provenance();
  void read_tf_errors();
  void read_boundary();
  void read_cells_index();
  void read_steps();
  void check_nodes();
  void check_node_stats(uint64_t id, uint32_t f, uint32_t step) const;
  void check_node_field(uint64_t node, uint32_t field, uint32_t step = 0) const;
  // Where the record holding node `node`'s entries for `step` starts (the node table's for step 0).
  uint64_t step_record_offset(uint64_t node, uint32_t step) const;
  // A later step's values of node `node`'s cells, `count` of them (from its cell block's header), checked.
  std::vector<float> read_values_block(uint64_t node, uint32_t step, uint64_t count) const;

  InputFile file_;
  store_format::HeaderRecord header_;
  store_format::TfErrorHeaderRecord tf_error_header_;
  std::vector<store_format::TfErrorEntry> tf_errors_;  // step × node × F; empty: none
  store_format::BoundaryHeaderRecord boundary_header_;
  StoreBoundary boundary_;
  store_format::CellsHeaderRecord cells_header_;
  std::vector<store_format::CellBlockRecord> cell_blocks_;  // by node id; empty: none
  store_format::StepsHeaderRecord steps_header_;
  std::vector<double> times_;                               // per step; empty: one step
  std::vector<store_format::StepFieldRange> ranges_;        // step × F; empty: one step
  std::vector<store_format::CellBlockRecord> cell_values_;  // (step - 1) × N; empty: none
  uint64_t steps_nodes_offset_ = 0;                         // where step 1's node records start in the section
  uint32_t step_ = 0;                                       // set_step()
  BrickStoreLayout layout_;
  uint64_t node_table_offset_ = 0;
  std::vector<BrickNode> nodes_;
  std::vector<FieldStats> stats_;  // step × node × F
  std::vector<BlockRef> blocks_;   // step × node × F
};

}  // namespace ugvr
