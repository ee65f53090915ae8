// Frame-time feedback for time-critical LOD (Leven et al. 2002, section 5: "maximize quality for a user-specified
// frame rate"): from the measured duration of each frame and the work it did, the budget of work for the next
// frame. The work is whatever the caller's frame time grows with and can limit, in the unit of the budget: cut nodes
// (ActiveCut's CutBudget::max_nodes, as the paper does), bricks, or ray samples.
//
// Model and choice. A frame costs about a + b · work seconds, with a (fixed overhead) and b (cost per unit, which
// changes with the view: the screen coverage of a node, the image size) unknown and drifting. The controller keeps
// one estimate, c = seconds per unit of work, an exponential moving average of the measured seconds / work, and sets
//   budget = target / c.
// This is a multiplicative correction (budget ≈ work · target / seconds) whose fixed point is exactly
// a + b · budget = target whatever a is (a only makes c overestimate b at small work, i.e. the step toward the target
// conservative), and in log space it converges without overshoot for any smoothing in (0, 1] (each step multiplies
// the log error by 1 - smoothing · b·work / seconds). Estimating a and b separately (least squares) would extrapolate
// better from far away but is noisier and needs the work to vary; the single ratio needs neither.
// Damping: a sample is first clamped to [c / spike_clamp, c · spike_clamp], so one frame stalled by the OS or a
// disk read moves the estimate by at most (1 + smoothing · (spike_clamp - 1)); the budget grows by at most
// max_growth per frame (it may shrink at once: overshooting the frame time is what the user notices), so a sudden
// drop in cost (a fast frame, a view of empty space) does not cause a burst of work followed by a slow frame.
//
// Without a target (target_seconds 0) the budget is unlimited (kUnlimited) and measurements are only recorded.
//
// With the active cut (active_cut.h), per frame: max_nodes = min(atlas capacity, budget()); update the cut; render;
// frame(measured seconds, nodes drawn). The cut follows a lower budget at once (capacity merges) and a higher one as
// fast as its upload budget allows; the controller only sees the work actually done, so a cut that needs fewer nodes
// than allowed does not inflate the estimate.
#pragma once

#include <cstdint>
#include <limits>

namespace ugvr {

struct FrameControllerOptions {
  double target_seconds = 0;     // per frame; 0: unlimited
  double initial_budget = 1024;  // until the first measurement with work > 0
  double min_budget = 1;
  double max_budget = 1e18;  // besides being the cap, keeps the budget representable as uint64_t
  double smoothing = 0.25;   // weight of the newest sample in the moving average, in (0, 1]
  double max_growth = 1.25;  // budget(n + 1) <= budget(n) · max_growth, >= 1
  double spike_clamp = 4;    // >= 1
};

class FrameController {
 public:
  static constexpr uint64_t kUnlimited = std::numeric_limits<uint64_t>::max();

  // Throws ugvr::Error for options out of range (negative or non-finite target, budgets not 0 < min <= initial <=
  // max, smoothing outside (0, 1], max_growth or spike_clamp < 1).
  explicit FrameController(FrameControllerOptions options = {});

  // 0: unlimited. Keeps the cost estimate (a new target does not change what a unit of work costs).
  void set_target_seconds(double seconds);
  void set_target_fps(double fps) { set_target_seconds(fps > 0 ? 1.0 / fps : 0.0); }
  double target_seconds() const { return options_.target_seconds; }

  // Feeds one frame: its duration by the caller's clock and the work it did; returns the budget for the next frame.
  // seconds must be finite and >= 0 (ugvr::Error otherwise). A frame with no work says nothing about the cost of
  // work and leaves the estimate alone (the budget may still grow toward target / c).
  uint64_t frame(double seconds, uint64_t work);

  uint64_t budget() const;                           // for the next frame
  double seconds_per_work() const { return cost_; }  // the estimate c; 0 before the first measurement
  void reset();                                      // forgets the estimate; the budget returns to initial_budget

 private:
  FrameControllerOptions options_;
  double cost_ = 0;
  double budget_ = 0;
};

}  // namespace ugvr
