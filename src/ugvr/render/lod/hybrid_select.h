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
//
// Degree of interest (`--focus FIELD:MIN:MAX[,...]`; Muigg's DOI, SimVis's brushes as value ranges): with focus ranges
// a node is a candidate only where one of them (OR) overlaps the node's value range of its field (the store's
// conservative subtree min / max): its interest is 1, else 0, and a node of zero interest is drawn from its brick and
// loads no cells. (Smooth brush edges, AND, and drawing the context desaturated are not done.)
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/lod/tf_error.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct FocusRange {
  std::string field;  // a store field name
  double min = 0, max = 0;
  bool operator==(const FocusRange&) const = default;
};
// "FIELD:MIN:MAX[,FIELD:MIN:MAX...]" (a field name may itself hold ':', as "velocity:magnitude": MIN and MAX are the
// last two). Throws ugvr::Error naming the text and what is wrong.
std::vector<FocusRange> parse_focus(std::string_view text);

// A focus range resolved against a store: field index and range.
struct ResolvedFocus {
  uint32_t field = 0;
  double min = 0, max = 0;
};
// Field names to indices; throws ugvr::Error listing the store's fields for an unknown name.
std::vector<ResolvedFocus> resolve_focus(const BrickStoreReader& store, std::span<const FocusRange> focus);
// 1 when `focus` is empty or one of its ranges overlaps the node's value range of that field, else 0.
double node_interest(const BrickStoreReader& store, uint64_t node, std::span<const ResolvedFocus> focus);

struct ExactCandidate {
  uint64_t node = 0;
  double priority = 0;
};

// The cut's nodes that may be drawn exact, highest priority first (ties: lower node id first).
// `focus`: the degree of interest (none: every node's is 1); `excluded`, if given, counts the nodes with cells left out
// for zero interest.
std::vector<ExactCandidate> exact_candidates(const BrickStoreReader& store, std::span<const uint64_t> cut,
                                             const Camera& camera, int width, int height, const TfNodeErrors& tf,
                                             std::span<const ResolvedFocus> focus = {}, uint64_t* excluded = nullptr);

}  // namespace ugvr
