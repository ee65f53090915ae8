// Camera paths for frame sequences (`ugvr render --path`, benchmarks): an orbit about the view-up axis with an optional
// rest at the end, or keyframes from a JSON file, resampled to a frame count.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/renderer.h"

namespace ugvr {

// "orbit[:N][,rest:M]": N frames (or `frames`, else 300) around the focal point about view_up (a full turn), then M
// frames back at the start; or a JSON file holding a list of cameras (camera.h's form): one frame each, or keyframes
// resampled to `frames` (> 0) frames. Throws OptionError naming "path" or "frames" (renderer_factory.h).
std::vector<Camera> camera_path(const std::string& spec, const Camera& start, int frames);

// Keyframes resampled to `frames` cameras, piecewise linearly over the keyframe index (a keyframe list is a path, not
// a schedule: frames are spread evenly over its segments). Position, focal point, view angle and parallel scale are
// interpolated; view up is interpolated and renormalised; the projection is the earlier keyframe's.
std::vector<Camera> resample_keyframes(const std::vector<Camera>& keys, int frames);

// One frame per camera of `path` with `request` (its camera replaced), each handed to `on_frame` in order.
void render_path(Renderer& renderer, const std::vector<Camera>& path, FrameRequest request,
                 const std::function<void(size_t index, const Frame& frame)>& on_frame);

}  // namespace ugvr
