// Playing a store with time steps in the time-critical session (lod_renderer.h, time_critical.h): a new step keeps the
// session's cut, and the bricks FrameRequest::prefetch_time_step asked for are read ahead, so that the first frame of
// the next step reads nothing from disk on the render thread.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>

#include "gl_test_support.h"
#include "test_data.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/lod/lod_renderer.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

struct Fixture {
  test::ScratchDir dir;
  std::string store;
  std::shared_ptr<const GlContext> gl;
  std::string gl_error;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture r;
    const std::string series = r.dir.file("w.pvd");
    r.store = r.dir.file("w.ugvr");
    EXPECT_EQ(test::run_ugvr("generate -o " + series + " --cells 3000 --time-steps 3").status, 0);
    EXPECT_EQ(test::run_ugvr("build " + series + " --time all --brick 8 --max-depth 4 --error 0 -o " + r.store).status,
              0);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return f;
}

FrameRequest request_for(const BrickStoreReader& store) {
  const BrickStoreField& fd = store.layout().fields[0];
  FrameRequest q;
  q.camera = camera_preset("iso", store.layout().data);
  q.tf.color_points = {{fd.min, {0.1, 0.2, 0.9}}, {fd.max, {0.95, 0.2, 0.1}}};
  q.tf.opacity_points = {{fd.min, 0.05}, {fd.max, 0.6}};
  q.tf.opacity_unit_distance = 0.05 * store.layout().data.size().x;
  q.settings.width = q.settings.height = 64;
  q.settings.field = fd.name;
  q.target_fps = 5;
  q.time_step = 0;
  return q;
}

// Frames of `q` until one is converged (at most 101).
Frame converge(InteractiveLodRenderer& r, const FrameRequest& q) {
  Frame frame = r.render(q);
  for (int i = 0; i < 100 && !frame.stats.converged; ++i) frame = r.render(q);
  return frame;
}

const TimeCriticalFrame& detail_of(const Frame& f) {
  return dynamic_cast<const InteractiveLodFrameStats&>(*f.stats.detail).frame;
}

// With and without reading ahead: the step switch keeps the converged cut (not the coarsest one); with the prefetch
// the new step's bricks all come from RAM, without it they are read from disk in the frame.
TEST(TimePlayback, StepSwitchKeepsTheCutAndReadsTheNextStepAhead) {
  const Fixture& f = fixture();
  UGVR_REQUIRE_GL_CONTEXT(f.gl, f.gl_error);
  const BrickStoreReader store(f.store);
  ASSERT_EQ(store.step_count(), 3u);
  auto scene = std::make_shared<LodScene>(f.store, f.gl);
  for (const bool prefetch : {false, true}) {
    SCOPED_TRACE(prefetch ? "prefetch" : "no prefetch");
    TimeCriticalOptions tco;
    tco.loader_threads = 2;
    InteractiveLodRenderer r(scene, tco);
    FrameRequest q = request_for(store);
    Frame frame = converge(r, q);
    ASSERT_TRUE(frame.stats.converged);
    const uint64_t cut = frame.stats.cut_nodes;
    const Image step0 = frame.image;
    ASSERT_GT(cut, 8u) << "the converged cut should be finer than the root's children";
    if (prefetch) {
      q.prefetch_time_step = 1;
      r.render(q);  // at rest: the same cut; the prefetch asks for its bricks of step 1
      EXPECT_TRUE(r.wait_prefetch(60));
      q.prefetch_time_step.reset();
    } else {
      EXPECT_FALSE(r.wait_prefetch(0));
    }
    q.time_step = 1;
    const Frame next = r.render(q);
    const TimeCriticalFrame& d = detail_of(next);
    EXPECT_FALSE(next.stats.resting);  // drawn within the frame budget, as a moving frame
    EXPECT_TRUE(d.switched);
    EXPECT_EQ(d.switch_cut_before, cut);
    EXPECT_GT(d.uploads, 0u);  // the new step's bricks replaced the old ones on the GPU
    if (prefetch) {
      EXPECT_EQ(d.switch_cut_after, cut);  // every drawn brick was read ahead: the cut carried over
      // The frame is budgeted as a moving one: the ancestors were read ahead too, so the cut can merge down to the
      // policy's node budget (the coarsest cut, at most the root's 8 children, whatever the budget).
      EXPECT_LE(next.stats.cut_nodes, std::max<uint64_t>(d.budget_nodes, 8));
      EXPECT_EQ(d.sync_reads, 0u);
      EXPECT_TRUE(d.playing);  // a prefetch was asked for after the last frame
    } else {
      // Nothing of step 1 in RAM: the cut is kept, and its bricks come from disk in this frame: read on the render
      // thread, or by the cache's workers (which may win the race for small bricks), loaded or still under way.
      EXPECT_EQ(d.prefetched, 0u);
      EXPECT_EQ(d.switch_cut_after, cut);
      EXPECT_GE(next.stats.cut_nodes, cut / 2);
      EXPECT_GT(d.sync_reads + d.cache.loads_completed + d.cache.queued + d.cache.loading, 0u);
      EXPECT_FALSE(d.playing);
    }
    EXPECT_NE(next.image.rgba, step0.rgba);  // the vortex street moved
  }
}

// Playing with the prefetch cut short (the next step asked for before its bricks can all be read): the switch
// coarsens the cut to the bricks that were read (coarse ones first), so the step's first frame reads nothing on the
// render thread, and being a playing frame it queues no read of its own step (the workers go to the next one).
TEST(TimePlayback, PlayingFramesDrawOnlyPrefetchedBricks) {
  const Fixture& f = fixture();
  UGVR_REQUIRE_GL_CONTEXT(f.gl, f.gl_error);
  const BrickStoreReader store(f.store);
  auto scene = std::make_shared<LodScene>(f.store, f.gl);
  TimeCriticalOptions tco;
  tco.loader_threads = 1;
  InteractiveLodRenderer r(scene, tco);
  FrameRequest q = request_for(store);
  Frame frame = converge(r, q);
  ASSERT_TRUE(frame.stats.converged);
  const uint64_t cut = frame.stats.cut_nodes;
  // Play 0 -> 1 -> 2 -> 0 with no wait between the steps.
  for (uint32_t s = 1; s <= 3; ++s) {
    SCOPED_TRACE("step " + std::to_string(s % 3));
    q.prefetch_time_step = s % 3;
    r.render(q);  // the previous step's frame asks for this one's bricks
    q.time_step = s % 3;
    q.prefetch_time_step = (s + 1) % 3;
    const Frame next = r.render(q);
    const TimeCriticalFrame& d = detail_of(next);
    EXPECT_TRUE(d.switched);
    EXPECT_TRUE(d.playing);
    EXPECT_LE(d.switch_cut_after, d.switch_cut_before);
    if (s == 1) {
      EXPECT_EQ(d.switch_cut_before, cut);  // the converged cut, kept by the frame at rest before
    }
    // One worker reads by priority, the root first: once it has read anything, every drawn brick is in RAM (before,
    // the switch keeps the cut and reads its bricks here).
    if (d.prefetched > 0) {
      EXPECT_EQ(d.sync_reads, 0u) << "prefetched " << d.prefetched << ", cut " << d.switch_cut_after;
    }
    EXPECT_EQ(d.cache.queued, 0u);  // nothing of this step queued: it is shown once
    EXPECT_GT(d.uploads, 0u);
  }
}

// A prefetch of a step out of range is ignored (the engine refuses the step itself when it is drawn).
TEST(TimePlayback, PrefetchOfAStepOutOfRangeIsIgnored) {
  const Fixture& f = fixture();
  UGVR_REQUIRE_GL_CONTEXT(f.gl, f.gl_error);
  const BrickStoreReader store(f.store);
  auto scene = std::make_shared<LodScene>(f.store, f.gl);
  InteractiveLodRenderer r(scene, TimeCriticalOptions{});
  FrameRequest q = request_for(store);
  q.prefetch_time_step = 7;
  EXPECT_NO_THROW(r.render(q));
  EXPECT_FALSE(r.wait_prefetch(0));
}

}  // namespace
}  // namespace ugvr
