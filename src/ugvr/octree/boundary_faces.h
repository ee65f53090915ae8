// The mesh's boundary faces per octree node, for the brick store's boundary section (format version 4,
// store/brick_store_format.h BoundaryHeaderRecord; Muigg 2008, section 5.1.2): a renderer clips each node's samples at
// these faces, so that the domain boundary is the mesh's own at every level instead of where each level's voxel
// stencil puts it (within half of that level's voxel). docs/octree-build.md, "Boundary faces".
//
// The boundary is every cell face with no neighbour (grid/topology.h: faces matched by vertex set), as triangles
// oriented outwards (cells are positively oriented), quadrilaterals split along the diagonal through their
// lexicographically smallest corner as the exact engine splits them (render/exact/walk_mesh.h). The section leaves out
// coincident pairs of opposite orientation: the faces that unwelded blocks of a multi-block grid share, with the mesh
// on both sides (store_boundary_faces; BoundaryFaceStats::inner_pairs counts them). A triangle belongs to
// every node whose closed cell it overlaps (separating axes: the box's 3, the triangle's normal, 9 edge products),
// found top-down: a node tests only its parent's triangles. A node with more than `max_per_node` lists none
// (kBoundaryOverflow): a ray looks in its children instead, so that it never tests more than that many triangles in one
// cell. A leaf with more is divided further for its faces alone (virtual nodes, up to kBoundaryVirtualLevels levels
// below it; a cell still over the cap there lists all of its triangles).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/topology.h"
#include "ugvr/grid/unstructured_mesh.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// The default cap on a node's triangles: a ray entering the node intersects each (docs/lod-engine.md, "Exact
// boundary" gives the cost).
inline constexpr uint32_t kBoundaryFacesPerNode = 16;
// How many levels below a leaf its faces may be divided.
inline constexpr int kBoundaryVirtualLevels = 6;

struct BoundaryFaceStats {
  uint64_t triangles = 0;          // of the mesh boundary
  uint64_t inner_pairs = 0;        // coincident pairs of opposite orientation (unwelded blocks' shared faces): dropped
  uint64_t crossed_nodes = 0;      // nodes some triangle overlaps
  uint64_t listed_nodes = 0;       // of those, with their triangles listed (at most max_per_node)
  uint64_t overflow_nodes = 0;     // interior nodes with more: their children list them
  uint64_t overflow_leaves = 0;    // leaves with more: divided into virtual nodes
  uint64_t virtual_divisions = 0;  // virtual nodes over the cap, divided again (8 entries each)
  uint64_t virtual_nodes = 0;      // entries past the tree's nodes
  uint64_t references = 0;
  double seconds = 0;
};

// Does triangle (a, b, c) overlap the closed box? Touching counts.
bool triangle_box_overlap(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Bounds& box);

// One boundary triangle: its corners in world coordinates, ordered so that (p1 - p0) x (p2 - p0) points out of the
// mesh.
using MeshFaceTriangle = std::array<Vec3f, 3>;

// Appends the triangles of one boundary face given its corners in the cell's face order (cell_info(type).faces),
// their vertex ids and positions: a triangle as it is, a quadrilateral split along the diagonal through its
// lexicographically smallest corner (ties by id), as the exact engine splits it. Shared by the in-core and the
// out-of-core builders (octree/soup_boundary.h), so both give the same triangles.
void append_face_triangles(int size, const uint32_t* ids, const Vec3f* positions, std::vector<MeshFaceTriangle>& out);

// The mesh's boundary (grid/topology.h) as triangles, in the order of its faces (cell, then local face).
// `topology`: the mesh's, when the caller has it (else it is built here).
std::vector<MeshFaceTriangle> mesh_boundary_triangles(const UnstructuredMesh& mesh,
                                                      const MeshTopology* topology = nullptr);

// The boundary section for `nodes` (the whole tree, node 0 the root covering `root`) from the boundary's triangles.
// An empty result (no nodes) when there are no triangles or max_per_node is 0.
StoreBoundary store_boundary_faces(std::span<const MeshFaceTriangle> triangles, const Bounds& root,
                                   std::span<const OctreeNode> nodes, uint32_t max_per_node = kBoundaryFacesPerNode,
                                   BoundaryFaceStats* stats = nullptr);
// The same for a mesh in memory.
StoreBoundary store_boundary_faces(const UnstructuredMesh& mesh, const Bounds& root, std::span<const OctreeNode> nodes,
                                   uint32_t max_per_node = kBoundaryFacesPerNode, BoundaryFaceStats* stats = nullptr,
                                   const MeshTopology* topology = nullptr);

}  // namespace ugvr
