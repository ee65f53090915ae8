#include "ugvr/render/resolve_view.h"

#include <cmath>

#include "ugvr/render/default_transfer_function.h"
#include "ugvr/render/visible_bounds.h"

namespace ugvr {
namespace {

constexpr double kDefaultViewAngle = 30;

TransferFunction resolve_transfer_function(const Renderer& renderer, const ViewChoices& c, const FieldRange& field,
                                           const Bounds& bounds) {
  TransferFunction tf = c.tf;
  if (c.auto_tf) {
    const double lo = c.range ? c.range->first : field.min, hi = c.range ? c.range->second : field.max;
    tf = auto_transfer_function(renderer, lo, hi, bounds);
  } else if (c.range) {
    tf.rescale(c.range->first, c.range->second);
  } else if (!c.keep_range && std::isfinite(field.min) && std::isfinite(field.max)) {
    tf.rescale(field.min, field.max);
  }
  tf.opacity_unit_distance =
      c.unit_distance.value_or(c.auto_tf ? tf.opacity_unit_distance : default_unit_distance(bounds));
  return tf;
}

Camera resolve_camera(const Renderer& renderer, const ViewChoices& c, const TransferFunction& tf,
                      const Bounds& bounds) {
  const double angle = c.view_angle.value_or(kDefaultViewAngle);
  if (c.camera) {
    Camera camera = *c.camera;
    if (c.view_angle) camera.view_angle = *c.view_angle;
    return camera;
  }
  if (!c.view.empty()) return camera_preset(c.view, bounds, angle);
  if (c.auto_tf) return framed_default_camera(renderer, tf, angle);
  return default_camera(bounds, angle);
}

}  // namespace

ResolvedView resolve_view(const Renderer& renderer, const ViewChoices& choices, const FieldRange& field_range) {
  const Bounds bounds = renderer.bounds();
  ResolvedView out;
  out.tf = resolve_transfer_function(renderer, choices, field_range, bounds);
  out.camera = resolve_camera(renderer, choices, out.tf, bounds);
  return out;
}

}  // namespace ugvr
