// Interactivity for a renderer that draws every frame whole, with no time-critical session of its own (the pieces of
// a partitioned store, the ranks of an MPI job): while the view moves the frame is drawn at a reduced image scale and
// magnified (bilinear) to the requested size; at rest, or when full quality is asked for, at full scale.
//
// A frame is *moving* when the request has a frame-rate target and does not ask for full quality (the viewer asks for
// full quality once the tab's view rests: view/engine_host.cpp). Its scale is the previous moving frame's times
// sqrt(target period / time the frame took), clamped to [kMinMovingScale, 1]: the cost of a frame is about
// proportional to its pixels, so the side scales by the square root of the time ratio. Under MPI "the time the frame
// took" is the slowest rank's (mpi/mpi_view.cpp); in one process, the frame's own.
#pragma once

#include <memory>
#include <vector>

#include "ugvr/render/renderer.h"

namespace ugvr {

// Below a quarter of each side the picture no longer tells the user where the camera is going.
inline constexpr double kMinMovingScale = 0.25;

class MovingScale {
 public:
  struct Plan {
    bool moving = false;
    double scale = 1;
    FrameRequest drawn;  // the request at `scale`, with no frame-rate target (drawn whole)
  };
  Plan plan(const FrameRequest& request) const;
  // After the frame drawn for `plan`: adapts the next moving frame's scale to `seconds` (what bounds the frame rate)
  // and makes `frame` the answer to `request` (magnified to its size; scale, converged and resting set).
  void finish(const Plan& plan, const FrameRequest& request, double seconds, Frame& frame);

 private:
  // The image scale of the next moving frame. The first frame's cost is not known, and a tab's first frame is a
  // moving one (no view drawn yet): it starts at the smallest scale, so that a large store shows something at once
  // (a billion-cell index: a quarter of each side, 16x fewer pixels than its 5.5 s full frame), and grows from there.
  double moving_scale_ = kMinMovingScale;
};

// `inner` made interactive by MovingScale, in one process. Everything else is `inner`'s.
class ScaledWhileMovingRenderer final : public Renderer {
 public:
  explicit ScaledWhileMovingRenderer(std::unique_ptr<Renderer> inner) : inner_(std::move(inner)) {}

  std::string_view engine() const override { return inner_->engine(); }
  std::string device() const override { return inner_->device(); }
  void set_field(std::string_view name) override { inner_->set_field(name); }
  const std::string& field_name() const override { return inner_->field_name(); }
  FieldRange field_range() const override { return inner_->field_range(); }
  Bounds bounds() const override { return inner_->bounds(); }
  std::vector<uint64_t> value_histogram(double lo, double hi, int bins) const override {
    return inner_->value_histogram(lo, hi, bins);
  }
  std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const override {
    return inner_->visible_bounds(tf, threshold);
  }
  std::vector<double> visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                      const Bounds& own) const override {
    return inner_->visible_weights(tf, threshold, over, own);
  }
  void describe(nlohmann::json& j) const override { inner_->describe(j); }
  std::string summary(const FrameStats& last) const override { return inner_->summary(last); }
  Frame render(const FrameRequest& request) override;

 private:
  std::unique_ptr<Renderer> inner_;
  MovingScale scale_;
};

}  // namespace ugvr
