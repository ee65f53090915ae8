// Face connectivity of an unstructured mesh, derived on demand (it is never stored in files): for every face of
// every cell, the cell on the other side, and the list of boundary faces. Ray casters walk cell to cell with it
// (Garrity / Bunyk) and find entry points on the boundary faces.
//
// Layout:
//   face_offsets  (C+1) x uint64   faces of cell c occupy slots face_offsets[c] .. face_offsets[c+1]
//                                  (in cell_info(type).faces order)
//   neighbors     F x uint64       per face slot: pack_face(neighbour cell, its local face), or kNoNeighbor
//   boundary      B x uint64       pack_face(cell, local face) of every face with no neighbour, in cell order
// Two faces match when they have the same vertex set (a triangle never matches a quadrilateral). A vertex set shared
// by more than two faces (non-manifold or duplicated cells) matches none of them; those faces count as boundary and
// are reported in nonmanifold_faces.
#pragma once

#include <cstdint>
#include <vector>

#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

inline constexpr uint64_t kNoNeighbor = ~uint64_t(0);
constexpr uint64_t pack_face(uint64_t cell, uint32_t local_face) { return (cell << 3) | local_face; }
constexpr uint64_t face_cell(uint64_t packed) { return packed >> 3; }
constexpr uint32_t face_local(uint64_t packed) { return uint32_t(packed & 7); }

struct MeshTopology {
  std::vector<uint64_t> face_offsets;
  std::vector<uint64_t> neighbors;
  std::vector<uint64_t> boundary;
  uint64_t nonmanifold_faces = 0;

  uint64_t neighbor(uint64_t cell, uint32_t local_face) const { return neighbors[face_offsets[cell] + local_face]; }
  uint64_t memory_bytes() const {
    return (face_offsets.capacity() + neighbors.capacity() + boundary.capacity()) * sizeof(uint64_t);
  }
};

// Builds the topology in parallel (oneTBB) in time linear in the number of faces: faces are bucketed by their
// smallest vertex, then matched within each bucket. Deterministic for any thread count.
MeshTopology build_topology(const UnstructuredMesh& mesh);

}  // namespace ugvr
