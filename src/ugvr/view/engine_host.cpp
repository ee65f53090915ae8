#include "ugvr/view/engine_host.h"

#include <algorithm>
#include <chrono>
#include <vector>

#include "ugvr/gpu/gl_context.h"
#include "ugvr/lod/octree_input.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"
#include "ugvr/view/exact_preview.h"
#include "ugvr/view/field_histogram.h"
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

std::unique_ptr<LodEngine> open_store(const ViewServerOptions& options, const GlContext& gl) {
  LodOptions lo;
  lo.atlas_budget_bytes = options.gpu_memory;
  auto engine = std::make_unique<LodEngine>(options.store, gl, lo);
  engine->set_field("");
  return engine;
}

}  // namespace

// What the render thread keeps for one tab.
struct EngineHost::Tab {
  std::unique_ptr<TimeCriticalRenderer> renderer;  // with the store: made for a field and a step
  std::string field;
  double fps = -1, step = -1;
  ExactPreview::Tab exact;  // while the grid is shown by the exact engine
  uint64_t seq = 0;
  double shown_fps = 0;
  Clock::time_point last;
  bool counting = false;  // the previous frame was part of an interaction (not converged): fps is measured
};

EngineHost::EngineHost(ViewServerOptions options) : options_(std::move(options)) {
  gl_ = std::make_unique<GlContext>(options_.gpu);
  renderer_ = gl_->renderer();
  if (!options_.dataset) {
    engine_ = open_store(options_, *gl_);
    scene_ = lod_scene();
    return;
  }
  SceneInfo sc;
  // The fields as the store will name them ("velocity:magnitude"), with their ranges; also validates them (NaN,
  // missing) before anything is served.
  std::vector<std::string> names;
  {
    const OctreeInput input = prepare_octree_input(*options_.dataset, options_.fields);
    for (size_t i = 0; i < input.fields.size(); ++i) {
      const BrickStoreField& f = input.fields[i];
      const ScalarRef& ref = input.scalars[i];
      sc.fields.push_back({f.name, f.min, f.max, field_histogram(*ref.field, ref.component, kHistogramBins)});
      names.push_back(f.name);
    }
    sc.bounds = input.bounds;
  }
  preview_ = std::make_unique<ExactPreview>(options_.dataset);
  sc.field = sc.fields.front().name;
  sc.camera = options_.camera.value_or(reset_camera(sc.bounds, 30));
  sc.tf = options_.tf;
  sc.preset = options_.preset;
  sc.fps = options_.fps;
  sc.width = options_.width, sc.height = options_.height;
  sc.renderer = "exact engine (CPU)";
  sc.engine = "exact";
  scene_ = std::move(sc);
  build_ =
      std::make_unique<BackgroundBuild>(options_.dataset, names, options_.build, options_.store, options_.before_build);
}

EngineHost::~EngineHost() {
  build_.reset();  // cancels a build still running
  tabs_.clear();
  preview_.reset();
  engine_.reset();
  gl_.reset();
}

SceneInfo EngineHost::lod_scene() const {
  SceneInfo sc;
  sc.fields = store_fields(*engine_);
  sc.field = engine_->field_name();
  sc.bounds = engine_->bounds();
  sc.camera = options_.camera.value_or(reset_camera(sc.bounds, 30));
  sc.tf = options_.tf;
  sc.preset = options_.preset;
  sc.fps = options_.fps;
  sc.width = options_.width, sc.height = options_.height;
  sc.renderer = renderer_;
  sc.engine = "lod";
  return sc;
}

std::optional<EngineHost::BuildReport> EngineHost::build_report() const {
  if (!build_) return std::nullopt;
  const BackgroundBuild::State st = build_->state();
  BuildReport r;
  r.stage = st.stage;
  if (st.stage == BackgroundBuild::Stage::Running)
    r.progress = {"build", st.label, st.fraction, "building the brick store " + options_.store};
  else if (st.stage == BackgroundBuild::Stage::Failed)
    r.progress = {"failed", st.label, st.fraction, "building the store failed: " + st.error};
  return r;
}

std::optional<ProgressInfo> EngineHost::initial_progress() const {
  if (!build_) return std::nullopt;
  return ProgressInfo{"build", "", 0, "building the brick store " + options_.store};
}

void EngineHost::drop_build() { build_.reset(); }

EngineHost::Switch EngineHost::switch_to_store() {
  if (options_.opening_store) options_.opening_store();
  std::string error;
  try {
    engine_ = open_store(options_, *gl_);
  } catch (const std::exception& e) {
    error = e.what();
  }
  build_.reset();
  if (!engine_) return {false, {"failed", "", 1, "cannot open the new store: " + error}};
  const Camera camera = scene_.camera;
  scene_ = lod_scene();
  scene_.camera = camera;  // the reset view stays the same
  for (auto& [id, tab] : tabs_) *tab = Tab{};
  preview_.reset();          // frees the walk mesh
  options_.dataset.reset();  // and the grid
  return {true, {"ready", "", 1, "showing the brick store " + options_.store}};
}

void EngineHost::forget(uint64_t tab) { tabs_.erase(tab); }

EngineHost::Frame EngineHost::render(const FrameJob& job) {
  const ViewRequest& request = job.request;
  std::unique_ptr<Tab>& slot = tabs_[job.tab];
  if (!slot) slot = std::make_unique<Tab>();
  Tab& tab = *slot;
  FrameStatus st;
  Image image;
  bool converged = false;
  if (engine_) {
    const std::string field = request.settings.field.empty() ? scene_.field : request.settings.field;
    if (engine_->field_name() != field) engine_->set_field(field);
    if (!tab.renderer || tab.field != field || tab.step != request.step_voxels) {
      TimeCriticalOptions tc;
      tc.target_fps = request.fps;
      tc.resting_step_voxels = request.step_voxels;
      tc.moving_step_voxels = std::max(1.0, request.step_voxels);
      tc.ram_budget_bytes = options_.ram_per_session;
      tc.loader_threads = 2;
      tab.renderer.reset();
      tab.renderer = std::make_unique<TimeCriticalRenderer>(*engine_, tc);
      tab.field = field, tab.step = request.step_voxels;
    }
    // The tabs streaming now share the frame time: each targets its rate x their number (FrameJob::target_fps).
    if (job.target_fps != tab.fps) tab.renderer->set_target_fps(job.target_fps);
    tab.fps = job.target_fps;
    RenderSettings rs = request.settings;
    rs.width = request.width, rs.height = request.height;
    TimeCriticalFrame f;
    image = job.full_quality ? tab.renderer->full_quality(request.camera, request.tf, rs, &f)
                             : tab.renderer->frame(request.camera, request.tf, rs, &f);
    converged = f.converged || job.full_quality;
    st.frame_seconds = f.seconds;
    st.cut_nodes = f.cut_nodes, st.visible_nodes = f.visible_nodes;
    st.texel_error = f.mean_error, st.max_texel_error = f.max_error;
    st.scale = f.scale;
    st.engine = "lod";
    st.ram_bytes = f.cache.resident_bytes, st.ram_budget = options_.ram_per_session;
    st.atlas_bytes = f.render.atlas_bytes, st.atlas_budget = options_.gpu_memory;
    st.pending_bricks = f.cache.queued + f.cache.loading;
  } else {
    ExactPreview::Frame f = preview_->render(tab.exact, request, job.resting || job.full_quality);
    image = std::move(f.image);
    converged = f.converged;
    st.frame_seconds = f.seconds;
    st.scale = f.scale;
    st.engine = "exact";
  }
  const std::vector<unsigned char> encoded = converged ? png_bytes(image) : jpeg_bytes(image);
  auto bytes = std::make_shared<const std::string>(encoded.begin(), encoded.end());
  const Clock::time_point now = Clock::now();
  if (tab.counting) {
    const double dt = std::chrono::duration<double>(now - tab.last).count();
    if (dt > 0) tab.shown_fps = tab.shown_fps > 0 ? 0.8 * tab.shown_fps + 0.2 / dt : 1 / dt;
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
