#include "ugvr/render/time_budget.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "ugvr/render/image.h"

namespace ugvr {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

Frame render_within_budget(Renderer& renderer, FrameRequest request, double budget, Clock::time_point start,
                           nlohmann::json& report, bool say) {
  const int w = request.settings.width, h = request.settings.height;
  report = {{"seconds", budget}, {"open_seconds", seconds_since(start)}};
  Frame frame;
  std::string drew;
  if (renderer.engine() == "lod") {
    int frames = 0;
    double left = budget - seconds_since(start);
    do {
      // The time-critical cut aims at the time left for this frame (at least a frame a second's worth of detail).
      request.target_fps = 1 / std::clamp(left, 0.05, 1.0);
      frame = renderer.render(request);
      ++frames;
      left = budget - seconds_since(start);
    } while (!frame.stats.converged && left > frame.stats.seconds);
    char buf[200];
    std::snprintf(buf, sizeof buf, "level-of-detail cut of %llu nodes after %d frames, %s, texel error %.2f px",
                  (unsigned long long)frame.stats.cut_nodes, frames,
                  frame.stats.converged ? "converged" : "still refining", frame.stats.texel_error);
    drew = buf;
    report["frames"] = frames;
  } else {
    request.target_fps = 0;
    // A probe at most 64 pixels a side measures the time per pixel.
    const double probe = std::min(1.0, 64.0 / std::max(w, h));
    const auto sized = [&](double scale) {
      FrameRequest r = request;
      r.settings.width = std::max(1, int(std::lround(w * scale)));
      r.settings.height = std::max(1, int(std::lround(h * scale)));
      Frame f = renderer.render(r);
      f.stats.scale = scale;
      return f;
    };
    frame = sized(probe);
    const double per_full = frame.stats.seconds / (probe * probe);  // the full size's estimated time
    const double left = budget - seconds_since(start);
    double scale = probe;
    if (probe < 1 && left > 0 && per_full > 0) {
      scale = std::clamp(std::sqrt(left / per_full), probe, 1.0);
      if (scale > probe) frame = sized(scale > 0.97 ? 1.0 : scale);
    }
    scale = frame.stats.scale;
    if (frame.image.width != w || frame.image.height != h) frame.image = resize_bilinear(frame.image, w, h);
    char buf[200];
    std::snprintf(buf, sizeof buf, "exact image at scale %.3f (%d x %d), magnified to %d x %d", scale,
                  std::max(1, int(std::lround(w * scale))), std::max(1, int(std::lround(h * scale))), w, h);
    drew = scale == 1 ? "exact image at full size" : std::string(buf);
    report["scale"] = scale;
    report["probe_scale"] = probe;
  }
  report["total_seconds"] = seconds_since(start);
  report["within_budget"] = report["total_seconds"].get<double>() <= budget;
  report["drew"] = drew;
  if (say)
    std::fprintf(stderr, "time budget %.3g s: %s, in %.3g s%s\n", budget, drew.c_str(),
                 report["total_seconds"].get<double>(),
                 report["within_budget"].get<bool>() ? "" : " (over: reading and preparing the input took longer)");
  return frame;
}

}  // namespace ugvr
