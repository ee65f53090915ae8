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

#include <array>
#include <cstdint>
#include <span>

#include "ugvr/core/vec.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/data_points.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct ErrorSum {
  double max = 0, sum_sq = 0;
  uint64_t count = 0;

  void add(double e) {
    max = e > max ? e : max;
    sum_sq += e * e;
    ++count;
  }
  FieldError result() const;
};

// The brick's trilinear interpolation at lattice coordinates u (0..R-1 per axis, clamped), every field into
// out[0..F). Returns false, leaving out alone, where none of the 8 corners has data.
bool interpolate_brick(const BrickSamples& brick, Vec3d u, double* out);

// Adds |brick(p) - child sample| over every data sample of every child (children[o]: octant o, null = none).
// `brick` padded. sums: one per field.
void measure_against_children(const BrickSamples& brick, const std::array<const BrickSamples*, 8>& children,
                              std::span<ErrorSum> sums);

// Adds |brick(p) - value(p)| over `points` (ids of `data`, inside `box`, the node's first to last sample).
void measure_against_points(const BrickSamples& brick, const Bounds& box, const OctreeDataPoints& data,
                            std::span<const uint64_t> points, std::span<ErrorSum> sums);

}  // namespace ugvr
