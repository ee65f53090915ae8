// The viewer's value histograms (src/ugvr/render/field_histogram.h): exact counts for known values, and over a store
// exactly the valid samples of the nodes asked for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/field_histogram.h"
#include "ugvr/store/brick_store.h"

namespace ugvr::view {
namespace {

using Counts = std::vector<uint64_t>;

uint64_t total(const Counts& c) { return std::accumulate(c.begin(), c.end(), uint64_t(0)); }

TEST(FieldHistogram, KnownValues) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> v = {0.0f, 0.1f, 0.25f, 0.5f, 0.74f, 0.75f, 1.0f, nan, -3.0f, 7.0f};
  // Bins [0, .25) [.25, .5) [.5, .75) [.75, 1]; below and above the range go to the end bins; NaN is skipped.
  EXPECT_EQ(value_histogram(v, 0, 1, 4), (Counts{3, 1, 2, 3}));
  const std::vector<double> d = {1, 2, 2, 3, 3, 3, std::numeric_limits<double>::infinity()};
  EXPECT_EQ(value_histogram(d, 1, 4, 3), (Counts{1, 2, 3}));
  EXPECT_EQ(value_histogram(d, 2, 2, 5), (Counts{0, 0, 6, 0, 0})) << "a constant range: the middle bin";
  EXPECT_EQ(value_histogram(std::span<const float>{}, 0, 1, 2), (Counts{0, 0}));
  EXPECT_THROW(value_histogram(v, 0, 1, 0), Error);
  EXPECT_THROW(value_histogram(d, 0, 1, kMaxHistogramBins + 1), Error);
}

TEST(FieldHistogram, GridFieldScalarAndMagnitude) {
  const Field s("s", Association::Vertex, DataArray::from(std::vector<int32_t>{0, 1, 2, 3, 4}, 1));
  EXPECT_EQ(field_histogram(s, kMagnitude, 2), (Counts{2, 3}));
  // A vector field by magnitude: 0, 5, 10 over [0, 10] in 2 bins; its x component: 0, 3, 6.
  const Field v("v", Association::Cell, DataArray::from(std::vector<double>{0, 0, 0, 3, 4, 0, 6, 8, 0}, 3));
  EXPECT_EQ(field_histogram(v, kMagnitude, 2), (Counts{1, 2}));
  EXPECT_EQ(field_histogram(v, 0, 3), (Counts{1, 1, 1}));
}

TEST(FieldHistogram, StoreCountsTheValidSamplesOfTheNodesAsked) {
  test::ScratchDir dir;
  const std::string path = dir.file("gen.ugvr");
  GenerateOptions g;
  g.cells = 3000;
  g.kind = GenCellKind::Mixed;
  const Dataset ds = generate_in_memory(g);
  const std::vector<std::string> fields = {"pressure", "velocity"};
  OctreeBuildOptions o;
  o.resolution = 8;
  o.max_depth = 3;
  build_octree(prepare_octree_input(ds, fields), o, path);
  const BrickStoreReader store(path);
  ASSERT_EQ(store.field_count(), 2u);
  const uint64_t r3 = uint64_t(store.resolution()) * store.resolution() * store.resolution();
  for (int max_level = 0; max_level <= 3; ++max_level) {
    uint64_t valid = 0;  // from the node table's valid fractions, independent of the decoder
    for (const BrickNode& n : store.nodes())
      if (n.level <= max_level && n.has_brick()) valid += uint64_t(std::llround(double(n.valid_fraction) * double(r3)));
    ASSERT_GT(valid, 0u);
    for (uint32_t f = 0; f < 2; ++f) {
      const Counts c = store_histogram(store, f, 32, max_level);
      ASSERT_EQ(c.size(), 32u);
      EXPECT_EQ(total(c), valid) << "field " << f << ", levels <= " << max_level;
      if (max_level == 3) {
        // A real distribution, not all in one bin (the range's extremes need not be sampled: bricks interpolate).
        EXPECT_LT(*std::max_element(c.begin(), c.end()), valid) << "field " << f;
      }
    }
  }
  EXPECT_THROW(store_histogram(store, 2, 32, 3), Error);
}

}  // namespace
}  // namespace ugvr::view
