// The default view frames what the transfer function leaves visible (render/visible_bounds.h): the box of a mesh's
// cells and of a store's coarse nodes that reach opacity, and the rule that frames default_camera's direction on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "hex_fixtures.h"
#include "test_data.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/render/exact/exact_renderer.h"
#include "ugvr/render/visible_bounds.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

constexpr int kCells = 8;  // per axis; points 0..8

// A cube of kCells^3 unit hexahedra whose vertex field "blob" is 1 at the points with i, j, k <= 1 (a corner) and 0
// elsewhere, and whose cell field "cblob" is 1 in the cell at (6, 6, 6) (the opposite corner) only.
Dataset corner_blob() {
  UnstructuredMesh m = test::unit_hex_mesh(kCells);
  std::vector<float> blob, cblob;
  for (const Vec3f& q : m.points) blob.push_back(q.x <= 1 && q.y <= 1 && q.z <= 1 ? 1.f : 0.f);
  const uint64_t corner = 6 + kCells * (6 + kCells * 6);  // cell (6, 6, 6): hex_fixtures.h's layout
  for (uint64_t c = 0; c < m.cell_count(); ++c) cblob.push_back(c == corner ? 1.f : 0.f);
  Block b;
  b.grid = std::move(m);
  b.fields.add(Field("blob", Association::Vertex, DataArray::from(std::move(blob), 1)));
  b.fields.add(Field("cblob", Association::Cell, DataArray::from(std::move(cblob), 1)));
  Dataset ds;
  ds.blocks.push_back(std::move(b));
  return ds;
}

TransferFunction ramp(double a0, double a1) {
  TransferFunction tf = builtin_preset("viridis");
  tf.opacity_points = {{0, a0}, {1, a1}};
  return tf;
}

void expect_box(const Bounds& b, Vec3d lo, Vec3d hi) {
  ASSERT_FALSE(b.empty());
  for (int a = 0; a < 3; ++a) {
    EXPECT_DOUBLE_EQ(b.lo[a], lo[a]) << "axis " << a;
    EXPECT_DOUBLE_EQ(b.hi[a], hi[a]) << "axis " << a;
  }
}

Bounds whole() {
  Bounds b;
  b.lo = {0, 0, 0};
  b.hi = {kCells, kCells, kCells};
  return b;
}

TEST(VisibleBounds, MaxOpacityFindsAPeakInsideTheRange) {
  TransferFunction tf = builtin_preset("viridis");
  tf.opacity_points = {{0, 0}, {0.5, 0.8}, {0.6, 0}, {1, 0}};
  EXPECT_DOUBLE_EQ(max_opacity(tf, 0, 1), 0.8);        // neither end reaches it: the point inside does
  EXPECT_DOUBLE_EQ(max_opacity(tf, 0.7, 1), 0.0);      // past the peak
  EXPECT_DOUBLE_EQ(max_opacity(tf, 0.25, 0.25), 0.4);  // one value
  EXPECT_DOUBLE_EQ(max_opacity(tf, NAN, 1), 0.0);
}

TEST(VisibleBounds, MeshBoxIsTheCornerThatReachesOpacity) {
  auto scene = std::make_shared<ExactScene>(std::make_shared<const Dataset>(corner_blob()));
  ExactRenderer r(scene);
  r.set_field("blob");
  // The cells touching a point of value 1: cells 0 and 1 on each axis.
  const std::optional<Bounds> box = r.visible_bounds(ramp(0, 1), kVisibleOpacity);
  ASSERT_TRUE(box);
  expect_box(*box, {0, 0, 0}, {2, 2, 2});
  // A cell field: the one cell of value 1.
  r.set_field("cblob");
  const std::optional<Bounds> cell = r.visible_bounds(ramp(0, 1), kVisibleOpacity);
  ASSERT_TRUE(cell);
  expect_box(*cell, {6, 6, 6}, {7, 7, 7});
  // Nothing reaches the threshold: an empty box.
  r.set_field("blob");
  const std::optional<Bounds> none = r.visible_bounds(ramp(0, 0.01), kVisibleOpacity);
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->empty());
}

TEST(VisibleBounds, StoreBoxIsTheCornerThatReachesOpacity) {
  test::ScratchDir dir;
  write_vtu(corner_blob(), dir.file("blob.vtu"));
  ASSERT_EQ(test::run_ugvr("build " + dir.file("blob.vtu") + " --fields blob -o " + dir.file("blob.ugvr")).status, 0);
  const BrickStoreReader store(dir.file("blob.ugvr"));
  const Bounds box = visible_node_bounds(store, 0, ramp(0, 1));
  ASSERT_FALSE(box.empty());
  // Nodes are conservative (a node's range covers its subtree, and its cell may be larger than the cells it holds):
  // the box holds the corner and stays inside the lower half of every axis.
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(box.lo[a], 0.0) << "axis " << a;
    EXPECT_GE(box.hi[a], 2.0) << "axis " << a;
    EXPECT_LE(box.hi[a], 0.5 * kCells) << "axis " << a;
  }
  EXPECT_TRUE(visible_node_bounds(store, 0, ramp(0, 0.01)).empty());
}

TEST(VisibleBounds, DefaultCameraFramesTheVisibleBoxAlongTheSameDirection) {
  const Camera today = default_camera(whole());
  Bounds corner;
  corner.lo = {0, 0, 0};
  corner.hi = {2, 2, 2};
  const Camera framed = framed_default_camera(whole(), corner);
  EXPECT_EQ(framed, default_camera(corner));
  EXPECT_NEAR(dot(framed.direction(), today.direction()), 1.0, 1e-12);
  EXPECT_LT(framed.distance(), 0.5 * today.distance());
  // Nothing visible, no answer, or everything visible: today's view.
  EXPECT_EQ(framed_default_camera(whole(), Bounds{}), today);
  EXPECT_EQ(framed_default_camera(whole(), std::nullopt), today);
  EXPECT_EQ(framed_default_camera(whole(), whole()), today);
  Bounds nearly = whole();
  nearly.lo = {0.5, 0.5, 0.5};  // 94 % of each axis
  EXPECT_EQ(framed_default_camera(whole(), nearly), today);
  nearly.lo.z = 1;  // 87.5 % of z: framed
  EXPECT_NE(framed_default_camera(whole(), nearly), today);
  // A node sticking out of the data is clipped to it first.
  Bounds beyond = whole();
  beyond.lo = {-4, -4, -4};
  EXPECT_EQ(framed_default_camera(whole(), beyond), today);
  // One point visible: widened to kMinVisibleFraction of the diagonal, not a camera at the point.
  Bounds point;
  point.add(Vec3d{4, 4, 4});
  const Camera tiny = framed_default_camera(whole(), point);
  EXPECT_NEAR(2 * tiny.parallel_scale, kMinVisibleFraction * length(whole().size()), 1e-9);
}

TEST(VisibleBounds, RendererDefaultCameraUsesTheBox) {
  auto scene = std::make_shared<ExactScene>(std::make_shared<const Dataset>(corner_blob()));
  ExactRenderer r(scene);
  r.set_field("blob");
  Bounds corner;
  corner.lo = {0, 0, 0};
  corner.hi = {2, 2, 2};
  EXPECT_EQ(framed_default_camera(r, ramp(0, 1)), default_camera(corner));
  EXPECT_EQ(framed_default_camera(r, ramp(0, 0.01)), default_camera(whole()));
}

// A bright blob (cells of x, y, z in [0, 2], value 1) and, across the domain, a faint thin tube (the cells of y and z
// in [9.9, 10] along all of x, value 0.1: opacity 0.1 under ramp(0, 1), above kVisibleOpacity), as a wing and a
// faint wake. The tube holds 0.1 % of opacity x volume.
Dataset blob_and_faint_tube() {
  RectilinearGrid g;
  std::vector<double> x, yz;
  for (int i = 0; i <= 10; ++i) x.push_back(i);
  for (int i = 0; i <= 9; ++i) yz.push_back(i);
  yz.push_back(9.9);
  yz.push_back(10);
  g.dims.points = {uint32_t(x.size()), uint32_t(yz.size()), uint32_t(yz.size())};
  g.coords = {x, yz, yz};
  std::vector<float> value;
  for (size_t k = 0; k + 1 < yz.size(); ++k)
    for (size_t j = 0; j + 1 < yz.size(); ++j)
      for (size_t i = 0; i + 1 < x.size(); ++i) {
        const bool blob = x[i] < 2 && yz[j] < 2 && yz[k] < 2, tube = yz[j] >= 9.9 && yz[k] >= 9.9;
        value.push_back(blob ? 1.f : tube ? 0.1f : 0.f);
      }
  Block b;
  b.grid = std::move(g);
  b.fields.add(Field("seen", Association::Cell, DataArray::from(std::move(value), 1)));
  Dataset ds;
  ds.blocks.push_back(std::move(b));
  return ds;
}

TEST(VisibleBounds, FaintThinTubeDoesNotStretchTheBox) {
  auto scene = std::make_shared<ExactScene>(std::make_shared<const Dataset>(blob_and_faint_tube()));
  ExactRenderer r(scene);
  r.set_field("seen");
  const std::optional<Bounds> box = r.visible_bounds(ramp(0, 1), kVisibleOpacity);
  ASSERT_TRUE(box);
  expect_box(*box, {0, 0, 0}, {2, 2, 2});  // a plain union was the whole domain, [0, 10] on every axis
  EXPECT_EQ(framed_default_camera(r, ramp(0, 1)), default_camera(*box));
  // The tube alone (the blob made transparent) is what is visible: its box.
  TransferFunction tube_only = ramp(0, 1);
  tube_only.opacity_points = {{0, 0}, {0.1, 1}, {0.5, 0}, {1, 0}};
  const std::optional<Bounds> tube = r.visible_bounds(tube_only, kVisibleOpacity);
  ASSERT_TRUE(tube);
  expect_box(*tube, {0, double(9.9f), double(9.9f)}, {10, 10, 10});  // float positions
}

TEST(VisibleBounds, WeightsKeepTheCentralShareOnEachAxis) {
  VisibleWeights w(whole());
  EXPECT_TRUE(w.box().empty()) << "nothing added";
  const auto cube = [](double lo, double hi) {
    Bounds b;
    b.lo = {lo, lo, lo};
    b.hi = {hi, hi, hi};
    return b;
  };
  // Flat pieces only (no weight): their union.
  w.add(cube(1, 1), 0);
  w.add(cube(3, 3), 0);
  expect_box(w.box(), {1, 1, 1}, {3, 3, 3});
  // 97 parts at [2, 3], a part at each end: within the tails, dropped; two parts at an end are not.
  w.add(cube(2, 3), 97);
  w.add(cube(0, 0.5), 1);
  w.add(cube(7.5, 8), 1);
  expect_box(w.box(), {2, 2, 2}, {3, 3, 3});
  w.add(cube(7.5, 8), 1);
  expect_box(w.box(), {2, 2, 2}, {8, 8, 8});
}

// MPI ranks add up their parts' weights (MpiRenderer::visible_bounds): two halves, each the cells whose centroid its
// box owns, add up to the whole's weights exactly, and so to its box.
TEST(VisibleBounds, WeightsOfOwnedPartsAddUpToTheWhole) {
  auto scene = std::make_shared<ExactScene>(std::make_shared<const Dataset>(blob_and_faint_tube()));
  ExactRenderer r(scene);
  r.set_field("seen");
  const Bounds over = r.bounds();
  Bounds left = all_space(), right = all_space();
  left.hi.x = 1;  // through the blob: each half holds part of it
  right.lo.x = 1;
  const std::vector<double> whole = r.visible_weights(ramp(0, 1), kVisibleOpacity, over, all_space());
  const auto a = VisibleWeights::from_flat(over, r.visible_weights(ramp(0, 1), kVisibleOpacity, over, left));
  const auto b = VisibleWeights::from_flat(over, r.visible_weights(ramp(0, 1), kVisibleOpacity, over, right));
  ASSERT_TRUE(a && b);
  EXPECT_NE(a->flat(), whole) << "a half is not the whole";
  VisibleWeights sum = *a;
  sum.merge(*b);
  const std::vector<double> added = sum.flat();
  ASSERT_EQ(added.size(), whole.size());
  for (size_t i = 0; i < added.size(); ++i)  // the same terms, summed in another order
    if (std::isinf(whole[i]))
      EXPECT_EQ(added[i], whole[i]) << "entry " << i;  // an empty bin's extent
    else
      EXPECT_NEAR(added[i], whole[i], 1e-12 * std::max(1.0, std::abs(whole[i]))) << "entry " << i;
  expect_box(sum.box(), {0, 0, 0}, {2, 2, 2});
  EXPECT_FALSE(VisibleWeights::from_flat(over, std::vector<double>(3, 0.0))) << "not a flattened VisibleWeights";
}

}  // namespace
}  // namespace ugvr
