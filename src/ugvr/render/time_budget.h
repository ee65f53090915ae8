// A still image within a time budget (issue 24): what can be drawn within S seconds of a start the caller chose
// (usually before reading the input, so that reading and preparing it count). Shared by `ugvr render --time-budget`
// and Python's ugvr.render(..., time_budget=S).
//
// The exact engine draws a probe at most 64 pixels a side, which measures the time per pixel, then the largest image
// whose estimated time (time grows with the pixel count) fits what is left, magnified to the requested size. The
// level-of-detail engine (an interactive renderer: its time-critical cut) refines frame after frame while the next
// frame still fits, each frame aiming at the time left.
#pragma once

#include <chrono>
#include <nlohmann/json.hpp>

#include "ugvr/render/renderer.h"

namespace ugvr {

// What was drawn goes to `report`: seconds (the budget), open_seconds (spent before the first frame), total_seconds,
// within_budget, drew (a sentence), and frames (LOD) or scale and probe_scale (exact). `say`: the sentence also goes
// to stderr.
Frame render_within_budget(Renderer& renderer, FrameRequest request, double budget_seconds,
                           std::chrono::steady_clock::time_point start, nlohmann::json& report, bool say);

}  // namespace ugvr
