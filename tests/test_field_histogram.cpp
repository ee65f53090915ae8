// The viewer's value histograms (src/ugvr/render/field_histogram.h): exact counts for known values, over a store
// exactly the valid samples of the nodes asked for, and a grid's weighted by volume (what auto is made from).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/default_transfer_function.h"
#include "ugvr/render/exact/exact_renderer.h"
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

// A slab crowded at one wall, as a curvilinear CFD grid packs its points: 10 thin cells (x in [0, 0.1], 0.01 wide)
// whose vertex field "v" and cell field "c" are 0.25, then 3 large ones (x up to 3) where they are 0.75. Counting
// points or cells, 0.25 is the mode; counting volume, 0.75 is (2.9 of the 3 unit-height cells' volume).
Block crowded_at_a_wall() {
  RectilinearGrid g;
  std::vector<double> x;
  for (int i = 0; i <= 10; ++i) x.push_back(0.01 * i);
  for (const double far : {1.0, 2.0, 3.0}) x.push_back(far);
  g.dims.points = {uint32_t(x.size()), 2, 2};
  g.coords = {x, {0, 1}, {0, 1}};
  std::vector<float> v, c;
  for (uint32_t k = 0; k < 2; ++k)
    for (uint32_t j = 0; j < 2; ++j)
      for (const double xi : x) v.push_back(xi <= 0.1 ? 0.25f : 0.75f);
  for (size_t i = 0; i + 1 < x.size(); ++i) c.push_back(x[i + 1] <= 0.1 ? 0.25f : 0.75f);
  Block b;
  b.grid = std::move(g);
  b.fields.add(Field("v", Association::Vertex, DataArray::from(std::move(v), 1)));
  b.fields.add(Field("c", Association::Cell, DataArray::from(std::move(c), 1)));
  return b;
}

// The same block as a curvilinear grid (its points listed), and as hexahedra of an unstructured mesh.
Grid as_curvilinear(const Block& b) {
  const auto& r = std::get<RectilinearGrid>(b.grid);
  StructuredGrid s;
  s.dims = r.dims;
  for (uint32_t k = 0; k < r.dims.points[2]; ++k)
    for (uint32_t j = 0; j < r.dims.points[1]; ++j)
      for (uint32_t i = 0; i < r.dims.points[0]; ++i) {
        const Vec3d p = r.point(i, j, k);
        s.points.push_back({float(p.x), float(p.y), float(p.z)});
      }
  return s;
}

TEST(FieldHistogram, VolumeWeightedModeIsWhatFillsTheVolume) {
  const Block b = crowded_at_a_wall();
  const Field& v = *b.fields.find("v");
  const Field& c = *b.fields.find("c");
  // Points and cells: the crowded wall's value is the mode.
  EXPECT_EQ(field_histogram(v, kMagnitude, 0, 1, 2), (Counts{44, 12}));
  EXPECT_EQ(field_histogram(c, kMagnitude, 0, 1, 2), (Counts{10, 3}));
  // By volume, scaled to the same totals. Cells: 0.1 against 2.9 of volume 3, times 13 / 3. Vertices: each corner a
  // an eighth of its cell: 0.25 holds the thin cells (0.1) and half the first large one (0.45), 0.75 the
  // rest (2.45); times 56 / 3.
  const Counts cw = volume_histogram(b.grid, c, kMagnitude, 0, 1, 2);
  const Counts vw = volume_histogram(b.grid, v, kMagnitude, 0, 1, 2);
  EXPECT_EQ(cw, (Counts{0, 13}));
  EXPECT_EQ(vw, (Counts{10, 46}));
  // The same weights from a curvilinear grid and from hexahedra (the mesh path the viewer's grid load takes).
  const Grid curvilinear = as_curvilinear(b);
  const Block hexes = to_unstructured_block(b, StructuredCellShape::Hexahedra);
  const auto& mesh = std::get<UnstructuredMesh>(hexes.grid);
  for (const Field* f : {&v, &c}) {
    const std::vector<double> want = volume_weights(b.grid, *f, kMagnitude, 0, 1, 2);
    EXPECT_NEAR(want[0] + want[1], 3.0, 1e-9) << f->name();
    const std::vector<double> s = volume_weights(curvilinear, *f, kMagnitude, 0, 1, 2);
    const std::vector<double> u = volume_weights(mesh, *hexes.fields.find(f->name()), kMagnitude, 0, 1, 2);
    for (size_t i = 0; i < 2; ++i) {
      EXPECT_NEAR(s[i], want[i], 1e-6) << f->name() << " bin " << i;
      EXPECT_NEAR(u[i], want[i], 1e-6) << f->name() << " bin " << i;
    }
  }
  EXPECT_EQ(volume_histogram(mesh, *hexes.fields.find("v"), kMagnitude, 2), (Counts{10, 46}));
}

TEST(FieldHistogram, VolumeWeightsSkipBlankedCellsAndFallBackWithoutVolume) {
  Block b = crowded_at_a_wall();
  StructuredGrid s = std::get<StructuredGrid>(as_curvilinear(b));
  // Blank the far end's points: the last large cell does not exist, 1.9 of volume is left at 0.75.
  s.iblank.assign(s.points.size(), 1);
  for (uint32_t p = 0; p < s.points.size(); ++p)
    if (p % s.dims.points[0] == s.dims.points[0] - 1) s.iblank[p] = 0;
  const std::vector<double> w = volume_weights(Grid(s), *b.fields.find("c"), kMagnitude, 0, 1, 2);
  EXPECT_NEAR(w[0], 0.1, 1e-6);
  EXPECT_NEAR(w[1], 1.9, 1e-6);
  // A flat grid (one point across z) has no volume: the unweighted counts.
  const Field flat("f", Association::Vertex, DataArray::from(std::vector<float>(28, 0.25f), 1));
  RectilinearGrid r = std::get<RectilinearGrid>(b.grid);
  r.dims.points[2] = 1;
  r.coords[2] = {0};
  EXPECT_EQ(volume_histogram(Grid(r), flat, kMagnitude, 0, 1, 2), (Counts{28, 0}));
  // A field that does not fit the grid is named.
  const Field wrong("wrong", Association::Cell, DataArray::from(std::vector<float>(5, 0.f), 1));
  try {
    volume_histogram(b.grid, wrong, kMagnitude, 0, 1, 2);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("wrong"), std::string::npos) << e.what();
  }
}

// What the default transfer function is made from on a mesh (ExactRenderer::value_histogram): volume-weighted, so
// auto hides the value that fills the volume (0.75), not the crowded wall's (0.25), for a vertex and a cell field.
TEST(FieldHistogram, AutoOnAMeshHidesTheValueThatFillsTheVolume) {
  Dataset ds;
  ds.blocks.push_back(crowded_at_a_wall());
  auto scene = std::make_shared<ExactScene>(std::make_shared<const Dataset>(std::move(ds)));
  ExactRenderer r(scene);
  for (const char* field : {"v", "c"}) {
    r.set_field(field);
    const TransferFunction tf = auto_transfer_function(r, 0, 1, r.bounds());
    EXPECT_EQ(tf.opacity(0.75), 0.0) << field;
    EXPECT_GT(tf.opacity(0.25), 0.4) << field;
    EXPECT_DOUBLE_EQ(tf.opacity_unit_distance, 0.1 * default_unit_distance(r.bounds())) << field << ": the mode hidden";
  }
}

}  // namespace
}  // namespace ugvr::view
