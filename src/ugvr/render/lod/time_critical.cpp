#include "ugvr/render/lod/time_critical.h"

#include <algorithm>
#include <chrono>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/active_cut.h"
#include "ugvr/render/lod/frame_controller.h"

namespace ugvr {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

struct TimeCriticalRenderer::Impl {
  LodEngine& engine;
  TimeCriticalOptions options;
  ActiveCut cut;
  BrickCache cache;
  FrameController controller;
  std::optional<Camera> last_camera;
  std::optional<TransferFunction> last_tf;
  std::optional<RenderSettings> last_settings;
  bool rest_converged = false;  // the cut converged in the last frame, at rest

  Impl(LodEngine& e, TimeCriticalOptions o)
      : engine(e),
        options(o),
        cut(e.store(), ActiveCutOptions{e.field(), o.pixels}),
        cache(e.store(), e.field(), o.ram_budget_bytes, o.loader_threads) {
    FrameControllerOptions fc;
    fc.target_seconds = o.target_fps > 0 ? 1.0 / o.target_fps : 0.0;
    fc.initial_budget = 64;
    controller = FrameController(fc);
  }

  // One update of the cut and one draw. `unlimited`: no frame-time budget (resting or no target).
  Image step(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings, bool unlimited,
             TimeCriticalFrame& f);
};

TimeCriticalRenderer::TimeCriticalRenderer(LodEngine& engine, TimeCriticalOptions options)
    : impl_(std::make_unique<Impl>(engine, options)) {
  if (!(options.pixels > 0) || !(options.moving_step_voxels > 0) || !(options.resting_step_voxels > 0))
    fail_in("time-critical renderer", "pixels and steps must be > 0");
  if (options.uploads_per_frame < 1 || options.reads_per_frame < 1)
    fail_in("time-critical renderer", "uploads and reads per frame must be >= 1");
}

TimeCriticalRenderer::~TimeCriticalRenderer() = default;

Image TimeCriticalRenderer::Impl::step(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                                       bool unlimited, TimeCriticalFrame& f) {
  const BrickCacheStats before = cache.stats();
  CutBudget budget;
  const uint64_t atlas = engine.atlas_budget_bricks();
  f.budget_nodes = unlimited ? CutBudget::kUnlimited : controller.budget();
  budget.max_nodes = std::max<uint64_t>(1, std::min(atlas, f.budget_nodes));
  budget.max_new_nodes_per_frame = options.uploads_per_frame;
  budget.max_reads_per_frame = options.reads_per_frame;
  const CutUpdate u = cut.update(camera, settings.width, settings.height, tf, budget,
                                 [&](uint64_t n) { return engine.in_atlas(n) || cache.resident(n); });
  // The cache keeps what the cut draws and has not uploaded yet (most important), then what it wants next.
  std::vector<std::pair<uint64_t, float>> requests;
  for (uint64_t n : u.visible)
    if (!engine.in_atlas(n)) requests.push_back({n, 1e30f});
  for (size_t i = 0; i < u.wanted.size(); ++i) requests.push_back({u.wanted[i], float(u.wanted_priority[i])});
  cache.request(requests);
  f.requested = requests.size();
  Image image = engine.render_nodes(
      camera, tf, settings, u.visible, [&](uint64_t n) { return cache.get(n); }, &f.render);
  cache.rethrow_load_error();
  f.cut_nodes = cut.size();
  f.visible_nodes = u.visible.size();
  f.splits = u.splits;
  f.merges = u.merges;
  f.max_error = u.max_error;
  f.mean_error = u.mean_error;
  f.uploads = f.render.bricks_loaded;
  f.sync_reads = f.render.bricks_read_sync;
  f.converged = u.converged && u.wanted.empty();
  f.cache = stats_since(cache.stats(), before);
  return image;
}

Image TimeCriticalRenderer::frame(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                                  TimeCriticalFrame* report) {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  TimeCriticalFrame f;
  f.resting = I.last_camera && *I.last_camera == camera && *I.last_tf == tf && *I.last_settings == settings;
  const bool no_target = I.options.target_fps <= 0;
  if (no_target) return full_quality(camera, tf, settings, report);
  // Moving: the controller's budget and the coarse step. At rest: no budget, the cut refines over the next frames;
  // once it has converged, one more frame at the fine step is full quality (and stays so while the view rests).
  const bool fine = f.resting && I.rest_converged;
  I.engine.set_step_voxels(fine ? I.options.resting_step_voxels : I.options.moving_step_voxels);
  Image image = I.step(camera, tf, settings, f.resting, f);
  I.rest_converged = f.resting && f.converged;
  f.converged = fine && f.converged;
  f.seconds = seconds_since(t0);
  // Only frames under the controller's budget teach it what work costs.
  if (!f.resting) I.controller.frame(f.seconds, std::max<uint64_t>(1, f.cut_nodes));
  I.last_camera = camera, I.last_tf = tf, I.last_settings = settings;
  if (report) *report = f;
  return image;
}

Image TimeCriticalRenderer::full_quality(const Camera& camera, const TransferFunction& tf,
                                         const RenderSettings& settings, TimeCriticalFrame* report) {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  TimeCriticalFrame f;
  I.engine.set_step_voxels(I.options.resting_step_voxels);
  // Refine without drawing until nothing improves: each round asks for the bricks the next splits need and waits.
  for (int round = 0; round < 10000; ++round) {
    CutBudget budget;
    budget.max_nodes = I.engine.atlas_budget_bricks();
    const CutUpdate u = I.cut.update(camera, settings.width, settings.height, tf, budget,
                                     [&](uint64_t n) { return I.engine.in_atlas(n) || I.cache.resident(n); });
    if (u.converged || (u.splits == 0 && u.merges == 0 && u.wanted.empty())) break;
    std::vector<std::pair<uint64_t, float>> requests;
    for (uint64_t n : u.visible)
      if (!I.engine.in_atlas(n)) requests.push_back({n, 1e30f});
    for (size_t i = 0; i < u.wanted.size(); ++i) requests.push_back({u.wanted[i], float(u.wanted_priority[i])});
    I.cache.request(requests);
    I.cache.wait_all(60);
    I.cache.rethrow_load_error();
    if (u.splits == 0 && u.merges == 0 && !u.wanted.empty() && !I.cache.wait_all(0)) break;  // over the RAM budget
  }
  Image image = I.step(camera, tf, settings, true, f);
  I.rest_converged = f.converged;
  f.seconds = seconds_since(t0);
  f.resting = true;
  I.last_camera = camera, I.last_tf = tf, I.last_settings = settings;
  if (report) *report = f;
  return image;
}

}  // namespace ugvr
