// `ugvr render`: one image (or N timed frames) of a dataset or a brick store. The flags are the engine-independent
// vocabulary of render_settings.h / camera.h / transfer_function.h; --engine picks who renders: the exact CPU ray
// caster (a mesh) or the level-of-detail GPU ray caster (a brick store written by `ugvr build`).
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>

#include "cli/cli_numbers.h"
#include "cli/commands.h"
#include "cli/render_flags.h"
#include "ugvr/api/default_field.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/core/threads.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/mpi/piece_build_ooc.h"
#include "ugvr/mpi/piece_index.h"
#include "ugvr/mpi/piece_renderer.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/camera_path.h"
#include "ugvr/render/image.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/render/resolve_view.h"
#include "ugvr/render/time_budget.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/view/over_budget_store.h"
#include "ugvr/view/voxel_store.h"
#ifdef UGVR_HAVE_MPI
#include "ugvr/mpi/mpi_renderer.h"
#include "ugvr/mpi/mpi_session.h"
#endif

namespace ugvr::cli {
namespace {

using Options = RenderOptions;

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

// Builds what open_renderer takes from the flags; the values are checked here so that a typo fails before any data is
// read.
RendererOptions renderer_options(const Options& o, const RenderSettings& settings) {
  RendererOptions r;
  r.engine = o.engine;
  r.interactive = !o.path.empty() || !o.fps.empty();
  r.field = settings.field;
  r.gpu = o.gpu;
  r.device = o.device;
  if (o.exact_precision != "double" && o.exact_precision != "float")
    fail_flag("--exact-precision", "must be double or float");
  r.exact_gpu.double_precision = o.exact_precision == "double";
  r.lod.atlas_budget_bytes = o.gpu_memory;
  if (!o.step_voxels.empty()) {
    r.lod.step_voxels = parse_number(o.step_voxels, "--step-voxels");
    if (!(r.lod.step_voxels > 0) || r.lod.step_voxels > 8) fail_flag("--step-voxels", "must be in (0, 8]");
    r.time_critical.resting_step_voxels = r.lod.step_voxels;
  }
  r.cut = with_flag("--cut", [&] { return parse_cut_spec(o.cut); });
  // hybrid: the still image at convergence draws every visible leaf with cells exact (within --gpu-cell-memory), so
  // its cut is the leaves unless --cut says otherwise.
  // Degree of interest (hybrid_select.h): the LOD engine's, with or without exact cells.
  for (const auto& [flag, value] :
       {std::pair{"--focus", &o.focus}, std::pair{"--roi", &o.roi},
        std::pair{"--context-saturation", &o.context_saturation}, std::pair{"--context-opacity", &o.context_opacity}})
    if (!value->empty() &&
        (o.engine == "exact" || (o.engine == "auto" && !(o.inputs.size() == 1 && is_brick_store(o.inputs[0])))))
      fail_flag(flag, "the degree of interest is the lod and hybrid engines' (a brick store): --engine lod or hybrid");
  if (!o.focus.empty()) r.lod.focus = with_flag("--focus", [&] { return parse_focus(o.focus); });
  if (!o.roi.empty()) r.lod.roi = parse_roi(o.roi, "--roi");
  if (!o.context_saturation.empty())
    r.lod.context_saturation = parse_number(o.context_saturation, "--context-saturation");
  if (!o.context_opacity.empty()) r.lod.context_opacity = parse_number(o.context_opacity, "--context-opacity");
  r.lod.validate();
  if (o.engine == "hybrid") {
    r.lod.cell_budget_bytes = o.gpu_cell_memory;
    if (o.cut.empty() || o.cut == "pixels:1") r.cut = CutSpec{CutSpec::Kind::Leaves, 0};
  }
  TimeCriticalOptions& tc = r.time_critical;
  tc.ram_budget_bytes = o.ram_memory;
  if (!o.uploads_per_frame.empty())
    tc.uploads_per_frame = uint64_t(parse_positive_int(o.uploads_per_frame, "--uploads-per-frame"));
  if (!o.reads_per_frame.empty())
    tc.reads_per_frame = uint64_t(parse_positive_int(o.reads_per_frame, "--reads-per-frame"));
  if (!o.error_weight.empty()) {
    tc.error_weight = parse_number(o.error_weight, "--error-weight");
    if (!(tc.error_weight >= 0) || tc.error_weight > 16) fail_flag("--error-weight", "must be in [0, 16]");
  }
  return r;
}

double target_fps(const Options& o) {
  if (o.fps.empty()) return 0;
  const double fps = parse_number(o.fps, "--fps");
  if (!(fps > 0) || fps > 1000) fail_flag("--fps", "must be in (0, 1000]");
  return fps;
}

// A library error blamed on an option is reported with the flag's name.
template <class F>
auto flag_errors(F&& f) {
  try {
    return f();
  } catch (const OptionError& e) {
    fail_flag("--" + e.option, e.what());
  }
}

// --path / --fps: frames along a camera path, one --stats JSON line each, and a closing line that says how well the
// frame rate was held.
void render_frames_along_path(const Options& o, Renderer& renderer, FrameRequest request) {
  const int frames = o.frames.empty() ? 0 : parse_positive_int(o.frames, "--frames");
  // No path: the one view, --frames times.
  const std::vector<Camera> path = o.path.empty()
                                       ? std::vector<Camera>(size_t(std::max(frames, 1)), request.camera)
                                       : flag_errors([&] { return camera_path(o.path, request.camera, frames); });
  if (!o.out_dir.empty()) std::filesystem::create_directories(o.out_dir);
  std::string lines;
  std::vector<double> seconds;
  std::vector<bool> resting;
  double error_sum = 0;
  Image image;
  Progress progress("frames", path.size());
  render_path(renderer, path, request, [&](size_t i, const Frame& f) {
    image = f.image;
    seconds.push_back(f.stats.seconds);
    resting.push_back(f.stats.resting);
    error_sum += f.stats.texel_error;
    if (!o.out_dir.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "/frame_%05zu.png", i);
      write_png(o.out_dir + name, f.image);
    }
    nlohmann::json line = {{"frame", i}};
    f.stats.to_json(line);
    lines += line.dump() + "\n";
    progress.set(i + 1);
  });
  write_image(o.output, image);
  if (!o.float_output.empty()) write_pfm(o.float_output, image);  // the last frame, as -o
  if (!o.stats.empty()) {
    AtomicOutputFile out(o.stats);
    out.write(lines);
    out.commit();
  }
  if (!Progress::enabled()) return;
  size_t within = 0, counted = 0;
  for (size_t i = std::min<size_t>(10, seconds.size()); i < seconds.size(); ++i) {
    if (resting[i]) continue;  // at rest the budget is lifted on purpose: the cut refines to full quality
    ++counted;
    if (request.target_fps > 0 && seconds[i] <= 1.2 / request.target_fps) ++within;
  }
  std::fprintf(stderr, "rendered %zu frames along %s: median %.3f s%s, mean texel error %.3f, %s\n", path.size(),
               o.path.empty() ? "the view" : o.path.c_str(), median(seconds),
               request.target_fps > 0 ? (", " + std::to_string(counted ? 100 * within / counted : 0) +
                                         "% of the moving frames after the 10th within 1.2x the target")
                                            .c_str()
                                      : "",
               path.empty() ? 0.0 : error_sum / double(path.size()), renderer.device().c_str());
}

// --time: the exact engine over a series, showing `step` first; the default field as open_renderer_default_field's.
std::unique_ptr<Renderer> open_series_renderer(const std::shared_ptr<ExactScene>& scene, RendererOptions ro) {
  if (ro.field.empty() && !scene->dataset->blocks.empty()) {
    const std::vector<std::string> names = default_field_names(scene->dataset->blocks[0], 1);
    if (!names.empty()) ro.field = names[0];
  }
  return make_renderer(scene, ro);
}

bool ffmpeg_on_path() {
  const char* path = std::getenv("PATH");
  for (std::string_view rest = path ? path : ""; !rest.empty();) {
    const size_t colon = rest.find(':');
    const std::string dir(rest.substr(0, colon));
    if (!dir.empty() && access((dir + "/ffmpeg").c_str(), X_OK) == 0) return true;
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
  }
  return false;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// --time: one image per selected step into --out (time_NNNNN.png, numbered by frame so that ffmpeg reads them in
// order), DIR/steps.json (step, time, range, switch and frame seconds), and DIR/movie.mp4 when ffmpeg is there. The
// colour range is global over the rendered steps (a first pass reading one step's values at a time, fields only
// where the mesh is the shown step's) unless `per_step`.
void render_time_steps(const Options& o, Renderer& renderer, ExactScene& scene, const std::vector<uint32_t>& steps,
                       FrameRequest request, bool global_range, bool per_step) {
  const TimeSeries& series = *scene.series;
  std::filesystem::create_directories(o.out_dir);
  const std::string selector = request.settings.field;
  if (global_range) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    const auto unite = [&](const FieldSet& fields) {
      const ScalarRef r = fields.scalar(selector);
      const Range range = r.field->range(r.component);
      lo = std::min(lo, range.min), hi = std::max(hi, range.max);
    };
    // The values alone: a step with the shown step's mesh (static geometry) is read without its mesh, by the scene's
    // reader (which keeps what an OpenFOAM step's fields need of the mesh read for the scene).
    StepFieldReader& values = scene.step_reader();
    Progress progress("range over steps", steps.size());
    for (size_t k = 0; k < steps.size(); ++k) {
      if (steps[k] == scene.step) {
        for (const Block& b : scene.dataset->blocks) unite(b.fields);
      } else {
        for (const FieldSet& f : values.read_values(steps[k], scene.step).blocks) unite(f);
      }
      progress.set(k + 1);
    }
    if (std::isfinite(lo) && std::isfinite(hi) && lo < hi) request.tf.rescale(lo, hi);
  }
  nlohmann::json list = nlohmann::json::array();
  std::vector<double> switch_seconds, frame_seconds;
  Image image;
  Progress progress("steps", steps.size());
  for (size_t k = 0; k < steps.size(); ++k) {
    const uint64_t changes = scene.swaps + scene.rebuilds;
    scene.set_step(steps[k]);  // before render (which would switch too) so that a per-step range can be read
    const bool switched = scene.swaps + scene.rebuilds != changes;
    if (k + 1 < steps.size()) scene.prefetch(steps[k + 1]);  // read while this step renders
    const FieldRange range = renderer.field_range();
    if (per_step && std::isfinite(range.min) && std::isfinite(range.max) && range.min < range.max)
      request.tf.rescale(range.min, range.max);
    request.time_step = steps[k];
    Frame f = renderer.render(request);
    char name[32];
    std::snprintf(name, sizeof name, "/time_%05zu.png", k);
    write_png(o.out_dir + name, f.image);
    if (switched) switch_seconds.push_back(scene.last_switch_seconds);
    frame_seconds.push_back(f.stats.seconds);
    list.push_back({{"frame", k},
                    {"image", name + 1},
                    {"step", steps[k]},
                    {"time", series.steps[steps[k]].time},
                    {"field_range", {range.min, range.max}},
                    {"tf_range", {request.tf.range_min(), request.tf.range_max()}},
                    {"switch_seconds", switched ? scene.last_switch_seconds : 0.0},
                    {"rebuilt", switched && scene.last_switch_rebuilt},
                    {"frame_seconds", f.stats.seconds}});
    image = std::move(f.image);
    progress.set(k + 1);
  }
  nlohmann::json j = {{"input", series.source},
                      {"kind", std::string(series_kind_name(series.kind))},
                      {"field", renderer.field_name()},
                      {"range", per_step       ? "per-step"
                                : global_range ? "global"
                                               : "given"},
                      {"median_switch_seconds", median(switch_seconds)},
                      {"median_frame_seconds", median(frame_seconds)},
                      {"steps", list}};
  renderer.describe(j);
  write_json_file(o.out_dir + "/steps.json", j);
  if (!o.stats.empty()) write_json_file(o.stats, j);
  if (!o.output.empty()) write_image(o.output, image);
  bool movie = false;
  if (steps.size() > 1 && ffmpeg_on_path()) {
    // Even sizes for yuv420p; 10 steps a second.
    const std::string cmd = "ffmpeg -loglevel error -y -framerate 10 -i " + shell_quote(o.out_dir + "/time_%05d.png") +
                            " -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -pix_fmt yuv420p " +
                            shell_quote(o.out_dir + "/movie.mp4");
    movie = std::system(cmd.c_str()) == 0;
    if (!movie) std::fprintf(stderr, "warning: ffmpeg failed; the images are in %s\n", o.out_dir.c_str());
  }
  if (Progress::enabled())
    std::fprintf(stderr,
                 "rendered %zu steps of %s into %s%s: field %s, step switch median %.4f s (%llu field swaps, %llu "
                 "walk-mesh rebuilds), frame median %.3f s\n",
                 steps.size(), series.source.c_str(), o.out_dir.c_str(), movie ? " (and movie.mp4)" : "",
                 renderer.field_name().c_str(), median(switch_seconds), (unsigned long long)scene.swaps,
                 (unsigned long long)scene.rebuilds, median(frame_seconds));
}

// --time on a store with time steps (format version 6): one image per selected step, as render_time_steps does for a
// series, the level-of-detail engine switching the step (FrameRequest::time_step). The colour range is the union of
// the rendered steps' ranges (stored: no pass over the data) unless `per_step` or a given one.
void render_store_time_steps(const Options& o, Renderer& renderer, const BrickStoreReader& store,
                             const std::vector<uint32_t>& steps, FrameRequest request, bool global_range,
                             bool per_step) {
  std::filesystem::create_directories(o.out_dir);
  const int field = store.field_index(renderer.field_name());
  auto step_range = [&](uint32_t s) {
    return field < 0 ? store_format::StepFieldRange{renderer.field_range().min, renderer.field_range().max}
                     : store.step_range(s, uint32_t(field));
  };
  if (global_range) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (uint32_t s : steps) lo = std::min(lo, step_range(s).min), hi = std::max(hi, step_range(s).max);
    if (std::isfinite(lo) && std::isfinite(hi) && lo < hi) request.tf.rescale(lo, hi);
  }
  nlohmann::json list = nlohmann::json::array();
  std::vector<double> frame_seconds;
  Image image;
  Progress progress("steps", steps.size());
  for (size_t k = 0; k < steps.size(); ++k) {
    const store_format::StepFieldRange range = step_range(steps[k]);
    if (per_step && range.min < range.max) request.tf.rescale(range.min, range.max);
    request.time_step = steps[k];
    Frame f = renderer.render(request);
    char name[32];
    std::snprintf(name, sizeof name, "/time_%05zu.png", k);
    write_png(o.out_dir + name, f.image);
    frame_seconds.push_back(f.stats.seconds);
    list.push_back({{"frame", k},
                    {"image", name + 1},
                    {"step", steps[k]},
                    {"time", store.step_time(steps[k])},
                    {"field_range", {range.min, range.max}},
                    {"tf_range", {request.tf.range_min(), request.tf.range_max()}},
                    {"frame_seconds", f.stats.seconds}});
    image = std::move(f.image);
    progress.set(k + 1);
  }
  nlohmann::json j = {{"input", store.path()},
                      {"kind", "store"},
                      {"field", renderer.field_name()},
                      {"range", per_step       ? "per-step"
                                : global_range ? "global"
                                               : "given"},
                      {"median_frame_seconds", median(frame_seconds)},
                      {"steps", list}};
  renderer.describe(j);
  write_json_file(o.out_dir + "/steps.json", j);
  if (!o.stats.empty()) write_json_file(o.stats, j);
  if (!o.output.empty()) write_image(o.output, image);
  if (Progress::enabled())
    std::fprintf(stderr, "rendered %zu steps of %s into %s: field %s, frame median %.3f s\n", steps.size(),
                 store.path().c_str(), o.out_dir.c_str(), renderer.field_name().c_str(), median(frame_seconds));
}

using Clock = std::chrono::steady_clock;

// --stats' "tf": which transfer function drew (a preset's name, the file's preset name, "auto") and its opacity
// points, [[x, opacity], ...], so that an automatic one can be read back.
nlohmann::json tf_to_json(const TransferFunction& tf) {
  nlohmann::json points = nlohmann::json::array();
  for (const OpacityPoint& p : tf.opacity_points) points.push_back({p.x, p.opacity});
  return {{"name", tf.name}, {"opacity_points", points}, {"opacity_unit_distance", tf.opacity_unit_distance}};
}

void run_render(const Options& o, std::optional<double> time_budget) {
  const Clock::time_point start = Clock::now();
  if (time_budget && !(*time_budget > 0)) fail_flag("--time-budget", "must be > 0 seconds");
  if (time_budget && (!o.path.empty() || !o.fps.empty()))
    fail_flag("--time-budget", "makes one still image: no --path or --fps");
  // Everything that can be checked without the data is checked first, so a typo fails in milliseconds.
  if (std::find(engine_names().begin(), engine_names().end(), o.engine) == engine_names().end())
    fail_flag("--engine", "unknown engine \"" + o.engine + "\" (valid: " + join(engine_names()) + ")");
  const bool timed = !o.time.empty();
  if (timed && time_budget) fail_flag("--time-budget", "makes one still image: no --time");
#ifdef UGVR_HAVE_MPI
  if (mpi::active() && (timed || time_budget))
    fail_flag(timed ? "--time" : "--time-budget", "is not supported under mpirun yet (docs/mpi.md)");
#endif
  if (o.output.empty() && !(timed && !o.out_dir.empty()))
    fail_flag("-o", "an output image is required (or --time with --out DIR)");
  if (!o.output.empty()) check_extension(o.output, "-o", {".png", ".pfm"});
  if (timed && o.out_dir.empty()) fail_flag("--time", "needs --out DIR for the steps' images");
  if (timed && (!o.path.empty() || !o.fps.empty())) fail_flag("--time", "cannot be combined with --path or --fps");
  // A store with time steps (format version 6) is opened here to list them; a store of one step has none to select.
  std::optional<BrickStoreReader> time_store;
  if (o.inputs.size() == 1 && is_brick_store(o.inputs[0])) {
    time_store.emplace(o.inputs[0]);
    if (!time_store->has_steps()) time_store.reset();
    if (!time_store && timed)
      fail_flag("--time", o.inputs[0] + " holds one time step (build a store with `ugvr build SERIES --time ...`)");
    if (!time_store && o.read.time_step > 0)
      fail_flag("--time-step",
                o.inputs[0] + " holds one time step (build a store with `ugvr build SERIES --time ...`)");
  }
  if (timed && o.engine == "lod" && !time_store)
    fail_flag("--time", "renders a series with the exact engine, a store with time steps with the lod engine");
  if (time_store && o.engine == "exact") fail_flag("--engine", "exact draws a mesh, not a brick store");
  const bool per_step = o.range == "per-step";
  if (per_step && !timed) fail_flag("--range", "per-step needs --time");
  if (!o.float_output.empty()) check_extension(o.float_output, "--float", {".pfm"});
  if (!o.camera.empty() && !o.view.empty()) fail_flag("--view", "cannot be combined with --camera");
  if (!o.view.empty() && std::find(kViews.begin(), kViews.end(), o.view) == kViews.end())
    fail_flag("--view", "unknown view \"" + o.view + "\" (expected " + join(kViews) + ")");
  std::optional<double> view_angle;
  if (!o.view_angle.empty()) {
    view_angle = parse_number(o.view_angle, "--view-angle");
    if (*view_angle <= 0 || *view_angle >= 180) fail_flag("--view-angle", "must be in (0, 180) degrees");
  }
  // The transfer function and camera are resolved once the data is open (render/resolve_view.h).
  ViewChoices choices;
  choices.view = o.view;
  choices.view_angle = view_angle;
  if (!o.camera.empty()) choices.camera = with_flag("--camera", [&] { return read_camera(o.camera); });
  const bool tf_from_file = !o.tf.empty() && is_tf_file(o.tf);
  // "auto" (the default): made from the field's histogram once the data is open (default_transfer_function.h).
  const bool auto_tf = !tf_from_file && (o.tf.empty() || o.tf == "auto");
  choices.auto_tf = auto_tf;
  choices.keep_range = o.keep_range;
  if (auto_tf && o.keep_range) fail_flag("--keep-range", "keeps a --tf preset's own range: name one (--tf viridis)");
  if (!o.tf_name.empty() && !tf_from_file) fail_flag("--tf-name", "needs --tf FILE.json");
  if (tf_from_file) {
    choices.tf = with_flag("--tf", [&] { return read_paraview_preset(o.tf, o.tf_name); });
    choices.unit_distance = with_flag("--tf", [&] { return read_preset_unit_distance(o.tf, o.tf_name); });
  } else if (!auto_tf) {
    choices.tf = with_flag("--tf", [&] { return builtin_preset(o.tf); });
  }
  std::optional<std::pair<double, double>>& range = choices.range;
  if (!o.range.empty() && !per_step) {
    const std::vector<double> r = parse_list(o.range, "--range", 2, 2, "MIN,MAX");
    if (!(r[0] < r[1])) fail_flag("--range", "MIN must be less than MAX");
    range = {r[0], r[1]};
  }
  if (!o.unit_distance.empty()) {
    choices.unit_distance = parse_number(o.unit_distance, "--unit-distance");
    if (*choices.unit_distance <= 0) fail_flag("--unit-distance", "must be > 0");
  }
  const int threads = o.threads.empty() ? 0 : parse_positive_int(o.threads, "--threads");
  const int frames = o.frames.empty() ? 1 : parse_positive_int(o.frames, "--frames");
  RenderSettings settings = settings_from_flags(o);

  // The limit must outlive every parallel region, engine construction included.
  std::optional<tbb::global_control> thread_limit;
  if (threads > 0) thread_limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(threads));

  const double fps = target_fps(o);
  RendererOptions ro = renderer_options(o, settings);
  // The time budget refines a store's cut frame by frame (time-critical); a mesh is drawn by the exact engine.
  const bool store_input = o.inputs.size() == 1 && std::filesystem::path(o.inputs[0]).extension() == ".ugvr";
  bool budget_lod = time_budget && (o.engine == "lod" || (o.engine == "auto" && store_input));
  // A mesh over the memory budget: drawn from its store, built out of core (view/over_budget_store.h).
  std::optional<view::OverBudgetStore> big;
  bool under_mpi = false;
#ifdef UGVR_HAVE_MPI
  under_mpi = mpi::active();
#endif
  if (!timed && !time_store && !under_mpi && !(o.inputs.size() == 1 && is_piece_index(o.inputs[0])))
    big = flag_errors([&] {
      return view::store_for_a_mesh_over_budget(
          o.inputs, settings.field, o.engine, time_budget, start, Progress::enabled(),
          [](const std::string& vtu, const std::vector<std::string>& fields, int pieces, int ghost_level,
             const OctreeBuildOptions& build, uint64_t budget, const std::string& index) {
            build_index_out_of_core(vtu, fields, pieces, ghost_level, build, budget, index, {}, print_warning);
          });
    });
  if (big && time_budget) budget_lod = true;
  // Tricubic isosurfaces are the lod engine's, drawn from a brick store's bricks (docs/tricubic.md): the exact engine
  // interpolates each cell with its own interpolant and would ignore the setting silently, and the lod engine draws
  // stores only. A voxel volume (NRRD, raw, .vti) is drawn from its store, built once into the cache on a lattice
  // that keeps its samples (view/voxel_store.h); a mesh has its own interpolants and stays an error with advice.
  std::optional<view::VoxelStore> voxel;
  if (settings.mode == RenderMode::Isosurface && settings.interpolation == Interpolation::Tricubic && !big &&
      !(o.inputs.size() == 1 && (is_brick_store(o.inputs[0]) || is_piece_index(o.inputs[0])))) {
    if (!view::is_voxel_volume_input(o.inputs))
      fail_flag("--interpolation",
                "tricubic isosurfaces are drawn by the lod engine from a brick store, and " +
                    (o.inputs.empty() ? std::string("the input") : o.inputs[0]) +
                    " is not one (nor a voxel volume: NRRD, raw, .vti, whose store is built here): the exact engine "
                    "draws a mesh with its cells' own interpolants; for the spline build a store with `ugvr build "
                    "INPUT -o STORE.ugvr`, then render STORE.ugvr --interpolation tricubic");
    if (o.engine != "auto" && o.engine != "lod")
      fail_flag("--engine", o.engine +
                                ": tricubic isosurfaces of a voxel volume are drawn by the lod engine from "
                                "its store (leave --engine out, or --engine lod)");
    if (timed) fail_flag("--interpolation", "tricubic of a series: build a store with `ugvr build SERIES --time ...`");
    // Every rank would build the same cache entry, and the ranks' renderer draws the inputs given.
    if (under_mpi)
      fail_flag("--interpolation", "tricubic of a voxel volume under mpirun: build its store first (`ugvr build " +
                                       o.inputs[0] + " -o STORE.ugvr`, or --pieces N) and render that");
    voxel = flag_errors(
        [&] { return view::voxel_store_for_tricubic(o.inputs, o.read, settings.field, Progress::enabled()); });
    if (time_budget) budget_lod = true;
  }
  if (budget_lod) ro.interactive = true;
  OpenedInput opened;
  std::shared_ptr<ExactScene> time_scene;
  std::vector<uint32_t> steps;
  std::vector<uint32_t> store_steps;
  if (timed && time_store) {
    store_steps = parse_step_selection(o.time, time_store->step_count(), "--time");
  } else if (timed) {
    auto series = std::make_shared<const TimeSeries>(list_time_steps(o.inputs, o.read));
    steps = parse_step_selection(o.time, series->size(), "--time");
    time_scene = std::make_shared<ExactScene>(std::move(series), steps[0], ro.progress);
    opened.warnings = time_scene->dataset->warnings;
  }
  // Under mpirun every rank renders its part and rank 0 alone gets the composited frame, writes and reports
  // (docs/mpi.md).
  bool writer = true;
  std::unique_ptr<Renderer> renderer = flag_errors([&] {
    if (time_scene) return open_series_renderer(time_scene, ro);
#ifdef UGVR_HAVE_MPI
    if (mpi::active()) {
      writer = mpi::rank() == 0;
      if (!writer) Progress::set_enabled(false);
      return mpi::open_renderer(o.inputs, o.read, ro, &opened);
    }
#endif
    // A partitioned store's index (`ugvr build --pieces`): every piece in this process (docs/mpi.md).
    if (o.inputs.size() == 1 && is_piece_index(o.inputs[0])) {
      if (time_budget) fail_flag("--time-budget", "is not supported for a partitioned store yet (docs/mpi.md)");
      return open_piece_renderer(read_piece_index(o.inputs[0]), {}, ro);
    }
    if (big && big->pieces > 0) return open_piece_renderer(read_piece_index(big->path), {}, ro);
    if (big) return open_renderer_default_field({big->path}, o.read, ro, &opened);
    if (voxel) return open_renderer_default_field({voxel->path}, o.read, ro, &opened);
    return open_renderer_default_field(o.inputs, o.read, ro, &opened);
  });
  if (big && big->build) big->build.reset();  // the preview or sketch is open: the build stops (nothing is kept)
  for (const std::string& w : opened.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  // Recorded in --stats so the settings reproduce the image; a selector the user gave ("velocity:x") is kept as is.
  const bool default_field = settings.field.empty();
  if (default_field) {
    settings.field = renderer->field_name();
    if (Progress::enabled())
      std::fprintf(stderr, "field %s: the first that varies (--field picks another)\n", settings.field.c_str());
  }
  FieldRange field_range = renderer->field_range();
  // A time store's step (--time-step N; -1, the default: the last, as for a series). Its colour range by default is the
  // step's own, as a series' step read alone has.
  std::optional<uint32_t> store_step;
  if (time_store && !timed) {
    const int64_t n = o.read.time_step < 0 ? int64_t(time_store->step_count()) - 1 : o.read.time_step;
    if (n >= int64_t(time_store->step_count()))
      fail_flag("--time-step", std::to_string(n) + " out of range: " + o.inputs[0] + " holds " +
                                   std::to_string(time_store->step_count()) + " steps (0 to " +
                                   std::to_string(time_store->step_count() - 1) + ")");
    store_step = uint32_t(n);
    if (const int f = time_store->field_index(renderer->field_name()); f >= 0) {
      const store_format::StepFieldRange r = time_store->step_range(*store_step, uint32_t(f));
      field_range = {r.min, r.max};
    }
  }

  // Every rank gets here: auto's histogram and the framed camera are collective calls under MPI.
  const ResolvedView resolved = resolve_view(*renderer, choices, field_range);
  const TransferFunction& tf = resolved.tf;
  const Camera& camera = resolved.camera;

  if (writer && !o.save_camera.empty()) write_camera(o.save_camera, camera);
  if (writer && !o.save_tf.empty()) write_paraview_preset(o.save_tf, tf);

  FrameRequest request;
  request.camera = camera;
  request.tf = tf;
  request.settings = settings;
  request.target_fps = fps;
  if (store_step) request.time_step = *store_step;
  if (timed && time_store) {
    render_store_time_steps(o, *renderer, *time_store, store_steps, request, !range && !o.keep_range && !per_step,
                            per_step);
    return;
  }
  if (timed) {
    render_time_steps(o, *renderer, *time_scene, steps, request, !range && !o.keep_range && !per_step, per_step);
    return;
  }
  if (ro.interactive && !budget_lod) {
    render_frames_along_path(o, *renderer, request);
    return;
  }

  Image image;
  FrameStats last;
  std::vector<double> frame_seconds, frame_cpu_seconds;
  nlohmann::json budget_report;
  for (int f = 0; f < frames; ++f) {
    if (time_budget) {  // one image (--frames does not apply)
      const double cpu0 = process_cpu_seconds();
      Frame frame = render_within_budget(*renderer, request, *time_budget, start, budget_report, Progress::enabled());
      if (big) {
        budget_report["drew_from"] = big->shown;
        budget_report["drew"] = "the " + big->shown + ": " + budget_report["drew"].get<std::string>();
      }
      frame_cpu_seconds.push_back(process_cpu_seconds() - cpu0);
      frame_seconds.push_back(frame.stats.seconds);
      image = std::move(frame.image);
      last = std::move(frame.stats);
      break;
    }
    const double cpu0 = process_cpu_seconds();
    Frame frame = renderer->render(request);
    frame_cpu_seconds.push_back(process_cpu_seconds() - cpu0);
    frame_seconds.push_back(frame.stats.seconds);
    image = std::move(frame.image);
    last = std::move(frame.stats);
  }
  // The first frame pays for page faults and cold caches; benchmarks want the steady state.
  const double median_seconds = frame_seconds.size() > 1
                                    ? median(std::vector<double>(frame_seconds.begin() + 1, frame_seconds.end()))
                                    : frame_seconds[0];
  const double median_cpu_seconds =
      frame_cpu_seconds.size() > 1 ? median(std::vector<double>(frame_cpu_seconds.begin() + 1, frame_cpu_seconds.end()))
                                   : frame_cpu_seconds[0];
  const int threads_used = worker_threads();

  if (!writer) return;
  write_image(o.output, image);
  if (!o.float_output.empty()) write_pfm(o.float_output, image);

  if (!o.stats.empty()) {
    std::string input;
    for (const std::string& p : o.inputs) input += (input.empty() ? "" : " ") + p;
    nlohmann::json j = {
        {"engine", std::string(renderer->engine())},
        {"input", input},
        {"field", renderer->field_name()},
        // true: no --field, the renderer's default (the first field that varies) was drawn.
        {"field_default", default_field},
        {"field_range", {field_range.min, field_range.max}},
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
    renderer->describe(j);
    if (last.detail) last.detail->to_json(j);
    if (time_budget) j["time_budget"] = budget_report;
    j["tf"] = tf_to_json(tf);
    // Where a voxel volume's tricubic isosurface was drawn from, and whether this render built it (false: cached).
    if (voxel) j["voxel_store"] = {{"path", voxel->path}, {"built", voxel->built}};
    write_json_file(o.stats, j);
  }

  if (Progress::enabled()) {
    std::fprintf(
        stderr, "rendered %s: %d x %d, %s engine, field %s [%.6g, %.6g], frame %.3f s%s, %s, %d threads, peak RSS %s\n",
        o.output.c_str(), settings.width, settings.height, std::string(renderer->engine()).c_str(),
        renderer->field_name().c_str(), field_range.min, field_range.max, median_seconds,
        frames > 1 ? (" (median of " + std::to_string(frames - 1) + ")").c_str() : "", renderer->summary(last).c_str(),
        threads_used, format_bytes(peak_rss_bytes()).c_str());
  }
}

}  // namespace

void register_render(CLI::App& app) {
  auto opts = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a volume image of a dataset (exact CPU ray casting) or of a brick store (level-of-detail GPU ray "
      "casting): emission-absorption, MIP or isosurfaces, with ParaView's camera, colour map and opacity conventions");
  add_render_flags(*cmd, *opts);
  auto time_budget = std::make_shared<double>(0);
  CLI::Option* budget = cmd->add_option(
      "--time-budget", *time_budget,
      "Seconds for the whole command, reading included: a still image of what can be drawn in that time (a mesh: "
      "the exact image at the size that fits, magnified; a store: the time-critical cut refined while it fits); "
      "--stats says what was drawn (\"time_budget\")");
  cmd->callback([opts, time_budget, budget] {
    run_render(*opts, budget->count() ? std::optional<double>(*time_budget) : std::nullopt);
  });
}

}  // namespace ugvr::cli
