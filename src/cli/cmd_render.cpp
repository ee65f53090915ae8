// `ugvr render`: one image (or N timed frames) of a dataset or a brick store. The flags are the engine-independent
// vocabulary of render_settings.h / camera.h / transfer_function.h; --engine picks who renders: the exact CPU ray
// caster (a mesh) or the level-of-detail GPU ray caster (a brick store written by `ugvr build`).
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>

#include "cli/cli_numbers.h"
#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr::cli {
namespace {

// Every value flag is bound as text and parsed here, so a bad value is a ugvr::Error naming the flag (exit 1) like
// every other user error, rather than CLI11's own message and exit code.
struct Options {
  std::vector<std::string> inputs;
  ReadOptions read;
  std::string output, size, engine = "auto", camera, view, view_angle, tf, tf_name, range, unit_distance, field, mode,
                            iso, iso_opacity, clip, boundary_opacity, background, settings, float_output, stats,
                            save_camera, save_tf, threads, frames, cut = "pixels:1", gpu = "auto", step_voxels, fps,
                            path, out_dir, uploads_per_frame, reads_per_frame, error_weight;
  uint64_t gpu_memory = uint64_t(2) << 30, ram_memory = uint64_t(1) << 30;
  bool keep_range = false, no_lighting = false, volume_lighting = false;
};

const std::vector<std::string> kEngines = {"auto", "exact", "lod"};

const std::vector<std::string> kViews = {"+x", "-x", "+y", "-y", "+z", "-z", "iso"};

[[noreturn]] void fail_flag(std::string_view flag, const std::string& message) { fail_in(flag, message); }

// Runs f; an error it raises (a file's own message naming the file) is prefixed with the flag that named the file.
template <class F>
auto with_flag(std::string_view flag, F&& f) {
  try {
    return f();
  } catch (const Error& e) {
    fail_flag(flag, e.what());
  }
}

int parse_positive_int(std::string_view text, std::string_view flag) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v < 1)
    fail_flag(flag, "expected a positive integer, found \"" + std::string(text) + "\"");
  return v;
}

// "a,b,c" with a count in [min_count, max_count].
std::vector<double> parse_list(std::string_view text, std::string_view flag, size_t min_count, size_t max_count,
                               std::string_view form) {
  std::vector<double> v;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string_view item = text.substr(start, comma == std::string_view::npos ? comma : comma - start);
    v.push_back(parse_number(item, flag));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (v.size() < min_count || v.size() > max_count)
    fail_flag(flag, "expected " + std::string(form) + ", found " + std::to_string(v.size()) + " value" +
                        (v.size() == 1 ? "" : "s"));
  return v;
}

double parse_fraction(std::string_view text, std::string_view flag) {
  const double v = parse_number(text, flag);
  if (v < 0 || v > 1) fail_flag(flag, "must be in [0, 1], found " + std::string(text));
  return v;
}

std::string join(const std::vector<std::string>& names, std::string_view sep = ", ") {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : std::string(sep)) + n;
  return s;
}

RenderMode parse_mode(std::string_view text) {
  if (text == "ea" || text == "emission_absorption") return RenderMode::EmissionAbsorption;
  if (text == "mip") return RenderMode::Mip;
  if (text == "iso" || text == "isosurface") return RenderMode::Isosurface;
  fail_flag("--mode", "unknown mode \"" + std::string(text) + "\" (expected ea, mip or iso)");
}

void check_extension(const std::string& path, std::string_view flag, const std::vector<std::string>& allowed) {
  const std::string ext = extension_lower(path);
  if (std::find(allowed.begin(), allowed.end(), ext) == allowed.end())
    fail_flag(flag, "\"" + path + "\" must end in " + join(allowed, " or "));
}

// The flags on top of --settings (or the defaults): only what was given overrides.
RenderSettings settings_from_flags(const Options& o) {
  RenderSettings s =
      o.settings.empty() ? RenderSettings{} : with_flag("--settings", [&] { return read_render_settings(o.settings); });
  if (!o.size.empty()) {
    const ImageSize size = parse_size(o.size, "--size");
    s.width = size.width;
    s.height = size.height;
  }
  if (!o.field.empty()) s.field = o.field;
  if (!o.iso.empty()) {
    s.iso_values = parse_list(o.iso, "--iso", 1, 4096, "one or more comma-separated values");
    // Iso values only mean something in isosurface mode, so giving them picks it unless --mode says otherwise.
    if (o.mode.empty()) s.mode = RenderMode::Isosurface;
  }
  if (!o.mode.empty()) s.mode = parse_mode(o.mode);
  if (s.mode == RenderMode::Isosurface && s.iso_values.empty())
    fail_flag("--mode", "isosurface mode needs --iso V1,V2,...");
  if (!o.iso_opacity.empty()) s.iso_opacity = parse_fraction(o.iso_opacity, "--iso-opacity");
  if (!o.clip.empty()) {
    const std::vector<double> c = parse_list(o.clip, "--clip", 6, 6, "PX,PY,PZ,NX,NY,NZ");
    const ClipPlane plane{{c[0], c[1], c[2]}, {c[3], c[4], c[5]}};
    if (length(plane.normal) == 0) fail_flag("--clip", "the normal NX,NY,NZ must be non-zero");
    s.clip_plane = plane;
  }
  if (!o.boundary_opacity.empty())
    s.boundary_overlay_opacity = parse_fraction(o.boundary_opacity, "--boundary-opacity");
  if (o.no_lighting) s.lighting = false;
  if (o.volume_lighting) s.volume_lighting = true;
  if (!o.background.empty()) {
    const std::vector<double> b = parse_list(o.background, "--background", 3, 4, "R,G,B or R,G,B,A");
    for (double c : b)
      if (c < 0 || c > 1) fail_flag("--background", "components must be in [0, 1]");
    s.background = {b[0], b[1], b[2], b.size() == 4 ? b[3] : 1.0};
  }
  with_flag("--settings", [&] { s.validate(o.settings.empty() ? "render settings" : o.settings); });
  return s;
}

bool is_tf_file(const std::string& tf) {
  std::error_code ec;
  return extension_lower(tf) == ".json" || std::filesystem::is_regular_file(tf, ec);
}

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

bool is_brick_store(const std::string& path) { return std::filesystem::path(path).extension() == ".ugvr"; }

// What run_render needs of an engine, whichever it is.
struct EngineRun {
  std::string field_name;
  double field_min = 0, field_max = 0;
  Bounds bounds;
  // Renders one frame; returns the frame's wall seconds as the engine measured them.
  std::function<Image(const Camera&, const TransferFunction&, const RenderSettings&, double&)> render;
  std::function<void(nlohmann::json&)> add_stats;  // engine-specific --stats keys
  std::function<std::string()> summary;            // engine-specific part of the progress line
  // Time-critical rendering along a camera path (lod only; empty otherwise).
  std::function<void(const Camera&, const TransferFunction&, const RenderSettings&)> run_path;
};

// Keyframes resampled to `frames` cameras, piecewise linearly over the keyframe index (a keyframe list is a path, not
// a schedule: frames are spread evenly over its segments). Position, focal point, view angle and parallel scale are
// interpolated; view up is interpolated and renormalised; the projection is the earlier keyframe's.
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

// "orbit[:N][,rest:M]": N frames (or --frames, else 300) around the focal point about view_up (a full turn), then M
// frames back at the start; or a JSON file holding a list of cameras (camera.h's form): one frame each, or keyframes
// resampled to --frames frames.
std::vector<Camera> camera_path(const std::string& spec_in, const Camera& start, int frames) {
  std::vector<Camera> path;
  std::string spec = spec_in;
  if (spec == "orbit" || spec.rfind("orbit,", 0) == 0)
    spec = "orbit:" + std::to_string(frames > 0 ? frames : 300) + spec.substr(5);
  else if (spec.rfind("orbit:", 0) == 0 && frames > 0)
    fail_flag("--frames", "orbit:N already gives the frame count (use --path orbit --frames N)");
  if (spec.rfind("orbit:", 0) == 0) {
    std::string n_text = spec.substr(6), rest_text;
    if (const size_t comma = n_text.find(','); comma != std::string::npos) {
      rest_text = n_text.substr(comma + 1);
      n_text = n_text.substr(0, comma);
      if (rest_text.rfind("rest:", 0) != 0)
        fail_flag("--path", "expected orbit, orbit:N or orbit:N,rest:M (or orbit,rest:M)");
      rest_text = rest_text.substr(5);
    }
    const int n = parse_positive_int(n_text, "--path");
    const int rest = rest_text.empty() ? 0 : parse_positive_int(rest_text, "--path");
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
  const nlohmann::json j = with_flag("--path", [&] { return read_json_file(spec); });
  if (!j.is_array() || j.empty()) fail_in(spec, "expected a non-empty list of cameras");
  for (size_t i = 0; i < j.size(); ++i) path.push_back(camera_from_json(j[i], spec + " [" + std::to_string(i) + "]"));
  return frames > 0 ? resample_keyframes(path, frames) : path;
}

EngineRun exact_run(const Options& o, RenderSettings& settings, std::shared_ptr<void>& keep) {
  auto ds = std::make_shared<Dataset>(read_dataset(o.inputs, o.read));
  for (const std::string& w : ds->warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  auto engine = std::make_shared<ExactEngine>(*ds);
  with_flag("--field", [&] { engine->set_field(*ds, settings.field); });
  // Recorded in --stats so the settings reproduce the image; a selector the user gave ("velocity:x") is kept as is.
  if (settings.field.empty()) settings.field = engine->field_name();
  keep = engine;
  auto stats = std::make_shared<ExactRenderStats>();
  EngineRun run;
  run.field_name = engine->field_name();
  run.field_min = engine->field_min(), run.field_max = engine->field_max();
  run.bounds = engine->bounds();
  run.render = [engine, stats](const Camera& c, const TransferFunction& tf, const RenderSettings& s, double& sec) {
    Image image = engine->render(c, tf, s, stats.get());
    sec = stats->render_seconds;
    return image;
  };
  run.add_stats = [engine, stats](nlohmann::json& j) {
    const uint64_t cells = engine->cell_count();
    j["cells"] = cells;
    j["points"] = engine->point_count();
    j["build_seconds"] = engine->build_seconds();
    j["rays"] = stats->rays;
    j["rays_hit"] = stats->rays_hit;
    j["cell_steps"] = stats->cell_steps;
    j["reentries"] = stats->reentries;
    j["nonlinear_samples"] = stats->nonlinear_samples;
    j["lost_rays"] = stats->lost_rays;
    j["engine_bytes"] = engine->memory_bytes();
    j["engine_bytes_per_cell"] = cells ? double(engine->memory_bytes()) / double(cells) : 0.0;
  };
  run.summary = [engine, stats] {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%llu cells, build %.3f s, %llu of %llu rays hit, engine %s",
                  (unsigned long long)engine->cell_count(), engine->build_seconds(),
                  (unsigned long long)stats->rays_hit, (unsigned long long)stats->rays,
                  format_bytes(engine->memory_bytes()).c_str());
    std::string s = buf;
    if (stats->lost_rays > 0)
      s += "\nwarning: " + std::to_string(stats->lost_rays) + " rays were abandoned on a degenerate walk";
    return s;
  };
  return run;
}

EngineRun lod_run(const Options& o, RenderSettings& settings, std::shared_ptr<void>& keep) {
  if (o.inputs.size() != 1 || !is_brick_store(o.inputs[0]))
    fail_flag("--engine", "the lod engine renders one brick store (.ugvr, made by `ugvr build`)");
  const CutSpec cut = with_flag("--cut", [&] { return parse_cut_spec(o.cut); });
  LodOptions lo;
  lo.atlas_budget_bytes = o.gpu_memory;
  if (!o.step_voxels.empty()) {
    lo.step_voxels = parse_number(o.step_voxels, "--step-voxels");
    if (!(lo.step_voxels > 0) || lo.step_voxels > 8) fail_flag("--step-voxels", "must be in (0, 8]");
  }
  struct Held {
    std::unique_ptr<GlContext> gl;
    std::unique_ptr<LodEngine> engine;
    LodRenderStats stats;
  };
  auto h = std::make_shared<Held>();
  h->gl = with_flag("--gpu", [&] { return std::make_unique<GlContext>(o.gpu); });
  h->engine = std::make_unique<LodEngine>(o.inputs[0], *h->gl, lo);
  with_flag("--field", [&] { h->engine->set_field(settings.field); });
  if (settings.field.empty()) settings.field = h->engine->field_name();
  keep = h;
  EngineRun run;
  run.field_name = h->engine->field_name();
  run.field_min = h->engine->field_min(), run.field_max = h->engine->field_max();
  run.bounds = h->engine->bounds();
  run.render = [h, cut](const Camera& c, const TransferFunction& tf, const RenderSettings& s, double& sec) {
    Image image = h->engine->render(c, tf, s, cut, &h->stats);
    sec = h->stats.render_seconds;
    return image;
  };
  run.add_stats = [h, cut](nlohmann::json& j) {
    const LodRenderStats& st = h->stats;
    j["renderer"] = h->gl->renderer();
    j["gl_version"] = h->gl->version();
    j["cut"] = cut_spec_name(cut);
    j["nodes"] = h->engine->node_count();
    j["brick_resolution"] = h->engine->resolution();
    j["cut_nodes"] = st.cut_nodes;
    j["cut_max_level"] = st.max_level;
    j["cut_mean_level"] = st.mean_level;
    j["culled_frustum"] = st.culled_frustum;
    j["culled_tf"] = st.culled_tf;
    j["budget_limited"] = st.budget_limited;
    j["bricks_loaded_last_frame"] = st.bricks_loaded;
    j["cut_seconds"] = st.cut_seconds;
    j["load_seconds"] = st.load_seconds;
    j["gpu_seconds"] = st.gpu_seconds;
    j["gpu_timer_seconds"] = st.gpu_timer_seconds;
    j["samples"] = st.samples;
    j["samples_per_second"] = st.gpu_seconds > 0 ? double(st.samples) / st.gpu_seconds : 0.0;
    j["bricks_entered"] = st.bricks_entered;
    j["readback_seconds"] = st.readback_seconds;
    j["atlas_bytes"] = st.atlas_bytes;
    j["atlas_slots"] = st.atlas_slots;
  };
  run.summary = [h, cut] {
    const LodRenderStats& st = h->stats;
    char buf[512];
    std::snprintf(buf, sizeof buf, "cut %s: %llu nodes (levels <= %d, mean %.2f%s), GPU %.3f s, atlas %s, %s",
                  cut_spec_name(cut).c_str(), (unsigned long long)st.cut_nodes, st.max_level, st.mean_level,
                  st.budget_limited ? ", limited by --gpu-memory" : "", st.gpu_seconds,
                  format_bytes(st.atlas_bytes).c_str(), h->gl->renderer().c_str());
    return std::string(buf);
  };
  run.run_path = [h, o](const Camera& start, const TransferFunction& tf, const RenderSettings& rs) {
    TimeCriticalOptions tc;
    if (!o.fps.empty()) {
      tc.target_fps = parse_number(o.fps, "--fps");
      if (!(tc.target_fps > 0) || tc.target_fps > 1000) fail_flag("--fps", "must be in (0, 1000]");
    }
    tc.ram_budget_bytes = o.ram_memory;
    if (!o.uploads_per_frame.empty())
      tc.uploads_per_frame = uint64_t(parse_positive_int(o.uploads_per_frame, "--uploads-per-frame"));
    if (!o.reads_per_frame.empty())
      tc.reads_per_frame = uint64_t(parse_positive_int(o.reads_per_frame, "--reads-per-frame"));
    if (!o.error_weight.empty()) {
      tc.error_weight = parse_number(o.error_weight, "--error-weight");
      if (!(tc.error_weight >= 0) || tc.error_weight > 16) fail_flag("--error-weight", "must be in [0, 16]");
    }
    if (!o.step_voxels.empty()) tc.resting_step_voxels = parse_number(o.step_voxels, "--step-voxels");
    const int frames = o.frames.empty() ? 0 : parse_positive_int(o.frames, "--frames");
    // No path: the one view, --frames times.
    const std::vector<Camera> path =
        o.path.empty() ? std::vector<Camera>(size_t(std::max(frames, 1)), start) : camera_path(o.path, start, frames);
    if (!o.out_dir.empty()) std::filesystem::create_directories(o.out_dir);
    TimeCriticalRenderer renderer(*h->engine, tc);
    std::string lines;
    std::vector<double> seconds;
    std::vector<bool> resting;
    double error_sum = 0;
    Image image;
    Progress progress("frames", path.size());
    for (size_t i = 0; i < path.size(); ++i) {
      TimeCriticalFrame f;
      image = renderer.frame(path[i], tf, rs, &f);
      seconds.push_back(f.seconds);
      resting.push_back(f.resting);
      error_sum += f.mean_error;
      if (!o.out_dir.empty()) {
        char name[32];
        std::snprintf(name, sizeof name, "/frame_%05zu.png", i);
        write_png(o.out_dir + name, image);
      }
      const nlohmann::json line = {
          {"frame", i},
          {"seconds", f.seconds},
          {"resting", f.resting},
          {"converged", f.converged},
          {"memory_limited", f.memory_limited},
          {"scale", f.scale},
          {"budget_samples", f.budget_samples == std::numeric_limits<uint64_t>::max()
                                 ? nlohmann::json(nullptr)
                                 : nlohmann::json(f.budget_samples)},
          {"budget_nodes", f.budget_nodes == std::numeric_limits<uint64_t>::max() ? nlohmann::json(nullptr)
                                                                                  : nlohmann::json(f.budget_nodes)},
          {"cut_nodes", f.cut_nodes},
          {"visible_nodes", f.visible_nodes},
          {"splits", f.splits},
          {"merges", f.merges},
          {"max_texel_error", f.max_error},
          {"mean_texel_error", f.mean_error},
          {"uploads", f.uploads},
          {"uploaded_bytes", f.uploads * uint64_t(std::pow(h->engine->resolution() + 2, 3)) * 4},
          {"sync_reads", f.sync_reads},
          {"requested", f.requested},
          {"ram_hits", f.cache.hits},
          {"ram_misses", f.cache.misses},
          {"disk_reads", f.cache.loads_completed},
          {"disk_bytes", f.cache.bytes_read},
          {"ram_evictions", f.cache.evictions},
          {"ram_over_budget", f.cache.over_budget},
          {"ram_resident_bytes", f.cache.resident_bytes},
          {"gpu_seconds", f.render.gpu_seconds},
          {"gpu_timer_seconds", f.render.gpu_timer_seconds},
          {"samples", f.render.samples},
      };
      lines += line.dump() + "\n";
      progress.set(i + 1);
    }
    write_image(o.output, image);
    if (!o.stats.empty()) {
      AtomicOutputFile out(o.stats);
      out.write(lines);
      out.commit();
    }
    if (Progress::enabled()) {
      size_t within = 0, counted = 0;
      for (size_t i = std::min<size_t>(10, seconds.size()); i < seconds.size(); ++i) {
        if (resting[i]) continue;  // at rest the budget is lifted on purpose: the cut refines to full quality
        ++counted;
        if (tc.target_fps > 0 && seconds[i] <= 1.2 / tc.target_fps) ++within;
      }
      std::fprintf(stderr, "rendered %zu frames along %s: median %.3f s%s, mean texel error %.3f, %s\n", path.size(),
                   o.path.empty() ? "the view" : o.path.c_str(), median(seconds),
                   tc.target_fps > 0 ? (", " + std::to_string(counted ? 100 * within / counted : 0) +
                                        "% of the moving frames after the 10th within 1.2x the target")
                                           .c_str()
                                     : "",
                   path.empty() ? 0.0 : error_sum / double(path.size()), h->gl->renderer().c_str());
    }
  };
  return run;
}
void run_render(const Options& o) {
  // Everything that can be checked without the data is checked first, so a typo fails in milliseconds.
  if (std::find(kEngines.begin(), kEngines.end(), o.engine) == kEngines.end())
    fail_flag("--engine", "unknown engine \"" + o.engine + "\" (valid: " + join(kEngines) + ")");
  check_extension(o.output, "-o", {".png", ".pfm"});
  if (!o.float_output.empty()) check_extension(o.float_output, "--float", {".pfm"});
  if (!o.camera.empty() && !o.view.empty()) fail_flag("--view", "cannot be combined with --camera");
  if (!o.view.empty() && std::find(kViews.begin(), kViews.end(), o.view) == kViews.end())
    fail_flag("--view", "unknown view \"" + o.view + "\" (expected " + join(kViews) + ")");
  std::optional<double> view_angle;
  if (!o.view_angle.empty()) {
    view_angle = parse_number(o.view_angle, "--view-angle");
    if (*view_angle <= 0 || *view_angle >= 180) fail_flag("--view-angle", "must be in (0, 180) degrees");
  }
  std::optional<Camera> file_camera;
  if (!o.camera.empty()) file_camera = with_flag("--camera", [&] { return read_camera(o.camera); });
  const bool tf_from_file = !o.tf.empty() && is_tf_file(o.tf);
  if (!o.tf_name.empty() && !tf_from_file) fail_flag("--tf-name", "needs --tf FILE.json");
  TransferFunction tf;
  std::optional<double> unit_distance;
  if (tf_from_file) {
    tf = with_flag("--tf", [&] { return read_paraview_preset(o.tf, o.tf_name); });
    unit_distance = with_flag("--tf", [&] { return read_preset_unit_distance(o.tf, o.tf_name); });
  } else {
    tf = with_flag("--tf", [&] { return builtin_preset(o.tf.empty() ? "viridis" : o.tf); });
  }
  std::optional<std::pair<double, double>> range;
  if (!o.range.empty()) {
    const std::vector<double> r = parse_list(o.range, "--range", 2, 2, "MIN,MAX");
    if (!(r[0] < r[1])) fail_flag("--range", "MIN must be less than MAX");
    range = {r[0], r[1]};
  }
  if (!o.unit_distance.empty()) {
    unit_distance = parse_number(o.unit_distance, "--unit-distance");
    if (*unit_distance <= 0) fail_flag("--unit-distance", "must be > 0");
  }
  const int threads = o.threads.empty() ? 0 : parse_positive_int(o.threads, "--threads");
  const int frames = o.frames.empty() ? 1 : parse_positive_int(o.frames, "--frames");
  RenderSettings settings = settings_from_flags(o);

  // The limit must outlive every parallel region, engine construction included.
  std::optional<tbb::global_control> thread_limit;
  if (threads > 0) thread_limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(threads));

  const bool lod = o.engine == "lod" || (o.engine == "auto" && o.inputs.size() == 1 && is_brick_store(o.inputs[0]));
  if (!lod && o.inputs.size() == 1 && is_brick_store(o.inputs[0]))
    fail_flag("--engine", "a brick store (.ugvr) renders with --engine lod");
  std::shared_ptr<void> keep;  // the engine and what it needs, alive until the end
  EngineRun engine = lod ? lod_run(o, settings, keep) : exact_run(o, settings, keep);
  const std::string engine_name = lod ? "lod" : "exact";

  const Bounds bounds = engine.bounds;
  Camera camera;
  if (file_camera) {
    camera = *file_camera;
    if (view_angle) camera.view_angle = *view_angle;
  } else if (!o.view.empty()) {
    camera = camera_preset(o.view, bounds, view_angle.value_or(30));
  } else {
    // ParaView's default view: along -z, +y up.
    camera = reset_camera(bounds, view_angle.value_or(30));
  }

  if (range) {
    tf.rescale(range->first, range->second);
  } else if (!o.keep_range) {
    const double lo = engine.field_min, hi = engine.field_max;
    // An all-NaN field has no range; the map then stays where it was rather than becoming NaN itself.
    if (std::isfinite(lo) && std::isfinite(hi)) tf.rescale(lo, hi);
  }
  if (!unit_distance) {
    const double diagonal = length(bounds.size());
    unit_distance = diagonal > 0 ? diagonal / 100 : 1.0;
  }
  tf.opacity_unit_distance = *unit_distance;

  if (!o.save_camera.empty()) write_camera(o.save_camera, camera);
  if (!o.save_tf.empty()) write_paraview_preset(o.save_tf, tf);

  if (!o.path.empty() || !o.fps.empty()) {
    if (!engine.run_path) fail_flag(o.path.empty() ? "--fps" : "--path", "needs the lod engine (a .ugvr store)");
    engine.run_path(camera, tf, settings);
    return;
  }

  Image image;
  std::vector<double> frame_seconds, frame_cpu_seconds;
  for (int f = 0; f < frames; ++f) {
    const double cpu0 = process_cpu_seconds();
    double seconds = 0;
    image = engine.render(camera, tf, settings, seconds);
    frame_cpu_seconds.push_back(process_cpu_seconds() - cpu0);
    frame_seconds.push_back(seconds);
  }
  // The first frame pays for page faults and cold caches; benchmarks want the steady state.
  const double median_seconds =
      frames > 1 ? median(std::vector<double>(frame_seconds.begin() + 1, frame_seconds.end())) : frame_seconds[0];
  const double median_cpu_seconds =
      frames > 1 ? median(std::vector<double>(frame_cpu_seconds.begin() + 1, frame_cpu_seconds.end()))
                 : frame_cpu_seconds[0];
  const int threads_used = tbb::this_task_arena::max_concurrency();

  write_image(o.output, image);
  if (!o.float_output.empty()) write_pfm(o.float_output, image);

  if (!o.stats.empty()) {
    std::string input;
    for (const std::string& p : o.inputs) input += (input.empty() ? "" : " ") + p;
    nlohmann::json j = {
        {"engine", engine_name},
        {"input", input},
        {"field", engine.field_name},
        {"field_range", {engine.field_min, engine.field_max}},
        {"width", settings.width},
        {"height", settings.height},
        {"frame_seconds", frame_seconds},
        {"median_frame_seconds", median_seconds},
        // CPU time (all threads) per frame: on a shared machine less disturbed by other load than wall time.
        {"frame_cpu_seconds", frame_cpu_seconds},
        {"median_frame_cpu_seconds", median_cpu_seconds},
        {"threads", threads_used},
        {"peak_rss_bytes", peak_rss_bytes()},
        {"camera", camera_to_json(camera)},
        {"settings", settings_to_json(settings)},
    };
    engine.add_stats(j);
    write_json_file(o.stats, j);
  }

  if (Progress::enabled()) {
    std::fprintf(
        stderr, "rendered %s: %d x %d, %s engine, field %s [%.6g, %.6g], frame %.3f s%s, %s, %d threads, peak RSS %s\n",
        o.output.c_str(), settings.width, settings.height, engine_name.c_str(), engine.field_name.c_str(),
        engine.field_min, engine.field_max, median_seconds,
        frames > 1 ? (" (median of " + std::to_string(frames - 1) + ")").c_str() : "", engine.summary().c_str(),
        threads_used, format_bytes(peak_rss_bytes()).c_str());
  }
}

}  // namespace

void register_render(CLI::App& app) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a volume image of a dataset (exact CPU ray casting) or of a brick store (level-of-detail GPU ray "
      "casting): emission-absorption, MIP or isosurfaces, with ParaView's camera, colour map and opacity conventions");
  add_input(*cmd, opts->inputs);
  add_read_options(*cmd, opts->read);
  cmd->add_option("-o,--output", opts->output, "Output image (.png or .pfm)")->required()->type_name("FILE");
  cmd->add_option("--size", opts->size, "Image size: N (square) or WxH (default 512, or from --settings)")
      ->type_name("N|WxH");
  cmd->add_option("--engine", opts->engine,
                  "Rendering engine: exact (CPU, a mesh), lod (GPU, a .ugvr brick store) or auto (lod for a .ugvr "
                  "input, else exact)")
      ->default_str("auto")
      ->type_name("NAME");
  cmd->add_option("--cut", opts->cut,
                  "lod: which octree nodes to render: leaves, error:E (node error <= E of the field range) or "
                  "pixels:P (one voxel <= P pixels on screen)")
      ->default_str("pixels:1")
      ->type_name("SPEC");
  cmd->add_option("--gpu", opts->gpu, "lod: EGL device index, or auto (first GPU, else Mesa's llvmpipe)")
      ->default_str("auto")
      ->type_name("DEVICE");
  cmd->add_option("--gpu-memory", opts->gpu_memory, "lod: GPU memory for bricks (e.g. 512MiB, 4GiB)")
      ->transform(CLI::AsSizeValue(true))
      ->default_str("2GiB");
  cmd->add_option("--step-voxels", opts->step_voxels, "lod: sample step in voxels of each node (default 0.5)")
      ->type_name("F");
  cmd->add_option("--fps", opts->fps, "lod: target frame rate held along --path (time-critical level of detail)")
      ->type_name("F");
  cmd->add_option("--path", opts->path,
                  "lod: camera path: orbit[:N][,rest:M] (a turn about view up in N frames, default --frames or 300, "
                  "then M still "
                  "frames at the start) or a JSON list of cameras (one frame each, or keyframes resampled to --frames "
                  "frames); --stats then writes one JSON line per frame")
      ->type_name("SPEC|FILE");
  cmd->add_option("--out", opts->out_dir, "lod: write every frame of --path as DIR/frame_NNNNN.png")->type_name("DIR");
  cmd->add_option("--ram-memory", opts->ram_memory, "lod: RAM cache for decoded bricks along --path")
      ->transform(CLI::AsSizeValue(true))
      ->default_str("1GiB");
  cmd->add_option("--uploads-per-frame", opts->uploads_per_frame, "lod: bricks uploaded to the GPU per frame (64)")
      ->type_name("N");
  cmd->add_option("--error-weight", opts->error_weight,
                  "lod, along --path: split by texel size x (node error / field range)^W, so nodes that hold their "
                  "data exactly are not split (default 0: texel size alone)")
      ->type_name("W");
  cmd->add_option("--reads-per-frame", opts->reads_per_frame, "lod: brick reads requested per frame (256)")
      ->type_name("N");
  cmd->add_option("--camera", opts->camera, "Camera JSON file (as written by --save-camera)")->type_name("FILE");
  cmd->add_option("--view", opts->view,
                  "View preset framed on the data: +x -x +y -y +z -z iso; default: ParaView's default view, looking "
                  "along -z with +y up")
      ->type_name("NAME");
  cmd->add_option("--view-angle", opts->view_angle, "Vertical view angle in degrees (default 30)")->type_name("DEG");
  cmd->add_option("--tf", opts->tf,
                  "Transfer function: a ParaView preset .json file, or a built-in preset: " +
                      join(builtin_preset_names()) + " (default viridis)")
      ->type_name("FILE|NAME");
  cmd->add_option("--tf-name", opts->tf_name, "Preset to take from the --tf file (default: its first)")
      ->type_name("NAME");
  cmd->add_flag("--keep-range", opts->keep_range,
                "Keep the transfer function's own scalar range instead of rescaling it to the field's range");
  cmd->add_option("--range", opts->range, "Rescale the transfer function to MIN,MAX (default: the field's range)")
      ->type_name("MIN,MAX");
  cmd->add_option("--unit-distance", opts->unit_distance,
                  "Scalar opacity unit distance (default: the --tf file's ScalarOpacityUnitDistance, else the "
                  "bounds diagonal / 100; ParaView uses the mean cell size)")
      ->type_name("D");
  cmd->add_option("--field", opts->field, "Scalar to render: NAME, NAME:x|y|z|k or NAME:magnitude (default: first)")
      ->type_name("NAME");
  cmd->add_option("--mode", opts->mode, "ea (emission-absorption, default), mip or iso (isosurfaces)")
      ->type_name("ea|mip|iso");
  cmd->add_option("--iso", opts->iso, "Isosurface values V1,V2,... (implies --mode iso)")->type_name("V1,V2,...");
  cmd->add_option("--iso-opacity", opts->iso_opacity, "Opacity of each isosurface in [0, 1] (default 1)")
      ->type_name("A");
  cmd->add_option("--clip", opts->clip, "Clip plane PX,PY,PZ,NX,NY,NZ: keeps the side the normal points to")
      ->type_name("PX,PY,PZ,NX,NY,NZ");
  cmd->add_option("--boundary-opacity", opts->boundary_opacity,
                  "Opacity of the dataset's outer boundary drawn over the image (default 0: off)")
      ->type_name("A");
  cmd->add_flag("--no-lighting", opts->no_lighting, "No headlight shading of isosurfaces and the boundary");
  cmd->add_flag("--volume-lighting", opts->volume_lighting, "Shade emission-absorption by the field gradient");
  cmd->add_option("--background", opts->background, "Background R,G,B[,A] in [0, 1] (default ParaView's)")
      ->type_name("R,G,B[,A]");
  cmd->add_option("--settings", opts->settings, "Render settings JSON; the flags above override it")->type_name("FILE");
  cmd->add_option("--float", opts->float_output, "Also write the image as a float .pfm")->type_name("FILE");
  cmd->add_option("--stats", opts->stats, "Write timings, counters and the camera and settings used as JSON")
      ->type_name("FILE");
  cmd->add_option("--save-camera", opts->save_camera, "Write the camera used as JSON")->type_name("FILE");
  cmd->add_option("--save-tf", opts->save_tf, "Write the transfer function used as a ParaView preset")
      ->type_name("FILE");
  cmd->add_option("--threads", opts->threads, "Limit the worker threads (default: all cores)")->type_name("N");
  cmd->add_option("--frames", opts->frames,
                  "Render N times (benchmarks): --stats lists every frame time and the median after the first; with "
                  "--path: the number of frames along it")
      ->type_name("N");
  cmd->callback([opts] { run_render(*opts); });
}

}  // namespace ugvr::cli
