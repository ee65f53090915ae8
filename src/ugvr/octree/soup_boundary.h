// The mesh's boundary found out of core, from a cell soup (octree/soup.h), for the out-of-core builder's boundary
// section (octree/boundary_faces.h): the same triangles, in the same order, as mesh_boundary_triangles gives for the
// mesh in memory, so that both builders write the same section.
//
// Faces are matched by vertex set as grid/topology.h matches them (a set met exactly twice is interior; once, or more
// than twice, boundary), without the mesh's topology in memory:
//  1. one pass over the soup writes every face as a 24-byte record (its sorted vertex ids, then the packed cell and
//     local face) to one of K bucket files, chosen by its smallest vertex id, K such that a bucket fits the budget;
//  2. each bucket in turn is read, sorted and scanned for sets not met exactly twice: the boundary faces (cell, face);
//  3. a second pass over the soup turns those faces into triangles (append_face_triangles), sorted by (cell, face).
// Memory: K file buffers and one bucket (within `memory_budget`), then the boundary's faces (8 bytes each) and
// triangles (36 bytes each, 44 while they are sorted); disk: 24 bytes per face (4 per tetrahedron) beside the soup,
// in `temp_dir`, removed as each bucket is read.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/octree/boundary_faces.h"
#include "ugvr/octree/soup.h"

namespace ugvr {

struct SoupBoundaryStats {
  uint64_t faces = 0;              // every cell face in the soup
  uint64_t boundary_faces = 0;     // of those, on the boundary
  uint64_t nonmanifold_faces = 0;  // of those, sharing their vertex set with two or more other faces
  uint32_t buckets = 0;
};

// `cells`: the records in the soup (to size the buckets). `observer`: progress of the three passes.
// `boundary_faces` (optional): also the boundary faces themselves, pack_face(cell id, local face) (grid/topology.h),
// ascending, a face met more than twice once per cell that has it (8 bytes each): what the out-of-core builder
// needs to mark the faces of the leaves' cell blocks (octree/node_cells.h) as the mesh's boundary.
std::vector<MeshFaceTriangle> soup_boundary_triangles(const std::string& soup_path, const SoupLayout& layout,
                                                      uint64_t cells, uint64_t memory_budget,
                                                      const std::string& temp_dir, const Progress::Observer& observer,
                                                      SoupBoundaryStats* stats = nullptr,
                                                      std::vector<uint64_t>* boundary_faces = nullptr);

}  // namespace ugvr
