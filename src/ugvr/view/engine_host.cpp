#include "ugvr/view/engine_host.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "ugvr/gpu/gl_context.h"
#include "ugvr/octree/coarse_preview.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/default_transfer_function.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/field_histogram.h"
#include "ugvr/render/lod/lod_renderer.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/render/visible_bounds.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/view/jpeg.h"

namespace ugvr::view {
namespace {

using Clock = std::chrono::steady_clock;

// Bins of the transfer-function editor's histograms, and the octree levels a store's histogram is taken from (up to
// 585 bricks: the shape of the distribution, read in a fraction of a second).
constexpr int kHistogramBins = 128, kHistogramMaxLevel = 3;

// Fields of a store: names, ranges, histograms of the coarse levels.
std::vector<FieldInfo> store_fields(const LodEngine& engine) {
  std::vector<FieldInfo> out;
  const BrickStoreReader& store = engine.store();
  for (uint32_t i = 0; i < store.field_count(); ++i) {
    const BrickStoreField& f = store.layout().fields[i];
    out.push_back({f.name, f.min, f.max, store_histogram(store, i, kHistogramBins, kHistogramMaxLevel)});
  }
  return out;
}

// What the page is told while a collective renderer opens (the renderer's name until then, poll_load, initial_progress)
// and when it failed.
constexpr const char* kOpeningTheData = "opening the data";

// ViewServerOptions::auto_tf: every field's auto transfer function (from its histogram, as `ugvr render` makes it:
// SceneInfo::auto_opacity, which tabs and the page's editor start from) and, without a camera given, the reset view
// framed on the box `visible` gives for the auto transfer function of the field new tabs show (nullopt: the whole
// domain).
void start_from_auto(SceneInfo& sc, const ViewServerOptions& options,
                     const std::function<std::optional<Bounds>(const TransferFunction&)>& visible) {
  if (!options.auto_tf || options.tf) return;
  for (const FieldInfo& f : sc.fields) {
    if (f.histogram.empty()) continue;
    const TransferFunction tf = auto_transfer_function(f.histogram, f.min, f.max, sc.bounds);
    sc.auto_opacity[f.name] = {tf.opacity_points, tf.opacity_unit_distance};
    if (f.name == sc.field && !options.camera)
      sc.camera = framed_default_camera(sc.bounds, visible ? visible(tf) : std::nullopt, 30);
  }
}

// The field new tabs show: the first whose range is not constant (a constant field draws a blank-looking image), else
// the first.
std::string first_varying(const std::vector<FieldInfo>& fields) {
  for (const FieldInfo& f : fields)
    if (f.max > f.min) return f.name;
  return fields.front().name;
}

std::shared_ptr<LodScene> open_store(const ViewServerOptions& options, std::shared_ptr<GlContext> gl,
                                     const std::string& path) {
  LodOptions lo;
  lo.atlas_budget_bytes = options.gpu_memory;
  auto scene = std::make_shared<LodScene>(path, std::move(gl), lo);
  scene->engine.set_field("");
  return scene;
}

// Playing a time series, the largest share of a step's period a render is budgeted: the frame controller aims at the
// budget's typical frame, and on a loaded machine frames of one budget vary by a factor of 1.5 or so; this keeps the
// slow ones within the bound (the gap between steps at p95 <= 1.5 periods).
constexpr double kPlayingRenderShare = 0.8;

// UGVR_PLAYBACK_TRACE=FILE: one JSON line per frame of a time series appended to FILE (bench/run_view_playback.sh):
// where a step frame's time goes. The renderer's figures (InteractiveLodFrameStats for a store: the cut, the image
// scale, the bricks uploaded and read on the render thread, the upload, draw and read-back seconds, the prefetch)
// and the encoding. Off (no cost) when the variable is unset.
void trace_time_frame(const FrameJob& job, const FrameRequest& fr, const ugvr::Frame& f, double encode_seconds) {
  static const char* path = std::getenv("UGVR_PLAYBACK_TRACE");
  if (!path || !*path) return;
  nlohmann::json j;
  if (f.stats.detail) f.stats.detail->to_json(j);
  j["tab"] = job.tab;
  j["step"] = fr.time_step ? int64_t(*fr.time_step) : -1;
  j["playing"] = job.request.playing;
  j["full_quality"] = job.full_quality;
  j["target_fps"] = fr.target_fps;
  j["frame_seconds"] = f.stats.seconds;
  j["encode_seconds"] = encode_seconds;
  j["t"] = std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
  if (FILE* out = std::fopen(path, "a")) {
    const std::string line = j.dump() + "\n";
    std::fwrite(line.data(), 1, line.size(), out);
    std::fclose(out);
  }
}

}  // namespace

// What the render thread keeps for one tab.
struct EngineHost::Tab {
  std::unique_ptr<Renderer> renderer;  // interactive, over the store or the grid
  std::string engine;                  // which of the two `renderer` draws with
  uint64_t seq = 0;
  double shown_fps = 0;
  Clock::time_point last;
  bool counting = false;  // the previous frame was part of an interaction (not converged): fps is measured
  // Interactive frames (a drag): what a frame's period takes beyond its render (encoding, the send, the scheduler's
  // turn), averaged over consecutive interactive frames; the render is given the target period less this.
  double frame_overhead = 0;
  // Playing a time series: the render's budget (seconds; adapted to the steps' period, see render()), and when the
  // previous step's render started.
  double render_budget = 0;
  std::optional<Clock::time_point> step_started;
  uint64_t interrupted = 0;  // FrameStatus::interrupted
};

EngineHost::EngineHost(ViewServerOptions options) : options_(std::move(options)) {
  if (options_.collective) {
    // Opened by finish_load on the render thread (the first turn): no GL context of ours is ever made, the collective
    // renderer makes its own there (the LOD engine), current on that thread from then on.
    pending_collective_ = std::move(options_.collective);
    renderer_ = kOpeningTheData;
    notice_ = options_.notice;
    if (options_.collective_build)
      collective_build_ = std::make_unique<BackgroundBuild>(std::move(options_.collective_build), options_.store);
    return;
  }
  gl_ = std::make_shared<GlContext>(options_.gpu);
  renderer_ = gl_->renderer();
  notice_ = options_.notice;
  if (!options_.out_of_core_input.empty()) {
    // Never in memory: nothing draws until the build's coarse preview is written (switch_to_preview shows it), then
    // the store once built (switch_to_store). The preview's depth, unless the caller chose one: the deepest whose
    // bricks take an eighth of the budget at most (3 for 1 GiB, one field, R = 32: 90 MiB).
    OctreeBuildOptions build = options_.build;
    if (build.preview_depth == 0) {
      const uint32_t fields = uint32_t(std::max<size_t>(options_.fields.size(), 1));
      build.preview_depth = coarse_preview_depth_for(options_.out_of_core_budget, build.resolution, fields);
    }
    // Before the preview, which needs every cell: a sketch from the points, within seconds (octree/point_sketch.h).
    build.point_sketch = true;
    BackgroundBuild::OutOfCore input{options_.out_of_core_input, options_.out_of_core_budget};
    build_ = std::make_unique<BackgroundBuild>(std::move(input), options_.fields, build, options_.store,
                                               options_.before_build);
    return;
  }
  if (options_.series) {
    // A series is shown by the exact engine alone: a brick store holds one step (docs/time-series.md), so none is
    // built.
    build_started_ = true;
    load_ = std::make_unique<GridLoad>(options_.series, options_.time_step, options_.fields, kHistogramBins);
    return;
  }
  if (!options_.dataset && !options_.load) {
    lod_ = open_store(options_, gl_, options_.store);
    scene_ = lod_scene();
    return;
  }
  // The grid is read (unless given) and prepared on the load's thread while the viewer serves; the store's build
  // starts as soon as its fields are known (poll_load).
  std::function<std::shared_ptr<const Dataset>()> load = options_.load;
  if (options_.dataset) load = [dataset = options_.dataset] { return dataset; };
  options_.load = {};
  options_.dataset.reset();  // the load holds it; finish_load puts it back
  load_ = std::make_unique<GridLoad>(std::move(load), options_.fields, kHistogramBins);
}

std::optional<EngineHost::LoadReport> EngineHost::poll_load() {
  if (opening_collective()) {
    LoadReport r;
    if (collective_build_) {
      const BackgroundBuild::State st = collective_build_->state();
      const std::string note = notice_.empty() ? "" : notice_ + "; ";
      switch (st.stage) {
        case BackgroundBuild::Stage::Running:
          r.progress = {"build", st.label, st.fraction,
                        note + std::to_string(int(std::lround(100 * st.fraction))) + " % (" + st.label + ")"};
          return r;
        case BackgroundBuild::Stage::Failed:
          collective_build_.reset();
          pending_collective_ = nullptr;
          r.failed = true;
          r.progress = {"failed", "", 0, "building " + options_.store + " failed: " + st.error};
          return r;
        case BackgroundBuild::Stage::Done: collective_build_.reset(); break;
      }
    }
    if (!collective_error_.empty()) {
      r.failed = true;
      r.progress = {"failed", "", 0, std::string(kOpeningTheData) + " failed: " + collective_error_};
      collective_error_.clear();
      return r;
    }
    r.ready = true;  // finish_load opens it
    r.progress = {"read", "", 0, kOpeningTheData};
    return r;
  }
  if (!load_) return std::nullopt;
  const GridLoad::State st = load_->state();
  LoadReport r;
  const std::string note = notice_.empty() ? "" : notice_ + "; ";
  switch (st.stage) {
    case GridLoad::Stage::Reading: r.progress = {"read", st.label, st.fraction, note + "reading the grid"}; return r;
    case GridLoad::Stage::Failed:
      if (build_ || lod_) {
        // The store's build goes on (or its store is shown already): the viewer shows the store, without the exact
        // engine.
        notice_ = note + "no exact preview (" + st.error + ")";
        load_.reset();
        return std::nullopt;
      }
      r.failed = true;
      r.progress = {"failed", "", 0, "loading the grid failed: " + st.error};
      load_.reset();
      return r;
    case GridLoad::Stage::Fields:
    case GridLoad::Stage::Done: break;
  }
  if (!build_started_) {
    build_started_ = true;
    const GridLoad::Grid& grid = load_->grid();
    build_ = std::make_unique<BackgroundBuild>(grid.dataset, grid.names, options_.build, options_.store,
                                               options_.before_build);
  }
  r.ready = st.stage == GridLoad::Stage::Done;
  r.progress = {"build", "walk mesh", st.fraction, note + "building the walk mesh (the first image)"};
  return r;
}

void EngineHost::finish_load() {
  if (pending_collective_) {
    const std::function<CollectiveRenderer()> open = std::move(pending_collective_);
    pending_collective_ = nullptr;
    try {
      CollectiveRenderer opened = open();
      collective_ = std::move(opened.renderer);
      renderer_ = collective_->device();
      scene_ = collective_scene(opened);
    } catch (const std::exception& e) {
      collective_.reset();
      scene_ = {};
      collective_error_ = e.what();  // poll_load reports it
    }
    return;
  }
  const GridLoad::Grid grid = load_->grid();
  std::shared_ptr<ExactScene> exact = load_->exact();
  load_.reset();
  if (lod_ && options_.free_grid) return;  // the store is already shown, and the grid is not wanted beside it
  options_.dataset = grid.dataset;
  exact_ = std::move(exact);
  // The exact engine on a hardware GPU when the grid fits there (docs/exact-engine.md), else on the CPU (llvmpipe
  // is slower than the CPU engine); a failure says why in the log and falls back.
  if (!exact_->use_gpu_if_it_pays(gl_, {}) && !gl_->software())
    std::fprintf(stderr, "ugvr view: exact engine on the CPU: %s\n", exact_->gpu_unavailable.c_str());
  exact_renderer_ = exact_->gpu_engine ? "exact engine (GPU: " + gl_->renderer() + ")" : "exact engine (CPU)";
  if (lod_) {  // the store was built first: the exact engine is one more to pick
    scene_.engines = engines();
    return;
  }
  SceneInfo sc = base_scene(grid.fields, grid.bounds);
  start_from_auto(sc, options_, [&](const TransferFunction& tf) -> std::optional<Bounds> {
    exact_->bind(sc.field);
    return visible_cell_bounds(exact_->engine, tf);
  });
  sc.renderer = exact_renderer_;
  sc.engine = kExactEngine;
  sc.engines = engines();
  if (options_.series)
    for (const TimeStep& t : options_.series->steps) sc.times.push_back(t.time);
  sc.time_step = options_.time_step;
  scene_ = std::move(sc);
}

EngineHost::~EngineHost() {
  collective_build_.reset();  // cancels a partitioned store's build still running
  collective_.reset();        // under MPI: the other ranks are told to quit
  load_.reset();              // stops the walk mesh (a read under way finishes first)
  build_.reset();             // cancels a build still running
  tabs_.clear();
  exact_.reset();
  lod_.reset();
  gl_.reset();
}

SceneInfo EngineHost::base_scene(std::vector<FieldInfo> fields, const Bounds& bounds) const {
  SceneInfo sc;
  sc.fields = std::move(fields);
  sc.field = first_varying(sc.fields);
  sc.bounds = bounds;
  sc.camera = options_.camera.value_or(default_camera(sc.bounds, 30));
  sc.tf = options_.tf;
  sc.preset = options_.preset;
  sc.background = options_.background;
  sc.fps = options_.fps;
  sc.width = options_.width, sc.height = options_.height;
  return sc;
}

SceneInfo EngineHost::lod_scene() const {
  SceneInfo sc = base_scene(store_fields(lod_->engine), lod_->engine.bounds());
  start_from_auto(sc, options_,
                  [&](const TransferFunction& tf) { return visible_node_bounds(lod_->engine.store(), sc.field, tf); });
  sc.renderer = renderer_;
  // A store with cells is drawn hybrid by default (docs/hybrid.md): voxels while moving, exact cells at rest; `ugvr
  // view --engine lod` makes lod the default (a tab may still pick hybrid).
  sc.engine = hybrid_available() && options_.hybrid ? kHybridEngine : kLodEngine;
  sc.engines = engines();
  // A store with time steps (docs/time-series.md, "Stores with time"): the time panel plays its steps.
  const BrickStoreReader& store = lod_->engine.store();
  if (store.has_steps()) {
    for (uint32_t s = 0; s < store.step_count(); ++s) sc.times.push_back(store.step_time(s));
    sc.time_step = std::min(options_.time_step, store.step_count() - 1);
  }
  return sc;
}

SceneInfo EngineHost::collective_scene(const CollectiveRenderer& opened) {
  // The ranges are the whole data's on every rank (mpi_renderer.h). The histograms come from the stores' coarse
  // levels, as store_fields', or from a mesh's values, as the grid's (GridLoad): over the same whole-data ranges.
  const std::vector<std::string>& fields = opened.fields;
  std::vector<FieldInfo> infos;
  std::vector<BrickStoreReader> stores;
  for (const std::string& path : opened.histogram_stores) stores.emplace_back(path);
  std::optional<OctreeInput> mesh;
  if (opened.histogram_dataset) mesh.emplace(prepare_octree_input(*opened.histogram_dataset, fields));
  for (size_t k = 0; k < fields.size(); ++k) {
    const std::string& name = fields[k];
    collective_->set_field(name);
    const FieldRange range = collective_->field_range();
    std::vector<uint64_t> histogram;
    if (mesh && k < mesh->scalars.size())
      histogram = volume_histogram(*mesh->mesh, *mesh->scalars[k].field, mesh->scalars[k].component, kHistogramBins);
    for (const BrickStoreReader& store : stores)
      for (uint32_t i = 0; i < store.field_count(); ++i) {
        if (store.layout().fields[i].name != name) continue;
        const std::vector<uint64_t> h = store_histogram(store, i, kHistogramBins, kHistogramMaxLevel);
        if (histogram.empty()) histogram.assign(h.size(), 0);
        for (size_t b = 0; b < h.size() && b < histogram.size(); ++b) histogram[b] += h[b];
      }
    infos.push_back({name, range.min, range.max, std::move(histogram)});
  }
  if (infos.empty()) infos.push_back({collective_->field_name(), 0, 1, {}});
  SceneInfo sc = base_scene(std::move(infos), collective_->bounds());
  collective_->set_field(sc.field);
  // A partitioned store in one process: its pieces' boxes united (PieceRenderer). Under mpirun the leader asks every
  // rank and the ranks' boxes are reduced (mpi_view.h): one camera, the one the single-process viewer frames.
  start_from_auto(sc, options_,
                  [&](const TransferFunction& tf) { return collective_->visible_bounds(tf, kVisibleOpacity); });
  sc.renderer = renderer_;
  sc.engine = collective_->engine() == kExactEngine ? kExactEngine : kLodEngine;
  sc.engines = {{sc.engine, renderer_}};
  return sc;
}

std::vector<EngineChoice> EngineHost::engines() const {
  std::vector<EngineChoice> out;
  if (exact_) out.push_back({std::string(kExactEngine), exact_renderer_});
  if (hybrid_available()) out.push_back({std::string(kHybridEngine), renderer_});
  if (lod_) out.push_back({std::string(kLodEngine), renderer_});
  return out;
}

bool EngineHost::hybrid_available() const { return lod_ && lod_->engine.store().has_cells(); }

std::optional<EngineHost::BuildReport> EngineHost::build_report() const {
  if (!build_) return std::nullopt;
  const BackgroundBuild::State st = build_->state();
  BuildReport r;
  r.stage = st.stage;
  const std::string note = notice_.empty() ? "" : notice_ + "; ";
  // While the walk mesh is built beside the store, the page is told that the first image waits for it.
  const std::string walk = load_ ? "the walk mesh for the first image and " : "";
  if (st.stage == BackgroundBuild::Stage::Running && preview_depth_ > 0)
    r.progress = {"build", st.label, st.fraction,
                  note +
                      (preview_sketch_ ? "sketch from the mesh's points (levels 0–" + std::to_string(preview_depth_) +
                                             ", approximate; the coarse preview follows)"
                                       : "coarse preview (levels 0–" + std::to_string(preview_depth_) + ")") +
                      " while the store is built: " + std::to_string(int(std::lround(100 * st.fraction))) + " % of " +
                      st.label};
  else if (st.stage == BackgroundBuild::Stage::Running)
    r.progress = {"build", st.label, st.fraction, note + "building " + walk + "the brick store " + options_.store};
  else if (st.stage == BackgroundBuild::Stage::Failed)
    r.progress = {"failed", st.label, st.fraction, "building the store failed: " + st.error};
  return r;
}

std::optional<ProgressInfo> EngineHost::initial_progress() const {
  if (collective_build_) return ProgressInfo{"build", "", 0, notice_};
  if (pending_collective_) return ProgressInfo{"read", "", 0, kOpeningTheData};
  const std::string note = notice_.empty() ? "" : notice_ + "; ";
  if (load_) return ProgressInfo{"read", "", 0, note + "reading the grid"};
  if (!build_) return std::nullopt;
  return ProgressInfo{"build", "", 0, note + "building the brick store " + options_.store};
}

void EngineHost::drop_build() { build_.reset(); }

EngineHost::Switch EngineHost::switch_to_store() {
  if (options_.opening_store) options_.opening_store();
  std::string error;
  std::shared_ptr<LodScene> store;
  try {
    store = open_store(options_, gl_, options_.store);
  } catch (const std::exception& e) {
    error = e.what();
  }
  const std::string note = build_ ? build_->state().note : "";
  build_.reset();
  if (!store) {
    // A preview shown meanwhile stays (its file is open); the page says the store failed.
    return {false, {"failed", "", 1, "cannot open the new store: " + error}};
  }
  if (options_.free_grid) {
    exact_.reset();            // frees the walk mesh
    options_.dataset.reset();  // and the grid (the scene above held it too)
  }
  show_store(std::move(store));
  preview_depth_ = 0;
  return {true,
          {"ready", "", 1, "showing the brick store " + options_.store + (note.empty() ? "" : "; warning: " + note)}};
}

void EngineHost::show_store(std::shared_ptr<LodScene> store) {
  // Every tab moves to it (the server resets the tabs' picks to the scene's engine): their renderers go first, before
  // the scene they drew (a preview's, or the grid's).
  for (auto& [id, tab] : tabs_) *tab = Tab{};
  lod_ = std::move(store);
  const bool had_scene = has_scene();
  const Camera camera = scene_.camera;
  scene_ = lod_scene();
  if (had_scene) scene_.camera = camera;  // the reset view stays the same
}

bool EngineHost::preview_ready() const {
  if (!build_ || (lod_ && preview_depth_ == 0)) return false;
  const BackgroundBuild::State st = build_->state();
  return st.stage == BackgroundBuild::Stage::Running && !st.preview.empty() && st.preview != preview_tried_;
}

EngineHost::Switch EngineHost::switch_to_preview() {
  const BackgroundBuild::State st = build_->state();
  preview_tried_ = st.preview;
  std::shared_ptr<LodScene> preview;
  try {
    preview = open_store(options_, gl_, st.preview);
  } catch (const std::exception& e) {
    // Removed meanwhile (the build ended) or unreadable: the store follows as before.
    return {false,
            {"build", st.label, st.fraction,
             std::string(st.preview_sketch ? "the point sketch" : "the coarse preview") +
                 " cannot be opened: " + e.what()}};
  }
  show_store(std::move(preview));
  preview_depth_ = st.preview_depth;
  preview_sketch_ = st.preview_sketch;
  return {true, build_report()->progress};
}

void EngineHost::forget(uint64_t tab) { tabs_.erase(tab); }

EngineHost::Frame EngineHost::render(const FrameJob& job, const std::function<bool()>& keep_going) {
  const ViewRequest& request = job.request;
  std::unique_ptr<Tab>& slot = tabs_[job.tab];
  if (!slot) slot = std::make_unique<Tab>();
  Tab& tab = *slot;
  // The engine the tab picked, if this viewer still has it (the request was checked against the scene it was made
  // with), else the scene's.
  const bool picked = (request.engine == kExactEngine && exact_) || (request.engine == kLodEngine && lod_) ||
                      (request.engine == kHybridEngine && hybrid_available());
  const std::string engine = picked ? request.engine : scene_.engine;
  const bool on_store = !collective_ && (engine == kLodEngine || engine == kHybridEngine);
  // "lod" and "hybrid" draw with the one engine of the store, shared by the tabs: each frame sets which this tab
  // picked (a tab's session starts afresh when it switches, below).
  if (on_store) {
    const bool hybrid = engine == kHybridEngine;
    lod_->engine.set_hybrid(hybrid);
    lod_->options.hybrid = hybrid;  // the renderer's name for the frame's stats (LodRendererBase::engine)
    lod_->engine.set_interest(request.focus, request.roi, request.context_saturation, request.context_opacity);
  }
  if (!collective_ && (!tab.renderer || tab.engine != engine)) {
    RendererOptions ro;
    ro.interactive = true;
    ro.time_critical.ram_budget_bytes = job.ram_budget ? job.ram_budget : options_.ram_per_session;
    ro.time_critical.loader_threads = 2;
    ro.time_critical.exact_batch = options_.exact_batch;
    ro.gl_context = gl_;  // the exact engine runs on the GPU where there is a hardware one (device auto)
    // The old renderer goes first: a level-of-detail session joins its loader threads and drops its RAM cache.
    tab.renderer.reset();
    tab.renderer = on_store ? make_renderer(lod_, ro) : make_renderer(exact_, ro);
    tab.engine = engine;
    // The new engine's first frames are not part of the old one's frame rate.
    tab.counting = false, tab.shown_fps = 0;
  }
  FrameRequest fr;
  fr.camera = request.camera;
  fr.tf = request.tf;
  fr.settings = request.settings;
  fr.settings.width = request.width, fr.settings.height = request.height;
  // The tabs streaming now share the frame time: each targets its rate x their number (FrameJob::target_fps).
  fr.target_fps = job.target_fps;
  fr.full_quality = job.full_quality;
  // The collective renderer (MPI) is not a session: it cannot tell one tab's resting view from another's moving one,
  // so a tab at rest asks it for full quality.
  if (collective_ && job.resting) fr.full_quality = true;
  fr.step_voxels = request.step_voxels;
  const bool timed = engine == kExactEngine && exact_ && exact_->series;
  if (timed) fr.time_step = request.time_step.value_or(scene_.time_step);
  // A store with time steps: the LOD renderer switches the step (its bricks, read ahead while playing).
  const bool timed_store = on_store && lod_ && lod_->engine.store().has_steps();
  if (timed_store)
    fr.time_step = std::min(request.time_step.value_or(scene_.time_step), lod_->engine.store().step_count() - 1);
  // Playing, a step's period is its render plus what the step costs around it (the switch, encoding, the trip to the
  // page and back): the render's budget is adapted so that the periods, not only the renders, hold the target rate.
  const bool playing = (timed || timed_store) && request.playing && !job.full_quality;
  const Clock::time_point render_start = Clock::now();
  const double target_period = job.target_fps > 0 ? 1 / job.target_fps : 0;
  // Moving (not playing): the period between frames is the render plus the frame's overhead, so the render aims at
  // what the target period leaves (at least half of it: a slow client's back-pressure is not the render's to absorb).
  if (!playing && tab.counting && tab.frame_overhead > 0 && target_period > 0 && !job.full_quality)
    fr.target_fps = 1 / std::max(0.5 * target_period, target_period - tab.frame_overhead);
  if (playing && target_period > 0) {
    if (tab.step_started) {
      // The period is what the server sees: this step's request arrived period seconds after the previous one's
      // render started. A late period (the render and its overhead exceeded it) takes the excess off the budget at
      // once; a period on time may hold the page's wait for the step's time (web/time_panel.js), which says nothing
      // about how much of the period the render may take, so the budget grows back slowly toward its cap. (Subtracting
      // period - render as an "overhead" instead had no fixed point: a 30 ms render left 70 ms of "overhead" and was
      // given 30 ms again, however coarse that made every step.)
      const double period = std::chrono::duration<double>(render_start - *tab.step_started).count();
      const double cap = kPlayingRenderShare * target_period;
      if (period > 1.05 * target_period)
        tab.render_budget = std::max(0.02, tab.render_budget - 0.5 * (period - target_period));
      else
        tab.render_budget += 0.1 * (cap - tab.render_budget);
      tab.render_budget = std::min(tab.render_budget, cap);
    } else {
      tab.render_budget = kPlayingRenderShare * target_period;
    }
    fr.target_fps = 1 / tab.render_budget;
  }
  // Playing: the next step is read while this frame is encoded and sent (the switch then costs the field swap). The
  // store's renderer starts the read after this frame's draw, for the nodes it drew.
  if (timed_store && request.playing) fr.prefetch_time_step = (*fr.time_step + 1) % lod_->engine.store().step_count();
  fr.keep_going = keep_going;
  ugvr::Frame f;
  try {
    f = (collective_ ? *collective_ : *tab.renderer).render(fr);
  } catch (const FrameInterrupted&) {
    // The tab's next frame is a move from the view it was last shown; this one counts in nothing.
    ++tab.interrupted;
    tab.step_started.reset();
    Frame none;
    none.interrupted = true;
    return none;
  }
  if (playing)
    tab.step_started = render_start;
  else
    tab.step_started.reset();
  if (timed && request.playing) exact_->prefetch((*fr.time_step + 1) % uint32_t(exact_->series->size()));
  const Image& image = f.image;
  const bool converged = f.stats.converged;
  FrameStatus st;
  st.frame_seconds = f.stats.seconds;
  st.cut_nodes = f.stats.cut_nodes, st.visible_nodes = f.stats.visible_nodes;
  st.texel_error = f.stats.texel_error, st.max_texel_error = f.stats.max_texel_error;
  st.scale = f.stats.scale;
  st.engine = f.stats.engine;
  st.ram_bytes = f.stats.ram_bytes, st.ram_budget = f.stats.ram_budget;
  st.atlas_bytes = f.stats.gpu_bytes, st.atlas_budget = f.stats.gpu_budget;
  st.pending_bricks = f.stats.pending;
  st.interrupted = tab.interrupted;
  if (timed) st.time_step = exact_->step, st.time = exact_->series->steps[exact_->step].time;
  if (timed_store) st.time_step = *fr.time_step, st.time = lod_->engine.store().step_time(*fr.time_step);
  // How much is exact (hybrid): the session's figures of the frame's draw.
  if (const auto* d = dynamic_cast<const InteractiveLodFrameStats*>(f.stats.detail.get());
      d && d->frame.render.hybrid) {
    const LodRenderStats& h = d->frame.render;
    st.hybrid = true;
    st.exact_nodes = h.exact_nodes, st.exact_candidates = h.exact_candidates, st.exact_cells = h.exact_cells;
    st.focus_excluded = h.focus_excluded;
    st.exact_fraction = h.cut_nodes ? double(h.exact_nodes) / double(h.cut_nodes) : 0.0;
    st.cell_bytes = h.cell_bytes, st.cell_budget = h.cell_budget_bytes;
    st.cell_budget_full = h.cell_budget_full;
    st.exact_off = h.hybrid_off;
  }
  const Clock::time_point encode_start = Clock::now();
  const std::vector<unsigned char> encoded = converged ? png_bytes(image) : jpeg_bytes(image);
  auto bytes = std::make_shared<const std::string>(encoded.begin(), encoded.end());
  const Clock::time_point now = Clock::now();
  if (timed || timed_store) trace_time_frame(job, fr, f, std::chrono::duration<double>(now - encode_start).count());
  if (tab.counting) {
    const double dt = std::chrono::duration<double>(now - tab.last).count();
    if (dt > 0) tab.shown_fps = tab.shown_fps > 0 ? 0.8 * tab.shown_fps + 0.2 / dt : 1 / dt;
    if (dt > 0 && !playing && !converged) {
      const double overhead = std::max(0.0, dt - f.stats.seconds);
      tab.frame_overhead = tab.frame_overhead > 0 ? 0.8 * tab.frame_overhead + 0.2 * overhead : overhead;
    }
  }
  tab.counting = !converged;
  tab.last = now;
  st.seq = ++tab.seq;
  st.request = job.generation;
  st.png = converged;
  st.width = image.width, st.height = image.height;
  st.fps = tab.shown_fps;
  st.converged = converged;
  return {st, std::move(bytes)};
}

}  // namespace ugvr::view
