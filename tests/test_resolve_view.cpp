// The rules `ugvr render` and `ugvr.render()` share for the transfer function and camera (render/resolve_view.h),
// in their order, on a small cube whose only feature sits in one corner (so that framing moves the camera).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "hex_fixtures.h"
#include "ugvr/render/default_transfer_function.h"
#include "ugvr/render/exact/exact_renderer.h"
#include "ugvr/render/resolve_view.h"
#include "ugvr/render/visible_bounds.h"

namespace ugvr {
namespace {

constexpr int kCells = 6;

// kCells^3 unit hexahedra; vertex field "blob" is 1 at the points with i, j, k <= 1 and 0 elsewhere: auto makes the
// zeros (the free stream) transparent, leaving the corner visible.
std::unique_ptr<ExactRenderer> corner_renderer() {
  UnstructuredMesh m = test::unit_hex_mesh(kCells);
  std::vector<float> blob;
  for (const Vec3f& q : m.points) blob.push_back(q.x <= 1 && q.y <= 1 && q.z <= 1 ? 1.f : 0.f);
  Block b;
  b.grid = std::move(m);
  b.fields.add(Field("blob", Association::Vertex, DataArray::from(std::move(blob), 1)));
  auto ds = std::make_shared<Dataset>();
  ds->blocks.push_back(std::move(b));
  auto r = std::make_unique<ExactRenderer>(std::make_shared<ExactScene>(std::move(ds)));
  r->set_field("blob");
  return r;
}

Camera some_camera() {
  Camera c;
  c.position = {1, 2, 30};
  c.focal_point = {1, 2, 3};
  c.view_up = {0, 1, 0};
  c.view_angle = 40;
  return c;
}

void expect_same_tf(const TransferFunction& a, const TransferFunction& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.color_points, b.color_points);
  EXPECT_EQ(a.opacity_points, b.opacity_points);
  EXPECT_EQ(a.opacity_unit_distance, b.opacity_unit_distance);
}

ViewChoices named(const char* preset) {
  ViewChoices c;
  c.auto_tf = false;
  c.tf = builtin_preset(preset);
  return c;
}

TEST(ResolveView, AutoFramesTheDefaultCameraOnWhatItLeavesVisible) {
  const auto r = corner_renderer();
  const FieldRange range = r->field_range();
  const ResolvedView v = resolve_view(*r, ViewChoices{}, range);
  expect_same_tf(v.tf, auto_transfer_function(*r, range.min, range.max, r->bounds()));
  EXPECT_EQ(v.camera, framed_default_camera(*r, v.tf, 30));
  EXPECT_NE(v.camera, default_camera(r->bounds(), 30)) << "the corner alone is visible: the camera moves closer";
  EXPECT_LT(v.camera.distance(), 0.5 * default_camera(r->bounds(), 30).distance());
}

TEST(ResolveView, ExplicitCameraBeatsViewBeatsFraming) {
  const auto r = corner_renderer();
  ViewChoices c;
  c.camera = some_camera();
  c.view = "+x";
  EXPECT_EQ(resolve_view(*r, c, r->field_range()).camera, some_camera());
  c.view_angle = 20;
  Camera narrower = some_camera();
  narrower.view_angle = 20;
  EXPECT_EQ(resolve_view(*r, c, r->field_range()).camera, narrower) << "view_angle applies to a given camera";
  c.camera.reset();
  EXPECT_EQ(resolve_view(*r, c, r->field_range()).camera, camera_preset("+x", r->bounds(), 20));
  c.view.clear();
  const ResolvedView framed = resolve_view(*r, c, r->field_range());
  EXPECT_EQ(framed.camera, framed_default_camera(*r, framed.tf, 20));
}

TEST(ResolveView, AnExplicitTransferFunctionKeepsTheWholeDomainInView) {
  const auto r = corner_renderer();
  const ResolvedView v = resolve_view(*r, named("viridis"), r->field_range());
  EXPECT_EQ(v.camera, default_camera(r->bounds(), 30));
  EXPECT_EQ(v.tf.opacity_unit_distance, default_unit_distance(r->bounds()));
  EXPECT_EQ(v.tf.range_min(), 0);
  EXPECT_EQ(v.tf.range_max(), 1);
}

TEST(ResolveView, RangeThenKeepRangeThenTheFieldsRange) {
  const auto r = corner_renderer();
  ViewChoices c = named("viridis");
  c.range = std::pair{-2.0, 5.0};
  c.keep_range = true;  // a range given wins over keep_range
  c.unit_distance = 0.25;
  ResolvedView v = resolve_view(*r, c, r->field_range());
  EXPECT_EQ(v.tf.range_min(), -2);
  EXPECT_EQ(v.tf.range_max(), 5);
  EXPECT_EQ(v.tf.opacity_unit_distance, 0.25);
  c.range.reset();
  c.tf.rescale(10, 20);
  v = resolve_view(*r, c, r->field_range());
  EXPECT_EQ(v.tf.range_min(), 10) << "keep_range: the tf's own points";
  EXPECT_EQ(v.tf.range_max(), 20);
  c.keep_range = false;
  v = resolve_view(*r, c, FieldRange{3, 4});
  EXPECT_EQ(v.tf.range_min(), 3) << "the range given by the front end (a time step's own), not the renderer's";
  EXPECT_EQ(v.tf.range_max(), 4);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  v = resolve_view(*r, c, FieldRange{nan, nan});
  EXPECT_EQ(v.tf.range_min(), 10) << "an all-NaN field leaves the map where it was";
}

TEST(ResolveView, AutoOverAGivenRangeWithItsOwnUnitDistanceUnlessOneIsGiven) {
  const auto r = corner_renderer();
  ViewChoices c;
  c.range = std::pair{0.5, 1.0};
  ResolvedView v = resolve_view(*r, c, r->field_range());
  expect_same_tf(v.tf, auto_transfer_function(*r, 0.5, 1.0, r->bounds()));
  c.unit_distance = 3;
  v = resolve_view(*r, c, r->field_range());
  EXPECT_EQ(v.tf.opacity_unit_distance, 3);
}

}  // namespace
}  // namespace ugvr
