#include "ugvr/octree/time_steps.h"

#include <cstdio>

#include "ugvr/core/error.h"

namespace ugvr {

void check_step_selection(const TimeSeries& series, std::span<const uint32_t> steps) {
  if (steps.empty()) throw Error(series.source + ": no time step selected");
  for (size_t k = 0; k < steps.size(); ++k) {
    if (steps[k] >= series.size())
      throw Error(series.source + ": time step " + std::to_string(steps[k]) + " out of range (the series has " +
                  std::to_string(series.size()) + ")");
    if (k > 0 && steps[k] <= steps[k - 1])
      throw Error(series.source + ": time steps must be given in increasing order");
  }
}

std::string step_label(const TimeSeries& series, std::span<const uint32_t> steps, size_t k) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "step %zu/%zu (#%u, t = %g)", k + 1, steps.size(), steps[k],
                series.steps[steps[k]].time);
  return buf;
}

void fail_geometry_differs(const TimeSeries& series, uint32_t step, uint32_t first, const std::string& how) {
  throw Error(series.source + ": the geometry of time step " + std::to_string(step) + " differs from that of step " +
              std::to_string(first) + " (" + how +
              "): a store shares one mesh over its steps, so build one store per step "
              "(ugvr build SERIES --time-step N -o step_N.ugvr)");
}

}  // namespace ugvr
