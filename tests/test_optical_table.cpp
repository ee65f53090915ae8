// The closed-form segment integration against brute-force quadrature, and the table's linearised extinction against
// the transfer function's definition.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ugvr/render/optical_table.h"

namespace ugvr {
namespace {

// Midpoint rule with many steps on the radiance and transmittance of one channel.
struct Reference {
  double radiance, transmittance;
};
Reference brute_force(const TransferFunction& tf, double s0, double s1, double length, int steps = 200000) {
  double radiance = 0, t = 1;
  const double h = length / steps;
  for (int i = 0; i < steps; ++i) {
    const double s = s0 + (s1 - s0) * (i + 0.5) / steps;
    const double a = 1 - std::exp(-tf.extinction(s) * h);
    radiance += t * a * tf.color(s).x;
    t *= 1 - a;
  }
  return {radiance, t};
}

TransferFunction ramp_tf() {
  TransferFunction tf;
  tf.color_points = {{0, {0.1, 0.2, 0.3}}, {0.4, {0.9, 0.1, 0.0}}, {1, {0.2, 0.8, 1.0}}};
  tf.opacity_points = {{0, 0}, {0.5, 0.3}, {1, 0.95}};
  tf.opacity_unit_distance = 0.5;
  return tf;
}

TEST(OpticalTable, TransmittanceMeanMatchesQuadrature) {
  const double values[] = {0, 1e-4, 0.03, 0.1, 0.11, 0.7, 2.5, 12, 60, 400};
  for (double a : values)
    for (double b : values) {
      const int n = 400000;
      double sum = 0;
      for (int i = 0; i < n; ++i) {
        const double u = (i + 0.5) / n;
        sum += std::exp(-(a * u + (b - a) * u * u / 2));
      }
      const double expected = sum / n;
      EXPECT_NEAR(segment_transmittance_mean(a, b), expected, 1e-7 * expected + 1e-9) << "A=" << a << " B=" << b;
    }
}

TEST(OpticalTable, ConstantSegmentIsClosedForm) {
  TransferFunction tf;
  tf.color_points = {{0, {0.5, 0.25, 1}}, {1, {0.5, 0.25, 1}}};
  tf.opacity_points = {{0, 0.4}, {1, 0.4}};
  tf.opacity_unit_distance = 2;
  const OpticalTable table(tf);
  RayAccumulator acc;
  table.integrate_linear_segment(0.3, 0.3, 3, acc);
  const double t = std::pow(1 - 0.4, 3.0 / 2);  // the table's opacity per unit distance, accumulated over 3
  EXPECT_NEAR(acc.transmittance, t, 1e-12);
  EXPECT_NEAR(acc.radiance.x, 0.5 * (1 - t), 1e-12);
  EXPECT_NEAR(acc.radiance.z, 1.0 * (1 - t), 1e-12);
}

TEST(OpticalTable, LinearSegmentsMatchBruteForce) {
  const TransferFunction tf = ramp_tf();
  const OpticalTable table(tf);
  const double cases[][3] = {{0, 1, 1}, {1, 0, 1}, {0.2, 0.45, 0.3}, {0.9, 0.1, 4}, {0.5, 0.5, 2}, {-1, 2, 0.7}};
  for (const auto& c : cases) {
    RayAccumulator acc;
    table.integrate_linear_segment(c[0], c[1], c[2], acc);
    const Reference ref = brute_force(tf, c[0], c[1], c[2]);
    // The table linearises extinction to kOpacityTolerance per unit distance; the rest is quadrature error.
    EXPECT_NEAR(acc.transmittance, ref.transmittance, 2e-4) << c[0] << " -> " << c[1];
    EXPECT_NEAR(acc.radiance.x, ref.radiance, 2e-4) << c[0] << " -> " << c[1];
  }
}

TEST(OpticalTable, SplittingASegmentChangesNothing) {
  const OpticalTable table(ramp_tf());
  RayAccumulator whole, halves;
  table.integrate_linear_segment(0.05, 0.85, 2, whole);
  table.integrate_linear_segment(0.05, 0.45, 1, halves);
  table.integrate_linear_segment(0.45, 0.85, 1, halves);
  EXPECT_NEAR(whole.transmittance, halves.transmittance, 1e-9);
  EXPECT_NEAR(whole.radiance.x, halves.radiance.x, 1e-9);
  EXPECT_NEAR(whole.radiance.y, halves.radiance.y, 1e-9);
}

TEST(OpticalTable, LinearisedExtinctionKeepsTheTablesOpacity) {
  TransferFunction tf = ramp_tf();
  tf.opacity_points = {{0, 0}, {1, 1}};  // ends at opacity 1: extinction grows without bound
  const OpticalTable table(tf);
  EXPECT_GT(table.size(), 4u);  // refined beyond the 3 colour points
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> s(0, 1);
  for (int i = 0; i < 10000; ++i) {
    const double x = s(rng);
    const double table_opacity = 1 - std::exp(-table.extinction_at(x) * tf.opacity_unit_distance);
    EXPECT_NEAR(table_opacity, std::min(tf.opacity(x), kMaxTableOpacity), kOpacityTolerance * 1.01) << x;
  }
}

TEST(OpticalTable, NanAndEmptySegmentsAddNothing) {
  const OpticalTable table(ramp_tf());
  RayAccumulator acc;
  table.integrate_linear_segment(std::nan(""), 0.5, 1, acc);
  table.integrate_linear_segment(0.5, 0.7, 0, acc);
  EXPECT_EQ(acc.transmittance, 1);
  EXPECT_EQ(acc.radiance.x, 0);
}

}  // namespace
}  // namespace ugvr
