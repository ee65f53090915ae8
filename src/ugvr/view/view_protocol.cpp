#include "ugvr/view/view_protocol.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ugvr/core/error.h"
#include "ugvr/render/settings_table.h"

namespace ugvr::view {
namespace {

using nlohmann::json;

[[noreturn]] void fail_field(std::string_view field, const std::string& message) { fail_in(field, message); }

// Only `allowed` keys (and "type") may appear.
void check_keys(const json& j, std::initializer_list<std::string_view> allowed) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key() == "type") continue;
    if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end())
      fail_field(it.key(), "unknown key for a \"" + j["type"].get<std::string>() + "\" message");
  }
}

double finite_number(const json& v, std::string_view key) {
  if (!v.is_number()) fail_field(key, "expected a number, found " + std::string(v.type_name()));
  const double d = v.get<double>();
  if (!std::isfinite(d)) fail_field(key, "expected a finite number");
  return d;
}

double number(const json& j, std::string_view key, double lo, double hi) {
  const double d = finite_number(j[std::string(key)], key);
  if (d < lo || d > hi)
    fail_field(key, "must be in [" + json(lo).dump() + ", " + json(hi).dump() + "], found " + json(d).dump());
  return d;
}

int side(const json& j, std::string_view key) {
  if (!j.contains(key)) fail_field(key, "missing");
  const json& v = j[std::string(key)];
  if (!v.is_number_integer()) fail_field(key, "expected an integer, found " + json(v).dump());
  const int64_t n = v.get<int64_t>();
  if (n < kMinViewSide || n > kMaxViewSide)
    fail_field(key, "must be in [" + std::to_string(kMinViewSide) + ", " + std::to_string(kMaxViewSide) + "], found " +
                        std::to_string(n));
  return int(n);
}

// A flat list of numbers, `stride` per point, at most kMaxTfPoints points.
std::vector<double> flat_points(const json& j, std::string_view key, size_t stride) {
  const json& v = j[std::string(key)];
  if (!v.is_array()) fail_field(key, "expected an array of numbers");
  if (v.empty() || v.size() % stride != 0)
    fail_field(key, "expected a non-empty multiple of " + std::to_string(stride) + " numbers, found " +
                        std::to_string(v.size()));
  if (v.size() / stride > kMaxTfPoints)
    fail_field(key, "at most " + std::to_string(kMaxTfPoints) + " points, found " + std::to_string(v.size() / stride));
  std::vector<double> out;
  for (const json& e : v) {
    if (!e.is_number() || !std::isfinite(e.get<double>())) fail_field(key, "expected finite numbers");
    out.push_back(e.get<double>());
  }
  for (size_t i = stride; i < out.size(); i += stride)
    if (!(out[i] > out[i - stride])) fail_field(key, "point x values must be strictly increasing");
  return out;
}

double unit(double v, std::string_view key) {
  if (v < 0 || v > 1) fail_field(key, "values must be in [0, 1]");
  return v;
}

TfMessage parse_tf(const json& j) {
  check_keys(j, {"preset", "opacity", "rgb_points", "opacity_points"});
  TfMessage m;
  if (j.contains("preset")) {
    if (!j["preset"].is_string()) fail_field("preset", "expected a string");
    const std::string name = j["preset"].get<std::string>();
    const std::vector<std::string> names = builtin_preset_names();
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      fail_field("preset", "unknown preset (valid: " + list + ")");
    }
    m.preset = name;
  }
  if (j.contains("opacity")) m.opacity = number(j, "opacity", 0, 1);
  if (j.contains("rgb_points")) {
    const std::vector<double> p = flat_points(j, "rgb_points", 4);
    for (size_t i = 0; i < p.size(); i += 4)
      m.color_points.push_back(
          {p[i], {unit(p[i + 1], "rgb_points"), unit(p[i + 2], "rgb_points"), unit(p[i + 3], "rgb_points")}});
  }
  if (j.contains("opacity_points")) {
    const std::vector<double> p = flat_points(j, "opacity_points", 2);
    for (size_t i = 0; i < p.size(); i += 2) m.opacity_points.push_back({p[i], unit(p[i + 1], "opacity_points")});
  }
  return m;
}

Vec3d vec3(const json& j, std::string_view key) {
  if (!j.is_array() || j.size() != 3) fail_field(key, "expected [x, y, z]");
  for (const json& e : j)
    if (!e.is_number() || !std::isfinite(e.get<double>())) fail_field(key, "expected 3 finite numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// {"point":[x,y,z],"normal":[x,y,z]} or null (off). Errors name "clip" and the sub-key.
std::optional<ClipPlane> parse_clip(const json& v) {
  if (v.is_null()) return std::nullopt;
  if (!v.is_object()) fail_field("clip", "expected {\"point\":[x,y,z],\"normal\":[x,y,z]} or null");
  for (auto it = v.begin(); it != v.end(); ++it)
    if (it.key() != "point" && it.key() != "normal") fail_field("clip", "unknown key \"" + it.key() + "\"");
  if (!v.contains("point") || !v.contains("normal")) fail_field("clip", "needs \"point\" and \"normal\"");
  ClipPlane c{vec3(v["point"], "clip.point"), vec3(v["normal"], "clip.normal")};
  if (!(length(c.normal) > 0)) fail_field("clip.normal", "must not be zero");
  return c;
}

// A RenderSettings number, in the range settings_table.h gives for its message key.
double setting_number(const json& v, std::string_view key) {
  const SettingInterval& range = *render_setting_for_message(key)->interval;
  const double d = finite_number(v, key);
  if (!range.contains(d)) fail_field(key, "must be in " + range.text() + ", found " + json(d).dump());
  return d;
}

bool boolean(const json& v, std::string_view key) {
  if (!v.is_boolean()) fail_field(key, "expected true or false");
  return v.get<bool>();
}

// The settings keys that are the viewer's own; the others are RenderSettings fields (settings_table.h).
constexpr std::string_view kViewerSettings[] = {"step_voxels", "fps", "full_quality"};

SettingsMessage parse_settings(const json& j) {
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "type" && !render_setting_for_message(it.key()) &&
        std::find(std::begin(kViewerSettings), std::end(kViewerSettings), it.key()) == std::end(kViewerSettings))
      fail_field(it.key(), "unknown key for a \"settings\" message");
  SettingsMessage m;
  if (j.contains("mode")) {
    const json& v = j["mode"];
    const std::string s = v.is_string() ? v.get<std::string>() : "";
    if (s == "ea")
      m.mode = RenderMode::EmissionAbsorption;
    else if (s == "mip")
      m.mode = RenderMode::Mip;
    else if (s == "iso")
      m.mode = RenderMode::Isosurface;
    else
      fail_field("mode", "expected \"ea\", \"mip\" or \"iso\", found " + v.dump());
  }
  if (j.contains("iso_value"))
    m.iso_value = number(j, "iso_value", std::numeric_limits<double>::lowest(), std::numeric_limits<double>::max());
  if (j.contains("step_voxels")) {
    m.step_voxels = number(j, "step_voxels", 0, 8);
    if (*m.step_voxels <= 0) fail_field("step_voxels", "must be > 0");
  }
  if (j.contains("fps")) m.fps = number(j, "fps", 0, kMaxFps);
  if (j.contains("full_quality")) m.full_quality = boolean(j["full_quality"], "full_quality");
  if (j.contains("field")) {
    const json& v = j["field"];
    if (!v.is_string()) fail_field("field", "expected a field name, found " + std::string(v.type_name()));
    const std::string name = v.get<std::string>();
    if (name.empty() || name.size() > kMaxFieldName)
      fail_field("field", "expected a name of 1 to " + std::to_string(kMaxFieldName) + " bytes, found " +
                              std::to_string(name.size()));
    m.field = name;
  }
  if (j.contains("boundary_opacity")) m.boundary_opacity = setting_number(j["boundary_opacity"], "boundary_opacity");
  if (j.contains("clip")) m.clip = parse_clip(j["clip"]);
  if (j.contains("iso_opacity")) m.iso_opacity = setting_number(j["iso_opacity"], "iso_opacity");
  if (j.contains("lighting")) m.lighting = boolean(j["lighting"], "lighting");
  if (j.contains("volume_lighting")) m.volume_lighting = boolean(j["volume_lighting"], "volume_lighting");
  if (j.contains("early_termination_opacity"))
    m.early_termination_opacity = setting_number(j["early_termination_opacity"], "early_termination_opacity");
  if (j.contains("sample_step")) m.sample_step = setting_number(j["sample_step"], "sample_step");
  if (j.contains("background")) {
    const json& v = j["background"];
    if (!v.is_array() || v.size() != 3) fail_field("background", "expected [r, g, b]");
    std::array<double, 4> c{0, 0, 0, 1};
    for (size_t i = 0; i < 3; ++i) c[i] = setting_number(v[i], "background");
    m.background = c;
  }
  // As in a settings file (render_settings.h), errors naming the key: "slices: key "slices[0].normal": ...".
  if (j.contains("slices")) m.slices = settings_from_json(json{{"slices", j["slices"]}}, "slices").slices;
  if (j.contains("hide_volume")) {
    const json& v = j["hide_volume"];
    m.hide_volume = parse_hide_volume(v.is_string() ? v.get<std::string>() : v.dump(), "hide_volume");
  }
  if (j.contains("interpolation")) {
    const json& v = j["interpolation"];
    if (!v.is_string() || (v != "trilinear" && v != "tricubic"))
      fail_field("interpolation", "expected \"trilinear\" or \"tricubic\", found " + v.dump());
    m.interpolation = parse_interpolation(v.get<std::string>(), "interpolation");
  }
  return m;
}

}  // namespace

ClientMessage parse_client_message(std::string_view text) {
  if (text.size() > kMaxClientMessageBytes)
    fail_field("message", "too large: " + std::to_string(text.size()) + " bytes (at most " +
                              std::to_string(kMaxClientMessageBytes) + ")");
  const json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) fail_field("message", "not valid JSON");
  if (!j.is_object()) fail_field("message", "expected a JSON object");
  if (!j.contains("type") || !j["type"].is_string()) fail_field("type", "missing or not a string");
  const std::string type = j["type"].get<std::string>();
  if (type == "hello" || type == "resize") {
    check_keys(j, {"width", "height"});
    return SizeMessage{type == "hello", side(j, "width"), side(j, "height")};
  }
  if (type == "camera") {
    json c = j;
    c.erase("type");
    // camera.h validates (finite, non-degenerate, angle range, unknown keys) and names the key in its message.
    return CameraMessage{camera_from_json(c, "camera")};
  }
  if (type == "tf") return parse_tf(j);
  if (type == "settings") return parse_settings(j);
  if (type == "engine") {
    check_keys(j, {"engine"});
    if (!j.contains("engine")) fail_field("engine", "missing");
    const json& v = j["engine"];
    const std::string name = v.is_string() ? v.get<std::string>() : "";
    if (name != kExactEngine && name != kLodEngine && name != kHybridEngine)
      fail_field("engine", "expected \"exact\", \"lod\" or \"hybrid\", found " +
                               v.dump(-1, ' ', false, json::error_handler_t::replace));
    return EngineMessage{name};
  }
  if (type == "interest") {
    check_keys(j, {"focus", "roi", "context_saturation", "context_opacity"});
    InterestMessage m;
    // The texts of `ugvr render --focus / --roi`; their errors name the key instead of the flag.
    const auto string_of = [&](const char* key) {
      const json& v = j[key];
      if (!v.is_string() || v.get<std::string>().empty()) fail_field(key, "expected a non-empty string or null");
      return v.get<std::string>();
    };
    if (j.contains("focus")) {
      if (j["focus"].is_null()) {
        m.focus.emplace();
      } else {
        const std::string f = string_of("focus");
        try {
          m.focus = parse_focus(f);
        } catch (const Error& e) {
          fail_field("focus", std::string(e.what()).substr(std::string("--focus ").size()));
        }
      }
    }
    if (j.contains("roi"))
      m.roi.emplace(j["roi"].is_null() ? std::nullopt : std::optional(parse_roi(string_of("roi"), "roi")));
    if (j.contains("context_saturation")) m.context_saturation = number(j, "context_saturation", 0, 1);
    if (j.contains("context_opacity")) m.context_opacity = number(j, "context_opacity", 0, 1);
    return m;
  }
  if (type == "time") {
    check_keys(j, {"step", "playing"});
    if (!j.contains("step")) fail_field("step", "missing");
    const json& v = j["step"];
    // An integer step, not a time: the page's slider moves over the steps (the scene lists their times).
    if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > int64_t(UINT32_MAX))
      fail_field("step", "expected a step index (an integer >= 0), found " +
                             v.dump(-1, ' ', false, json::error_handler_t::replace));
    TimeMessage m;
    m.step = uint32_t(v.get<int64_t>());
    if (j.contains("playing")) {
      if (!j["playing"].is_boolean()) fail_field("playing", "expected true or false");
      m.playing = j["playing"].get<bool>();
    }
    return m;
  }
  fail_field("type",
             "unknown message type \"" + type + "\" (expected hello, resize, camera, tf, settings, engine or time)");
}

std::string error_message(std::string_view message) {
  // error_handler_t::replace: a message quoting invalid UTF-8 from the client must not throw while being reported.
  return json{{"type", "error"}, {"message", std::string(message)}}.dump(-1, ' ', false,
                                                                         json::error_handler_t::replace);
}

std::string status_message(const FrameStatus& s) {
  json j{{"type", "status"},
         {"seq", s.seq},
         {"request", s.request},
         {"format", s.png ? "png" : "jpeg"},
         {"width", s.width},
         {"height", s.height},
         {"fps", s.fps},
         {"frame_seconds", s.frame_seconds},
         {"cut_nodes", s.cut_nodes},
         {"visible_nodes", s.visible_nodes},
         {"texel_error", s.texel_error},
         {"max_texel_error", s.max_texel_error},
         {"scale", s.scale},
         {"converged", s.converged},
         {"engine", s.engine},
         {"ram_bytes", s.ram_bytes},
         {"ram_budget", s.ram_budget},
         {"atlas_bytes", s.atlas_bytes},
         {"atlas_budget", s.atlas_budget},
         {"pending_bricks", s.pending_bricks},
         {"interrupted", s.interrupted}};
  if (s.time_step >= 0) j["time_step"] = s.time_step, j["time"] = s.time;
  if (s.hybrid)
    j["exact"] = {{"nodes", s.exact_nodes},
                  {"candidates", s.exact_candidates},
                  {"fraction", s.exact_fraction},
                  {"cells", s.exact_cells},
                  {"cell_bytes", s.cell_bytes},
                  {"cell_budget", s.cell_budget},
                  {"budget_full", s.cell_budget_full},
                  {"focus_excluded", s.focus_excluded},
                  {"off", s.exact_off.empty() ? json(nullptr) : json(s.exact_off)}};
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string ack_message(uint64_t request) { return json{{"type", "ack"}, {"request", request}}.dump(); }

std::string progress_message(const ProgressInfo& p) {
  return json{
      {"type", "progress"}, {"stage", p.stage}, {"label", p.label}, {"fraction", p.fraction}, {"message", p.message}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

const FieldInfo* SceneInfo::find_field(std::string_view name) const {
  const std::string_view wanted = name.empty() ? std::string_view(field) : name;
  for (const FieldInfo& f : fields)
    if (f.name == wanted) return &f;
  // A vector's name alone is its magnitude, as on a mesh and in `ugvr render` of a store.
  const std::string magnitude = std::string(wanted) + ":magnitude";
  for (const FieldInfo& f : fields)
    if (f.name == magnitude) return &f;
  return nullptr;
}

bool SceneInfo::has_engine(std::string_view name) const {
  return std::any_of(engines.begin(), engines.end(), [&](const EngineChoice& e) { return e.name == name; });
}

namespace {

// A transfer function's points as the page's editor takes them: flat [x, r, g, b, ...] and [x, opacity, ...].
json tf_points_json(const TransferFunction& tf) {
  json rgb = json::array(), opacity = json::array();
  for (const ColorPoint& p : tf.color_points)
    for (const double v : {p.x, p.rgb.x, p.rgb.y, p.rgb.z}) rgb.push_back(v);
  for (const OpacityPoint& p : tf.opacity_points)
    for (const double v : {p.x, p.opacity}) opacity.push_back(v);
  return {{"rgb_points", rgb}, {"opacity_points", opacity}};
}

}  // namespace

std::string scene_message(const SceneInfo& scene) {
  json fields = json::array();
  for (const FieldInfo& f : scene.fields) {
    fields.push_back({{"name", f.name}, {"range", {f.min, f.max}}, {"histogram", f.histogram}});
    if (const auto it = scene.auto_opacity.find(f.name); it != scene.auto_opacity.end()) {
      json flat = json::array();
      for (const OpacityPoint& p : it->second.points) flat.insert(flat.end(), {p.x, p.opacity});
      fields.back()["auto_opacity"] = flat;
    }
  }
  const FieldInfo* current = scene.find_field("");
  // The presets' colours over [0, 1], so that a page can draw the colour map it asks for.
  json preset_points = json::object();
  for (const std::string& name : builtin_preset_names()) {
    json flat = json::array();
    for (const ColorPoint& p : builtin_preset(name).color_points)
      flat.insert(flat.end(), {p.x, p.rgb.x, p.rgb.y, p.rgb.z});
    preset_points[name] = flat;
  }
  json engines = json::array(), renderers = json::object();
  for (const EngineChoice& e : scene.engines) {
    engines.push_back(e.name);
    renderers[e.name] = e.renderer;
  }
  const Bounds& b = scene.bounds;
  json j{{"type", "scene"},
         {"field", scene.field},
         {"range", {current ? current->min : 0.0, current ? current->max : 1.0}},
         {"fields", fields},
         {"bounds", {{"min", {b.lo.x, b.lo.y, b.lo.z}}, {"max", {b.hi.x, b.hi.y, b.hi.z}}}},
         {"camera", camera_to_json(scene.camera)},
         {"presets", builtin_preset_names()},
         {"preset_points", preset_points},
         {"preset", scene.preset},
         {"fps", scene.fps},
         {"width", scene.width},
         {"height", scene.height},
         {"renderer", scene.renderer},
         {"engine", scene.engine},
         {"engines", engines},
         {"renderers", renderers},
         {"limits", {{"min_side", kMinViewSide}, {"max_side", kMaxViewSide}, {"max_fps", kMaxFps}}}};
  if (scene.tf) j["tf"] = tf_points_json(*scene.tf);
  if (!scene.times.empty()) {
    j["time"] = {{"count", scene.times.size()}, {"times", scene.times}, {"step", scene.time_step}};
    if (scene.play_rate > 0) j["time"]["play"] = scene.play_rate;
  }
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string view_message(const std::optional<Camera>& camera, const std::optional<TransferFunction>& tf) {
  json j{{"type", "view"}};
  if (camera) j["camera"] = camera_to_json(*camera);
  if (tf) j["tf"] = tf_points_json(*tf);
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace ugvr::view
