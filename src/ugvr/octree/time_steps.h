// The steps of a series selected for a store with time (docs/time-series.md, "Stores with time"): what the in-core
// builder (build_octree_steps) and the out-of-core one (build_octree_out_of_core_steps) check and say alike.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ugvr/io/time_series.h"
#include "ugvr/octree/builder.h"

namespace ugvr {

// Throws ugvr::Error naming the series when `steps` is empty, out of range or not increasing.
void check_step_selection(const TimeSeries& series, std::span<const uint32_t> steps);

// "step 3/21 (#2, t = 0.2)": the k-th selected step, for progress labels.
std::string step_label(const TimeSeries& series, std::span<const uint32_t> steps, size_t k);

// The error for a step whose geometry is not the first step's, naming both and saying what to do instead; `how` says
// how it was found ("geometry fingerprint", ...).
[[noreturn]] void fail_geometry_differs(const TimeSeries& series, uint32_t step, uint32_t first,
                                        const std::string& how);

}  // namespace ugvr
