// The image scale of a renderer that draws every frame whole (render/scaled_while_moving.h): reduced while the view
// moves, following the frame-rate target; full at rest and on a full-quality request.
#include <gtest/gtest.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ugvr/render/scaled_while_moving.h"

namespace ugvr {
namespace {

FrameRequest request(double fps, bool full_quality = false) {
  FrameRequest r;
  r.settings.width = 400, r.settings.height = 200;
  r.target_fps = fps;
  r.full_quality = full_quality;
  return r;
}

// What the inner renderer would return for `plan`: an image of the drawn size.
Frame drawn(const MovingScale::Plan& plan) {
  Frame f;
  f.image = Image(plan.drawn.settings.width, plan.drawn.settings.height);
  return f;
}

TEST(MovingScale, ScalesTheSideByTheSquareRootOfTheTimeOverTheTarget) {
  MovingScale ms;
  const FrameRequest moving = request(4);  // a 0.25 s period
  MovingScale::Plan p = ms.plan(moving);
  EXPECT_TRUE(p.moving);
  EXPECT_DOUBLE_EQ(p.scale, kMinMovingScale) << "the first frame's cost is unknown: it starts at the smallest scale";
  EXPECT_EQ(p.drawn.settings.width, 100);
  EXPECT_EQ(p.drawn.target_fps, 0.0) << "the inner renderer draws the frame whole";
  Frame f = drawn(p);
  ms.finish(p, moving, 0.25 / 4, f);  // a quarter of the period at a quarter of the side: half the side next
  EXPECT_FALSE(f.stats.converged);
  EXPECT_FALSE(f.stats.resting);

  p = ms.plan(moving);
  EXPECT_DOUBLE_EQ(p.scale, 0.5);
  EXPECT_EQ(p.drawn.settings.width, 200);
  EXPECT_EQ(p.drawn.settings.height, 100);
  f = drawn(p);
  ms.finish(p, moving, 0.25 / 4, f);  // a quarter of the period at half the side: back to full
  EXPECT_EQ(f.image.width, 400) << "magnified to the requested size";
  EXPECT_EQ(f.image.height, 200);
  EXPECT_DOUBLE_EQ(f.stats.scale, 0.5);
  EXPECT_FALSE(f.stats.converged);
  EXPECT_DOUBLE_EQ(ms.plan(moving).scale, 1.0) << "clamped at full scale";

  p = ms.plan(moving);
  f = drawn(p);
  ms.finish(p, moving, 100.0, f);  // far too slow: not below a quarter of the side
  EXPECT_TRUE(f.stats.converged) << "drawn at full scale: full quality for its request";
  EXPECT_DOUBLE_EQ(ms.plan(moving).scale, kMinMovingScale);
}

TEST(MovingScale, RestAndFullQualityAreDrawnAtFullScale) {
  MovingScale ms;
  MovingScale::Plan p = ms.plan(request(4));
  Frame f = drawn(p);
  ms.finish(p, request(4), 16.0, f);
  ASSERT_LT(ms.plan(request(4)).scale, 1.0);
  for (const FrameRequest& r : {request(4, true), request(0)}) {
    p = ms.plan(r);
    EXPECT_FALSE(p.moving);
    EXPECT_EQ(p.scale, 1.0);
    EXPECT_EQ(p.drawn.settings.width, 400);
    f = drawn(p);
    ms.finish(p, r, 16.0, f);
    EXPECT_TRUE(f.stats.converged);
    EXPECT_TRUE(f.stats.resting);
  }
  EXPECT_LT(ms.plan(request(4)).scale, 1.0) << "a frame at rest leaves the moving scale alone";
}

// The wrapper answers for the renderer it wraps: the default transfer function asks it for the histogram.
class CountingRenderer final : public Renderer {
 public:
  std::string_view engine() const override { return "lod"; }
  std::string device() const override { return "test"; }
  void set_field(std::string_view) override {}
  const std::string& field_name() const override { return name_; }
  FieldRange field_range() const override { return {0, 1}; }
  Bounds bounds() const override { return {}; }
  std::vector<uint64_t> value_histogram(double, double, int bins) const override {
    return std::vector<uint64_t>(size_t(bins), 3);
  }
  Frame render(const FrameRequest&) override { return {}; }
  void describe(nlohmann::json&) const override {}
  std::string summary(const FrameStats&) const override { return {}; }

 private:
  std::string name_ = "f";
};

TEST(MovingScale, TheWrapperForwardsTheHistogram) {
  const ScaledWhileMovingRenderer r(std::make_unique<CountingRenderer>());
  EXPECT_EQ(r.value_histogram(0, 1, 4), (std::vector<uint64_t>{3, 3, 3, 3}));
}

}  // namespace
}  // namespace ugvr
