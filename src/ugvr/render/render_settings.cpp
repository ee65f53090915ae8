#include "ugvr/render/render_settings.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

[[noreturn]] void fail_key(std::string_view source, std::string_view key, std::string_view message) {
  fail_in(source, "key \"" + std::string(key) + "\": " + std::string(message));
}

bool finite(Vec3d v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::vector<double> numbers_of(const nlohmann::json& j, std::string_view source, std::string_view key) {
  if (!j.is_array()) fail_key(source, key, "expected an array of numbers");
  std::vector<double> v;
  for (const auto& e : j) {
    if (!e.is_number()) fail_key(source, key, "expected an array of numbers");
    v.push_back(e.get<double>());
  }
  return v;
}

Vec3d vec_of(const nlohmann::json& j, std::string_view source, std::string_view key) {
  const std::vector<double> v = numbers_of(j, source, key);
  if (v.size() != 3) fail_key(source, key, "expected [x, y, z]");
  return {v[0], v[1], v[2]};
}

double number_of(const nlohmann::json& j, std::string_view source, std::string_view key) {
  if (!j.is_number()) fail_key(source, key, "expected a number");
  return j.get<double>();
}

int side_of(const nlohmann::json& j, std::string_view source, std::string_view key) {
  if (!j.is_number_integer()) fail_key(source, key, "expected an integer");
  const int64_t v = j.get<int64_t>();
  if (v < 1 || v > kMaxImageSide) fail_key(source, key, "must be in [1, " + std::to_string(kMaxImageSide) + "]");
  return int(v);
}

RenderMode mode_of(const nlohmann::json& j, std::string_view source) {
  for (RenderMode m : {RenderMode::EmissionAbsorption, RenderMode::Mip, RenderMode::Isosurface})
    if (j.is_string() && j.get<std::string>() == render_mode_name(m)) return m;
  fail_key(source, "mode", "expected \"emission_absorption\", \"mip\" or \"isosurface\"");
}

// One side of a size string: digits only, in [1, kMaxImageSide].
int parse_side(std::string_view digits, std::string_view text, std::string_view source) {
  int v = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (digits.empty() || ec != std::errc() || end != digits.data() + digits.size() || v < 1 || v > kMaxImageSide)
    fail_in(source, "invalid image size \"" + std::string(text) + "\" (expected N or WxH with sides in [1, " +
                        std::to_string(kMaxImageSide) + "])");
  return v;
}

std::string slice_key(size_t i, std::string_view key) {
  return "slices[" + std::to_string(i) + "]" + (key.empty() ? "" : "." + std::string(key));
}

Slice slice_of(const nlohmann::json& j, size_t i, std::string_view source) {
  if (!j.is_object() || !j.contains("point") || !j.contains("normal"))
    fail_key(source, slice_key(i, ""),
             "expected {\"point\": [x, y, z], \"normal\": [x, y, z], \"opacity\": A, \"color_map\": NAME, "
             "\"range\": [lo, hi] | null, \"contours\": N | [v1, ..]}");
  Slice s;
  for (const auto& [key, v] : j.items()) {
    if (key == "point") {
      s.point = vec_of(v, source, slice_key(i, key));
    } else if (key == "normal") {
      s.normal = vec_of(v, source, slice_key(i, key));
    } else if (key == "opacity") {
      s.opacity = number_of(v, source, slice_key(i, key));
    } else if (key == "color_map") {
      if (!v.is_string()) fail_key(source, slice_key(i, key), "expected a string");
      s.color_map = v.get<std::string>();
    } else if (key == "range") {
      if (v.is_null()) continue;
      const std::vector<double> r = numbers_of(v, source, slice_key(i, key));
      if (r.size() != 2) fail_key(source, slice_key(i, key), "expected [lo, hi] or null");
      s.range = std::array<double, 2>{r[0], r[1]};
    } else if (key == "contours") {
      // A count of evenly spaced lines, or the values themselves.
      if (v.is_number_integer()) {
        const int64_t n = v.get<int64_t>();
        if (n < 0 || n > kMaxSliceContours)
          fail_key(source, slice_key(i, key), "must be in [0, " + std::to_string(kMaxSliceContours) + "]");
        s.contours = int(n), s.contour_values.clear();
      } else if (v.is_array()) {
        s.contour_values = numbers_of(v, source, slice_key(i, key)), s.contours = 0;
      } else {
        fail_key(source, slice_key(i, key), "expected a count N or an array of values");
      }
    } else if (key == "contour_color") {
      const std::vector<double> c = numbers_of(v, source, slice_key(i, key));
      if (c.size() != 3) fail_key(source, slice_key(i, key), "expected [r, g, b]");
      s.contour_color = {c[0], c[1], c[2]};
    } else if (key == "contour_width") {
      s.contour_width = number_of(v, source, slice_key(i, key));
    } else {
      fail_key(source, slice_key(i, key),
               "unknown slice key (expected point, normal, opacity, color_map, range, contours, contour_color, "
               "contour_width)");
    }
  }
  return s;
}

}  // namespace

std::string_view hide_volume_name(HideVolume h) {
  switch (h) {
    case HideVolume::None: return "none";
    case HideVolume::Front: return "front";
    case HideVolume::Back: return "back";
    case HideVolume::All: return "all";
  }
  return "?";
}

HideVolume parse_hide_volume(std::string_view text, std::string_view source) {
  for (HideVolume h : {HideVolume::None, HideVolume::Front, HideVolume::Back, HideVolume::All})
    if (text == hide_volume_name(h)) return h;
  fail_in(source, "expected none, front, back or all, found \"" + std::string(text) + "\"");
}

std::string_view interpolation_name(Interpolation i) { return i == Interpolation::Tricubic ? "tricubic" : "trilinear"; }

Interpolation parse_interpolation(std::string_view text, std::string_view source) {
  for (Interpolation i : {Interpolation::Trilinear, Interpolation::Tricubic})
    if (text == interpolation_name(i)) return i;
  fail_in(source, "expected trilinear or tricubic, found \"" + std::string(text) + "\"");
}

std::string_view render_mode_name(RenderMode m) {
  switch (m) {
    case RenderMode::EmissionAbsorption: return "emission_absorption";
    case RenderMode::Mip: return "mip";
    case RenderMode::Isosurface: return "isosurface";
  }
  return "?";
}

void RenderSettings::validate(std::string_view source) const {
  if (width < 1 || width > kMaxImageSide) fail_key(source, "width", "out of range");
  if (height < 1 || height > kMaxImageSide) fail_key(source, "height", "out of range");
  for (double c : background)
    if (!(c >= 0 && c <= 1)) fail_key(source, "background", "components must be in [0, 1]");
  for (double v : iso_values)
    if (!std::isfinite(v)) fail_key(source, "iso_values", "values must be finite");
  if (mode == RenderMode::Isosurface && iso_values.empty())
    fail_key(source, "iso_values", "isosurface mode needs at least one iso value");
  if (!(iso_opacity >= 0 && iso_opacity <= 1)) fail_key(source, "iso_opacity", "must be in [0, 1]");
  if (clip_plane) {
    if (!finite(clip_plane->point)) fail_key(source, "clip_plane", "point must be finite");
    if (!finite(clip_plane->normal) || !(length(clip_plane->normal) > 0))
      fail_key(source, "clip_plane", "normal must be finite and non-zero");
  }
  if (!(early_termination_opacity > 0 && early_termination_opacity <= 1))
    fail_key(source, "early_termination_opacity", "must be in (0, 1]");
  if (!(sample_step >= 0) || !std::isfinite(sample_step)) fail_key(source, "sample_step", "must be finite and >= 0");
  if (!(boundary_overlay_opacity >= 0 && boundary_overlay_opacity <= 1))
    fail_key(source, "boundary_overlay_opacity", "must be in [0, 1]");
  if (slices.size() > kMaxSlices) fail_key(source, "slices", "at most " + std::to_string(kMaxSlices) + " slices");
  const std::vector<std::string> maps = builtin_preset_names();
  for (size_t i = 0; i < slices.size(); ++i) {
    const Slice& sl = slices[i];
    if (!finite(sl.point)) fail_key(source, slice_key(i, "point"), "must be finite");
    if (!finite(sl.normal) || !(length(sl.normal) > 0))
      fail_key(source, slice_key(i, "normal"), "must be finite and non-zero");
    if (!(sl.opacity > 0 && sl.opacity <= 1)) fail_key(source, slice_key(i, "opacity"), "must be in (0, 1]");
    if (!sl.color_map.empty() && std::find(maps.begin(), maps.end(), sl.color_map) == maps.end()) {
      std::string names;
      for (const std::string& n : maps) names += (names.empty() ? "" : ", ") + n;
      fail_key(source, slice_key(i, "color_map"),
               "unknown colour map \"" + sl.color_map + "\" (expected \"\" for the volume's, or one of " + names + ")");
    }
    if (sl.range &&
        !(std::isfinite((*sl.range)[0]) && std::isfinite((*sl.range)[1]) && (*sl.range)[0] < (*sl.range)[1]))
      fail_key(source, slice_key(i, "range"), "must be finite with lo < hi");
    if (sl.contours < 0 || sl.contours > kMaxSliceContours)
      fail_key(source, slice_key(i, "contours"), "must be in [0, " + std::to_string(kMaxSliceContours) + "]");
    if (sl.contours > 0 && !sl.contour_values.empty())
      fail_key(source, slice_key(i, "contours"), "a count or a list of values, not both");
    if (sl.contour_values.size() > size_t(kMaxSliceContours))
      fail_key(source, slice_key(i, "contours"), "at most " + std::to_string(kMaxSliceContours) + " values");
    for (double v : sl.contour_values)
      if (!std::isfinite(v)) fail_key(source, slice_key(i, "contours"), "values must be finite");
    for (double c : sl.contour_color)
      if (!(c >= 0 && c <= 1)) fail_key(source, slice_key(i, "contour_color"), "components must be in [0, 1]");
    if (!(sl.contour_width > 0 && sl.contour_width <= 64))
      fail_key(source, slice_key(i, "contour_width"), "must be in (0, 64] pixels");
  }
}

std::vector<double> slice_contour_values(const Slice& slice, double tf_lo, double tf_hi) {
  std::vector<double> v = slice.contour_values;
  if (slice.contours > 0) {
    const double lo = slice.range ? (*slice.range)[0] : tf_lo, hi = slice.range ? (*slice.range)[1] : tf_hi;
    for (int k = 1; k <= slice.contours; ++k) v.push_back(lo + (hi - lo) * double(k) / double(slice.contours + 1));
  }
  std::sort(v.begin(), v.end());
  return v;
}

double slice_contour_coverage(std::span<const double> values, double width, double value, double per_pixel) {
  if (values.empty() || std::isnan(value)) return 0;
  double nearest = kInfinity;
  for (double c : values) nearest = std::min(nearest, std::abs(value - c));
  // Pixels to the nearest line; a flat field (per_pixel 0) is on a line only where it equals the value.
  const double d = per_pixel > 0 ? nearest / per_pixel : nearest == 0 ? 0 : kInfinity;
  return std::clamp(0.5 * width + 0.5 - d, 0.0, 1.0);
}

std::vector<float> slice_contour_row(const Slice& slice, std::span<const double> values, double scale, double offset) {
  std::vector<float> row((2 + values.size()) * 4, 0.0f);
  row[0] = float(values.size()), row[1] = float(slice.contour_width);
  for (int c = 0; c < 3; ++c) row[4 + c] = float(slice.contour_color[size_t(c)]);
  row[7] = 1;
  for (size_t j = 0; j < values.size(); ++j) row[(2 + j) * 4] = float(values[j] * scale + offset);
  return row;
}

double slice_screen_derivative(Vec3d gradient, Vec3d normal, Vec3d dir, Vec3d px, Vec3d py) {
  const double nd = dot(normal, dir);
  if (nd == 0) return 0;
  const Vec3d ex = px - dir * (dot(normal, px) / nd), ey = py - dir * (dot(normal, py) / nd);
  return std::hypot(dot(gradient, ex), dot(gradient, ey));
}

nlohmann::json settings_to_json(const RenderSettings& s) {
  nlohmann::json j = {{"width", s.width},
                      {"height", s.height},
                      {"background", s.background},
                      {"mode", render_mode_name(s.mode)},
                      {"field", s.field},
                      {"iso_values", s.iso_values},
                      {"iso_opacity", s.iso_opacity},
                      {"clip_plane", nullptr},
                      {"lighting", s.lighting},
                      {"volume_lighting", s.volume_lighting},
                      {"early_termination_opacity", s.early_termination_opacity},
                      {"sample_step", s.sample_step},
                      {"boundary_overlay_opacity", s.boundary_overlay_opacity}};
  j["slices"] = nlohmann::json::array();
  for (const Slice& sl : s.slices) {
    nlohmann::json r = nullptr;
    if (sl.range) r = {(*sl.range)[0], (*sl.range)[1]};
    j["slices"].push_back({{"point", {sl.point.x, sl.point.y, sl.point.z}},
                           {"normal", {sl.normal.x, sl.normal.y, sl.normal.z}},
                           {"opacity", sl.opacity},
                           {"color_map", sl.color_map},
                           {"range", r}});
    // The contour keys only where they differ from the defaults: settings without lines read as they always did.
    nlohmann::json& out = j["slices"].back();
    const Slice defaults;
    if (sl.contours > 0 || !sl.contour_values.empty())
      out["contours"] = sl.contour_values.empty() ? nlohmann::json(sl.contours) : nlohmann::json(sl.contour_values);
    if (sl.contour_color != defaults.contour_color) out["contour_color"] = sl.contour_color;
    if (sl.contour_width != defaults.contour_width) out["contour_width"] = sl.contour_width;
  }
  j["hide_volume"] = hide_volume_name(s.hide_volume);
  j["interpolation"] = interpolation_name(s.interpolation);
  if (s.clip_plane) {
    const ClipPlane& c = *s.clip_plane;
    j["clip_plane"] = {{"point", {c.point.x, c.point.y, c.point.z}}, {"normal", {c.normal.x, c.normal.y, c.normal.z}}};
  }
  return j;
}

RenderSettings settings_from_json(const nlohmann::json& j, std::string_view source) {
  if (!j.is_object()) fail_in(source, "render settings must be a JSON object");
  RenderSettings s;
  for (const auto& [key, v] : j.items()) {
    if (key == "width") {
      s.width = side_of(v, source, key);
    } else if (key == "height") {
      s.height = side_of(v, source, key);
    } else if (key == "background") {
      const std::vector<double> c = numbers_of(v, source, key);
      if (c.size() != 3 && c.size() != 4) fail_key(source, key, "expected [r, g, b] or [r, g, b, a]");
      s.background = {c[0], c[1], c[2], c.size() == 4 ? c[3] : 1.0};
    } else if (key == "mode") {
      s.mode = mode_of(v, source);
    } else if (key == "field") {
      if (!v.is_string()) fail_key(source, key, "expected a string");
      s.field = v.get<std::string>();
    } else if (key == "iso_values") {
      s.iso_values = numbers_of(v, source, key);
    } else if (key == "clip_plane") {
      if (v.is_null()) continue;
      if (!v.is_object() || !v.contains("point") || !v.contains("normal") || v.size() != 2)
        fail_key(source, key, "expected {\"point\": [x, y, z], \"normal\": [x, y, z]} or null");
      s.clip_plane =
          ClipPlane{vec_of(v["point"], source, "clip_plane.point"), vec_of(v["normal"], source, "clip_plane.normal")};
    } else if (key == "lighting") {
      if (!v.is_boolean()) fail_key(source, key, "expected true or false");
      s.lighting = v.get<bool>();
    } else if (key == "volume_lighting") {
      if (!v.is_boolean()) fail_key(source, key, "expected true or false");
      s.volume_lighting = v.get<bool>();
    } else if (key == "iso_opacity") {
      s.iso_opacity = number_of(v, source, key);
    } else if (key == "early_termination_opacity") {
      s.early_termination_opacity = number_of(v, source, key);
    } else if (key == "sample_step") {
      s.sample_step = number_of(v, source, key);
    } else if (key == "boundary_overlay_opacity") {
      s.boundary_overlay_opacity = number_of(v, source, key);
    } else if (key == "slices") {
      if (!v.is_array()) fail_key(source, key, "expected an array of slices");
      s.slices.clear();
      for (size_t i = 0; i < v.size(); ++i) s.slices.push_back(slice_of(v[i], i, source));
    } else if (key == "hide_volume") {
      if (!v.is_string()) fail_key(source, key, "expected \"none\", \"front\", \"back\" or \"all\"");
      s.hide_volume = parse_hide_volume(v.get<std::string>(), std::string(source) + ": key \"hide_volume\"");
    } else if (key == "interpolation") {
      if (!v.is_string()) fail_key(source, key, "expected \"trilinear\" or \"tricubic\"");
      s.interpolation = parse_interpolation(v.get<std::string>(), std::string(source) + ": key \"interpolation\"");
    } else {
      fail_key(source, key, "unknown render setting");
    }
  }
  s.validate(source);
  return s;
}

RenderSettings read_render_settings(const std::string& path) {
  return settings_from_json(read_json_file(path), base_name(path));
}

ImageSize parse_size(std::string_view text, std::string_view source) {
  const size_t x = text.find_first_of("xX");
  if (x == std::string_view::npos) {
    const int side = parse_side(text, text, source);
    return {side, side};
  }
  return {parse_side(text.substr(0, x), text, source), parse_side(text.substr(x + 1), text, source)};
}

}  // namespace ugvr
