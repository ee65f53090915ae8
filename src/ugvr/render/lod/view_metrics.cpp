#include "ugvr/render/lod/view_metrics.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "ugvr/core/error.h"

namespace ugvr {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// max over the box of dot(p - origin, n): the corner furthest along n.
double max_over_box(const Bounds& b, Vec3d origin, Vec3d n) {
  double s = 0;
  for (int a = 0; a < 3; ++a) s += n[a] * ((n[a] >= 0 ? b.hi[a] : b.lo[a]) - origin[a]);
  return s;
}

// min over the box of dot(p - origin, n).
double min_over_box(const Bounds& b, Vec3d origin, Vec3d n) {
  double s = 0;
  for (int a = 0; a < 3; ++a) s += n[a] * ((n[a] >= 0 ? b.lo[a] : b.hi[a]) - origin[a]);
  return s;
}

}  // namespace

ViewMetrics::ViewMetrics(const Camera& camera, int width, int h, const Bounds& root) {
  if (!(length(camera.focal_point - camera.position) > 0)) fail_in("lod cut", "camera position equals focal point");
  if (camera.parallel_projection) {
    if (!(camera.parallel_scale > 0 && std::isfinite(camera.parallel_scale)))
      fail_in("lod cut", "parallel scale must be positive");
  } else if (!(camera.view_angle > 0 && camera.view_angle < 180)) {
    fail_in("lod cut", "view angle must be in (0, 180) degrees");
  }
  const CameraRays rays(camera, width, h);  // checks the image size; the frame the renderer uses
  const Vec3d right = rays.right(), up = rays.up();
  if (!(std::abs(length(right) - 1) < 1e-6)) fail_in("lod cut", "view up is parallel to the view direction");
  parallel_ = camera.parallel_projection;
  eye_ = camera.position;
  forward_ = rays.forward();
  half_height_ = parallel_ ? camera.parallel_scale : std::tan(0.5 * camera.view_angle * kDegree);
  const double half_width = half_height_ * double(width) / double(h);
  height_ = h;
  max_pixels_ = std::hypot(double(width), double(h));
  const Vec3d s = root.size();
  min_depth_ = 1e-9 * std::max(length(s), 1e-300);
  planes_[0] = {forward_, 0};
  if (parallel_) {
    planes_[1] = {right * -1.0, half_width};
    planes_[2] = {right, half_width};
    planes_[3] = {up * -1.0, half_height_};
    planes_[4] = {up, half_height_};
  } else {
    planes_[1] = {forward_ * half_width - right, 0};
    planes_[2] = {forward_ * half_width + right, 0};
    planes_[3] = {forward_ * half_height_ - up, 0};
    planes_[4] = {forward_ * half_height_ + up, 0};
  }
}

bool ViewMetrics::outside(const Bounds& box) const {
  for (const Plane& p : planes_)
    if (max_over_box(box, eye_, p.normal) + p.offset < 0) return true;
  return false;
}

double ViewMetrics::pixels(const Bounds& box, double h) const {
  double p = 0;
  if (parallel_) {
    p = h / (2 * half_height_) * height_;
  } else {
    const double d = std::max(min_depth_, min_over_box(box, eye_, forward_));
    p = h / (2 * d * half_height_) * height_;
  }
  return std::min(p, max_pixels_);  // NaN (an unknown box) stays NaN: the callers refine those first
}

double ViewMetrics::texel_pixels(const Bounds& box, uint32_t resolution) const {
  const Vec3d s = box.size();
  return pixels(box, std::max({s.x, s.y, s.z}) * (1.0 / double(resolution - 1)));
}

}  // namespace ugvr
