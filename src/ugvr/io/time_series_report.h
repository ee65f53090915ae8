// `ugvr info`'s time axis: the steps of a series (io/time_series.h) as JSON and as text.
//
// JSON: {"kind": "exodus"|"pvd"|..., "source": PATH, "count": N, "first_time": T0, "last_time": TN,
//        "geometry": "static"|"detected per step", "geometry_reason": TEXT,
//        "steps": [{"index": i, "time": t, "files": [...] (file series) | "reader_step": k (multi-step files)}, ...]}
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "ugvr/io/time_series.h"

namespace ugvr {

nlohmann::json time_series_json(const TimeSeries& series);
// "time:     21 steps (exodus), t = 0 .. 2; geometry static (...)" then one line per step.
std::string format_time_series_text(const nlohmann::json& j);

}  // namespace ugvr
