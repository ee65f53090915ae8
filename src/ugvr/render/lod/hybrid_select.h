// Which nodes of a cut get exact cells (hybrid rendering, docs/hybrid.md; Muigg 2007, section 4.3.2, with the
// priority the [hybrid] issue asks for instead of his DOI entropy): per node, priority = screen-space error × the
// transfer-function-aware data error.
//  - Screen-space error: pixels covered by one texel of the node's brick at its nearest depth (view_metrics.h), the
//    cut's own criterion: a voxel larger on screen hides more of the cells' detail.
//  - Data error: TfNodeErrors::error (tf_error.h), how far the node's voxels differ from its finest data under the
//    current transfer function; unknown (a store without the table): 1, the screen-space error alone.
// Nodes without cells in the store, and nodes whose data error is exactly 0 (transparent or uniform under the transfer
// function: their voxels and their cells draw the same nothing), are no candidates. The cell cache (cell_cache.h)
// grants candidates in this order within its budget; the rest stay resampled.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/lod/tf_error.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct ExactCandidate {
  uint64_t node = 0;
  double priority = 0;
};

// The cut's nodes that may be drawn exact, highest priority first (ties: lower node id first).
std::vector<ExactCandidate> exact_candidates(const BrickStoreReader& store, std::span<const uint64_t> cut,
                                             const Camera& camera, int width, int height, const TfNodeErrors& tf);

}  // namespace ugvr
