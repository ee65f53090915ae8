// The walk mesh: the compact, read-only form of a dataset's cells that the exact ray caster walks through.
//
// Cells of all blocks are gathered and sorted by type (stable within a type, blocks in order), so a cell's type
// and where its vertices and faces live follow from its index with no per-cell offset (8 bytes a cell saved):
//   type_begin[k] .. type_begin[k+1]   cells of kAllCellTypes[k] (Tetra, Pyramid, Wedge, Hexahedron)
//   connectivity   uint32 vertex indices, cell c of type k at conn_begin[k] + (c - type_begin[k]) * vertex_count
//   neighbors      uint32 per face slot, at face_begin[k] + (c - type_begin[k]) * face_count + local_face:
//                  pack(cell across, its local face) = cell << 3 | face, or kWalkBoundary
//   quad_split     uint8 per non-tetrahedral cell (index c - type_begin[1]): bit f set when quadrilateral face f is
//                  split into triangles along its 1-3 diagonal instead of 0-2 (see quad_split_13)
//   points         float32 positions, all blocks' points concatenated (block b's vertex v at point_base[b] + v)
//   boundary       every boundary face as triangles (quadrilaterals split as above), for finding where rays enter
// A tetrahedral mesh costs 16 (connectivity) + 16 (neighbours) bytes per cell plus 12 per vertex.
//
// Quadrilateral faces are walked as two triangles. The diagonal holds the face's vertex with the lexicographically
// smallest position (ties broken by index), a rule both cells sharing the face apply identically, so the triangulated
// surfaces of neighbours coincide exactly and no ray can slip between them. Curvilinear grids enter as hexahedra
// (trilinear, as the data was defined) rather than as 5 or 6 tetrahedra, which would change the interpolant and
// cost 3-4x the memory.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/dataset.h"

namespace ugvr {

inline constexpr uint32_t kWalkBoundary = ~uint32_t(0);
inline constexpr uint32_t kMaxWalkCells = (uint32_t(1) << 29) - 1;

// A triangle of the mesh boundary: face `local_face` of `cell`; corners index that face's vertex list (0..3).
struct BoundaryTriangle {
  uint32_t cell;
  uint8_t local_face;
  std::array<uint8_t, 3> corners;
};

struct WalkMesh {
  std::vector<Vec3f> points;
  std::vector<uint64_t> point_base;                       // per block
  std::vector<std::array<uint32_t, 4>> block_type_begin;  // per block: its first cell of each type
  std::array<uint32_t, 5> type_begin{};
  std::array<uint64_t, 4> conn_begin{}, face_begin{};
  std::vector<uint32_t> connectivity;
  std::vector<uint32_t> neighbors;
  std::vector<uint8_t> quad_split;
  std::vector<BoundaryTriangle> boundary;
  Bounds bounds;

  uint32_t cell_count() const { return type_begin[4]; }
  // Index into kAllCellTypes of cell c's type.
  int type_index(uint32_t c) const { return c < type_begin[1] ? 0 : c < type_begin[2] ? 1 : c < type_begin[3] ? 2 : 3; }
  const uint32_t* cell_vertices(uint32_t c, int k) const {
    return connectivity.data() + conn_begin[k] + uint64_t(c - type_begin[k]) * cell_vertex_count(kAllCellTypes[k]);
  }
  const uint32_t* cell_neighbors(uint32_t c, int k) const {
    return neighbors.data() + face_begin[k] + uint64_t(c - type_begin[k]) * cell_face_count(kAllCellTypes[k]);
  }
  bool quad_split_13(uint32_t c, int face) const { return (quad_split[c - type_begin[1]] >> face) & 1; }
  uint64_t memory_bytes() const;
};

// Builds the walk mesh of every block (structured blocks as hexahedra, IBLANKed cells dropped). Throws ugvr::Error
// for an empty dataset or more than kMaxWalkCells cells.
WalkMesh build_walk_mesh(const Dataset& dataset);

// One rank's part of a walk mesh (data-parallel rendering, docs/mpi.md): the cells whose bounding boxes meet the
// closed box `box`, renumbered in their old order (so still sorted by type) with their vertices compacted. Faces to
// dropped cells become boundary faces (triangulated as the cell's quad_split says, like the mesh's own boundary), so
// rays enter the part where it was cut as they enter the mesh. Every point of the box inside the mesh lies in a kept
// cell, so the part covers box ∩ mesh and a renderer clipped to the box draws what the whole mesh draws there.
// The part's point_base and block_type_begin still describe the source mesh's numbering (what a dataset's fields
// are laid out by); cell_source[c] / point_source[p] give the source index of the part's cell c / point p. bounds
// stay the whole mesh's (every rank frames the same camera).
struct WalkMeshPart {
  WalkMesh mesh;
  std::vector<uint32_t> cell_source, point_source;
};
WalkMeshPart restrict_walk_mesh(const WalkMesh& mesh, const Bounds& box);

// For a block, the engine cell index of each of its cells in the order the block's cell field lists them (for
// structured blocks: only cells kept after IBLANK, in structured order, with the dropped ones marked kWalkBoundary).
std::vector<uint32_t> block_cell_order(const Dataset& dataset, const WalkMesh& mesh, size_t block);

}  // namespace ugvr
