// The transfer function as the integrator sees it: colour c(s) and extinction tau(s) (transfer_function.h defines
// the optical model) as one piecewise-linear table over s, so that along a ray segment where s is linear in distance
// both are linear in distance between breakpoints and the ray integral has a closed form (pre-integration without
// tables: a transfer-function edit rebuilds this table in microseconds and nothing else).
//
// Layout: x[0] < x[1] < ... < x[n-1] (n >= 1), and at each x[i] the colour rgb[i] and extinction tau[i]; linear in
// between, constant beyond the ends. The breakpoints are the union of the transfer function's colour and opacity
// points, plus points inserted where tau = -ln(1 - a)/u, which is convex in the opacity a, would otherwise be
// linearised too coarsely: an interval is split until, at its midpoint, the opacity of a unit-distance slab computed
// from the linear tau differs from the table's opacity by at most kOpacityTolerance.
//
// integrate_linear_segment: for a segment of length l over which s goes linearly from s0 to s1, splits at the
// breakpoints it crosses and, per piece with tau and c linear (tau0 -> tau1, c0 -> c1 over length h),
//   T = exp(-(tau0 + tau1) h / 2),  psi = integral_0^1 exp(-(A u + (B - A) u^2 / 2)) du  (A = tau0 h, B = tau1 h)
//   radiance = c0 - c1 T + (c1 - c0) psi
// (integrate c tau T by parts: tau T = -dT/dx). psi comes from a 4-term Taylor series when the optical depth
// D = (A + B) / 2 <= 0.1 (error <= D^5/120 < 1e-7) and otherwise from 4-point Gauss-Legendre over pieces in which
// the exponent grows by at most 1/2 (relative error ~1e-9), stopping once it passes 40 (T < 5e-18).
#pragma once

#include <cstddef>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

inline constexpr double kOpacityTolerance = 1e-4;

// Front-to-back accumulation along one ray: premultiplied radiance and transmittance.
struct RayAccumulator {
  Vec3d radiance{0, 0, 0};
  double transmittance = 1;
  // Table interval of the last segment's end. Consecutive segments of a ray continue where the previous one ended,
  // so checking this first replaces a binary search (and its branch mispredictions) in almost every lookup.
  std::ptrdiff_t interval_hint = 0;
  double opacity() const { return 1 - transmittance; }
};

class OpticalTable {
 public:
  explicit OpticalTable(const TransferFunction& tf);

  size_t size() const { return x_.size(); }
  double x(size_t i) const { return x_[i]; }
  Vec3d color_at(double s) const;
  double extinction_at(double s) const;

  // Adds the emission and absorption of a segment of `length` over which s varies linearly from s0 to s1. A NaN
  // end makes the segment contribute nothing (NaN data is transparent, as in the transfer function).
  void integrate_linear_segment(double s0, double s1, double length, RayAccumulator& acc) const;
  // Same with the emitted colour scaled by `shade` (volume lighting: the shade is constant over the segment).
  void integrate_linear_segment(double s0, double s1, double length, double shade, RayAccumulator& acc) const;

  // The table as shaders/optical.glsl reads it (layout there): 8 floats per breakpoint.
  std::vector<float> pack_for_gpu() const;

 private:
  // Index i of the interval [x[i], x[i+1]) holding s; -1 below x[0]; n-1 at or above x[n-1].
  std::ptrdiff_t interval(double s) const;
  std::ptrdiff_t interval(double s, std::ptrdiff_t hint) const;
  void integrate_piece(double tau0, double tau1, Vec3d c0, Vec3d c1, double h, double shade, RayAccumulator& acc) const;

  std::vector<double> x_;
  std::vector<Vec3d> rgb_;
  std::vector<double> tau_;
  std::vector<double> inv_width_;  // 1 / (x[i+1] - x[i])
};

// psi(A, B) above; exposed for tests.
double segment_transmittance_mean(double a, double b);

}  // namespace ugvr
