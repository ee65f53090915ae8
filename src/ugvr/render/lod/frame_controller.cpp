#include "ugvr/render/lod/frame_controller.h"

#include <algorithm>
#include <cmath>

#include "ugvr/core/error.h"

namespace ugvr {

FrameController::FrameController(FrameControllerOptions options) : options_(options) {
  const FrameControllerOptions& o = options_;
  if (!(o.target_seconds >= 0 && std::isfinite(o.target_seconds)))
    fail_in("frame controller", "the target frame time must be finite and >= 0");
  if (!(o.min_budget > 0 && o.min_budget <= o.initial_budget && o.initial_budget <= o.max_budget &&
        o.max_budget <= 1e18))
    fail_in("frame controller", "the budgets must satisfy 0 < min <= initial <= max <= 1e18");
  if (!(o.smoothing > 0 && o.smoothing <= 1)) fail_in("frame controller", "smoothing must be in (0, 1]");
  if (!(o.max_growth >= 1 && std::isfinite(o.max_growth))) fail_in("frame controller", "max_growth must be >= 1");
  if (!(o.spike_clamp >= 1 && std::isfinite(o.spike_clamp))) fail_in("frame controller", "spike_clamp must be >= 1");
  reset();
}

void FrameController::set_target_seconds(double seconds) {
  if (!(seconds >= 0 && std::isfinite(seconds)))
    fail_in("frame controller", "the target frame time must be finite and >= 0");
  options_.target_seconds = seconds;
}

void FrameController::reset() {
  cost_ = 0;
  budget_ = options_.initial_budget;
}

uint64_t FrameController::budget() const {
  if (options_.target_seconds == 0) return kUnlimited;
  return uint64_t(std::floor(budget_));
}

uint64_t FrameController::frame(double seconds, uint64_t work) {
  if (!(seconds >= 0 && std::isfinite(seconds)))
    fail_in("frame controller", "the measured frame time must be finite and >= 0");
  if (work > 0) {
    const double sample = seconds / double(work);
    if (cost_ == 0) {
      cost_ = sample;  // the first measurement (or a clock too coarse to see one) is all we know
    } else {
      const double clamped = std::clamp(sample, cost_ / options_.spike_clamp, cost_ * options_.spike_clamp);
      cost_ += options_.smoothing * (clamped - cost_);
    }
  }
  if (options_.target_seconds > 0) {
    // A zero estimate (a clock that cannot resolve the frame): work is free as far as we can tell, so grow.
    const double desired = cost_ > 0 ? options_.target_seconds / cost_ : options_.max_budget;
    budget_ = std::clamp(std::min(desired, budget_ * options_.max_growth), options_.min_budget, options_.max_budget);
  }
  return budget();
}

}  // namespace ugvr
