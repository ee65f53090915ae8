// The default transfer function's rule (render/default_transfer_function.h): the histogram's dominant mode made
// transparent, the ramp kept where there is none.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "ugvr/render/default_transfer_function.h"
#include "ugvr/render/field_histogram.h"

namespace ugvr {
namespace {

using Counts = std::vector<uint64_t>;

const Bounds kBounds{{0, 0, 0}, {10, 0, 0}};  // diagonal 10: the ramp's unit distance is 1

// A free stream: most values in a narrow bump at 0.7 of the range, the rest spread thinly over all of it.
Counts free_stream(int bins = 100) {
  Counts c(size_t(bins), 10);
  const int peak = bins * 7 / 10;
  c[size_t(peak)] = 5000;
  c[size_t(peak - 1)] = 2000;
  c[size_t(peak + 1)] = 1500;
  c[size_t(peak + 2)] = 400;  // below a quarter of the peak: the skirt, not the bump
  return c;
}

void expect_valid(const TransferFunction& tf) {
  EXPECT_NO_THROW(tf.validate("test"));  // sorted, opacities in [0, 1], finite numbers
}

TEST(DefaultTransferFunction, PeakedHistogramHidesTheModeAndShowsTheRest) {
  const Counts c = free_stream();
  const std::optional<ModeBump> mode = dominant_mode(c);
  ASSERT_TRUE(mode);
  EXPECT_EQ(mode->first, 69);
  EXPECT_EQ(mode->last, 71);
  const TransferFunction tf = auto_transfer_function(c, -1, 1, kBounds);
  expect_valid(tf);
  EXPECT_EQ(tf.name, "auto");
  // Bins 69..71 cover [0.38, 0.44]: transparent there, opaque at both ends, rising in between.
  EXPECT_EQ(tf.opacity(0.40), 0.0);
  EXPECT_NEAR(tf.opacity(0.38), 0.0, 1e-9);
  EXPECT_NEAR(tf.opacity(0.44), 0.0, 1e-9);
  EXPECT_EQ(tf.opacity(-1), 1.0);
  EXPECT_EQ(tf.opacity(1), 1.0);
  EXPECT_GT(tf.opacity(-0.5), 0.5);
  EXPECT_GT(tf.opacity(0.9), 0.5);
  EXPECT_LT(tf.opacity(0.3), tf.opacity(0.0));
  // The ramp would draw the mode at 0.7, the haze the rule is there to remove.
  EXPECT_NEAR(default_transfer_function(-1, 1, kBounds).opacity(0.40), 0.7, 1e-12);
  // What is left is a few cells: a shorter unit distance than the ramp's.
  EXPECT_DOUBLE_EQ(tf.opacity_unit_distance, kHiddenModeUnitDistanceScale * default_unit_distance(kBounds));
  // Colours are viridis over the range either way.
  EXPECT_EQ(tf.color_points, default_transfer_function(-1, 1, kBounds).color_points);
}

TEST(DefaultTransferFunction, BimodalHistogramHidesTheTallerMode) {
  Counts c(64, 0);
  c[10] = 900, c[11] = 400;  // the taller mode
  c[50] = 300;               // a second mode: over 1/4 of 900 but not next to the first bump, so it stays visible
  const std::optional<ModeBump> mode = dominant_mode(c);
  ASSERT_TRUE(mode);
  EXPECT_EQ(mode->first, 10);
  EXPECT_EQ(mode->last, 11);
  EXPECT_NEAR(mode->share, 1300.0 / 1600.0, 1e-12);
  const TransferFunction tf = auto_transfer_function(c, 0, 64, kBounds);
  expect_valid(tf);
  EXPECT_EQ(tf.opacity(11), 0.0);
  EXPECT_GT(tf.opacity(50.5), 0.5);
}

TEST(DefaultTransferFunction, ModeAtAnEndRisesOnTheOtherSideOnly) {
  Counts low(32, 5);
  low[0] = 1000;
  const TransferFunction a = auto_transfer_function(low, 0, 32, kBounds);
  expect_valid(a);
  EXPECT_EQ(a.opacity(0), 0.0);
  EXPECT_EQ(a.opacity(1), 0.0);
  EXPECT_EQ(a.opacity(32), 1.0);
  Counts high(32, 5);
  high[31] = 1000;
  const TransferFunction b = auto_transfer_function(high, 0, 32, kBounds);
  expect_valid(b);
  EXPECT_EQ(b.opacity(0), 1.0);
  EXPECT_EQ(b.opacity(31.5), 0.0);
  EXPECT_EQ(b.opacity(32), 0.0);
}

// Without a dominant mode the old default, exactly (but the name): viridis's ramp over the range.
void expect_the_ramp(const Counts& c, double lo, double hi, const char* what) {
  SCOPED_TRACE(what);
  EXPECT_FALSE(dominant_mode(c));
  TransferFunction tf = auto_transfer_function(c, lo, hi, kBounds);
  expect_valid(tf);
  EXPECT_EQ(tf.name, "auto");
  tf.name = "viridis";
  EXPECT_EQ(tf, default_transfer_function(lo, hi, kBounds));
  for (const OpacityPoint& p : tf.opacity_points) EXPECT_FALSE(std::isnan(p.x) || std::isnan(p.opacity));
}

TEST(DefaultTransferFunction, FlatHistogramKeepsTheRamp) { expect_the_ramp(Counts(100, 37), -2, 5, "flat"); }

TEST(DefaultTransferFunction, SmoothAnalyticFieldKeepsTheRamp) {
  // sin sampled evenly piles up at its ends (7x the mean bin here), but that bump holds too little of the data.
  std::vector<double> values;
  for (int i = 0; i < 100000; ++i) values.push_back(std::sin(2 * std::numbers::pi * (i + 0.5) / 100000));
  const Counts c = value_histogram(values, -1, 1, kAutoTfBins);
  const uint64_t peak = *std::max_element(c.begin(), c.end());
  EXPECT_GT(double(peak), 5.0 * 100000 / kAutoTfBins) << "the test's field is peaked at its ends";
  expect_the_ramp(c, -1, 1, "sine");
}

TEST(DefaultTransferFunction, DegenerateHistogramsKeepTheRamp) {
  expect_the_ramp(Counts{}, 0, 1, "no bins");
  expect_the_ramp(Counts{12345}, 0, 1, "one bin");
  expect_the_ramp(Counts(50, 0), 0, 1, "all zero counts");
  // A few values equally common (a field of 3 values), or two modes of about one height: which to hide is a guess.
  Counts few(128, 0);
  few[0] = few[64] = few[127] = 4;
  expect_the_ramp(few, 0, 1, "three values");
  Counts twins(64, 1);
  twins[10] = 500, twins[40] = 400;
  expect_the_ramp(twins, 0, 1, "two modes");
  // A wide bump (most of the range) is no free stream.
  Counts wide(10, 100);
  wide[0] = wide[9] = 0;
  expect_the_ramp(wide, 0, 1, "wide bump");
}

TEST(DefaultTransferFunction, DegenerateRangesStayFinite) {
  const Counts c = free_stream();
  for (const auto& [lo, hi] : {std::pair{3.0, 3.0}, std::pair{std::nan(""), std::nan("")}}) {
    const TransferFunction tf = auto_transfer_function(c, lo, hi, kBounds);
    expect_valid(tf);
    const std::vector<OpacityPoint> points = auto_opacity_points(c, lo, hi);
    ASSERT_FALSE(points.empty());
    for (const OpacityPoint& p : points) EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.opacity));
  }
}

}  // namespace
}  // namespace ugvr
