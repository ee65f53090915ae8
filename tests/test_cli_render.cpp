// End to end: `ugvr render` on a small generated mixed-cell dataset.
// Tests named Engine* need a working exact engine (they render); the others check the command line alone, which is
// validated before the dataset is read.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_data.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

using nlohmann::json;
using test::CommandResult;
using test::run_ugvr;

// A scratch directory holding a 2,000-cell mixed dataset (all four cell types).
class CliRender : public ::testing::Test {
 protected:
  void SetUp() override {
    const CommandResult r = run_ugvr("generate --cells 2000 --kind mixed -o " + dir_.file("mixed.vtu"));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  std::string data() const { return dir_.file("mixed.vtu"); }
  std::string file(const std::string& name) const { return dir_.file(name); }
  CommandResult render(const std::string& args) const { return run_ugvr("render " + data() + " " + args); }
  // Renders and expects success.
  void render_ok(const std::string& args) const {
    const CommandResult r = render(args);
    ASSERT_EQ(r.status, 0) << args << "\n" << r.out;
  }

  test::ScratchDir dir_;
};

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

TEST_F(CliRender, BadFlagsNameTheFlag) {
  const std::string out = "-o " + file("a.png") + " ";
  const std::pair<std::string, std::string> cases[] = {
      {"--engine foo", "--engine"},
      {"--size 0", "--size"},
      {"--size 20000", "--size"},
      {"--size 3x", "--size"},
      {"--range 1", "--range"},
      {"--range 2,1", "--range"},
      {"--range 0,nan", "--range"},
      {"--range a,b", "--range"},
      {"--clip 1,2,3", "--clip"},
      {"--clip 0,0,0,0,0,0", "--clip"},
      {"--background 1,1", "--background"},
      {"--background 2,0,0", "--background"},
      {"--background 0,0,0,0,0", "--background"},
      {"--view up", "--view"},
      {"--view-angle 190", "--view-angle"},
      {"--view-angle x", "--view-angle"},
      {"--tf nope", "--tf"},
      {"--tf " + file("missing.json"), "--tf"},
      {"--tf-name x", "--tf-name"},
      {"--unit-distance -1", "--unit-distance"},
      {"--unit-distance 0", "--unit-distance"},
      {"--mode foo", "--mode"},
      {"--mode iso", "--mode"},
      {"--iso 1,x", "--iso"},
      {"--iso 1,,2", "--iso"},
      {"--iso-opacity 2", "--iso-opacity"},
      {"--boundary-opacity x", "--boundary-opacity"},
      {"--threads 0", "--threads"},
      {"--threads 1.5", "--threads"},
      {"--frames 0", "--frames"},
      {"--float " + file("x.png"), "--float"},
      {"--settings " + file("nosuch.json"), "--settings"},
      {"--camera " + file("nosuch.json"), "--camera"},
      {"--view +x --camera " + file("nosuch.json"), "--view"},
  };
  for (const auto& [args, flag] : cases) {
    const CommandResult r = render(out + args);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("error: " + flag + ":"), std::string::npos) << args << "\n" << r.out;
  }
  const CommandResult r = render("-o " + file("a.jpg"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("a.jpg"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(file("a.png")));
}

TEST_F(CliRender, BadFilesNameTheFile) {
  std::ofstream(file("bad-settings.json")) << R"({"width": 0})";
  CommandResult r = render("-o " + file("a.png") + " --settings " + file("bad-settings.json"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("bad-settings.json"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("width"), std::string::npos) << r.out;
  std::ofstream(file("bad-camera.json")) << R"({"position": [0, 0, 1]})";
  r = render("-o " + file("a.png") + " --camera " + file("bad-camera.json"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("bad-camera.json"), std::string::npos) << r.out;
}

TEST_F(CliRender, HelpListsTheFlags) {
  const CommandResult r = run_ugvr("render --help");
  EXPECT_EQ(r.status, 0);
  for (const char* flag : {"--size", "--camera", "--view", "--tf", "--range", "--unit-distance", "--mode", "--iso",
                           "--clip", "--background", "--settings", "--float", "--stats", "--save-camera", "--save-tf",
                           "--threads", "--frames", "diagonal / 10"})
    EXPECT_NE(r.out.find(flag), std::string::npos) << flag;
}

// ---- Engine-dependent: these render.

TEST_F(CliRender, EngineWritesPngOfRequestedSize) {
  // --tf viridis: the ramp's haze covers the slab (auto leaves the wing alone, a few pixels at this size).
  render_ok("-o " + file("a.png") + " --size 64x48 --tf viridis");
  const Image im = read_png(file("a.png"));
  ASSERT_EQ(im.width, 64);
  ASSERT_EQ(im.height, 48);
  // ParaView's default background (0.32, 0.34, 0.43); the data must cover some pixels.
  int covered = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const float* p = im.pixel(x, y);
      if (std::abs(p[0] - 0.32f) + std::abs(p[1] - 0.34f) + std::abs(p[2] - 0.43f) > 4.0f / 255) ++covered;
    }
  EXPECT_GT(covered, 64 * 48 / 20);
  // Corners are outside the data under the default framing.
  EXPECT_NEAR(im.pixel(0, 0)[0], 0.32f, 1.0f / 255);
}

TEST_F(CliRender, EngineSavedCameraAndTransferFunctionReproduceTheImage) {
  render_ok("-o " + file("a.png") + " --size 40 --view iso --tf inferno --save-camera " + file("cam.json") +
            " --save-tf " + file("tf.json") + " --stats " + file("s.json"));
  const Camera cam = read_camera(file("cam.json"));
  const json stats = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(cam, camera_from_json(stats["camera"], "stats"));
  const Vec3d d = cam.direction(), iso = normalized({-1, -1, -1});
  EXPECT_NEAR(dot(d, iso), 1.0, 1e-9);
  const TransferFunction tf = read_paraview_preset(file("tf.json"));
  // The builtin map was rescaled to the field's range.
  EXPECT_DOUBLE_EQ(tf.range_min(), stats["field_range"][0].get<double>());
  EXPECT_DOUBLE_EQ(tf.range_max(), stats["field_range"][1].get<double>());
  EXPECT_GT(tf.opacity_unit_distance, 0);
  render_ok("-o " + file("b.png") + " --size 40 --camera " + file("cam.json") + " --tf " + file("tf.json") +
            " --keep-range");
  EXPECT_EQ(read_bytes(file("a.png")), read_bytes(file("b.png")));
}

TEST_F(CliRender, EngineStatsHaveEveryKey) {
  render_ok("-o " + file("a.png") + " --size 32x24 --frames 3 --threads 2 --float " + file("a.pfm") + " --stats " +
            file("s.json"));
  const json s = json::parse(read_bytes(file("s.json")));
  for (const char* key : {"engine",
                          "input",
                          "field",
                          "field_range",
                          "width",
                          "height",
                          "cells",
                          "points",
                          "build_seconds",
                          "frame_seconds",
                          "median_frame_seconds",
                          "rays",
                          "rays_hit",
                          "cell_steps",
                          "reentries",
                          "nonlinear_samples",
                          "lost_rays",
                          "threads",
                          "engine_bytes",
                          "engine_bytes_per_cell",
                          "peak_rss_bytes",
                          "camera",
                          "settings"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_EQ(s["engine"], "exact");
  EXPECT_EQ(s["width"], 32);
  EXPECT_EQ(s["height"], 24);
  EXPECT_EQ(s["frame_seconds"].size(), 3u);
  EXPECT_EQ(s["rays"], 32 * 24);
  EXPECT_GT(s["rays_hit"].get<uint64_t>(), 0u);
  EXPECT_EQ(s["lost_rays"], 0);
  EXPECT_EQ(s["field"], "pressure");
  EXPECT_GT(s["cells"].get<uint64_t>(), 1900u);
  EXPECT_LE(s["threads"].get<int>(), 2);
  EXPECT_NO_THROW(camera_from_json(s["camera"], "stats"));
  // The float copy is the same image as the PNG, before quantisation.
  const Image png = read_png(file("a.png")), pfm = read_pfm(file("a.pfm"));
  EXPECT_LE(compare_images(png, pfm).max_abs, 0.5 / 255 + 1e-6);
}

TEST_F(CliRender, EngineFlagsOverrideSettingsFile) {
  std::ofstream(file("settings.json")) << R"({"width": 40, "height": 30, "background": [1, 1, 1, 1]})";
  render_ok("-o " + file("a.pfm") + " --settings " + file("settings.json") + " --size 20x10");
  const Image im = read_pfm(file("a.pfm"));
  EXPECT_EQ(im.width, 20);
  EXPECT_EQ(im.height, 10);
  EXPECT_EQ(im.pixel(0, 0)[0], 1.0f);  // the settings' white background, the flag's size
}

TEST_F(CliRender, EngineIsDeterministicAcrossThreadCounts) {
  render_ok("-o " + file("a.pfm") + " --size 48 --threads 1");
  render_ok("-o " + file("b.pfm") + " --size 48");
  EXPECT_EQ(read_bytes(file("a.pfm")), read_bytes(file("b.pfm")));
}

TEST_F(CliRender, EngineModesAndUnknownField) {
  render_ok("-o " + file("mip.png") + " --size 24 --mode mip --field wall_distance");
  render_ok("-o " + file("iso.png") + " --size 24 --iso 0,0.5 --clip 0,0,1,0,0,1 --no-lighting");
  render_ok("-o " + file("b.png") + " --size 24 --boundary-opacity 0.3 --volume-lighting --background 0,0,0,0");
  const CommandResult r = render("-o " + file("x.png") + " --field nosuch");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("nosuch"), std::string::npos) << r.out;
}

// The level-of-detail engine end to end: `ugvr build` then `ugvr render STORE` (the engine chosen by the extension),
// against the exact engine's image of the same mesh with the same camera and transfer function.
TEST_F(CliRender, LodEngineRendersABrickStore) {
  const std::string store = file("mixed.ugvr");
  const CommandResult b = run_ugvr("build " + data() + " --fields pressure --brick 8 --max-depth 3 -o " + store);
  ASSERT_EQ(b.status, 0) << b.out;
  const std::string view = " --size 48 --view iso --save-camera " + file("cam.json");
  const CommandResult r = run_ugvr("render " + store + " -o " + file("lod.pfm") + view + " --cut leaves --stats " +
                                   file("s.json") + " --save-tf " + file("tf.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  const json s = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(s["engine"], "lod");
  EXPECT_EQ(s["cut"], "leaves");
  EXPECT_GT(s["cut_nodes"].get<uint64_t>(), 1u);
  EXPECT_GT(s["samples"].get<uint64_t>(), 0u);
  EXPECT_FALSE(s["renderer"].get<std::string>().empty());
  EXPECT_EQ(s["field"], "pressure");
  render_ok("-o " + file("exact.pfm") + " --size 48 --camera " + file("cam.json") + " --tf " + file("tf.json"));
  EXPECT_GE(compare_images(read_pfm(file("lod.pfm")), read_pfm(file("exact.pfm"))).psnr_db, 30.0);

  const std::pair<std::string, std::string> bad[] = {
      {"--cut nodes:3", "--cut"}, {"--cut pixels:0", "--cut"}, {"--engine exact", "--engine"},
      {"--gpu 99", "--gpu"},      {"--field nope", "--field"}, {"--step-voxels 0", "--step-voxels"}};
  for (const auto& [flags, name] : bad) {
    const CommandResult e = run_ugvr("render " + store + " -o " + file("x.png") + " " + flags);
    EXPECT_EQ(e.status, 1) << flags << "\n" << e.out;
    EXPECT_NE(e.out.find(name), std::string::npos) << flags << "\n" << e.out;
  }
  // A mesh is not a brick store.
  const CommandResult m = render("-o " + file("x.png") + " --engine lod");
  EXPECT_EQ(m.status, 1);
  EXPECT_NE(m.out.find(".ugvr"), std::string::npos) << m.out;
}

// --time-budget S (issue 24): one still image from what fits in S seconds, reading included, and --stats says what
// was drawn. With time to spare the exact image is the one without a budget; with none, the probe's small image,
// magnified to the requested size; a store's cut is refined frame by frame.
TEST_F(CliRender, EngineTimeBudgetDrawsWhatFitsAndSaysWhat) {
  const std::string view = " --size 128x96 --view iso";
  render_ok("-o " + file("plain.pfm") + view);
  render_ok("-o " + file("ample.pfm") + view + " --time-budget 300 --stats " + file("ample.json"));
  const json ample = json::parse(read_bytes(file("ample.json")));
  EXPECT_EQ(ample["time_budget"]["drew"], "exact image at full size") << ample["time_budget"].dump();
  EXPECT_EQ(ample["time_budget"]["scale"], 1.0);
  EXPECT_EQ(ample["time_budget"]["within_budget"], true);
  EXPECT_EQ(read_bytes(file("ample.pfm")), read_bytes(file("plain.pfm"))) << "the same exact image";

  render_ok("-o " + file("tight.pfm") + view + " --time-budget 0.000001 --stats " + file("tight.json"));
  const json tight = json::parse(read_bytes(file("tight.json")));
  EXPECT_EQ(tight["time_budget"]["within_budget"], false);
  EXPECT_EQ(tight["time_budget"]["scale"], 0.5) << "the probe: 64 pixels on the longer side";
  EXPECT_NE(tight["time_budget"]["drew"].get<std::string>().find("scale 0.500 (64 x 48), magnified to 128 x 96"),
            std::string::npos)
      << tight["time_budget"].dump();
  const Image small = read_pfm(file("tight.pfm"));
  EXPECT_EQ(small.width, 128);
  EXPECT_EQ(small.height, 96);
  EXPECT_GE(compare_images(small, read_pfm(file("plain.pfm"))).psnr_db, 20.0) << "the same picture, coarser";

  const std::string store = file("budget.ugvr");
  ASSERT_EQ(run_ugvr("build " + data() + " --fields pressure --brick 8 --max-depth 3 -o " + store).status, 0);
  const CommandResult lod =
      run_ugvr("render " + store + " -o " + file("lod.png") + view + " --time-budget 30 --stats " + file("lod.json"));
  ASSERT_EQ(lod.status, 0) << lod.out;
  const json l = json::parse(read_bytes(file("lod.json")));
  EXPECT_EQ(l["engine"], "lod");
  EXPECT_GE(l["time_budget"]["frames"].get<int>(), 1);
  EXPECT_NE(l["time_budget"]["drew"].get<std::string>().find("level-of-detail cut of "), std::string::npos)
      << l["time_budget"].dump();

  for (const std::string& bad : {std::string(" --time-budget 0"), std::string(" --time-budget 5 --fps 10")}) {
    const CommandResult e = render("-o " + file("x.png") + bad);
    EXPECT_EQ(e.status, 1) << bad << "\n" << e.out;
    EXPECT_NE(e.out.find("--time-budget"), std::string::npos) << bad << "\n" << e.out;
  }
}

// A mesh over the memory budget (here 100 KiB) is never read whole: its store is built out of core into the viewer's
// cache and drawn by the LOD engine; the next render draws that store at once; the exact engine is refused with why.
TEST_F(CliRender, AMeshOverTheMemoryBudgetIsDrawnFromItsStoreBuiltOutOfCore) {
  const std::string env = "UGVR_CACHE_DIR=" + file("cache") + " UGVR_VIEW_MEMORY_BUDGET=100KiB ";
  const std::string view = " --size 64 --view iso --field pressure";
  const CommandResult first = test::run_command(env + UGVR_BINARY + " render " + data() + " -o " + file("a.png") +
                                                view + " --stats " + file("a.json"));
  ASSERT_EQ(first.status, 0) << first.out;
  EXPECT_NE(first.out.find("over the memory budget of "), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("building its store out of core"), std::string::npos) << first.out;
  EXPECT_EQ(json::parse(read_bytes(file("a.json")))["engine"], "lod");
  int stores = 0;
  for (const auto& e : std::filesystem::directory_iterator(file("cache"))) stores += e.path().extension() == ".ugvr";
  EXPECT_EQ(stores, 1);

  const CommandResult again = test::run_command(env + UGVR_BINARY + " render " + data() + " -o " + file("b.png") +
                                                view + " --time-budget 30 --stats " + file("b.json"));
  ASSERT_EQ(again.status, 0) << again.out;
  EXPECT_NE(again.out.find("drawing the store built earlier"), std::string::npos) << again.out;
  const json b = json::parse(read_bytes(file("b.json")));
  EXPECT_EQ(b["time_budget"]["drew_from"], "store") << b.dump();
  EXPECT_EQ(read_bytes(file("a.png")).empty(), false);

  const CommandResult exact = test::run_command(env + UGVR_BINARY + " --quiet render " + data() + " -o " +
                                                file("c.png") + view + " --engine exact");
  EXPECT_EQ(exact.status, 1) << exact.out;
  EXPECT_NE(exact.out.find("--engine"), std::string::npos) << exact.out;
  EXPECT_NE(exact.out.find("over the memory budget"), std::string::npos) << exact.out;
}

// A mesh over the memory budget whose one out-of-core build's scratch does not fit the cache's disk (here
// $UGVR_SCRATCH_FREE_BYTES says 200,000 bytes are free, and the whole build needs at least 2 x 2,000 cells x 84 bytes)
// is built in pieces into the cache, one piece's scratch at a time (4: the least that fits, view/scratch_pieces.h),
// and drawn from their index: the same image, pixel for pixel, as `ugvr build --pieces 4 --out-of-core` at the same
// memory budget and a render of that index. At this budget the pieces leave out the exact boundary (its triangles
// need more than half of it; at 1 GiB the stores keep it and the image differs), and both commands say so for each
// such piece. The next render draws the cached index without building; a time budget is refused (drawn whole).
TEST_F(CliRender, AMeshWhoseScratchDoesNotFitIsBuiltInPiecesIntoTheCache) {
  const std::string env =
      "UGVR_CACHE_DIR=" + file("cache") + " UGVR_VIEW_MEMORY_BUDGET=100KiB UGVR_SCRATCH_FREE_BYTES=200000 ";
  const std::string view = " --size 48 --view iso --field pressure --tf viridis";
  const CommandResult first =
      test::run_command(env + UGVR_BINARY + " render " + data() + " -o " + file("a.pfm") + view);
  ASSERT_EQ(first.status, 0) << first.out;
  EXPECT_NE(first.out.find("not enough scratch for one build"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("building 4 pieces, one at a time"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find(" of 4: the mesh boundary's"), std::string::npos) << first.out;
  std::vector<std::string> indexes;
  for (const auto& e : std::filesystem::directory_iterator(file("cache")))
    if (e.path().extension() == ".json") indexes.push_back(e.path().string());
  ASSERT_EQ(indexes.size(), 1u);
  EXPECT_EQ(json::parse(read_bytes(indexes[0]))["pieces"].size(), 4u);

  const std::string index = file("manual.json");
  const CommandResult built =
      run_ugvr("build " + data() + " --pieces 4 --out-of-core --memory 100KiB --fields pressure -o " + index);
  ASSERT_EQ(built.status, 0) << built.out;
  EXPECT_NE(built.out.find("warning: piece "), std::string::npos) << built.out;
  EXPECT_NE(built.out.find("over half of the memory budget"), std::string::npos) << built.out;
  ASSERT_EQ(run_ugvr("render " + index + " -o " + file("b.pfm") + view).status, 0);
  const Image a = read_pfm(file("a.pfm")), b = read_pfm(file("b.pfm"));
  EXPECT_TRUE(a == b);
  bool drawn = false;  // not one colour all over
  for (size_t i = 0; i < a.rgba.size(); ++i) drawn = drawn || a.rgba[i] != a.rgba[i % 4];
  EXPECT_TRUE(drawn);

  const CommandResult again =
      test::run_command(env + UGVR_BINARY + " render " + data() + " -o " + file("c.pfm") + view);
  ASSERT_EQ(again.status, 0) << again.out;
  EXPECT_NE(again.out.find("drawing the partitioned store built earlier"), std::string::npos) << again.out;
  EXPECT_TRUE(read_pfm(file("c.pfm")) == a);

  const CommandResult timed = test::run_command(env + UGVR_BINARY + " --quiet render " + data() + " -o " +
                                                file("d.pfm") + view + " --time-budget 30");
  EXPECT_NE(timed.status, 0) << timed.out;
  EXPECT_NE(timed.out.find("--time-budget"), std::string::npos) << timed.out;
}

// Time-critical rendering along a path: one stats line per frame; once the camera rests the image converges to the
// full-quality single image of the same view.
TEST_F(CliRender, LodPathConvergesWhenTheCameraRests) {
  const std::string store = file("mixed.ugvr");
  ASSERT_EQ(run_ugvr("build " + data() + " --fields pressure --brick 8 --max-depth 3 -o " + store).status, 0);
  const std::string view = " --size 48 --view iso";
  const CommandResult r = run_ugvr(
      "render " + store + view + " --fps 1000 --path orbit:6,rest:30 --uploads-per-frame 4 -o " + file("path.pfm") +
      " --stats " + file("path.jsonl") + " --out " + file("frames") + " --float " + file("last.pfm"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(compare_images(read_pfm(file("last.pfm")), read_pfm(file("path.pfm"))).max_abs, 0.0);  // the last frame
  std::ifstream in(file("path.jsonl"));
  std::vector<json> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(json::parse(line));
  ASSERT_EQ(lines.size(), 36u);
  EXPECT_TRUE(std::filesystem::exists(file("frames/frame_00035.png")));
  EXPECT_FALSE(lines[3]["resting"].get<bool>());
  EXPECT_TRUE(lines.back()["resting"].get<bool>());
  EXPECT_TRUE(lines.back()["converged"].get<bool>()) << lines.back().dump();
  for (const json& l : lines) EXPECT_LE(l["uploads"].get<uint64_t>(), 64u);  // a split's children at most (R 8: 8)
  ASSERT_EQ(run_ugvr("render " + store + view + " --cut pixels:1 -o " + file("still.pfm")).status, 0);
  EXPECT_GE(compare_images(read_pfm(file("path.pfm")), read_pfm(file("still.pfm"))).psnr_db, 40.0);
  // Keyframes resampled to --frames frames; `orbit` takes its count from --frames; orbit:N and --frames conflict.
  ASSERT_EQ(run_ugvr("render " + store + " --size 16 --view iso --cut pixels:8 -o " + file("k.png") +
                     " --save-camera " + file("k0.json"))
                .status,
            0);
  const json k0 = json::parse(read_bytes(file("k0.json")));
  json k1 = k0;
  k1["position"][0] = k0["position"][0].get<double>() * 1.5;
  write_bytes(file("keys.json"), json::array({k0, k1}).dump());
  auto path_lines = [&](const std::string& flags) {
    const CommandResult p = run_ugvr("render " + store + " --size 16 --fps 1000 -o " + file("p.png") + " --stats " +
                                     file("p.jsonl") + " " + flags);
    EXPECT_EQ(p.status, 0) << flags << "\n" << p.out;
    std::ifstream f(file("p.jsonl"));
    size_t n = 0;
    for (std::string line; std::getline(f, line);) ++n;
    return n;
  };
  EXPECT_EQ(path_lines("--path " + file("keys.json")), 2u);
  EXPECT_EQ(path_lines("--path " + file("keys.json") + " --frames 7"), 7u);
  EXPECT_EQ(path_lines("--path orbit --frames 5"), 5u);
  EXPECT_EQ(path_lines("--path orbit,rest:2 --frames 4"), 6u);
  const CommandResult both =
      run_ugvr("render " + store + " --size 16 --fps 10 --path orbit:3 --frames 5 -o " + file("x.png"));
  EXPECT_EQ(both.status, 1);
  EXPECT_NE(both.out.find("--frames"), std::string::npos) << both.out;
  // Error weighting: a node's texel size is scaled by (its data error / range)^W, so with a large W the cut at rest
  // stops where the data are held well enough, with fewer nodes than by texel size alone.
  auto rest_cut = [&](const std::string& flags) {
    EXPECT_EQ(path_lines("--path orbit,rest:20 --frames 2 " + flags), 22u);
    std::ifstream f(file("p.jsonl"));
    std::string line, last;
    while (std::getline(f, line)) last = line;
    return json::parse(last)["cut_nodes"].get<uint64_t>();
  };
  const uint64_t plain = rest_cut(""), weighted = rest_cut("--error-weight 4");
  std::fprintf(stderr, "cut at rest: %llu nodes, %llu with --error-weight 4\n", (unsigned long long)plain,
               (unsigned long long)weighted);
  EXPECT_GT(plain, 1u);
  EXPECT_LT(weighted, plain);
  const CommandResult w = run_ugvr("render " + store + " --size 16 --fps 10 --error-weight -1 -o " + file("x.png"));
  EXPECT_EQ(w.status, 1);
  EXPECT_NE(w.out.find("--error-weight"), std::string::npos) << w.out;
  // A RAM cache too small for the cut the view wants: at rest the cut stops refining, and the frames say full quality
  // within the memory (instead of refining frames forever). That needs the cache's loader threads to have settled,
  // which 30 frames of a millisecond did not always allow on a loaded machine (about 1 run in 12 with 8 at once, the
  // same before and after the renderer interface): 600 resting frames give them the time.
  const CommandResult small =
      run_ugvr("render " + store + view + " --fps 1000 --path orbit:2,rest:600 --ram-memory 20KiB" + " -o " +
               file("small.png") + " --stats " + file("small.jsonl"));
  ASSERT_EQ(small.status, 0) << small.out;
  std::ifstream sin(file("small.jsonl"));
  json last;
  for (std::string line; std::getline(sin, line);) last = json::parse(line);
  EXPECT_TRUE(last["resting"].get<bool>());
  EXPECT_TRUE(last["memory_limited"].get<bool>()) << last.dump();
  EXPECT_TRUE(last["converged"].get<bool>()) << last.dump();
  EXPECT_LT(last["cut_nodes"].get<uint64_t>(), lines.back()["cut_nodes"].get<uint64_t>())
      << "a coarser cut than with RAM";
}

// Every engine draws along a path through the renderer interface: the exact engine at full quality without a target,
// and with one at a reduced scale while the camera moves, converged (full size) once it rests.
TEST_F(CliRender, ExactPathHoldsATargetAndConvergesAtRest) {
  auto lines_of = [&](const std::string& flags) {
    const CommandResult r = render("--size 24 --view iso -o " + file("x.png") + " --stats " + file("x.jsonl") + flags);
    EXPECT_EQ(r.status, 0) << r.out;
    std::ifstream in(file("x.jsonl"));
    std::vector<json> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(json::parse(line));
    return lines;
  };
  const std::vector<json> full = lines_of(" --path orbit:3");
  ASSERT_EQ(full.size(), 3u);
  for (const json& l : full) {
    EXPECT_EQ(l["engine"], "exact");
    EXPECT_TRUE(l["converged"].get<bool>());
    EXPECT_EQ(l["scale"].get<double>(), 1.0);
    EXPECT_GT(l["cell_steps"].get<uint64_t>(), 0u);
  }
  const std::vector<json> held = lines_of(" --path orbit:3,rest:2 --fps 1000");
  ASSERT_EQ(held.size(), 5u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_FALSE(held[i]["converged"].get<bool>()) << i;
    EXPECT_LT(held[i]["scale"].get<double>(), 1.0) << i;
  }
  EXPECT_TRUE(held[4]["resting"].get<bool>());
  EXPECT_TRUE(held[4]["converged"].get<bool>());
  EXPECT_EQ(read_png(file("x.png")).width, 24);
}

// ---- First impressions (issue 25): the default view, transfer function and field.

// The default camera is the three-quarter oblique view framed on the bounds (+z up), and the default opacity unit
// distance is a tenth of the bounds' diagonal: the inside shows. Measured by the light the data lets through, T =
// image over white - image over black: with the old unit distance (diagonal / 100) the slab was nearly opaque.
TEST_F(CliRender, EngineDefaultViewIsObliqueAndShowsTheInside) {
  // The ramp (--tf viridis) and its unit distance: "auto", the default, is tested in test_cli_default_tf.cpp.
  render_ok("-o " + file("a.pfm") + " --size 48 --tf viridis --save-camera " + file("cam.json") + " --save-tf " +
            file("tf.json") + " --stats " + file("s.json"));
  const Camera cam = read_camera(file("cam.json"));
  EXPECT_NEAR(dot(cam.direction(), normalized({0.6, 0.8, -0.55})), 1.0, 1e-9);
  EXPECT_GT(cam.view_up.z, 0.8);
  // ResetCamera's framing: distance = radius / sin(15 degrees), radius = half the diagonal.
  const double diagonal = 2 * cam.distance() * std::sin(15 * 3.141592653589793 / 180);
  const TransferFunction tf = read_paraview_preset(file("tf.json"));
  EXPECT_NEAR(tf.opacity_unit_distance, diagonal / 10, 1e-9 * diagonal);
  EXPECT_EQ(tf.name, "viridis");
  const json s = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(s["field"], "pressure");
  EXPECT_TRUE(s["field_default"].get<bool>());

  // Mean transmittance over the pixels the data covers.
  const auto see_through = [&](const std::string& flags) {
    render_ok("-o " + file("w.pfm") + " --size 48 --tf viridis --background 1,1,1" + flags);
    render_ok("-o " + file("b.pfm") + " --size 48 --tf viridis --background 0,0,0" + flags);
    const Image w = read_pfm(file("w.pfm")), b = read_pfm(file("b.pfm"));
    double sum = 0;
    int covered = 0;
    for (int y = 0; y < w.height; ++y)
      for (int x = 0; x < w.width; ++x) {
        const double t = w.pixel(x, y)[0] - b.pixel(x, y)[0];
        if (t < 0.99) sum += t, ++covered;
      }
    EXPECT_GT(covered, 48 * 48 / 10) << flags;
    return covered ? sum / covered : 0.0;
  };
  const double now = see_through("");
  const double before = see_through(" --unit-distance " + std::to_string(diagonal / 100));
  EXPECT_GT(now, 0.3) << "the data lets light through";
  EXPECT_LT(before, 0.1) << "at diagonal / 100 it was a slab";
}

// A legacy VTK mesh of two hexahedra whose first field is constant: "density" 1, "heat" varying along x, and a
// vector "velocity".
std::string write_constant_first(const std::string& path) {
  std::ofstream out(path);
  out << "# vtk DataFile Version 3.0\nbar\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 12 float\n";
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) out << i << " " << j << " " << k << "\n";
  const auto id = [](int i, int j, int k) { return i * 4 + j * 2 + k; };
  out << "CELLS 2 18\n";
  for (int i = 0; i < 2; ++i)
    out << "8 " << id(i, 0, 0) << " " << id(i + 1, 0, 0) << " " << id(i + 1, 1, 0) << " " << id(i, 1, 0) << " "
        << id(i, 0, 1) << " " << id(i + 1, 0, 1) << " " << id(i + 1, 1, 1) << " " << id(i, 1, 1) << "\n";
  out << "CELL_TYPES 2\n12\n12\nPOINT_DATA 12\nSCALARS density float 1\nLOOKUP_TABLE default\n";
  for (int p = 0; p < 12; ++p) out << "1\n";
  out << "SCALARS heat float 1\nLOOKUP_TABLE default\n";
  for (int p = 0; p < 12; ++p) out << float((p / 4) * (p / 4)) << "\n";
  out << "VECTORS velocity float\n";
  for (int p = 0; p < 12; ++p) out << float(p / 4) << " 0 " << float(p % 2) << "\n";
  return path;
}

// Without --field, the first field whose range is not constant is drawn, and --stats and the log say which.
TEST_F(CliRender, EngineDefaultFieldIsTheFirstThatVaries) {
  const std::string mesh = write_constant_first(file("bar.vtk"));
  const std::string cmd = "render " + mesh + " --size 24 -o " + file("a.png") + " --stats " + file("s.json");
  ASSERT_EQ(run_ugvr(cmd).status, 0);
  json s = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(s["field"], "heat");
  EXPECT_TRUE(s["field_default"].get<bool>());
  EXPECT_EQ(s["field_range"][1].get<double>(), 4.0);
  // Without --quiet the log names it.
  std::string log;
  {
    FILE* p = popen((std::string(UGVR_BINARY) + " " + cmd + " 2>&1").c_str(), "r");
    ASSERT_NE(p, nullptr);
    char buf[4096];
    for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) log.append(buf, n);
    EXPECT_EQ(pclose(p), 0) << log;
  }
  EXPECT_NE(log.find("field heat: the first that varies"), std::string::npos) << log;
  // Named, a constant field is still drawn.
  ASSERT_EQ(run_ugvr(cmd + " --field density").status, 0);
  s = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(s["field"], "density");
  EXPECT_FALSE(s["field_default"].get<bool>());
}

// The issue's case: the LOX post's first field, Density, is 1 everywhere.
TEST_F(CliRender, EngineDefaultFieldOfTheLoxPostVaries) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const std::string q = test::data_path("lox-post/postq.bin");
  ASSERT_EQ(run_ugvr("render " + relative_data_path + " " + q + " --size 16 -o " + file("a.png") + " --stats " +
                     file("s.json"))
                .status,
            0);
  const json s = json::parse(read_bytes(file("s.json")));
  EXPECT_NE(s["field"], "Density");
  EXPECT_LT(s["field_range"][0].get<double>(), s["field_range"][1].get<double>());
}

// A store built from a vector field names it "velocity:magnitude"; `--field velocity` selects it, as on the mesh. A
// store's default field is also the first that varies.
TEST_F(CliRender, LodVectorNameSelectsItsMagnitudeAndDefaultFieldVaries) {
  const std::string mesh = write_constant_first(file("bar.vtk"));
  const std::string store = file("bar.ugvr");
  const CommandResult b = run_ugvr("build " + mesh + " --fields density,velocity --brick 8 --max-depth 2 -o " + store);
  ASSERT_EQ(b.status, 0) << b.out;
  const std::string out = " --size 24 -o " + file("a.png") + " --stats " + file("s.json");
  CommandResult r = run_ugvr("render " + store + out + " --field velocity");
  ASSERT_EQ(r.status, 0) << r.out;
  json s = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(s["field"], "velocity:magnitude");
  EXPECT_GT(s["field_range"][1].get<double>(), 1.0);
  r = run_ugvr("render " + store + out);
  ASSERT_EQ(r.status, 0) << r.out;
  s = json::parse(read_bytes(file("s.json")));
  EXPECT_EQ(s["field"], "velocity:magnitude") << "density, the store's first field, is constant";
  EXPECT_TRUE(s["field_default"].get<bool>());
  ASSERT_EQ(run_ugvr("render " + store + out + " --field density").status, 0);
  EXPECT_EQ(json::parse(read_bytes(file("s.json")))["field"], "density");
  r = run_ugvr("render " + store + out + " --field heat");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("no field \"heat\""), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ugvr

namespace ugvr {
namespace {

// `--device`: the exact engine on the GPU engine (llvmpipe here) draws the CPU engine's picture; --stats says where it
// ran and what it cost on the device; `auto` on a software renderer stays on the CPU and says why.
TEST_F(CliRender, ExactEngineOnEitherDevice) {
  render_ok("--size 64 --device cpu -o " + file("cpu.pfm") + " --stats " + file("cpu.json"));
  render_ok("--size 64 --device gpu -o " + file("gpu.pfm") + " --stats " + file("gpu.json"));
  render_ok("--size 64 --device gpu --exact-precision float -o " + file("gpuf.pfm"));
  const Image cpu = read_pfm(file("cpu.pfm"));
  EXPECT_GE(compare_images(cpu, read_pfm(file("gpu.pfm"))).psnr_db, 60.0);
  EXPECT_GE(compare_images(cpu, read_pfm(file("gpuf.pfm"))).psnr_db, 50.0);
  std::ifstream cs(file("cpu.json")), gs(file("gpu.json"));
  const json c = json::parse(cs), g = json::parse(gs);
  EXPECT_EQ(c["device"].get<std::string>().rfind("CPU", 0), 0u) << c["device"];
  EXPECT_EQ(g["device"].get<std::string>().rfind("GPU", 0), 0u) << g["device"];
  EXPECT_GT(g["device_mesh_bytes_per_cell"].get<double>(), 20.0);
  EXPECT_EQ(g["lost_rays"].get<uint64_t>(), 0u);
  render_ok("--size 32 -o " + file("auto.png") + " --stats " + file("auto.json"));
  std::ifstream as(file("auto.json"));
  const json a = json::parse(as);
  if (a["device"].get<std::string>().rfind("CPU", 0) == 0) {
    EXPECT_TRUE(a.contains("gpu_unavailable")) << a.dump();
  }
  for (const char* bad : {"--device tpu", "--exact-precision half"}) {
    const CommandResult r = render(std::string(bad) + " -o " + file("bad.png"));
    EXPECT_EQ(r.status, 1) << bad;
    EXPECT_NE(r.out.find(std::string(bad).substr(0, std::string(bad).find(' '))), std::string::npos) << r.out;
  }
}

}  // namespace
}  // namespace ugvr
