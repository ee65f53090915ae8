// Interior bricks from their children: subsampling, coarse[x] = fine[2x].
//
// Lattice lines nest (octree/brick_sampler.h): sample x of a node lies on line 2x of the next level, which is a sample
// of exactly one child (or, for odd R - 1, of two children sharing that face). So a parent built this way holds the
// field's exact value at each of its samples, bit for bit what sampling the mesh there would give, and the same
// holds for its mask. Consequences, all by construction:
//  - neighbours of one level share identical border samples whatever the tree looks like around them, so the
//    paper's internal-border fix (its figure 8b: a child whose own children lack same-level neighbours) and its
//    loading of the 7 neighbours of each child (figure 8a) are not needed: every node is built from its own
//    children, depth first, with no I/O beyond them;
//  - a missing child (no cell overlaps it) means no sample of its box is in the mesh: the parent's samples there are
//    invalid, which is exactly right;
//  - coarse levels are point samples, not averages. The paper's 3x3 box filter smooths them, at the price of the
//    border bookkeeping above and of values that are no longer the data's; subsampling can alias features smaller
//    than the coarse voxels instead, which the node's error (octree/node_error.h) measures, so the renderer refines
//    there.
#pragma once

#include <array>
#include <cstdint>

#include "ugvr/octree/brick_sampler.h"

namespace ugvr {

// `children[o]`: the brick of the child in octant o (o = dx | dy << 1 | dz << 2), null where there is none; all of
// resolution R with the same field count. Fills `parent` (resized; values unpadded, invalid samples 0).
void downsample_children(uint32_t resolution, uint32_t fields, const std::array<const BrickSamples*, 8>& children,
                         BrickSamples& parent);

}  // namespace ugvr
