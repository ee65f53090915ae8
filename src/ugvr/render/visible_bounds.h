// The default view frames what the transfer function leaves visible (docs/first-look.md, issue 25 part 5).
//
// Why: the "auto" transfer function (default_transfer_function.h) makes the free stream transparent, and what is left
// is often small (a wing among a 30 x 30 x 2 slab): framed on the whole domain it is a speck in an empty frame. The
// first view keeps default_camera's direction but fits its distance and focal point to the box of the visible part.
//
// "Visible": the largest opacity the transfer function reaches over a piece of the data's value range is above
// kVisibleOpacity. A piece is a cell of a mesh (its vertices' [min, max], which bounds the cell's interpolant, or its
// own value for a cell field) or an octree node of a store, down to kVisibleLevel (its subtree's [min, max] from the
// node table: no brick is read).
//
// The box is weighted by what is seen: each visible piece weighs its largest opacity times its volume, and per axis
// the box keeps the pieces whose centres fall in the central kFramedShare of that weight (the tails, kFramedShare's
// complement split between both ends, are dropped), then spans those pieces' own extents; clipped to the data's
// bounds. Why: a plain union counts a faint thin wake tube far downstream as much as the wing, so the box stretches
// to it and the wing sits off centre; such a tube holds a sliver of the weight. The weight is binned along each axis
// (VisibleWeights: kFramingBins bins over the data's bounds), so the cut is at a bin: a bin's pieces are kept or
// dropped together. No weight at all (every visible piece flat) gives the union of the visible pieces.
//
// The rule (framed_default_camera): nothing visible, no answer from the renderer, or a box that spans at least
// kNearlyAllVisible of the domain on every axis -> default_camera(bounds), today's view. Otherwise default_camera(box),
// with the box widened about its centre to at least kMinVisibleFraction of the bounds' diagonal, so that one visible
// cell does not fill the screen. Only the default camera with the auto transfer function is framed this way (the front
// ends decide: an explicit
// --tf, --camera or --view keeps today's view, bit for bit).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

class BrickStoreReader;
class ExactEngine;
class Renderer;
struct WalkMesh;

inline constexpr double kVisibleOpacity = 0.05;
inline constexpr int kVisibleLevel = 6;
inline constexpr double kMinVisibleFraction = 0.05;
inline constexpr double kNearlyAllVisible = 0.9;
inline constexpr double kFramedShare = 0.97;
inline constexpr int kFramingBins = 256;

// The visible pieces' weights along the three axes (the rule above). Layout: per axis a, bin i covers
// [over.lo[a] + i * w, over.lo[a] + (i + 1) * w), w = over.size()[a] / kFramingBins (centres outside go to the end
// bins); weight[a][i] sums opacity x volume of the pieces whose centre is there, lo[a][i] / hi[a][i] the least / most
// coordinate on axis a of those pieces (+inf / -inf when none). `all` is the union of every visible piece's box.
struct VisibleWeights {
  Bounds over;
  std::array<std::array<double, kFramingBins>, 3> weight{}, lo{}, hi{};
  Bounds all;

  explicit VisibleWeights(const Bounds& over);
  void add(const Bounds& piece, double weight);
  // Another's pieces, over the same `over` (a partitioned store's pieces, MPI ranks' parts).
  void merge(const VisibleWeights& other);
  // The box of the rule above; empty Bounds when nothing was added.
  Bounds box() const;

  // Flattened for Renderer::visible_weights and MPI reductions: [weight (axis-major) | lo, all.lo | hi, all.hi], so
  // that ranks reduce it with one sum and one min and one max over contiguous ranges.
  static constexpr size_t kAxisBins = 3 * size_t(kFramingBins);
  static constexpr size_t kFlatSize = 3 * kAxisBins + 6;
  std::vector<double> flat() const;
  // nullopt when `values` is not kFlatSize long.
  static std::optional<VisibleWeights> from_flat(const Bounds& over, std::span<const double> values);
};

// The `own` box that keeps every piece (below).
Bounds all_space();
// Whether a piece centred at `c` is one's own: lo <= c < hi on every axis (neighbouring boxes that share a face own
// disjoint sets: each piece is counted once over MPI ranks whose kd-tree boxes are `own`).
bool owns(const Bounds& own, Vec3d c);

// The largest opacity `tf` gives a value in [lo, hi] (its opacity points are piecewise linear, clamped at both ends).
// NaN bounds give 0.
double max_opacity(const TransferFunction& tf, double lo, double hi);

// The box (weighted, the rule above) of the cells of `mesh` whose values reach more than `threshold` opacity. `values`
// are per vertex (indexed as mesh.points) or, with `per_cell`, per cell in the mesh's order. Empty Bounds when none
// does.
Bounds visible_cell_bounds(const WalkMesh& mesh, std::span<const float> values, bool per_cell,
                           const TransferFunction& tf, double threshold = kVisibleOpacity);

// The same over the exact engine's walk mesh and the values of its bound field.
Bounds visible_cell_bounds(const ExactEngine& engine, const TransferFunction& tf, double threshold = kVisibleOpacity);

// The weights behind visible_cell_bounds, binned over `over`, of the cells whose centroid (the mean of their
// vertices, as the MPI kd-tree's) `own` owns.
VisibleWeights visible_cell_weights(const WalkMesh& mesh, std::span<const float> values, bool per_cell,
                                    const TransferFunction& tf, double threshold, const Bounds& over,
                                    const Bounds& own);
VisibleWeights visible_cell_weights(const ExactEngine& engine, const TransferFunction& tf, double threshold,
                                    const Bounds& over, const Bounds& own);

// The box (weighted, the rule above) of the store's nodes at level `max_level` (and leaves above it) whose subtree
// range of field `field` reaches more than `threshold` opacity, at the store's current step. Empty Bounds when none
// does.
Bounds visible_node_bounds(const BrickStoreReader& store, uint32_t field, const TransferFunction& tf,
                           double threshold = kVisibleOpacity, int max_level = kVisibleLevel);

// The weights behind visible_node_bounds, binned over `over`, of the nodes whose box centre `own` owns.
VisibleWeights visible_node_weights(const BrickStoreReader& store, uint32_t field, const TransferFunction& tf,
                                    double threshold, int max_level, const Bounds& over, const Bounds& own);

// The same for the field named `field`; nullopt when the store does not hold it.
std::optional<Bounds> visible_node_bounds(const BrickStoreReader& store, const std::string& field,
                                          const TransferFunction& tf, double threshold = kVisibleOpacity);

// The rule above, given the data's bounds and the visible box (nullopt: the renderer cannot say).
Camera framed_default_camera(const Bounds& bounds, const std::optional<Bounds>& visible, double view_angle = 30);
// The same with Renderer::visible_bounds (under MPI a collective call: every rank gets the same camera).
Camera framed_default_camera(const Renderer& renderer, const TransferFunction& tf, double view_angle = 30);

}  // namespace ugvr
