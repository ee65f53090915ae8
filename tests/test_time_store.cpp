// Stores with time (format version 6, docs/time-series.md "Stores with time"): the writer's and reader's steps section,
// its validation, and `ugvr build SERIES --time`, `info`, `render --time-step / --time` on such a store.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/render/image.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using nlohmann::json;
using test::run_ugvr;

constexpr uint32_t kR = 4;

// A linear ramp scaled by `scale`: R³ samples, x fastest.
std::vector<float> ramp(float scale) {
  std::vector<float> v(kR * kR * kR);
  for (uint32_t i = 0; i < v.size(); ++i) v[i] = scale * float(i) / float(v.size() - 1);
  return v;
}

BrickStoreLayout two_step_layout() {
  BrickStoreLayout l;
  l.resolution = kR;
  l.fields = {{"v", Association::Vertex, 0, 1}};
  l.root.lo = {0, 0, 0};
  l.root.hi = {1, 1, 1};
  l.data = l.root;
  l.times = {0.0, 0.5};
  return l;
}

// Writes a store of one node and two steps: step 0 the ramp over [0, 1], step 1 over [0, 2].
void write_two_steps(const std::string& path) {
  BrickStoreWriter w(path, two_step_layout());
  const std::vector<OctreeNode> nodes(1);
  for (uint32_t s = 0; s < 2; ++s) {
    const float scale = float(s + 1);
    const store_format::StepFieldRange range{0.0, double(scale)};
    w.begin_step(s, std::span(&range, 1));
    const std::vector<float> v = ramp(scale);
    const float* fields[] = {v.data()};
    w.add_brick(0, fields, nullptr);
    const FieldError e{0.25f * scale, 0.125f * scale};
    w.end_step(std::span(&e, 1));
  }
  w.commit(nodes);
}

TEST(TimeStore, WriterAndReaderKeepEveryStep) {
  test::ScratchDir dir;
  const std::string path = dir.file("t.ugvr");
  write_two_steps(path);
  BrickStoreReader r(path);
  EXPECT_EQ(r.header().version, 6u);
  ASSERT_TRUE(r.has_steps());
  ASSERT_EQ(r.step_count(), 2u);
  EXPECT_EQ(r.step_time(0), 0.0);
  EXPECT_EQ(r.step_time(1), 0.5);
  // The field record holds the union of the steps' ranges; each step keeps its own.
  EXPECT_EQ(r.layout().fields[0].min, 0.0);
  EXPECT_EQ(r.layout().fields[0].max, 2.0);
  EXPECT_EQ(r.step_range(0, 0).max, 1.0);
  EXPECT_EQ(r.step_range(1, 0).max, 2.0);
  EXPECT_FLOAT_EQ(r.stats(0, 0, 0).error_max, 0.25f);
  EXPECT_FLOAT_EQ(r.stats(0, 0, 1).error_max, 0.5f);
  EXPECT_NEAR(r.stats(0, 0, 1).max, 2.0f, 1e-4);
  EXPECT_NE(r.block(0, 0, 0).offset, r.block(0, 0, 1).offset);
  std::vector<float> got(kR * kR * kR);
  for (uint32_t s = 0; s < 2; ++s) {
    r.read_brick(0, 0, got.data(), nullptr, s);
    const std::vector<float> want = ramp(float(s + 1));
    for (size_t i = 0; i < got.size(); ++i) ASSERT_NEAR(got[i], want[i], 2e-5 * (s + 1)) << "step " << s << " " << i;
  }
  // The accessors without a step follow set_step.
  r.set_step(1);
  EXPECT_FLOAT_EQ(r.stats(0, 0).error_max, 0.5f);
  r.read_brick(0, 0, got.data(), nullptr);
  EXPECT_NEAR(got.back(), 2.0f, 1e-4);
  EXPECT_NE(test::error_of([&] { r.set_step(2); }).find("time step 2 out of range"), std::string::npos);
}

TEST(TimeStore, ReaderRefusesADamagedStepsSection) {
  test::ScratchDir dir;
  const std::string path = dir.file("t.ugvr");
  write_two_steps(path);
  const uint64_t at = BrickStoreReader(path).steps_header().section_offset + 3;
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(at));
    char c = 0;
    f.read(&c, 1);
    c = char(c ^ 0x40);
    f.seekp(std::streamoff(at));
    f.write(&c, 1);
  }
  const std::string e = test::error_of([&] { BrickStoreReader r(path); });
  EXPECT_NE(e.find("steps section checksum mismatch"), std::string::npos) << e;
  EXPECT_NE(e.find("byte " + std::to_string(at - 3)), std::string::npos) << e;
}

TEST(TimeStore, WriterRefusesStepsOutOfOrderOrWithOtherGeometry) {
  test::ScratchDir dir;
  {
    BrickStoreWriter w(dir.file("a.ugvr"), two_step_layout());
    const store_format::StepFieldRange range{0, 1};
    EXPECT_NE(test::error_of([&] { w.begin_step(1, std::span(&range, 1)); }).find("in order"), std::string::npos);
  }
  {
    // Step 1 has no brick where step 0 has one: the masks (the geometry) differ.
    BrickStoreWriter w(dir.file("b.ugvr"), two_step_layout());
    const store_format::StepFieldRange range{0, 1};
    const std::vector<float> v = ramp(1);
    const float* fields[] = {v.data()};
    w.begin_step(0, std::span(&range, 1));
    w.add_brick(0, fields, nullptr);
    w.end_step({});
    w.begin_step(1, std::span(&range, 1));
    w.end_step({});
    const std::vector<OctreeNode> nodes(1);
    EXPECT_NE(test::error_of([&] { w.commit(nodes); }).find("geometry differs"), std::string::npos);
  }
  BrickStoreLayout bad = two_step_layout();
  bad.times = {1.0, NAN};
  EXPECT_NE(test::error_of([&] { BrickStoreWriter w(dir.file("c.ugvr"), bad); }).find("not finite"), std::string::npos);
}

json run_json(const std::string& args) {
  const test::CommandResult r = run_ugvr(args);
  EXPECT_EQ(r.status, 0) << args << "\n" << r.out;
  const size_t brace = r.out.find('{');
  return brace == std::string::npos ? json() : json::parse(r.out.substr(brace), nullptr, false);
}

// The test: mug.e's 21 steps in one store; info lists them; steps 0 and 20 differ; step k of the time store is
// the image of a store of step k alone.
TEST(TimeStore, MugAllStepsInOneStore) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  test::ScratchDir dir;
  const std::string mug = relative_data_path;
  const std::string opts = " --fields diffused --brick 8 --max-depth 3 --error 0 ";
  const test::CommandResult b = run_ugvr("build " + mug + opts + "--time all -o " + dir.file("all.ugvr"));
  ASSERT_EQ(b.status, 0) << b.out;

  const json info = run_json("info " + dir.file("all.ugvr") + " --json");
  ASSERT_TRUE(info.contains("time")) << info.dump();
  ASSERT_EQ(info["time"]["count"].get<int>(), 21);
  const json series = run_json("info " + mug + " --json");
  for (int s = 0; s < 21; ++s)
    EXPECT_DOUBLE_EQ(info["time"]["steps"][size_t(s)]["time"].get<double>(),
                     series["time"]["steps"][size_t(s)]["time"].get<double>());
  const test::CommandResult text = run_ugvr("info " + dir.file("all.ugvr"));
  EXPECT_NE(text.out.find("time:     21 steps"), std::string::npos) << text.out;

  // A fixed range and transfer function for the comparisons: the same colour map for every image (the default, auto,
  // is made from each store's own histogram, which a store of all steps and one of a step do not share).
  const json range = info["time"]["steps"][20]["ranges"]["diffused"];
  const std::string fixed =
      " --range " + std::to_string(range[0].get<double>()) + "," + std::to_string(range[1].get<double>()) + " ";
  auto render_fixed = [&](const std::string& store, const std::string& step, const std::string& out) {
    const test::CommandResult r = run_ugvr("render " + store + " --size 64 --view iso --cut leaves --tf viridis" +
                                           fixed + step + " -o " + dir.file(out));
    EXPECT_EQ(r.status, 0) << r.out;
    return read_png(dir.file(out));
  };
  const Image first = render_fixed(dir.file("all.ugvr"), "--time-step 0", "s0.png");
  const Image last = render_fixed(dir.file("all.ugvr"), "--time-step 20", "s20.png");
  EXPECT_GT(compare_images(first, last).max_abs, 0.1) << "steps 0 and 20 of mug.e look the same";

  for (int k : {10, 20}) {
    const std::string one = dir.file("one" + std::to_string(k) + ".ugvr");
    const test::CommandResult b1 = run_ugvr("build " + mug + opts + "--time-step " + std::to_string(k) + " -o " + one);
    ASSERT_EQ(b1.status, 0) << b1.out;
    const Image from_series = render_fixed(dir.file("all.ugvr"), "--time-step " + std::to_string(k), "a.png");
    const Image alone = render_fixed(one, "", "b.png");
    const ImageDifference d = compare_images(from_series, alone);
    EXPECT_GE(d.psnr_db, 60.0) << "step " << k << ": max difference " << d.max_abs;
  }

  // The time-critical renderer (--time-budget) honours the step too: its RAM cache is made for the step drawn.
  auto budget = [&](const std::string& step, const std::string& out) {
    const test::CommandResult r = run_ugvr("render " + dir.file("all.ugvr") + " --size 64 --view iso --time-budget 20" +
                                           fixed + step + " -o " + dir.file(out));
    EXPECT_EQ(r.status, 0) << r.out;
    return read_png(dir.file(out));
  };
  EXPECT_GT(compare_images(budget("--time-step 0", "t0.png"), budget("--time-step 20", "t20.png")).max_abs, 0.1);

  // --time on the store: one image per step, steps.json listing them.
  const test::CommandResult t =
      run_ugvr("render " + dir.file("all.ugvr") + " --size 32 --cut leaves --time 0:20:10 --out " + dir.file("frames"));
  ASSERT_EQ(t.status, 0) << t.out;
  std::ifstream steps_json(dir.file("frames/steps.json"));
  const json steps = json::parse(steps_json);
  ASSERT_EQ(steps["steps"].size(), 3u);
  EXPECT_EQ(steps["steps"][2]["step"].get<int>(), 20);
  EXPECT_TRUE(std::filesystem::exists(dir.file("frames/time_00002.png")));
  // Out of range.
  const test::CommandResult bad =
      run_ugvr("render " + dir.file("all.ugvr") + " --time-step 21 -o " + dir.file("x.png"));
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("holds 21 steps"), std::string::npos) << bad.out;
}

// A generated series with --error > 0: the tree is the union of the steps' trees (at least the first step's own), and
// the out-of-core builder (at --error 0 only: tests/test_octree_out_of_core_steps.cpp) and changing geometry are
// refused with a clear message.
TEST(TimeStore, GeneratedSeriesUnionTreeAndRefusals) {
  test::ScratchDir dir;
  ASSERT_EQ(run_ugvr("generate -o " + dir.file("w.pvd") + " --cells 3000 --time-steps 3").status, 0);
  const json b = run_json("build " + dir.file("w.pvd") + " --time all --brick 8 --max-depth 4 --error 0.02 --json -o " +
                          dir.file("w.ugvr"));
  ASSERT_TRUE(b.is_object());
  EXPECT_EQ(b["time_steps"].get<int>(), 3);
  EXPECT_GE(b["nodes"].get<uint64_t>(), b["first_step_nodes"].get<uint64_t>());
  BrickStoreReader r(dir.file("w.ugvr"));
  ASSERT_EQ(r.step_count(), 3u);
  // The vortex street moves: the steps' bricks differ somewhere.
  std::vector<float> a(size_t(8 * 8 * 8)), c(a.size());
  bool differ = false;
  for (uint64_t n = 0; n < r.node_count() && !differ; ++n) {
    if (!r.node(n).has_brick()) continue;
    r.read_brick(n, 0, a.data(), nullptr, 0);
    r.read_brick(n, 0, c.data(), nullptr, 2);
    differ = a != c;
  }
  EXPECT_TRUE(differ);

  const test::CommandResult ooc =
      run_ugvr("build " + dir.file("w.pvd") + " --time all --out-of-core -o " + dir.file("o.ugvr"));
  EXPECT_NE(ooc.status, 0);
  EXPECT_NE(ooc.out.find("--out-of-core --time"), std::string::npos) << ooc.out;

  // Changing geometry: two meshes of other sizes as one series.
  ASSERT_EQ(run_ugvr("generate -o " + dir.file("g_0001.vtu") + " --cells 2000").status, 0);
  ASSERT_EQ(run_ugvr("generate -o " + dir.file("g_0002.vtu") + " --cells 3000").status, 0);
  const test::CommandResult moving =
      run_ugvr("build '" + dir.file("g_%04d.vtu") + "' --time all -o " + dir.file("g.ugvr"));
  EXPECT_NE(moving.status, 0);
  EXPECT_NE(moving.out.find("build one store per step"), std::string::npos) << moving.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("g.ugvr")));
}

}  // namespace
}  // namespace ugvr
