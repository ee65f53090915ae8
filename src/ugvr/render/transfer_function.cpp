#include "ugvr/render/transfer_function.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"

namespace ugvr {
namespace {

[[noreturn]] void fail_key(std::string_view source, std::string_view key, std::string_view message) {
  fail_in(source, "key \"" + std::string(key) + "\": " + std::string(message));
}

bool in_unit(double v) { return v >= 0 && v <= 1; }

// Index i of the segment [points[i], points[i+1]] holding s, for points sorted by x and s inside their range.
template <class Point>
size_t segment_of(const std::vector<Point>& points, double s) {
  const auto it = std::upper_bound(points.begin(), points.end(), s, [](double v, const Point& p) { return v < p.x; });
  const size_t upper = size_t(it - points.begin());
  return std::min(upper, points.size() - 1) - 1;
}

// Piecewise-linear evaluation with clamping; `value` extracts the interpolated quantity from a point.
template <class Point, class Value>
auto evaluate(const std::vector<Point>& points, double s, Value value) {
  if (s <= points.front().x) return value(points.front());
  if (s >= points.back().x) return value(points.back());
  const size_t i = segment_of(points, s);
  const Point& a = points[i];
  const Point& b = points[i + 1];
  const double t = (s - a.x) / (b.x - a.x);
  return value(a) * (1 - t) + value(b) * t;
}

std::vector<double> numbers_of(const nlohmann::json& j, std::string_view source, std::string_view key) {
  if (!j.is_array()) fail_key(source, key, "expected an array of numbers");
  std::vector<double> v;
  v.reserve(j.size());
  for (const auto& e : j) {
    if (!e.is_number()) fail_key(source, key, "expected an array of numbers");
    v.push_back(e.get<double>());
  }
  return v;
}

TransferFunction preset_from_json(const nlohmann::json& j, std::string_view source) {
  if (!j.is_object()) fail_in(source, "a preset must be a JSON object");
  TransferFunction tf;
  if (j.contains("Name")) {
    if (!j["Name"].is_string()) fail_key(source, "Name", "expected a string");
    tf.name = j["Name"].get<std::string>();
  }
  if (j.contains("ColorSpace")) {
    if (!j["ColorSpace"].is_string()) fail_key(source, "ColorSpace", "expected a string");
    tf.color_space = j["ColorSpace"].get<std::string>();
  }
  if (!j.contains("RGBPoints")) fail_key(source, "RGBPoints", "missing (presets without colours are not supported)");
  const std::vector<double> rgb = numbers_of(j["RGBPoints"], source, "RGBPoints");
  if (rgb.empty() || rgb.size() % 4 != 0) fail_key(source, "RGBPoints", "length must be a positive multiple of 4");
  for (size_t i = 0; i < rgb.size(); i += 4) tf.color_points.push_back({rgb[i], {rgb[i + 1], rgb[i + 2], rgb[i + 3]}});
  if (j.contains("Points")) {
    const std::vector<double> op = numbers_of(j["Points"], source, "Points");
    if (op.empty() || op.size() % 4 != 0) fail_key(source, "Points", "length must be a positive multiple of 4");
    for (size_t i = 0; i < op.size(); i += 4) tf.opacity_points.push_back({op[i], op[i + 1]});
  } else {
    tf.opacity_points = {{tf.color_points.front().x, 0.0}, {tf.color_points.back().x, 1.0}};
  }
  if (j.contains("NanColor")) {
    const std::vector<double> nan = numbers_of(j["NanColor"], source, "NanColor");
    if (nan.size() != 3) fail_key(source, "NanColor", "expected [r, g, b]");
    tf.nan_color = {nan[0], nan[1], nan[2]};
  }
  if (j.contains("ScalarOpacityUnitDistance")) {
    if (!j["ScalarOpacityUnitDistance"].is_number()) fail_key(source, "ScalarOpacityUnitDistance", "expected a number");
    tf.opacity_unit_distance = j["ScalarOpacityUnitDistance"].get<double>();
  }
  // Name the preset in the message when a file holds several.
  tf.validate(tf.name.empty() ? std::string(source) : std::string(source) + " (preset \"" + tf.name + "\")");
  return tf;
}

nlohmann::json preset_to_json(const TransferFunction& tf) {
  nlohmann::json rgb = nlohmann::json::array(), op = nlohmann::json::array();
  for (const ColorPoint& p : tf.color_points) rgb.insert(rgb.end(), {p.x, p.rgb.x, p.rgb.y, p.rgb.z});
  for (const OpacityPoint& p : tf.opacity_points) op.insert(op.end(), {p.x, p.opacity, 0.5, 0.0});
  nlohmann::json j = {{"Name", tf.name},
                      {"ColorSpace", tf.color_space},
                      {"RGBPoints", rgb},
                      {"Points", op},
                      {"NanColor", {tf.nan_color.x, tf.nan_color.y, tf.nan_color.z}}};
  if (tf.opacity_unit_distance != 1) j["ScalarOpacityUnitDistance"] = tf.opacity_unit_distance;
  return j;
}

// A built-in map over [0, 1] from rows {x, r, g, b}, with the default linear opacity ramp.
TransferFunction make_builtin(std::string name, std::string color_space,
                              std::initializer_list<std::array<double, 4>> rows) {
  TransferFunction tf;
  tf.name = std::move(name);
  tf.color_space = std::move(color_space);
  for (const auto& r : rows) tf.color_points.push_back({r[0], {r[1], r[2], r[3]}});
  tf.opacity_points = {{0.0, 0.0}, {1.0, 1.0}};
  return tf;
}

// matplotlib's viridis and inferno (_cm_listed.py, 256 entries) sampled at entries 0, 17, ..., 255: each row holds
// viridis' r, g, b, then inferno's.
constexpr std::array<std::array<double, 6>, 16> kListedSamples = {{
    {0.267004, 0.004874, 0.329415, 0.001462, 0.000466, 0.013866},
    {0.282656, 0.100196, 0.422160, 0.046915, 0.030324, 0.150164},
    {0.277134, 0.185228, 0.489898, 0.142378, 0.046242, 0.308553},
    {0.253935, 0.265254, 0.529983, 0.258234, 0.038571, 0.406485},
    {0.221989, 0.339161, 0.548752, 0.366529, 0.071579, 0.431994},
    {0.190631, 0.407061, 0.556089, 0.472328, 0.110547, 0.428334},
    {0.163625, 0.471133, 0.558148, 0.578304, 0.148039, 0.404411},
    {0.139147, 0.533812, 0.555298, 0.682656, 0.189501, 0.360757},
    {0.120565, 0.596422, 0.543611, 0.780517, 0.243327, 0.299523},
    {0.134692, 0.658636, 0.517649, 0.865006, 0.316822, 0.226055},
    {0.208030, 0.718701, 0.472873, 0.929644, 0.411479, 0.145367},
    {0.327796, 0.773980, 0.406640, 0.970919, 0.522853, 0.058367},
    {0.477504, 0.821444, 0.318195, 0.987622, 0.645320, 0.039886},
    {0.647257, 0.858400, 0.209861, 0.978806, 0.774545, 0.176037},
    {0.824940, 0.884720, 0.106217, 0.950018, 0.903409, 0.380271},
    {0.993248, 0.906157, 0.143936, 0.988362, 0.998364, 0.644924},
}};

// One of the maps of kListedSamples (`column`: 0 viridis, 3 inferno), its samples evenly spaced over [0, 1].
TransferFunction listed_map(std::string name, size_t column) {
  TransferFunction tf = make_builtin(std::move(name), "RGB", {});
  constexpr double k = 1.0 / 15;
  for (size_t i = 0; i < kListedSamples.size(); ++i) {
    const auto& row = kListedSamples[i];
    const double x = i + 1 == kListedSamples.size() ? 1.0 : double(i) * k;
    tf.color_points.push_back({x, {row[column], row[column + 1], row[column + 2]}});
  }
  return tf;
}

TransferFunction viridis() { return listed_map("viridis", 0); }
TransferFunction inferno() { return listed_map("inferno", 3); }

}  // namespace

double corrected_opacity(double alpha, double length, double unit_distance) {
  if (alpha >= 1) return 1;
  if (alpha <= 0 || length <= 0) return 0;
  return 1 - std::pow(1 - alpha, length / unit_distance);
}

double TransferFunction::extinction(double s) const {
  const double a = std::min(opacity(s), kMaxTableOpacity);
  return -std::log1p(-a) / opacity_unit_distance;
}

Vec3d TransferFunction::color(double s) const {
  if (std::isnan(s)) return nan_color;
  return evaluate(color_points, s, [](const ColorPoint& p) { return p.rgb; });
}

double TransferFunction::opacity(double s) const {
  if (std::isnan(s) || opacity_points.empty()) return 0;
  return evaluate(opacity_points, s, [](const OpacityPoint& p) { return p.opacity; });
}

void TransferFunction::rescale(double lo, double hi) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi) fail_in("transfer function", "invalid rescale range");
  if (lo == hi) {
    lo -= 0.5;
    hi += 0.5;
  }
  const double old_lo = range_min(), old_hi = range_max();
  // A single colour point has no extent: place it at lo and keep the opacity points' offsets from it.
  const double scale = old_hi > old_lo ? (hi - lo) / (old_hi - old_lo) : 1.0;
  auto map = [&](double x) { return lo + (x - old_lo) * scale; };
  for (ColorPoint& p : color_points) p.x = map(p.x);
  for (OpacityPoint& p : opacity_points) p.x = map(p.x);
}

void TransferFunction::validate(std::string_view source) const {
  if (color_points.empty()) fail_key(source, "RGBPoints", "needs at least one point");
  for (size_t i = 0; i < color_points.size(); ++i) {
    const ColorPoint& p = color_points[i];
    if (!std::isfinite(p.x)) fail_key(source, "RGBPoints", "x values must be finite");
    if (i > 0 && !(p.x > color_points[i - 1].x))
      fail_key(source, "RGBPoints", "x values must be strictly increasing (point " + std::to_string(i) + ")");
    if (!in_unit(p.rgb.x) || !in_unit(p.rgb.y) || !in_unit(p.rgb.z))
      fail_key(source, "RGBPoints", "colour components must be in [0, 1] (point " + std::to_string(i) + ")");
  }
  for (size_t i = 0; i < opacity_points.size(); ++i) {
    const OpacityPoint& p = opacity_points[i];
    if (!std::isfinite(p.x)) fail_key(source, "Points", "x values must be finite");
    if (i > 0 && !(p.x > opacity_points[i - 1].x))
      fail_key(source, "Points", "x values must be strictly increasing (point " + std::to_string(i) + ")");
    if (!in_unit(p.opacity)) fail_key(source, "Points", "opacity must be in [0, 1] (point " + std::to_string(i) + ")");
  }
  if (!in_unit(nan_color.x) || !in_unit(nan_color.y) || !in_unit(nan_color.z))
    fail_key(source, "NanColor", "components must be in [0, 1]");
  if (!(opacity_unit_distance > 0) || !std::isfinite(opacity_unit_distance))
    fail_key(source, "ScalarOpacityUnitDistance", "must be finite and > 0");
}

std::vector<TransferFunction> parse_paraview_presets(std::string_view json_text, std::string_view source) {
  const nlohmann::json j = parse_json_text(json_text, source);
  std::vector<TransferFunction> out;
  if (j.is_array()) {
    if (j.empty()) fail_in(source, "the preset array is empty");
    for (const auto& e : j) out.push_back(preset_from_json(e, source));
  } else {
    out.push_back(preset_from_json(j, source));
  }
  return out;
}

TransferFunction read_paraview_preset(const std::string& path, std::string_view name) {
  const InputFile in(path);
  std::vector<TransferFunction> all = parse_paraview_presets(in.read_all(uint64_t(1) << 26), in.name());
  if (name.empty()) return all.front();
  for (TransferFunction& tf : all)
    if (tf.name == name) return tf;
  fail_in(in.name(), "no preset named \"" + std::string(name) + "\"");
}

std::string paraview_preset_json(const TransferFunction& tf) {
  return nlohmann::json::array({preset_to_json(tf)}).dump(2) + "\n";
}

void write_paraview_preset(const std::string& path, const TransferFunction& tf) {
  AtomicOutputFile out(path);
  out.write(paraview_preset_json(tf));
  out.commit();
}

TransferFunction builtin_preset(std::string_view name) {
  if (name == "viridis") return viridis();
  if (name == "inferno") return inferno();
  if (name == "cool-warm")  // ParaView's "Cool to Warm"
    return make_builtin(
        "cool-warm", "Diverging",
        {{0, 0.231373, 0.298039, 0.752941}, {0.5, 0.865003, 0.865003, 0.865003}, {1, 0.705882, 0.0156863, 0.14902}});
  if (name == "grayscale") return make_builtin("grayscale", "RGB", {{0, 0, 0, 0}, {1, 1, 1, 1}});
  if (name == "rainbow")  // ParaView's "Jet" moved from [-1, 1] to [0, 1]
    return make_builtin("rainbow", "RGB",
                        {{0, 0, 0, 0.5625},
                         {0.111111, 0, 0, 1},
                         {0.365079, 0, 1, 1},
                         {0.492063, 0.5, 1, 0.5},
                         {0.619048, 1, 1, 0},
                         {0.873016, 1, 0, 0},
                         {1, 0.5, 0, 0}});
  std::string names;
  for (const std::string& n : builtin_preset_names()) names += (names.empty() ? "" : ", ") + n;
  fail_in("transfer function", "unknown preset \"" + std::string(name) + "\" (built-in: " + names + ")");
}

std::vector<std::string> builtin_preset_names() { return {"viridis", "inferno", "cool-warm", "grayscale", "rainbow"}; }

double default_unit_distance(const Bounds& bounds) {
  const double diagonal = bounds.empty() ? 0.0 : length(bounds.size());
  return diagonal > 0 && std::isfinite(diagonal) ? diagonal / 10 : 1.0;
}

TransferFunction default_transfer_function(double lo, double hi, const Bounds& bounds) {
  TransferFunction tf = builtin_preset("viridis");
  if (std::isfinite(lo) && std::isfinite(hi)) tf.rescale(lo, hi);
  tf.opacity_unit_distance = default_unit_distance(bounds);
  return tf;
}

std::optional<double> read_preset_unit_distance(const std::string& path, std::string_view name) {
  const nlohmann::json j = read_json_file(path);
  const nlohmann::json* preset = nullptr;
  if (j.is_object()) {
    preset = &j;
  } else if (j.is_array()) {
    for (const nlohmann::json& p : j) {
      if (!p.is_object()) continue;
      if (name.empty() || (p.contains("Name") && p["Name"].is_string() && p["Name"].get<std::string>() == name)) {
        preset = &p;
        break;
      }
    }
  }
  if (!preset || !preset->contains("ScalarOpacityUnitDistance")) return std::nullopt;
  return (*preset)["ScalarOpacityUnitDistance"].get<double>();
}

}  // namespace ugvr
