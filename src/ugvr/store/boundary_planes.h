// Where a node's boundary faces (octree/boundary_faces.h, the store's boundary section) all lie on one plane: the LOD
// renderer then clips the node at the plane, one ray-plane test instead of its triangles and of the walk through its
// descendants (docs/lod-engine.md, "Exact boundary"). Computed when a store is opened, not stored.
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// A plane n·p = w in the root cell's normalised coordinates, n a unit vector pointing out of the mesh.
struct BoundaryPlane {
  Vec3d normal;
  double offset = 0;
};

// Per entry of `boundary` (the tree's nodes `nodes`, then the virtual nodes): the plane on which every triangle the
// entry reaches lies (its own list, or its descendants' for one over the cap), all facing the same way, when those
// triangles also cover the plane's section of the entry's cell. A ray then crosses the boundary inside that cell
// exactly where it crosses the plane, so the renderer tests one plane instead of the triangles and skips the walk
// through the descendants (the oxygen post's flat top: docs/lod-engine.md, "Exact boundary"). Empty elsewhere: no
// faces, faces on more than one plane (within 1e-6, normalised), or a section they leave partly open (its area and
// theirs inside the cell differ by more than 1e-5 of it).
std::vector<std::optional<BoundaryPlane>> boundary_face_planes(const StoreBoundary& boundary,
                                                               std::span<const OctreeNode> nodes);

}  // namespace ugvr
