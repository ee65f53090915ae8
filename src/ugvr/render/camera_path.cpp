#include "ugvr/render/camera_path.h"

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>

#include "ugvr/core/json_file.h"
#include "ugvr/render/renderer_factory.h"

namespace ugvr {

namespace {

int positive_int(std::string_view text, const std::string& option) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v < 1)
    throw OptionError(option, "expected a positive integer, found \"" + std::string(text) + "\"");
  return v;
}

std::vector<Camera> orbit(const Camera& start, int n, int rest) {
  std::vector<Camera> path;
  const Vec3d axis = normalized(start.view_up);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * 3.14159265358979323846 * double(i) / double(n);
    const Vec3d v = start.position - start.focal_point;
    // Rodrigues: v cos a + (k x v) sin a + k (k . v)(1 - cos a)
    const Vec3d r = v * std::cos(a) + cross(axis, v) * std::sin(a) + axis * (dot(axis, v) * (1 - std::cos(a)));
    Camera c = start;
    c.position = start.focal_point + r;
    path.push_back(c);
  }
  for (int i = 0; i < rest; ++i) path.push_back(start);  // the turn completed: back where it began
  return path;
}

}  // namespace

std::vector<Camera> resample_keyframes(const std::vector<Camera>& keys, int frames) {
  std::vector<Camera> out;
  for (int i = 0; i < frames; ++i) {
    const double u = frames == 1 ? 0.0 : double(i) * double(keys.size() - 1) / double(frames - 1);
    const size_t k = std::min(size_t(u), keys.size() - 1);
    const Camera& a = keys[k];
    const Camera& b = keys[std::min(k + 1, keys.size() - 1)];
    const double w = u - double(k);
    Camera c = a;
    c.position = a.position + (b.position - a.position) * w;
    c.focal_point = a.focal_point + (b.focal_point - a.focal_point) * w;
    c.view_up = normalized(a.view_up + (b.view_up - a.view_up) * w);
    c.view_angle = a.view_angle + (b.view_angle - a.view_angle) * w;
    c.parallel_scale = a.parallel_scale + (b.parallel_scale - a.parallel_scale) * w;
    out.push_back(c);
  }
  return out;
}

std::vector<Camera> camera_path(const std::string& spec_in, const Camera& start, int frames) {
  std::string spec = spec_in;
  if (spec == "orbit" || spec.rfind("orbit,", 0) == 0)
    spec = "orbit:" + std::to_string(frames > 0 ? frames : 300) + spec.substr(5);
  else if (spec.rfind("orbit:", 0) == 0 && frames > 0)
    throw OptionError("frames", "orbit:N already gives the frame count (use --path orbit --frames N)");
  if (spec.rfind("orbit:", 0) == 0) {
    std::string n_text = spec.substr(6), rest_text;
    if (const size_t comma = n_text.find(','); comma != std::string::npos) {
      rest_text = n_text.substr(comma + 1);
      n_text = n_text.substr(0, comma);
      if (rest_text.rfind("rest:", 0) != 0)
        throw OptionError("path", "expected orbit, orbit:N or orbit:N,rest:M (or orbit,rest:M)");
      rest_text = rest_text.substr(5);
    }
    const int n = positive_int(n_text, "path");
    const int rest = rest_text.empty() ? 0 : positive_int(rest_text, "path");
    return orbit(start, n, rest);
  }
  nlohmann::json j;
  try {
    j = read_json_file(spec);
  } catch (const Error& e) {
    throw OptionError("path", e.what());
  }
  if (!j.is_array() || j.empty()) fail_in(spec, "expected a non-empty list of cameras");
  std::vector<Camera> path;
  for (size_t i = 0; i < j.size(); ++i) path.push_back(camera_from_json(j[i], spec + " [" + std::to_string(i) + "]"));
  return frames > 0 ? resample_keyframes(path, frames) : path;
}

void render_path(Renderer& renderer, const std::vector<Camera>& path, FrameRequest request,
                 const std::function<void(size_t, const Frame&)>& on_frame) {
  for (size_t i = 0; i < path.size(); ++i) {
    request.camera = path[i];
    on_frame(i, renderer.render(request));
  }
}

}  // namespace ugvr
