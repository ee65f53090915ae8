#include "ugvr/render/camera.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"

namespace ugvr {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

bool is_finite(Vec3d v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// True when a and b are (anti)parallel within a relative tolerance, so their cross product cannot define a frame.
bool parallel(Vec3d a, Vec3d b) { return length(cross(a, b)) <= 1e-9 * length(a) * length(b); }

[[noreturn]] void fail_key(std::string_view source, std::string_view key, std::string_view message) {
  fail_in(source, "key \"" + std::string(key) + "\": " + std::string(message));
}

Vec3d vec_from_json(const nlohmann::json& j, std::string_view source, std::string_view key) {
  if (!j.is_array() || j.size() != 3) fail_key(source, key, "expected an array of 3 numbers");
  Vec3d v;
  for (int i = 0; i < 3; ++i) {
    if (!j[size_t(i)].is_number()) fail_key(source, key, "expected an array of 3 numbers");
    v[i] = j[size_t(i)].get<double>();
  }
  if (!is_finite(v)) fail_key(source, key, "numbers must be finite");
  return v;
}

double number_from_json(const nlohmann::json& j, std::string_view source, std::string_view key) {
  if (!j.is_number()) fail_key(source, key, "expected a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail_key(source, key, "must be finite");
  return v;
}

}  // namespace

Vec3d normalized(Vec3d v) {
  const double l = length(v);
  return l > 0 ? v * (1.0 / l) : v;
}

Vec3d Camera::direction() const { return normalized(focal_point - position); }

Camera reset_camera(const Bounds& bounds, double view_angle, Vec3d direction, Vec3d up) {
  if (bounds.empty()) fail_in("camera", "cannot frame empty bounds");
  if (!(view_angle > 0 && view_angle < 180)) fail_in("camera", "view angle must be in (0, 180) degrees");
  if (!(length(direction) > 0) || !is_finite(direction)) fail_in("camera", "view direction must be non-zero");
  if (parallel(direction, up)) fail_in("camera", "view up is parallel to the view direction");
  const Vec3d d = normalized(direction);
  const Vec3d s = bounds.size();
  // vtkRenderer::ResetCamera: a degenerate (single point) box gets radius 0.5 rather than 0.
  const double diagonal_sq = dot(s, s);
  const double radius = 0.5 * std::sqrt(diagonal_sq == 0 ? 1.0 : diagonal_sq);
  const double distance = radius / std::sin(0.5 * view_angle * kDegree);
  Camera c;
  c.focal_point = bounds.center();
  c.position = c.focal_point - d * distance;
  c.view_up = normalized(up - d * dot(up, d));  // orthogonalised, as vtkCamera::OrthogonalizeViewUp
  c.view_angle = view_angle;
  c.parallel_scale = radius;
  return c;
}

Camera default_camera(const Bounds& bounds, double view_angle) {
  return reset_camera(bounds, view_angle, {0.6, 0.8, -0.55}, {0, 0, 1});
}

Camera camera_preset(std::string_view name, const Bounds& bounds, double view_angle) {
  struct Preset {
    std::string_view name;
    Vec3d direction, up;
  };
  static constexpr std::array<Preset, 7> kPresets{{
      {"+x", {1, 0, 0}, {0, 0, 1}},
      {"-x", {-1, 0, 0}, {0, 0, 1}},
      {"+y", {0, 1, 0}, {0, 0, 1}},
      {"-y", {0, -1, 0}, {0, 0, 1}},
      {"+z", {0, 0, 1}, {0, 1, 0}},
      {"-z", {0, 0, -1}, {0, 1, 0}},
      {"iso", {-1, -1, -1}, {0, 1, 0}},
  }};
  for (const Preset& p : kPresets)
    if (p.name == name) return reset_camera(bounds, view_angle, p.direction, p.up);
  fail_in("camera", "unknown view preset \"" + std::string(name) + "\" (expected +x, -x, +y, -y, +z, -z or iso)");
}

nlohmann::json camera_to_json(const Camera& c) {
  auto vec = [](Vec3d v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  return {{"position", vec(c.position)},
          {"focal_point", vec(c.focal_point)},
          {"view_up", vec(c.view_up)},
          {"view_angle", c.view_angle},
          {"parallel_projection", c.parallel_projection},
          {"parallel_scale", c.parallel_scale}};
}

Camera camera_from_json(const nlohmann::json& j, std::string_view source) {
  if (!j.is_object()) fail_in(source, "a camera must be a JSON object");
  for (const auto& [key, value] : j.items()) {
    static constexpr std::array<std::string_view, 6> kKeys{"position",   "focal_point",         "view_up",
                                                           "view_angle", "parallel_projection", "parallel_scale"};
    if (std::find(kKeys.begin(), kKeys.end(), key) == kKeys.end()) fail_key(source, key, "unknown camera key");
  }
  for (std::string_view key : {"position", "focal_point", "view_up"})
    if (!j.contains(key)) fail_key(source, key, "missing");
  Camera c;
  c.position = vec_from_json(j["position"], source, "position");
  c.focal_point = vec_from_json(j["focal_point"], source, "focal_point");
  c.view_up = vec_from_json(j["view_up"], source, "view_up");
  if (j.contains("view_angle")) c.view_angle = number_from_json(j["view_angle"], source, "view_angle");
  if (j.contains("parallel_projection")) {
    if (!j["parallel_projection"].is_boolean()) fail_key(source, "parallel_projection", "expected true or false");
    c.parallel_projection = j["parallel_projection"].get<bool>();
  }
  if (j.contains("parallel_scale")) c.parallel_scale = number_from_json(j["parallel_scale"], source, "parallel_scale");

  if (!(c.distance() > 0)) fail_key(source, "focal_point", "must differ from position");
  if (!(length(c.view_up) > 0) || parallel(c.view_up, c.focal_point - c.position))
    fail_key(source, "view_up", "must be non-zero and not parallel to the view direction");
  if (!(c.view_angle > 0 && c.view_angle < 180)) fail_key(source, "view_angle", "must be in (0, 180) degrees");
  if (!(c.parallel_scale > 0)) fail_key(source, "parallel_scale", "must be > 0");
  return c;
}

Camera read_camera(const std::string& path) { return camera_from_json(read_json_file(path), base_name(path)); }

void write_camera(const std::string& path, const Camera& camera) { write_json_file(path, camera_to_json(camera)); }

CameraRays::CameraRays(const Camera& camera, int width, int height) : camera_(camera), width_(width), height_(height) {
  if (width <= 0 || height <= 0) fail_in("camera", "image size must be positive");
  forward_ = camera.direction();
  right_ = normalized(cross(forward_, camera.view_up));
  up_ = cross(right_, forward_);
  half_height_ = camera.parallel_projection ? camera.parallel_scale : std::tan(0.5 * camera.view_angle * kDegree);
  half_width_ = half_height_ * double(width) / double(height);
}

Ray CameraRays::at(double px, double py) const {
  // Screen coordinates in [-1, 1]: sx grows to the right, sy grows upwards (image rows grow downwards).
  const double sx = 2.0 * px / width_ - 1.0;
  const double sy = 1.0 - 2.0 * py / height_;
  const Vec3d offset = right_ * (sx * half_width_) + up_ * (sy * half_height_);
  if (camera_.parallel_projection) return {camera_.position + offset, forward_};
  return {camera_.position, normalized(forward_ + offset)};
}

}  // namespace ugvr
