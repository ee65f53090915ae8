// `ugvr render` without --tf draws with "auto" (render/default_transfer_function.h): on the generated mesh, whose
// pressure is mostly the free stream, the free stream is transparent where `--tf viridis` draws it as a haze.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_data.h"
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
  ASSERT_EQ(test::run_ugvr(common + "-o " + dir.file("auto.png") + " --stats " + dir.file("auto.json")).status, 0);
  ASSERT_EQ(
      test::run_ugvr(common + "--tf viridis -o " + dir.file("ramp.png") + " --stats " + dir.file("ramp.json")).status,
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
  ASSERT_EQ(test::run_ugvr(common + "--tf auto -o " + dir.file("named.png")).status, 0);
  EXPECT_EQ(read_png(dir.file("named.png")), read_png(dir.file("auto.png")));
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
