// The GPU cell cache of hybrid rendering (docs/hybrid.md; Muigg 2007): beside the brick atlas, the cells of the cut
// nodes granted an exact representation, in the form the LOD shader's HYBRID variant walks (shaders/lod_raycast.comp
// walk_node, shaders/cell_walk.glsl), within a byte budget (`--gpu-cell-memory`).
//
// A node's cells come from the store (format version 5, BrickStoreReader::read_cells: every cell overlapping the leaf,
// replicated across node borders) and are turned into a walk mesh of their own (render/exact/walk_mesh.h: sorted by
// type, neighbours as cell << 3 | face, quadrilateral diagonals by the exact engine's rule, and the faces whose
// neighbour the node does not keep or the mesh lacks as the node's entry triangles), with positions normalised to the
// octree's root cell and the field's values as stored, both float.
//
// GPU layout: three storage buffers, the nodes granted this frame back to back in priority order.
//   CellNodeRecord × nodes (CELL_NODE_BUFFER_BINDING), uvec4[CELL_NODE_UVEC4S = 6] each:
//     [0] first local cell of each type (tetra, pyramid, wedge, hexahedron)
//     [1] where each type's connectivity starts in the uint buffer (absolute)
//     [2] where each type's neighbours start in the uint buffer (absolute)
//     [3] first point (float index of its x), first value (float index), first quad-split word, first entry
//         triangle (uint index)
//     [4] entry triangles, cells, first id word, first word of the id order
//     [5] the entry grid: first word of its cell offsets (uint index), its box (float index), its size
//         (nx | ny << 10 | nz << 20), 0
//   uint (CELL_INT_BUFFER_BINDING), per node: connectivity (local point indices), neighbours (local cell << 3 | face,
//     0xFFFFFFFF: none in the node), quad splits (one byte per non-tetrahedral cell, four to a word), entry triangles
//     (two words each: cell << 3 | face; corner0 | corner1 << 2 | corner2 << 4), the cells' ids in the input mesh
//     (two words each, low then high), the cells in ascending id order (the handover between exact nodes), the entry
//     grid: nx·ny·nz + 1 offsets (grid cell (x, y, z) at x + nx (y + ny z); in list entries), then the list: per grid
//     cell its entry triangles' indices, ascending, 16 bits each, two to a word (entry j in word j / 2, the low half
//     first); a grid of one cell keeps no list (its entry j is triangle j)
//   float (CELL_FLOAT_BUFFER_BINDING), per node: points (x, y, z normalised), values (the field's own units), the entry
//     grid's box: its low corner and its cells' size (x, y, z each, normalised)
//
// The entry grid (a uniform grid over the box of the node's entry triangles, a grid cell per two triangles): a ray
// that enters the node's cells from outside them (its first exact node, or after leaving the mesh) looks for the first
// entering crossing in (t, triangle) order. Instead of testing every entry triangle, the shader walks the grid cells
// along the ray (3D DDA) and tests only theirs, stopping after the grid cell in which a crossing is found. Each
// triangle is listed in every grid cell that its bounding box, grown by kEntryGridMargin, meets: the crossing's
// computed point lies within float rounding (far below the margin) of the triangle, so no triangle that the linear
// scan would pick is missed, and the same arithmetic picks the same crossing (docs/hybrid.md, "One ray-casting pass").
//
// Residency: decoded and prepared nodes are kept in RAM, least recently granted dropped first beyond twice the budget;
// the GPU buffers hold exactly the granted set and are rewritten when it changes (a transfer-function edit or a
// camera move that keeps the set uploads nothing). A time store's step change (BrickStoreReader::set_step) keeps the
// prepared nodes: each granted one gets the new step's values alone (a values block per node, swap_step_values), and
// the buffers are rewritten.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "ugvr/gpu/gl_program.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct PreparedNodeCells {
  std::array<uint32_t, 4> type_begin{}, conn_begin{}, face_begin{};  // conn/face: relative to `ints`
  uint32_t quad_begin = 0, entry_begin = 0, entry_count = 0;         // relative to `ints`
  uint32_t id_begin = 0, order_begin = 0;                            // relative to `ints`
  uint32_t cells = 0, points = 0;
  uint32_t grid_begin = 0, grid_float_begin = 0;  // relative to `ints` / `floats`
  std::array<uint32_t, 3> grid_size{1, 1, 1};     // grid cells along x, y, z
  std::vector<uint32_t> ints;
  std::vector<float> floats;  // points.size() * 3 normalised coordinates, the values, the grid's low corner and step
  uint64_t bytes() const;     // on the GPU: both arrays and the node record
  // The entry triangles listed in grid cell (x, y, z).
  std::vector<uint32_t> grid_cell(uint32_t x, uint32_t y, uint32_t z) const;
};

// How far (normalised coordinates) an entry triangle's box is grown before it is binned: well above the float
// rounding of the shader's crossing (coordinates below 2, a few ulps: about 1e-6).
inline constexpr float kEntryGridMargin = 2e-5f;
// A node with more entry triangles than 16-bit list entries can name gets a grid of one cell (the linear scan).
inline constexpr uint32_t kEntryGridMaxTriangles = 65536;

// Node `node`'s cells as the GPU walks them, for store field `field` and the store's step (BrickStoreReader::set_step).
// Throws ugvr::Error for a node without cells. With `entry_grid` false the entry grid is one cell holding every entry
// triangle: the shader then tests them all, as the linear scan did (the environment's UGVR_HYBRID_ENTRY_GRID=0 makes
// the cell cache do that, for A/B checks).
PreparedNodeCells prepare_node_cells(const BrickStoreReader& store, uint64_t node, uint32_t field,
                                     bool entry_grid = true);
// A time store (format version 6 with cells): `p`, node `node`'s prepared cells for field `field`, given the values of
// step `step` in place of those it holds (read alone: BrickStoreReader::read_cell_values). The cells themselves are
// the same in every step, so the walk mesh, ids and entry grid stay.
void swap_step_values(const BrickStoreReader& store, uint64_t node, uint32_t field, uint32_t step,
                      PreparedNodeCells& p);
// How much of each GPU buffer a node's prepared cells take (PreparedNodeCells: ints, floats, one node record).
struct PreparedSize {
  uint64_t ints = 0, floats = 0;  // words
  uint64_t bytes() const;         // as PreparedNodeCells::bytes()
};
// A lower bound of the PreparedSize of the node whose block has header `h`, from its counts alone (CellCache::grant
// sizes a node by it before reading the block).
PreparedSize prepared_size_at_least(const store_format::CellBlockHeader& h);
inline uint64_t prepared_bytes_at_least(const store_format::CellBlockHeader& h) {
  return prepared_size_at_least(h).bytes();
}

class CellCache {
 public:
  // The store must outlive the cache; `budget_bytes` bounds the GPU buffers (further capped by the driver's largest
  // storage block, GL_MAX_SHADER_STORAGE_BLOCK_SIZE, per buffer; the environment's UGVR_CELL_BUFFER_MAX_BYTES lowers
  // that cap, for tests of a driver with a small one). GL calls need the engine's context current.
  CellCache(const BrickStoreReader& store, uint64_t budget_bytes);

  struct Grant {
    std::vector<uint64_t> nodes;    // granted, in priority order
    std::vector<uint32_t> entries;  // their entries in the node buffer (the shader's NODE_EXACT | entry)
    uint64_t cells = 0, bytes = 0;  // of the granted nodes
    uint64_t prepared = 0;          // nodes read and prepared for this grant (not in RAM before)
    uint64_t swapped = 0;           // nodes in RAM given another time step's values (swap_step_values)
    bool budget_full = false;       // a candidate did not fit the budget
    bool uploaded = false;          // the GPU buffers were rewritten
  };
  // Grants exact cells to `candidates` (nodes with cells, highest priority first), at most `max_nodes`, each while the
  // budget and the buffers' cap allow (a node that does not fit is skipped; smaller ones after it may still fit), and
  // uploads the granted set if it changed. The values are those of the store's step (BrickStoreReader::set_step): a
  // node prepared for another step gets this one's values alone (swap_step_values), and the set is uploaded again. A
  // node is read and prepared only when its size (the bound from its block's header, or its prepared size once known)
  // fits what is left, so a full budget costs no reads; the nodes prepared and kept in RAM never exceed twice the
  // budget, even within one grant.
  Grant grant(std::span<const uint64_t> candidates, uint32_t field, uint64_t max_nodes);
  void bind() const;  // the three buffers at their bindings (lod_shared.h)
  uint64_t budget_bytes() const { return budget_; }
  uint64_t ram_bytes() const { return ram_bytes_; }
  std::vector<uint64_t> nodes_in_ram() const;  // ascending

 private:
  // The node's prepared cells, read and prepared if not in RAM (after dropping the least recently granted to keep
  // RAM within twice the budget).
  const PreparedNodeCells& get(uint64_t node, uint32_t field, bool& fresh, bool& swapped);
  // The node's size as far as it is known without preparing it: its prepared size once it has been prepared for the
  // current field, else prepared_size_at_least of its block's header, read once. A node that does not fit is a
  // candidate again every frame: neither its header nor its cells are read again.
  PreparedSize known_size(uint64_t node);
  // Drops the least recently granted nodes not granted in this grant until RAM holds at most `limit` bytes.
  void drop_from_ram(uint64_t limit);
  const BrickStoreReader& store_;
  uint64_t budget_ = 0, max_block_ = 0;
  uint32_t field_ = UINT32_MAX;
  uint32_t step_ = 0;       // the store's step the uploaded buffers hold
  bool entry_grid_ = true;  // false: UGVR_HYBRID_ENTRY_GRID=0, one grid cell per node (the linear scan)
  struct Entry {
    PreparedNodeCells cells;
    uint64_t last_used = 0;
    uint32_t step = 0;  // whose values `cells` holds
  };
  std::unordered_map<uint64_t, Entry> ram_;
  struct KnownSize {
    PreparedSize size;
    bool prepared = false;  // the prepared size (for field_), not the header's bound
  };
  std::unordered_map<uint64_t, KnownSize> sizes_;  // known_size, by node
  uint64_t ram_bytes_ = 0, tick_ = 0;
  std::vector<uint64_t> uploaded_;  // the granted set the buffers hold
  GlBuffer nodes_buf_, ints_buf_, floats_buf_;
};

}  // namespace ugvr
