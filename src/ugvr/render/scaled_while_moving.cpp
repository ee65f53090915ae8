#include "ugvr/render/scaled_while_moving.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "ugvr/render/image.h"

namespace ugvr {

MovingScale::Plan MovingScale::plan(const FrameRequest& request) const {
  Plan p;
  p.moving = request.target_fps > 0 && !request.full_quality;
  p.scale = p.moving ? moving_scale_ : 1.0;
  p.drawn = request;
  p.drawn.settings.width = std::max(1, int(std::lround(p.scale * request.settings.width)));
  p.drawn.settings.height = std::max(1, int(std::lround(p.scale * request.settings.height)));
  p.drawn.target_fps = 0;
  return p;
}

void MovingScale::finish(const Plan& plan, const FrameRequest& request, double seconds, Frame& frame) {
  if (plan.moving && seconds > 0)
    moving_scale_ = std::clamp(plan.scale * std::sqrt((1.0 / request.target_fps) / seconds), kMinMovingScale, 1.0);
  if (frame.image.width != request.settings.width || frame.image.height != request.settings.height)
    frame.image = resize_bilinear(frame.image, request.settings.width, request.settings.height);
  frame.stats.scale = plan.scale;
  frame.stats.converged = plan.scale >= 1;
  frame.stats.resting = !plan.moving;
}

Frame ScaledWhileMovingRenderer::render(const FrameRequest& request) {
  const auto start = std::chrono::steady_clock::now();
  const MovingScale::Plan plan = scale_.plan(request);
  Frame frame = inner_->render(plan.drawn);
  scale_.finish(plan, request, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), frame);
  frame.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return frame;
}

}  // namespace ugvr
