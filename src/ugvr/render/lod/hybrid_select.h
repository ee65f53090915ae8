// Which nodes of a cut get exact cells (hybrid rendering, docs/hybrid.md; Muigg 2007, section 4.3.2, with the
// priority the [hybrid] issue asks for instead of his DOI entropy): per node, priority = screen-space error × the
// transfer-function-aware data error.
//  - Screen-space error: pixels covered by one texel of the node's brick at its nearest depth (view_metrics.h), the
//    cut's own criterion: a voxel larger on screen hides more of the cells' detail.
//  - Data error: TfNodeErrors::error (tf_error.h), how far the node's voxels differ from its finest data under the
//    current transfer function; unknown (a store without the table; MIP and isosurfaces, where a node transparent
//    under the transfer function still holds the ray's maximum or a surface: lod_engine.cpp passes no table): 1,
//    the screen-space error alone.
// Nodes without cells in the store, and nodes whose data error is exactly 0 (transparent or uniform under the transfer
// function: their voxels and their cells draw the same nothing), are no candidates. The cell cache (cell_cache.h)
// grants candidates in this order within its budget; the rest stay resampled.
//
// Degree of interest (Muigg's DOI; SimVis's brushes as value ranges, LaMar's region of interest as a box or sphere).
// A node's interest is in [0, 1]:
//  - focus (`--focus`): a list of value-range brushes on any of the store's fields, ranges joined by '+' ANDed (the
//    least of their interests), the groups separated by ',' ORed (the greatest) ("pressure:0:1+velocity:2:3,
//    temperature:5:9"). A range may have a smooth edge ("pressure:0:1~0.1", SimVis's brushes): a value's interest is
//    1 in [MIN, MAX] and falls to 0 over EDGE outside it (focus_window). For a node, a range's interest is the window
//    at the distance between [MIN, MAX] and the node's value range of its field (the store's conservative subtree
//    min / max): the most any of its values can have, 1 where the ranges overlap. Without edges: 1 or 0 as before;
//  - region of interest (`--roi box:X0,Y0,Z0,X1,Y1,Z1` or `sphere:CX,CY,CZ,R`, world coordinates): it holds where the
//    node's box meets the region;
//  - both given, both must hold. None: every node's interest is 1.
// A node of zero interest is no candidate: it is drawn from its brick and loads no cells; with focus or a region set,
// it is drawn as context (desaturated and faint, LodOptions::context_*, Muigg eq. 3.15). The candidates' priority is
// multiplied by their interest. The store's per-node ranges bound the values, they do not say how much of a node is
// inside: the smooth border within a node is drawn per sample by the LOD shader (lod_engine.cpp set_focus_windows).
#pragma once

#include <cstdint>
#include <optional>
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
  uint32_t group = 0;  // ranges of one group (joined by '+') must all hold; any group (separated by ',') will do
  double edge = 0;     // >= 0, the field's units: the interest falls from 1 at MIN / MAX to 0 at EDGE beyond them
  bool operator==(const FocusRange&) const = default;
};
// "FIELD:MIN:MAX[~EDGE][+FIELD:MIN:MAX[~EDGE]...][,...]" (a field name may itself hold ':', as "velocity:magnitude":
// MIN and MAX are the last two; it may not hold ',' or '+'; a '~' after the last ':' starts the edge). Throws
// ugvr::Error naming the text and what is wrong.
std::vector<FocusRange> parse_focus(std::string_view text);
// The text parse_focus reads back (numbers with 17 significant digits).
std::string focus_text(std::span<const FocusRange> focus);

// LaMar's region of interest, in world coordinates.
struct RegionOfInterest {
  enum class Shape { Box, Sphere };
  Shape shape = Shape::Box;
  Vec3d lo{0, 0, 0}, hi{0, 0, 0};  // a box: its corners, lo <= hi
  Vec3d centre{0, 0, 0};           // a sphere
  double radius = 0;               // > 0
  // Whether the region meets the axis-aligned box b (closed sets: touching counts).
  bool meets(const Bounds& b) const;
  bool operator==(const RegionOfInterest&) const = default;
};
// "box:X0,Y0,Z0,X1,Y1,Z1" (any two opposite corners) or "sphere:CX,CY,CZ,R". Throws ugvr::Error naming `source` (the
// flag or key) and what is wrong.
RegionOfInterest parse_roi(std::string_view text, std::string_view source = "--roi");
std::string roi_text(const RegionOfInterest& roi);

// The interest of a value at `distance` (>= 0) outside a range whose edge is `edge`: 1 at the range, falling smoothly
// (1 - smoothstep) to 0 at the edge's end; a range without edge: 1 at distance 0, else 0. shaders/lod_raycast.comp
// focus_window is the same function.
double focus_window(double distance, double edge);

// A focus range resolved against a store: field index and range.
struct ResolvedFocus {
  uint32_t field = 0;
  double min = 0, max = 0;
  uint32_t group = 0;
  double edge = 0;
};
// Field names to indices; throws ugvr::Error listing the store's fields for an unknown name.
std::vector<ResolvedFocus> resolve_focus(const BrickStoreReader& store, std::span<const FocusRange> focus);

// What a node's interest is taken from: the resolved focus ranges and the region of interest (either may be absent).
struct NodeInterest {
  std::vector<ResolvedFocus> focus;
  std::optional<RegionOfInterest> roi;
  bool any() const { return !focus.empty() || roi.has_value(); }
};
// The focus's interest (above; no focus: 1), times 1 where the node meets the region of interest (no region: 1) and
// 0 where it does not.
double node_interest(const BrickStoreReader& store, uint64_t node, const NodeInterest& interest);
double node_interest(const BrickStoreReader& store, uint64_t node, std::span<const ResolvedFocus> focus);

struct ExactCandidate {
  uint64_t node = 0;
  double priority = 0;
};

// The cut's nodes that may be drawn exact, highest priority first (ties: lower node id first).
// `interest`: the degree of interest (none: every node's is 1); `excluded`, if given, counts the nodes with cells left
// out for zero interest.
std::vector<ExactCandidate> exact_candidates(const BrickStoreReader& store, std::span<const uint64_t> cut,
                                             const Camera& camera, int width, int height, const TfNodeErrors& tf,
                                             const NodeInterest& interest = {}, uint64_t* excluded = nullptr);

}  // namespace ugvr
