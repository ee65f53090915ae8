// What a newcomer sees first (issue 25, part 5): the default view and transfer function, the built-in demo's view
// (src/cli/demo_scene.h, the same as scripts/demo.sh writes), and a texel error that stays finite with the eye inside
// the data.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli/demo_scene.h"
#include "test_paths.h"
#include "ugvr/core/error.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/lod/view_metrics.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

TEST(FirstLook, DefaultCameraIsAThreeQuarterViewFramingTheBounds) {
  const Bounds b{{-2, 0, 0}, {4, 8, 2}};
  const Camera c = default_camera(b);
  const Camera framed = reset_camera(b);
  EXPECT_EQ(c.focal_point, b.center());
  EXPECT_NEAR(c.distance(), framed.distance(), 1e-12) << "framed like ResetCamera";
  const Vec3d d = c.direction();
  // From the -x -y side, above: not along any axis, every component of the view direction well away from 0.
  EXPECT_GT(d.x, 0.3);
  EXPECT_GT(d.y, 0.3);
  EXPECT_LT(d.z, -0.3);
  EXPECT_NEAR(std::asin(-d.z) * 180 / 3.141592653589793, 28.8, 0.2) << "degrees above the xy plane";
  EXPECT_NEAR(dot(c.view_up, d), 0, 1e-12);
  EXPECT_GT(c.view_up.z, 0.8) << "+z up";
  EXPECT_EQ(default_camera(b, 50).view_angle, 50);
  EXPECT_THROW(default_camera(Bounds{}), Error);
}

TEST(FirstLook, DefaultTransferFunctionIsAViridisRampOverTheRange) {
  const Bounds b{{0, 0, 0}, {3, 4, 12}};  // diagonal 13
  EXPECT_DOUBLE_EQ(default_unit_distance(b), 1.3);
  EXPECT_EQ(default_unit_distance(Bounds{}), 1.0);
  EXPECT_EQ(default_unit_distance(Bounds{{1, 1, 1}, {1, 1, 1}}), 1.0);
  const TransferFunction tf = default_transfer_function(-2, 6, b);
  EXPECT_EQ(tf.range_min(), -2);
  EXPECT_EQ(tf.range_max(), 6);
  EXPECT_EQ(tf.name, "viridis");
  EXPECT_EQ(tf.opacity(-2), 0);
  EXPECT_DOUBLE_EQ(tf.opacity(2), 0.5);
  EXPECT_EQ(tf.opacity(6), 1);
  EXPECT_DOUBLE_EQ(tf.opacity_unit_distance, 1.3);
  // A slab of the middle value a tenth of the diagonal thick lets half the light through: the inside shows.
  EXPECT_NEAR(tf.opacity_for_length(2, 1.3), 0.5, 1e-12);
  const TransferFunction nan_range = default_transfer_function(NAN, NAN, b);
  EXPECT_EQ(nan_range.range_min(), 0);
  EXPECT_EQ(nan_range.range_max(), 1);
}

// A box around the eye (or behind it) had its depth clamped to 1e-9 of the root's diagonal and reported some 1e9
// pixels per texel; now every size is at most the image's diagonal, and sizes below that are unchanged.
TEST(FirstLook, TexelSizeIsNeverLargerThanTheImage) {
  const Bounds root{{0, 0, 0}, {1, 1, 1}};
  Camera cam;
  cam.position = {0.5, 0.5, 0.5};  // inside the root
  cam.focal_point = {0.5, 0.5, 2};
  cam.view_up = {0, 1, 0};
  const ViewMetrics inside(cam, 640, 480, root);
  EXPECT_DOUBLE_EQ(inside.max_pixels(), 800);
  EXPECT_DOUBLE_EQ(inside.texel_pixels(root, 32), 800) << "the node holding the eye";
  const Bounds behind{{0, 0, -2}, {1, 1, -1}};
  EXPECT_DOUBLE_EQ(inside.pixels(behind, 1), 800);
  // In front, far enough: the perspective formula h / (2 d tan(angle / 2)) * height, unclamped.
  const Bounds ahead{{0, 0, 10.5}, {1, 1, 11.5}};
  const double expected = 1.0 / (2 * 10 * std::tan(15 * 3.141592653589793 / 180)) * 480;
  EXPECT_NEAR(inside.pixels(ahead, 1), expected, 1e-9);
  EXPECT_LT(expected, 800);
  // Monotone down the tree still: a child is never larger than its parent.
  const Bounds child{{0, 0, 0}, {0.5, 0.5, 0.5}};
  EXPECT_LE(inside.texel_pixels(child, 32), inside.texel_pixels(root, 32));
  // Parallel projection, zoomed far in: clamped too.
  cam.parallel_projection = true;
  cam.parallel_scale = 1e-12;
  const ViewMetrics zoomed(cam, 100, 100, root);
  EXPECT_DOUBLE_EQ(zoomed.pixels(ahead, 1), std::hypot(100.0, 100.0));
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The text of scripts/demo.sh's here-document that writes `file`.
std::string heredoc(const std::string& script, const std::string& file) {
  const std::string start = "cat >" + file + " <<'JSON'\n";
  const size_t a = script.find(start);
  if (a == std::string::npos) return {};
  const size_t b = script.find("\nJSON\n", a + start.size());
  return script.substr(a + start.size(), b - a - start.size());
}

// scripts/demo.sh renders the view `ugvr view --demo` starts from: the same camera, transfer function, field and
// background.
TEST(FirstLook, DemoScriptAndViewerShareTheDemoView) {
  const std::string script = read_text(std::string(UGVR_SOURCE_DIR) + "/scripts/demo.sh");
  ASSERT_FALSE(script.empty());
  const nlohmann::json camera = nlohmann::json::parse(heredoc(script, "out/demo-camera.json"));
  const nlohmann::json tf = nlohmann::json::parse(heredoc(script, "out/demo-tf.json"));
  EXPECT_EQ(camera, nlohmann::json::parse(cli::kDemoCameraJson));
  EXPECT_EQ(tf, nlohmann::json::parse(cli::kDemoTfJson));
  EXPECT_NE(script.find(std::string("--field ") + cli::kDemoField), std::string::npos);
  EXPECT_NE(script.find("--background 0.02,0.02,0.04 "), std::string::npos);
  EXPECT_EQ(cli::kDemoBackground, (std::array<double, 4>{0.02, 0.02, 0.04, 1.0}));
  // Both parse and validate.
  EXPECT_NO_THROW(camera_from_json(camera, "demo camera"));
  const TransferFunction t = parse_paraview_presets(cli::kDemoTfJson, "demo tf").at(0);
  EXPECT_NO_THROW(t.validate("demo tf"));
  // The free stream (pressure 0) is transparent, the vortex cores (about -0.2) and the wing's suction are not.
  EXPECT_EQ(t.opacity(0), 0);
  EXPECT_GT(t.opacity(-0.2), 0.3);
  EXPECT_GT(t.opacity(-1), 0.6);
  EXPECT_DOUBLE_EQ(t.opacity_unit_distance, 0.2);
}

}  // namespace
}  // namespace ugvr
