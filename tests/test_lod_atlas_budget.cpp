// Issue 23: a cut larger than what the device will allocate (llvmpipe refused a 13,217-brick atlas that --gpu-memory's
// default allowed: "out of GPU memory"). The engine finds the largest atlas the device does allocate, makes it the
// budget, and chooses the cut again within it, in a still image and in the time-critical path. The device's refusal is
// injected with UGVR_ATLAS_MAX_BYTES.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"

namespace ugvr {
namespace {

TEST(LodAtlasBudget, ACutOverWhatTheDeviceAllocatesIsChosenAgainWithinIt) {
  // 40 slots of 10³ texels x 4 bytes (brick 8): the limit the "device" allocates.
  ::setenv("UGVR_ATLAS_MAX_BYTES", std::to_string(40 * 1000 * 4).c_str(), 1);
  test::ScratchDir dir;
  GenerateOptions g;
  g.cells = 20000, g.kind = GenCellKind::Mixed;
  const Dataset ds = generate_in_memory(g);
  OctreeBuildOptions o;
  o.resolution = 8, o.max_depth = 5, o.error = 0.001;
  const std::string store = dir.file("s.ugvr");
  const std::vector<std::string> fields{"pressure"};
  build_octree(prepare_octree_input(ds, fields), o, store);

  std::unique_ptr<GlContext> gl;
  try {
    gl = std::make_unique<GlContext>("auto");
  } catch (const Error& e) {
    if (std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << e.what();
    FAIL() << e.what();
  }
  LodEngine engine(store, *gl, LodOptions{});
  ASSERT_GT(engine.node_count(), 100u) << "the store must need more than the injected limit at its leaves";
  const Camera camera = default_camera(engine.bounds());
  const TransferFunction tf = default_transfer_function(engine.field_min(), engine.field_max(), engine.bounds());
  RenderSettings settings;
  settings.width = settings.height = 48;
  CutSpec leaves;
  leaves.kind = CutSpec::Kind::Leaves;
  LodRenderStats st;
  const uint64_t budget_before = engine.atlas_budget_bricks();
  const Image image = engine.render(camera, tf, settings, leaves, &st);
  EXPECT_GT(budget_before, 1000u);
  EXPECT_LE(engine.atlas_budget_bricks(), 40u) << "the budget is what the device allocates";
  EXPECT_GE(engine.atlas_budget_bricks(), 30u) << "and not much less";
  EXPECT_LE(st.cut_nodes, engine.atlas_budget_bricks());
  EXPECT_TRUE(st.budget_limited);
  EXPECT_LE(st.atlas_bytes, uint64_t(40 * 1000 * 4));
  EXPECT_EQ(image.width, 48);
  // Much of the image is data (not the background): the cut is drawn, not dropped.
  int drawn = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x) {
      const float* p = image.pixel(x, y);
      drawn += std::abs(p[0] - float(settings.background[0])) + std::abs(p[1] - float(settings.background[1])) > 0.02f;
    }
  EXPECT_GT(drawn, 48 * 48 / 10);

  // The time-critical path (the viewer's): a fresh engine learns the device's limit inside a frame, and the frame's
  // cut merges down to it instead of failing; refining at rest stays within it.
  LodEngine fresh(store, *gl, LodOptions{});
  TimeCriticalRenderer tc(fresh, TimeCriticalOptions{});
  TimeCriticalFrame report;
  const Image full = tc.full_quality(camera, tf, settings, &report);
  EXPECT_LE(fresh.atlas_budget_bricks(), 40u);
  EXPECT_LE(report.visible_nodes, fresh.atlas_budget_bricks());
  EXPECT_EQ(full.width, 48);
  ::unsetenv("UGVR_ATLAS_MAX_BYTES");
}

}  // namespace
}  // namespace ugvr
