// `ugvr render` without --tf draws with "auto" (render/default_transfer_function.h): on the generated mesh, whose
// pressure is mostly the free stream, the free stream is transparent where `--tf viridis` draws it as a haze.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_data.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"

namespace ugvr {
namespace {

using nlohmann::json;

double mean_alpha(const Image& im) {
  double sum = 0;
  for (size_t i = 3; i < im.rgba.size(); i += 4) sum += im.rgba[i];
  return sum / double(size_t(im.width) * size_t(im.height));
}

json read_json(const std::string& path) {
  std::ifstream in(path);
  return json::parse(in);
}

TEST(CliDefaultTf, FreeStreamIsTransparentByDefault) {
  test::ScratchDir dir;
  const std::string mesh = dir.file("tet.vtu");
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind tet -o " + mesh).status, 0);
  // A transparent background: what the volume covers is the image's alpha.
  const std::string common = "render " + mesh + " --size 64 --background 0,0,0,0 ";
  // One view for both: auto's default view frames what it leaves visible (DefaultViewFramesWhatIsVisible), a named
  // --tf keeps the whole domain; here the transfer functions are compared, on the whole domain.
  ASSERT_EQ(test::run_ugvr(common + "--tf viridis -o " + dir.file("ramp.png") + " --stats " + dir.file("ramp.json") +
                           " --save-camera " + dir.file("whole.cam"))
                .status,
            0);
  const std::string whole = " --camera " + dir.file("whole.cam");
  ASSERT_EQ(test::run_ugvr(common + "-o " + dir.file("auto.png") + " --stats " + dir.file("auto.json") + whole).status,
            0);
  const double auto_alpha = mean_alpha(read_png(dir.file("auto.png")));
  const double ramp_alpha = mean_alpha(read_png(dir.file("ramp.png")));
  std::printf("mean alpha: auto %.4f, viridis %.4f\n", auto_alpha, ramp_alpha);
  // The ramp covers the slab with haze; auto leaves the wing and its wake, a small part of the picture.
  EXPECT_GT(ramp_alpha, 0.1);
  EXPECT_LT(auto_alpha, 0.25 * ramp_alpha);
  EXPECT_GT(auto_alpha, 0.0) << "the structure away from the free stream must still show";

  // --stats says which transfer function drew, with its opacity points: auto's zero over the free stream's bump.
  const json a = read_json(dir.file("auto.json")), r = read_json(dir.file("ramp.json"));
  EXPECT_EQ(a["tf"]["name"], "auto");
  EXPECT_EQ(r["tf"]["name"], "viridis");
  EXPECT_EQ(r["tf"]["opacity_points"].size(), 2u);
  ASSERT_EQ(a["tf"]["opacity_points"].size(), 4u);
  EXPECT_EQ(a["tf"]["opacity_points"][1][1].get<double>(), 0.0);
  EXPECT_EQ(a["tf"]["opacity_points"][2][1].get<double>(), 0.0);
  EXPECT_LT(a["tf"]["opacity_unit_distance"].get<double>(), r["tf"]["opacity_unit_distance"].get<double>());
  // "auto" named explicitly is the default.
  ASSERT_EQ(test::run_ugvr(common + "--tf auto -o " + dir.file("named.png") + whole).status, 0);
  EXPECT_EQ(read_png(dir.file("named.png")), read_png(dir.file("auto.png")));
}

// The fraction of pixels whose alpha is above a tenth: what the picture shows over a transparent background.
double covered(const Image& im) {
  size_t n = 0;
  for (size_t i = 3; i < im.rgba.size(); i += 4) n += im.rgba[i] > 0.1f;
  return double(n) / double(size_t(im.width) * size_t(im.height));
}

// With no flags the camera frames what auto leaves visible (render/visible_bounds.h): the wing and its wake, a small
// part of the 30 x 30 x 2 slab, fill the picture instead of a speck in the middle. Before, the same transfer function
// from the whole domain's view (default_camera, which a named --tf still uses): 0.3 % of the pixels covered on this
// mesh when tried, 4.4 % framed; with auto from volume and the weighted box (issue 25, helper-tfweight) 0.56 % and
// 11.3 %.
TEST(CliDefaultTf, DefaultViewFramesWhatIsVisible) {
  test::ScratchDir dir;
  const std::string mesh = dir.file("tet.vtu");
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind tet -o " + mesh).status, 0);
  const std::string common = "render " + mesh + " --size 64 --background 0,0,0,0 ";
  ASSERT_EQ(test::run_ugvr(common + "--tf viridis -o " + dir.file("v.png") + " --save-camera " + dir.file("whole.cam"))
                .status,
            0);
  ASSERT_EQ(test::run_ugvr(common + "-o " + dir.file("framed.png") + " --save-camera " + dir.file("framed.cam")).status,
            0);
  ASSERT_EQ(test::run_ugvr(common + "--camera " + dir.file("whole.cam") + " -o " + dir.file("before.png")).status, 0);
  const double before = covered(read_png(dir.file("before.png")));
  const double framed = covered(read_png(dir.file("framed.png")));
  std::printf("pixels with alpha > 0.1: whole domain %.4f, framed %.4f\n", before, framed);
  EXPECT_GT(framed, 4 * before);
  EXPECT_GT(framed, 0.02);
  // Same direction, closer.
  const Camera w = read_camera(dir.file("whole.cam")), f = read_camera(dir.file("framed.cam"));
  EXPECT_NEAR(dot(w.direction(), f.direction()), 1.0, 1e-9);
  EXPECT_LT(f.distance(), 0.5 * w.distance());
}

TEST(CliDefaultTf, KeepRangeNeedsANamedTf) {
  test::ScratchDir dir;
  std::ofstream(dir.file("x.vtu")) << "not read: the flags are checked first";
  const test::CommandResult r = test::run_ugvr("render " + dir.file("x.vtu") + " --keep-range -o " + dir.file("a.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--keep-range"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ugvr
