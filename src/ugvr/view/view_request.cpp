#include "ugvr/view/view_request.h"

#include <cmath>
#include <string>

#include "ugvr/core/error.h"

namespace ugvr::view {
namespace {

// SceneInfo::auto_opacity: a tab on a field that has them starts from the auto transfer function's points and unit
// distance (`ugvr view` without --tf), where it would start from the preset's ramp.
void start_from_auto(ViewState& s, const SceneInfo& scene) {
  const FieldInfo* f = scene.find_field(s.request.settings.field);
  if (!f) return;
  const auto it = scene.auto_opacity.find(f->name);
  if (it == scene.auto_opacity.end()) return;
  s.tf_opacities = it->second.points;
  s.unit_distance = it->second.unit_distance;
}

}  // namespace

ViewState initial_view(const SceneInfo& scene) {
  ViewState s;
  s.request.width = scene.width;
  s.request.height = scene.height;
  s.request.camera = scene.camera;
  s.request.fps = scene.fps;
  s.request.settings.field = scene.field;
  if (scene.background) s.request.settings.background = *scene.background;
  // Each tab asks for its step explicitly: the tabs share one exact scene, which shows the step the frame asks for.
  if (!scene.times.empty()) s.request.time_step = scene.time_step;
  s.tf_preset = scene.preset;
  if (scene.tf) {
    s.tf_colors = scene.tf->color_points;
    s.tf_opacities = scene.tf->opacity_points;
    s.unit_distance = scene.tf->opacity_unit_distance;
  } else {
    start_from_auto(s, scene);
  }
  s.request.tf = compose_tf(s, scene);
  return s;
}

TransferFunction compose_tf(const ViewState& s, const SceneInfo& scene) {
  TransferFunction tf = builtin_preset(s.tf_preset);
  const FieldInfo* f = scene.find_field(s.request.settings.field);
  if (f && std::isfinite(f->min) && std::isfinite(f->max)) tf.rescale(f->min, f->max);
  if (!s.tf_colors.empty()) tf.color_points = s.tf_colors;
  if (!s.tf_opacities.empty()) tf.opacity_points = s.tf_opacities;
  for (OpacityPoint& p : tf.opacity_points) p.opacity *= s.tf_opacity;
  tf.opacity_unit_distance = s.unit_distance > 0 ? s.unit_distance : default_unit_distance(scene.bounds);
  return tf;
}

void apply_message(ViewState& state, const ClientMessage& m, const SceneInfo& scene) {
  ViewState s = state;
  ViewRequest& r = s.request;
  if (const auto* size = std::get_if<SizeMessage>(&m)) {
    r.width = size->width, r.height = size->height;
    if (size->hello) s.ready = true;
  } else if (const auto* cam = std::get_if<CameraMessage>(&m)) {
    r.camera = cam->camera;
  } else if (const auto* tf = std::get_if<TfMessage>(&m)) {
    if (tf->preset) {
      // A preset replaces any explicit points: picking one starts from it.
      s.tf_preset = *tf->preset;
      s.tf_colors.clear(), s.tf_opacities.clear();
      start_from_auto(s, scene);
    }
    if (tf->opacity) s.tf_opacity = *tf->opacity;
    if (!tf->color_points.empty()) s.tf_colors = tf->color_points;
    if (!tf->opacity_points.empty()) s.tf_opacities = tf->opacity_points;
    r.tf = compose_tf(s, scene);
    r.tf.validate("tf");
  } else if (const auto* set = std::get_if<SettingsMessage>(&m)) {
    RenderSettings& rs = r.settings;
    if (set->field) {
      const FieldInfo* f = scene.find_field(*set->field);
      if (!f) {
        std::string names;
        for (const FieldInfo& i : scene.fields) names += (names.empty() ? "" : ", ") + i.name;
        fail_in("field", "no field \"" + *set->field + "\" (fields: " + names + ")");
      }
      if (f->name != (rs.field.empty() ? scene.field : rs.field)) {
        rs.field = f->name;
        // Explicit points were in the old field's values: start again from the preset over the new range.
        s.tf_colors.clear(), s.tf_opacities.clear();
        start_from_auto(s, scene);
        r.tf = compose_tf(s, scene);
        for (double& v : rs.iso_values)
          if (!(v >= f->min && v <= f->max)) v = 0.5 * (f->min + f->max);
      }
    }
    if (set->iso_value) rs.iso_values = {*set->iso_value};
    if (set->mode) {
      rs.mode = *set->mode;
      // Isosurface mode needs a value: the middle of the range until the client sends one.
      const FieldInfo* f = scene.find_field(rs.field);
      if (rs.mode == RenderMode::Isosurface && rs.iso_values.empty())
        rs.iso_values = {f ? 0.5 * (f->min + f->max) : 0.0};
    }
    if (set->boundary_opacity) rs.boundary_overlay_opacity = *set->boundary_opacity;
    if (set->clip) rs.clip_plane = *set->clip;
    if (set->iso_opacity) rs.iso_opacity = *set->iso_opacity;
    if (set->lighting) rs.lighting = *set->lighting;
    if (set->volume_lighting) rs.volume_lighting = *set->volume_lighting;
    if (set->early_termination_opacity) rs.early_termination_opacity = *set->early_termination_opacity;
    if (set->sample_step) rs.sample_step = *set->sample_step;
    if (set->background) rs.background = *set->background;
    if (set->slices) rs.slices = *set->slices;
    if (set->hide_volume) rs.hide_volume = *set->hide_volume;
    if (set->interpolation) rs.interpolation = *set->interpolation;
    rs.validate("settings");
    if (set->step_voxels) r.step_voxels = *set->step_voxels;
    if (set->fps) r.fps = *set->fps;
    if (set->full_quality) s.full_quality = true;
  } else if (const auto* engine = std::get_if<EngineMessage>(&m)) {
    if (!scene.has_engine(engine->engine)) {
      std::string names;
      for (const EngineChoice& e : scene.engines) names += (names.empty() ? "" : ", ") + e.name;
      // Why it is missing: the store is not there yet, or the grid was not kept (a viewer of a store, --free-grid).
      const std::string why = engine->engine == kLodEngine ? "the brick store is not ready yet"
                              : engine->engine == kHybridEngine
                                  ? "the brick store is not ready yet or keeps no cells (ugvr build --cells)"
                                  : "the grid is not kept (a viewer of a brick store, or --free-grid)";
      fail_in("engine", "\"" + engine->engine + "\" is not available: " + why + " (engines: " + names + ")");
    }
    r.engine = engine->engine;
  } else if (const auto* interest = std::get_if<InterestMessage>(&m)) {
    if (interest->focus) {
      for (const FocusRange& f : *interest->focus)
        if (!scene.find_field(f.field)) fail_in("focus", "no field \"" + f.field + "\" in the scene");
      r.focus = *interest->focus;
      // A vector's name alone is its magnitude, as the store names it.
      for (FocusRange& f : r.focus) f.field = scene.find_field(f.field)->name;
    }
    if (interest->roi) r.roi = *interest->roi;
    if (interest->context_saturation) r.context_saturation = *interest->context_saturation;
    if (interest->context_opacity) r.context_opacity = *interest->context_opacity;
  } else if (const auto* time = std::get_if<TimeMessage>(&m)) {
    if (scene.times.empty()) fail_in("step", "this viewer shows one step (the input is not a time series)");
    if (time->step >= scene.times.size())
      fail_in("step", "step " + std::to_string(time->step) + " is out of range (the series has " +
                          std::to_string(scene.times.size()) + " steps: 0 to " +
                          std::to_string(scene.times.size() - 1) + ")");
    r.time_step = time->step;
    r.playing = time->playing;
  }
  ++s.generation;
  if (!(s.request == state.request) || s.ready != state.ready || s.full_quality != state.full_quality)
    s.changed = s.generation;
  state = std::move(s);
}

}  // namespace ugvr::view
