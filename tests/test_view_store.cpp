// The viewer's store cache (view_store.h), its background build (background_build.h) and the exact engine's preview
// frames (render/exact/exact_renderer.h).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/view/background_build.h"
#include "ugvr/view/view_store.h"

namespace ugvr::view {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("ugvr-test-view-store-" + std::to_string(::getpid())) / name;
  fs::create_directories(d);
  return d;
}

std::shared_ptr<const Dataset> wing(uint64_t cells) {
  GenerateOptions g;
  g.cells = cells, g.kind = GenCellKind::Mixed;
  return std::make_shared<Dataset>(generate_in_memory(g));
}

// The build's state once it is no longer running (or after a minute).
BackgroundBuild::State finished(const BackgroundBuild& build) {
  BackgroundBuild::State st;
  for (int i = 0; i < 1200; ++i) {
    st = build.state();
    if (st.stage != BackgroundBuild::Stage::Running) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return st;
}

TEST(ViewStore, CachePathFollowsInputsFieldsAndOptions) {
  const fs::path dir = scratch("key");
  const std::string a = (dir / "a.vtu").string(), b = (dir / "b.vtu").string();
  std::ofstream(a) << "one";
  std::ofstream(b) << "two";
  ::setenv("UGVR_CACHE_DIR", (dir / "cache").c_str(), 1);
  const OctreeBuildOptions o;
  const std::vector<std::string> none, p = {"pressure"};
  const std::string pa = cached_store_path(std::vector{a}, none, o);
  EXPECT_EQ(pa, cached_store_path(std::vector{a}, none, o)) << "stable";
  EXPECT_EQ(fs::path(pa).parent_path(), dir / "cache");
  EXPECT_TRUE(fs::path(pa).filename().string().starts_with("a-"));
  EXPECT_EQ(fs::path(pa).extension(), ".ugvr");
  EXPECT_NE(pa, cached_store_path(std::vector{b}, none, o)) << "another file";
  EXPECT_NE(pa, cached_store_path(std::vector{a}, p, o)) << "other fields";
  OctreeBuildOptions deeper = o;
  deeper.max_depth = o.max_depth + 1;
  EXPECT_NE(pa, cached_store_path(std::vector{a}, none, deeper)) << "other build options";
  OctreeBuildOptions cells = o;  // the out-of-core viewer's build keeps the leaves' cells
  cells.leaf_cells = true;
  EXPECT_NE(pa, cached_store_path(std::vector{a}, none, cells)) << "with the leaves' cells";
  std::ofstream(a) << "one, edited";  // a new size
  EXPECT_NE(pa, cached_store_path(std::vector{a}, none, o)) << "an edited file";
  ::unsetenv("UGVR_CACHE_DIR");
}

TEST(ViewStore, DefaultFieldsSkipConstantOnes) {
  Dataset ds = *wing(2000);
  // The generated wing: pressure, velocity (vector) per vertex, wall_distance per cell, all varying.
  EXPECT_EQ(default_view_fields(ds), (std::vector<std::string>{"pressure", "velocity", "wall_distance"}));
  EXPECT_EQ(default_view_fields(ds, 1), (std::vector<std::string>{"pressure"}));
  const uint64_t n = ds.blocks[0].fields.find("pressure")->tuples();
  ds.blocks[0].fields.add(Field("flat", Association::Vertex, DataArray::from(std::vector<float>(n, 2.0f), 1)));
  EXPECT_EQ(default_view_fields(ds).size(), 3u) << "a constant field is not offered";
}

TEST(BackgroundBuild, BuildsTheStoreAndReportsProgress) {
  const fs::path path = scratch("build") / "wing.ugvr";
  OctreeBuildOptions o;
  o.resolution = 8, o.max_depth = 3;
  BackgroundBuild build(wing(3000), {"pressure"}, o, path.string());
  const BackgroundBuild::State st = finished(build);
  ASSERT_EQ(st.stage, BackgroundBuild::Stage::Done) << st.error;
  EXPECT_EQ(st.fraction, 1.0);
  const BrickStoreReader reader(path.string());
  EXPECT_EQ(reader.layout().fields.at(0).name, "pressure");
}

TEST(BackgroundBuild, CancelledWhenDestroyedLeavingNothing) {
  const fs::path path = scratch("cancel") / "wing.ugvr";
  OctreeBuildOptions o;
  o.max_depth = 8, o.error = 0;  // far more work than the moment before the destructor cancels it
  const auto dataset = wing(100'000);
  const auto start = std::chrono::steady_clock::now();
  {
    BackgroundBuild build(dataset, {"velocity"}, o, path.string());
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_EQ(build.state().stage, BackgroundBuild::Stage::Running);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(fs::exists(path));
  for (const auto& e : fs::directory_iterator(path.parent_path())) ADD_FAILURE() << "left behind: " << e.path();
  // Not a timing target: a destructor that waited for the whole build would take minutes here.
  EXPECT_LT(seconds, 60.0);
}

// Issue 23: two viewers of the same grid at once share the cache entry: one builds, the other waits on its lock and
// then uses the store it wrote.
TEST(BackgroundBuild, TwoViewersOfOneGridBuildItOnce) {
  const fs::path path = scratch("shared") / "wing.ugvr";
  OctreeBuildOptions o;
  o.resolution = 8, o.max_depth = 4;
  const auto dataset = wing(20'000);
  BackgroundBuild a(dataset, {"pressure"}, o, path.string());
  BackgroundBuild b(dataset, {"pressure"}, o, path.string());
  BackgroundBuild::State sa, sb;
  for (int i = 0; i < 2400; ++i) {
    sa = a.state(), sb = b.state();
    if (sa.stage != BackgroundBuild::Stage::Running && sb.stage != BackgroundBuild::Stage::Running) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(sa.stage, BackgroundBuild::Stage::Done) << sa.error;
  ASSERT_EQ(sb.stage, BackgroundBuild::Stage::Done) << sb.error;
  EXPECT_EQ(int(sa.reused) + int(sb.reused), 1) << "exactly one of the two builds the store";
  const BrickStoreReader reader(path.string());
  EXPECT_EQ(reader.layout().fields.at(0).name, "pressure");
  for (const auto& e : fs::directory_iterator(path.parent_path()))
    EXPECT_EQ(e.path(), path) << "left behind: " << e.path();
}

// Out of core at a budget too small for the mesh boundary's triangles the store keeps the stencil's boundary; the
// build says so (State::note), and the viewer and `ugvr render` pass it on. At a roomy budget it says nothing.
TEST(BackgroundBuild, OutOfCoreSaysWhenItLeavesOutTheBoundary) {
  const fs::path dir = scratch("boundary-note");
  GenerateOptions g;
  g.cells = 2000, g.kind = GenCellKind::Mixed;
  const std::string vtu = (dir / "wing.vtu").string();
  generate_dataset(g, vtu);
  OctreeBuildOptions o;
  o.resolution = 8, o.max_depth = 3;
  auto note_at = [&](uint64_t budget, const std::string& name) {
    BackgroundBuild build(BackgroundBuild::OutOfCore{vtu, budget}, {"pressure"}, o, (dir / name).string());
    const BackgroundBuild::State st = finished(build);
    EXPECT_EQ(st.stage, BackgroundBuild::Stage::Done) << st.error;
    return st.note;
  };
  const std::string tight = note_at(100 << 10, "tight.ugvr");
  EXPECT_NE(tight.find("over half of the memory budget"), std::string::npos) << tight;
  EXPECT_EQ(tight.find("about 0 MiB"), std::string::npos) << tight;  // a small boundary in KiB, not "0 MiB"
  EXPECT_EQ(note_at(uint64_t(256) << 20, "roomy.ugvr"), "");
}

TEST(BackgroundBuild, AFailureIsReported) {
  BackgroundBuild build(wing(2000), {"no_such_field"}, OctreeBuildOptions{}, (scratch("fail") / "x.ugvr").string());
  BackgroundBuild::State st;
  for (int i = 0; i < 600 && (st = build.state()).stage == BackgroundBuild::Stage::Running; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_EQ(st.stage, BackgroundBuild::Stage::Failed);
  EXPECT_NE(st.error.find("no_such_field"), std::string::npos) << st.error;
}

// The viewer's picture of a grid while its store is built: the exact engine as an interactive renderer.
TEST(ExactPreview, ScaledWhileMovingAndFullSizeAtRest) {
  RendererOptions ro;
  ro.interactive = true;
  auto scene = std::make_shared<ExactScene>(wing(3000));
  auto preview = make_renderer(scene, ro);
  auto other_tab = make_renderer(scene, ro);  // one walk mesh, a scale per tab
  FrameRequest r;
  r.settings.width = 96, r.settings.height = 64;
  r.camera = reset_camera(preview->bounds(), 30);
  r.tf = builtin_preset("viridis");
  r.tf.rescale(0, 1.2);
  r.settings.field = "velocity";
  r.target_fps = 1e6;  // a target no frame meets (a microsecond; 1000 fps was met at 48 x 32 on an idle machine)
  const Frame moving = preview->render(r);
  EXPECT_FALSE(moving.stats.converged);
  EXPECT_EQ(moving.image.width, 96);
  EXPECT_EQ(moving.image.height, 64);
  EXPECT_LT(moving.stats.scale, 1.0);
  r.camera.position.x += 1;
  const Frame smaller = preview->render(r);
  EXPECT_LT(smaller.stats.scale, moving.stats.scale) << "too slow for the target: the next frame is smaller";
  r.settings.field = "pressure";
  EXPECT_EQ(other_tab->render(r).stats.scale, 0.5) << "the other tab starts at its own scale, on its own field";
  r.settings.field = "velocity";
  const Frame rest = preview->render(r);  // the same view again: at rest
  EXPECT_TRUE(rest.stats.converged);
  EXPECT_TRUE(rest.stats.resting);
  EXPECT_EQ(rest.stats.scale, 1.0);
  EXPECT_EQ(rest.image.width, 96);
  r.full_quality = true;
  r.camera.position.x += 1;
  EXPECT_TRUE(preview->render(r).stats.converged) << "full quality asked for: converged while moving";
  r.settings.field = "nope";
  EXPECT_THROW(preview->render(r), Error);
}

}  // namespace
}  // namespace ugvr::view
