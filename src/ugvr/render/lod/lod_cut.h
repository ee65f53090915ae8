// Choosing the cut of a brick store's octree that one frame renders (Leven et al. 2002, section 5; LaMar et al. 1999).
//
// Why. A brick store (lod/brick_store.h) holds the data at every level of an adaptive octree; the GPU ray caster
// (render/lod/) renders one set of nodes, a *cut*, whose bricks fit its atlas and which covers every visible part of
// the data exactly once: no cut node together with one of its ancestors, and every data-bearing leaf either below
// exactly one cut node or culled. This module chooses that set on the CPU, from the node table alone (no brick is
// read), for a criterion (CutSpec), a camera, an image size, a transfer function and a budget of atlas slots.
//
// How. Greedy top-down refinement with a priority queue: the cut starts as the root, and the node with the highest
// priority (error_max for "error:E", the projected size of one of its voxels in pixels for "pixels:P" and "leaves") is
// replaced by its children while the criterion wants it refined, it has children and the budget allows it. Refining
// replaces one node by its children that survive culling, so under a budget the most needed refinements happen first;
// a refinement that would take the cut past max_nodes is refused (budget_limited) and smaller ones further down the
// queue may still be made. Every node a refinement adds, and the root, is first classified:
//  - no data (a leaf without brick, or an empty value range): dropped silently;
//  - frustum culled: its box lies entirely outside one plane of the view frustum (4 side planes and, for both
//    projections, the plane through the camera perpendicular to the view direction: nothing behind the camera is
//    drawn); a conservative box-plane test, so a node any pixel ray reaches is never dropped;
//  - transfer-function culled: its subtree's value range [min, max] (FieldStats, conservative over the subtree) lies
//    where the opacity is exactly zero (tf_transparent_over); NaN ranges are never culled;
//  - without brick but with children (the store's format allows it; the builder makes a brick for every node with
//    data): refined on the spot, whatever the criterion and the budget say, since only nodes with bricks can be drawn;
//  - otherwise it joins the cut. A subtree dropped by culling is counted once, at its root.
// Since a node's box contains its descendants' boxes and its value range contains theirs, culling a node never drops
// a descendant that the same tests would keep: the cut covers exactly the data-bearing leaves that survive them.
//
// Criteria (the same numbers the builder and the renderer use):
//  - "leaves": refine every node down to the leaves (the full-resolution cut; under a budget, nearest and largest on
//    screen first);
//  - "error:E": refine while the node's error_max (max |brick sample - finest data| over its cell, the builder's
//  figure)
//    is > E × (field max - field min), the global range of the field in the store's header, as `ugvr build --error`;
//  - with CutOptions::tf_error, "pixels:P" compares the voxel's size times the node's transfer-function weight
//    (0 for a node transparent or uniform under the transfer function, 1 to 2 by its image error; tf_error.h) and
//    ranks nodes by that weighted size ("error:E" stays the data's own criterion, "leaves" the full resolution);
//  - "pixels:P": refine while one voxel of the node, h = edge / (R - 1) (R the brick resolution, edge the node box's
//    longest side), projects to more than P pixels: perspective h / (2 d tan(view_angle / 2)) · height with d the
//    distance from the camera plane to the nearest point of the box along the view direction (clamped to a tiny
//    positive value: a box reaching the camera plane always refines); parallel h / (2 parallel_scale) · height.
//
// Output: node ids, sorted ascending, each with a brick. Deterministic: no dependence on threads or allocation.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

class TfNodeErrors;  // render/lod/tf_error.h

struct CutSpec {
  enum class Kind { Leaves, Error, Pixels };
  Kind kind = Kind::Pixels;
  double value = 1;  // E for Error (>= 0), P for Pixels (> 0); 0 for Leaves
  bool operator==(const CutSpec&) const = default;
};

// "leaves" | "error:E" (E >= 0, finite, relative to the field's global range) | "pixels:P" (P > 0, finite: pixels per
// voxel). Throws ugvr::Error naming the spec and what is wrong.
CutSpec parse_cut_spec(std::string_view text);
// The text parse_cut_spec reads back to the same spec ("pixels:1.5").
std::string cut_spec_name(const CutSpec& spec);

struct CutOptions {
  uint32_t field = 0;                                         // whose stats and errors are used
  uint64_t max_nodes = std::numeric_limits<uint64_t>::max();  // budget: cut nodes (atlas slots), >= 1
  bool frustum_cull = true;
  bool tf_cull = true;
  // Weigh "pixels:P" texel sizes by the transfer-function-aware error (render/lod/tf_error.h): nodes transparent or
  // uniform under the transfer function are never split, nodes whose image differs from their finest data's are
  // split first (and to half the texel size). `tf_errors`: the caller's, already updated for this transfer function
  // and field (a renderer keeps one across frames); null: computed here for this call.
  bool tf_error = true;
  const TfNodeErrors* tf_errors = nullptr;
};

struct Cut {
  std::vector<uint64_t> nodes;                 // node ids, each with a brick, ascending; cover the visible data once
  uint64_t culled_frustum = 0, culled_tf = 0;  // subtrees dropped, counted at their root
  // Some refinement the criterion wanted was refused by max_nodes. Also set when even the coarsest possible cut (the
  // root, or its forced refinement when it has no brick) exceeds max_nodes: that cut is returned all the same.
  bool budget_limited = false;
  int max_level = 0;      // of the cut nodes (0 for an empty cut)
  double mean_level = 0;  // likewise
};

// Chooses the cut (see the header comment). `width` × `height` is the image the camera renders (CameraRays'
// conventions). Throws ugvr::Error for a field out of range, max_nodes 0, an invalid spec value, an image size < 1 or
// a degenerate camera (position at the focal point, view up parallel to the view direction, view angle outside
// (0, 180), parallel scale <= 0).
Cut select_cut(const BrickStoreReader& store, const CutSpec& spec, const Camera& camera, int width, int height,
               const TransferFunction& tf, const CutOptions& options = {});

// Whether the transfer function's opacity is exactly zero over the whole closed interval [lo, hi]: the opacity is
// piecewise linear between its points and clamped to the end values outside them (TransferFunction::opacity), so it
// is zero at lo, at hi and at every opacity point inside. No opacity point: opacity 0 everywhere (true). lo > hi
// (an empty range: no data): true. NaN lo or hi: false (nothing is known about the values). Infinite ends are fine.
bool tf_transparent_over(const TransferFunction& tf, double lo, double hi);

}  // namespace ugvr
