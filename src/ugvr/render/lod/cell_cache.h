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
//   CellNodeRecord × nodes (CELL_NODE_BUFFER_BINDING), uvec4[5] each:
//     [0] first local cell of each type (tetra, pyramid, wedge, hexahedron)
//     [1] where each type's connectivity starts in the uint buffer (absolute)
//     [2] where each type's neighbours start in the uint buffer (absolute)
//     [3] first point (float index of its x), first value (float index), first quad-split word, first entry
//         triangle (uint index)
//     [4] entry triangles, cells, first id word, first word of the id order
//   uint (CELL_INT_BUFFER_BINDING), per node: connectivity (local point indices), neighbours (local cell << 3 | face,
//     0xFFFFFFFF: none in the node), quad splits (one byte per non-tetrahedral cell, four to a word), entry triangles
//     (two words each: cell << 3 | face; corner0 | corner1 << 2 | corner2 << 4), the cells' ids in the input mesh
//     (two words each, low then high), the cells in ascending id order (the handover between exact nodes)
//   float (CELL_FLOAT_BUFFER_BINDING), per node: points (x, y, z normalised), values (the field's own units)
//
// Residency: decoded and prepared nodes are kept in RAM, least recently granted dropped first beyond twice the budget;
// the GPU buffers hold exactly the granted set and are rewritten when it changes (a transfer-function edit or a
// camera move that keeps the set uploads nothing).
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
  std::vector<uint32_t> ints;
  std::vector<float> floats;  // points.size() * 3 normalised coordinates, then the values
  uint64_t bytes() const { return ints.size() * 4 + floats.size() * 4 + 80; }
};

// Node `node`'s cells as the GPU walks them, for store field `field`. Throws ugvr::Error for a node without cells.
PreparedNodeCells prepare_node_cells(const BrickStoreReader& store, uint64_t node, uint32_t field);

class CellCache {
 public:
  // The store must outlive the cache; `budget_bytes` bounds the GPU buffers (further capped by the driver's largest
  // storage block). GL calls need the engine's context current.
  CellCache(const BrickStoreReader& store, uint64_t budget_bytes);

  struct Grant {
    std::vector<uint64_t> nodes;    // granted, in priority order
    std::vector<uint32_t> entries;  // their entries in the node buffer (the shader's NODE_EXACT | entry)
    uint64_t cells = 0, bytes = 0;  // of the granted nodes
    uint64_t prepared = 0;          // nodes read and prepared for this grant (not in RAM before)
    bool budget_full = false;       // a candidate did not fit the budget
    bool uploaded = false;          // the GPU buffers were rewritten
  };
  // Grants exact cells to `candidates` (nodes with cells, highest priority first), at most `max_nodes`, each while the
  // budget allows (a node that does not fit is skipped; smaller ones after it may still fit), and uploads the granted
  // set if it changed.
  Grant grant(std::span<const uint64_t> candidates, uint32_t field, uint64_t max_nodes);
  void bind() const;  // the three buffers at their bindings (lod_shared.h)
  uint64_t budget_bytes() const { return budget_; }
  uint64_t ram_bytes() const { return ram_bytes_; }
  std::vector<uint64_t> nodes_in_ram() const;  // ascending

 private:
  const PreparedNodeCells& get(uint64_t node, uint32_t field, bool& fresh);
  const BrickStoreReader& store_;
  uint64_t budget_ = 0, max_block_ = 0;
  uint32_t field_ = UINT32_MAX;
  struct Entry {
    PreparedNodeCells cells;
    uint64_t last_used = 0;
  };
  std::unordered_map<uint64_t, Entry> ram_;
  uint64_t ram_bytes_ = 0, tick_ = 0;
  std::vector<uint64_t> uploaded_;  // the granted set the buffers hold
  GlBuffer nodes_buf_, ints_buf_, floats_buf_;
};

}  // namespace ugvr
