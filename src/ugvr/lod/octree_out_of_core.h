// The out-of-core octree builder (Leven et al. 2002, figure 6): the same tree and bricks as build_octree
// (octree_builder.h) from a .vtu file whose cells never are in memory all at once.
//
//  1. The file's cells become a cell soup (octree_soup.h), the root's cell file, streamed from the .vtu
//     (octree_vtu_cells.h); the points and vertex scalars are read whole for that and freed afterwards.
//  2. process(node, file), depth first, subtrees in parallel: the node streams its file once through the split
//     test (VoxelSpread), keeping the records in memory as long as they fit its share of the budget. A node that
//     splits streams its file again, routes each cell to the children it overlaps (the same separating-axis test
//     and margin as in core), deletes its file and recurses; a leaf welds its records into a small mesh (vertices
//     by their ids, cells in id order, so the sampler's tie rule picks the same cell as in core), samples it with
//     the brick sampler and deletes its file. Interior bricks, padding and encoding are as in core.
//
// What differs from the in-core build, by design: node ids are given at split time (each split takes a block of
// consecutive ids for its children, which keeps the store's rules) so they depend on the schedule, and an interior
// node's error is measured at its children's samples only (its data points would have to be streamed again), then
// made monotone as in core. Leaves, their errors and every brick are the same (the tests compare them).
//
// Memory: the points and vertex scalars while the soup is written (12 + 4 bytes per point and scalar), then, per
// worker thread, one node's records up to its share of `memory_budget` (a leaf needs all of its own), its small mesh,
// the file buffers of a split (9 MiB) and the bricks of the subtrees in progress. Disk: the soup (80 bytes per
// tetrahedron with one scalar) and the files of the nodes pending, about twice the soup at most, next to the output.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ugvr/lod/octree_builder.h"

namespace ugvr {

OctreeBuildStats build_octree_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                          const OctreeBuildOptions& options, uint64_t memory_budget,
                                          const std::string& path);

}  // namespace ugvr
