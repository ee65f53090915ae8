#include "ugvr/render/lod/quality_policy.h"

#include <algorithm>
#include <cmath>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {
// Headroom (budget / samples) above which one more split is allowed whatever the growth law says.
constexpr double kSplitMargin = 1.1;
// The dead band: with budget / samples in [1, kHoldUpTo) the levers hold. A cut is quantised (merging the root's
// children takes 7 nodes to 1), so following every few percent of timing noise would make the cut, and the image
// quality, jump back and forth around the fixed point. The band lies below the target (frames at 90-100 % of it), so
// that a held frame rate is the target's: a band above it (frames at up to 1/0.9 of the target, as before) held a
// 10 fps target at 9.0-9.7 fps (bench/README.md, "Cutting planes", the drag).
constexpr double kHoldUpTo = 1 / 0.9;
// When a lever moves, it aims its frame at this share of the target: the middle of the band, so that noise does not
// move it again at once.
constexpr double kAim = 0.95;
}  // namespace

QualityPolicy::QualityPolicy(QualityPolicyOptions options) : options_(options) {
  const QualityPolicyOptions& o = options_;
  if (!(o.min_scale > 0 && o.min_scale <= 1)) fail_in("quality policy", "min_scale must be in (0, 1]");
  if (!(o.max_sample_growth >= 1 && std::isfinite(o.max_sample_growth)))
    fail_in("quality policy", "max_sample_growth must be finite and >= 1");
  if (!(o.max_scale_growth >= 1 && std::isfinite(o.max_scale_growth)))
    fail_in("quality policy", "max_scale_growth must be finite and >= 1");
  if (o.initial_nodes < 1) fail_in("quality policy", "initial_nodes must be >= 1");
  reset();
}

void QualityPolicy::reset() { current_ = {options_.initial_nodes, 1.0}; }

QualityChoice QualityPolicy::next(uint64_t sample_budget, uint64_t samples, uint64_t cut_nodes, bool coarsest) {
  const QualityPolicyOptions& o = options_;
  cut_nodes = std::max<uint64_t>(cut_nodes, 1);
  // No samples (nothing visible): nothing to learn about the cost; let the cut grow as far as a frame allows.
  const double ratio = samples > 0 ? double(sample_budget) / double(samples) : o.max_sample_growth;
  QualityChoice c = current_;
  auto nodes_for = [&](double r) {
    const double n = double(cut_nodes) * std::pow(std::clamp(r, 0.5, o.max_sample_growth), 3.0);
    return uint64_t(std::clamp(std::floor(n), 1.0, 1e18));
  };
  const double aimed = ratio * kAim;  // S / S_now for a frame at kAim of the target
  if (ratio >= 1 && ratio < kHoldUpTo) {
    c.max_nodes = cut_nodes;
  } else if (ratio < 1) {
    if (!coarsest) {
      c.max_nodes = std::min(nodes_for(aimed), cut_nodes);
    } else {
      c.max_nodes = cut_nodes;
      c.scale = std::max(o.min_scale, c.scale * std::sqrt(std::max(aimed, 0.25)));
    }
  } else if (c.scale < 1) {
    c.max_nodes = cut_nodes;
    c.scale = std::min({1.0, c.scale * std::sqrt(aimed), c.scale * o.max_scale_growth});
  } else {
    // Growth comes in splits: one adds up to 7 nodes, so a small cut (the root alone) could never grow by a factor.
    c.max_nodes = std::max(nodes_for(aimed), ratio > kSplitMargin ? cut_nodes + 7 : cut_nodes);
  }
  current_ = c;
  return c;
}

}  // namespace ugvr
