// The octree's shape, decided top-down before the bricks of pass 2 (Leven et al. 2002, figure 6): a node splits
// while the split criterion asks (octree/split.h: the voxel rule, and above --error 0 the interpolant check, which
// samples the node it would keep) and its level is below the maximum depth; each child gets the cells
// that overlap it (octree/cell_box_overlap.h, with the sampler's margin, so its list is a valid candidate list for the
// sampler), and a child that no cell overlaps is not created: no sample of its box can hold data.
//
// Level by level, the nodes of one level in parallel. Node ids follow the brick store's rules (store/brick_store.h):
// the root is 0, a node's children are contiguous in octant order and come after it; ids are assigned level by level in
// the order of their parents, so the tree and its ids do not depend on the thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/grid/unstructured_mesh.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/split.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct OctreeShape {
  std::vector<OctreeNode> nodes;
  // Per node id: the cells overlapping the node, in increasing id order, kept for leaves only (interior nodes'
  // lists are dropped once their children have theirs).
  std::vector<std::vector<uint64_t>> leaf_cells;
};

// `progress` (optional) advances by one per level.
// `interpolant` (optional): a node the split test keeps whole still splits where it says so.
// `max_leaf_cells` (0: none): a node overlapping more cells splits whatever the tests say, down to level `deepest`
// (>= max_depth; OctreeBuildOptions::max_leaf_cells).
OctreeShape subdivide_octree(const UnstructuredMesh& mesh, const BrickLattice& lattice, const SplitTest& split,
                             int max_depth, Progress* progress = nullptr, const InterpolantCheck* interpolant = nullptr,
                             uint64_t max_leaf_cells = 0, int deepest = 0);

// The same, a node splitting where `splits` says (called from several threads at once), instead of the split test:
// the time store's union of the steps' trees (octree/builder.h), whose interior nodes are those of any step's tree.
OctreeShape subdivide_octree_where(const UnstructuredMesh& mesh, const BrickLattice& lattice, int max_depth,
                                   const std::function<bool(const OctreeNode&)>& splits, Progress* progress = nullptr);

}  // namespace ugvr
