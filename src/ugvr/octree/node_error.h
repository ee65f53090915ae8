// How far a node's brick is from the finest data it covers, per field: the store's error_max and error_rms
// (store/brick_store.h), which a renderer's level-of-detail choice reads.
//
// The brick is read the way a renderer reads it: padded (store/brick_pad.h) and trilinearly interpolated. It is
// compared
//  - at the mesh's data points inside the node (octree/data_points.h): the data itself, so a leaf's error is what
//    voxelization loses, typically a fraction of the split threshold;
//  - for an interior node, also at its children's data samples: each is the exact field at that point
//    (octree/downsample.h), so this is the error against the exact field on the next finer lattice.
// Points where none of the 8 surrounding samples has data are skipped: the stencil hides them, they are a loss of
// coverage (the valid fraction shows it), not of value.
//
// The builder then makes the figures monotone up the tree, error(parent) = max(measured, children's errors), for
// both max and rms: refining a node never raises the error, as the paper's cut refinement assumes, and the parent's
// figure covers what its descendants' finer lattices show (which it does not measure directly).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/data_points.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// The (node value, finest value) pairs of one node and field, for the transfer-function error table, as a histogram
// over the finest value: kErrorBins bins over the field's global range, each with its count and sum of squared
// differences, plus the exact extremes. A fixed 16 KiB per node and field in progress, no allocation per point;
// 1/1024 of the range is as fine as a renderer samples a transfer function (render/lod/tf_error.h).
inline constexpr int kErrorBins = 1024;
struct ErrorHistogram {
  ErrorHistogram(double field_min, double field_max)
      : lo(field_min), scale(field_max > field_min ? kErrorBins / (field_max - field_min) : 0.0) {}
  void add(double coarse, double fine) {
    const int b = std::clamp(int((fine - lo) * scale), 0, kErrorBins - 1);
    const double d = coarse - fine;
    ++count[size_t(b)];
    sum_sq[size_t(b)] += d * d;
    fine_min = std::min(fine_min, fine);
    fine_max = std::max(fine_max, fine);
    ++total;
  }
  double lo, scale;
  std::array<uint64_t, kErrorBins> count{};
  std::array<double, kErrorBins> sum_sq{};
  double fine_min = INFINITY, fine_max = -INFINITY;
  uint64_t total = 0;
};

struct ErrorSum {
  double max = 0, sum_sq = 0;
  uint64_t count = 0;
  ErrorHistogram* pairs = nullptr;  // when set, every measured point also goes into the histogram

  void add(double e) {
    max = e > max ? e : max;
    sum_sq += e * e;
    ++count;
  }
  // The node's value and the finest value at one point.
  void add(double coarse, double fine) {
    add(std::abs(coarse - fine));
    if (pairs) pairs->add(coarse, fine);
  }
  FieldError result() const;
};

// The transfer-function error entry (store/brick_store_format.h, TfErrorEntry) of a node from its pairs: the bins in
// kTfErrorGroups groups of about equal count, per group the range of finest values (bin edges, the exact extremes at
// both ends) and the rms difference. Codes over the field's global range [field_min, field_max]. No pair: an
// all-zero entry (unknown).
store_format::TfErrorEntry make_tf_error_entry(const ErrorHistogram& pairs, double field_min, double field_max);

// The brick's trilinear interpolation at lattice coordinates u (0..R-1 per axis, clamped), every field into
// out[0..F). Returns false, leaving out alone, where none of the 8 corners has data.
bool interpolate_brick(const BrickSamples& brick, Vec3d u, double* out);

// The split criterion's interpolant check (octree/split.h, error > 0): whether the brick (padded) read trilinearly
// departs from the cell's own interpolant by more than thresholds[f] at any of the cell's vertices, edge midpoints
// and its centre that lie in `box` (the node's first to last sample) and whose 8 surrounding samples all hold data
// (near the mesh boundary the pad's extrapolation, not the resolution, decides the value). The cell's interpolant at
// those points is exact without locating them: along an edge every cell type's interpolant and its map are linear in
// the edge parameter, so the midpoint is the mean of the two ends in position and in value; at the parametric centre
// (tetrahedron, wedge, hexahedron, and the pyramid's at height 1/5) every vertex has the same weight. `values[f]`: the
// cell's vertex values of field f in VTK order, or null for a field the cell's vertices do not carry (a cell field:
// constant per cell, which the voxel field cannot follow across faces at any resolution).
bool cell_interpolant_exceeds(const BrickSamples& brick, const Bounds& box, CellType type, const Vec3d* vertices,
                              std::span<const float* const> values, std::span<const double> thresholds);

// Adds |brick(p) - child sample| over every data sample of every child (children[o]: octant o, null = none).
// `brick` padded. sums: one per field.
void measure_against_children(const BrickSamples& brick, const std::array<const BrickSamples*, 8>& children,
                              std::span<ErrorSum> sums);

// Adds |brick(p) - value(p)| over `points` (ids of `data`, inside `box`, the node's first to last sample).
void measure_against_points(const BrickSamples& brick, const Bounds& box, const OctreeDataPoints& data,
                            std::span<const uint64_t> points, std::span<ErrorSum> sums);

// The same measure one point at a time, for points that are not in a mesh in memory (the out-of-core builder's leaves
// sampled in pieces: octree/out_of_core.h). `brick` padded, covering `box`; both must outlive this.
class BrickPointMeasure {
 public:
  BrickPointMeasure(const BrickSamples& brick, const Bounds& box);
  // Adds |brick(p) - exact[f]| to sums[f] for each field f whose exact[f] is not NaN (NaN: the point carries no value
  // of f), unless none of the 8 samples around p has data.
  void add(Vec3d p, const float* exact, std::span<ErrorSum> sums);

 private:
  const BrickSamples& brick_;
  Bounds box_;
  Vec3d scale_;
  std::vector<double> interpolated_;
};

}  // namespace ugvr
