#include "ugvr/render/lod/time_critical.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <unordered_map>
#include <unordered_set>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/active_cut.h"
#include "ugvr/render/lod/frame_controller.h"
#include "ugvr/render/lod/quality_policy.h"

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
  std::unique_ptr<BrickCache> cache;          // the RAM tier, for the engine's time step
  std::unique_ptr<BrickResidency> residency;  // where each brick is: the engine's atlas (shared), cache, or the store
  std::unique_ptr<BrickCache> prefetch;       // the next time step's bricks, being read (prefetch_time_step)
  std::vector<std::pair<uint64_t, float>> last_drawn;  // the last frame's visible nodes, then what it wanted
  FrameController controller;                          // budgets ray samples
  QualityPolicy policy;
  std::optional<Camera> last_camera;
  std::optional<TransferFunction> last_tf;
  std::optional<RenderSettings> last_settings;
  std::vector<uint64_t> last_visible;  // the last frame's drawn nodes, ascending
  bool prefetch_asked = false;         // prefetch_time_step since the last frame: the next frame is a playing one
  TimeCriticalFrame switch_report;     // switch_time_step's figures, for the next frame's report
  bool rest_converged = false;         // the cut converged in the last frame, at rest
  int stalled_frames = 0;              // resting frames in a row in which the cut could not refine for lack of memory
  uint64_t exact_limit = 0;  // hybrid: nodes that may be exact in the next frame (grows at rest: exact_growth)

  Impl(LodEngine& e, TimeCriticalOptions o)
      : engine(e),
        options(o),
        cut(e.store(), ActiveCutOptions{e.field(), o.pixels, o.error_weight}),
        cache(std::make_unique<BrickCache>(e.store(), e.field(), o.ram_budget_bytes, o.loader_threads)),
        residency(std::make_unique<BrickResidency>(e.store(), e.gpu_slots(), cache.get())),
        policy(QualityPolicyOptions{.min_scale = o.min_scale}) {
    FrameControllerOptions fc;
    fc.target_seconds = o.target_fps > 0 ? 1.0 / o.target_fps : 0.0;
    // Samples. No cap before the first measurement (its growth limit would hold the second frame to a guess); the
    // policy's first node budget decides the first frame.
    fc.initial_budget = fc.max_budget;
    controller = FrameController(fc);
  }

  // One update of the cut and one draw at `choice` (max_nodes, scale); `unlimited`: no node budget (resting or no
  // target; the scale is then 1).
  Image step(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings, bool unlimited,
             const QualityChoice& choice, TimeCriticalFrame& f);
  // switch_time_step: the cut coarsened to what the new step's cache holds (see there).
  void coarsen_to_resident();
  // Brick-tree depth of a node (0 for the coarsest cut's nodes).
  int depth(uint64_t n) const {
    int d = 0;
    for (uint64_t p = cut.brick_parent(n); p != kNoNode; p = cut.brick_parent(p)) ++d;
    return d;
  }

  // The transfer-function rules of the cut for these settings (lod_engine.h, tf_cut_rules).
  void cull_for(const RenderSettings& settings) {
    const TfCutRules rules = tf_cut_rules(settings);
    if (cut.options().tf_cull == rules.cull && cut.options().tf_error == rules.error) return;
    ActiveCutOptions co = cut.options();
    co.tf_cull = rules.cull;
    co.tf_error = rules.error;
    cut.set_options(co);
  }
};

void TimeCriticalRenderer::set_target_fps(double fps) {
  if (!(fps >= 0) || !std::isfinite(fps)) fail_in("time-critical renderer", "target fps must be finite and >= 0");
  impl_->options.target_fps = fps;
  impl_->controller.set_target_fps(fps);
}

TimeCriticalRenderer::TimeCriticalRenderer(LodEngine& engine, TimeCriticalOptions options)
    : impl_(std::make_unique<Impl>(engine, options)) {
  if (!(options.pixels > 0) || !(options.moving_step_voxels > 0) || !(options.resting_step_voxels > 0))
    fail_in("time-critical renderer", "pixels and steps must be > 0");
  if (!(options.min_scale > 0 && options.min_scale <= 1))
    fail_in("time-critical renderer", "min_scale must be in (0, 1]");
  if (options.uploads_per_frame < 1 || options.reads_per_frame < 1 || options.resting_uploads_per_frame < 1 ||
      options.resting_reads_per_frame < 1)
    fail_in("time-critical renderer", "uploads and reads per frame must be >= 1");
  if (options.exact_batch < 1 || !(options.exact_growth >= 1) || !std::isfinite(options.exact_growth))
    fail_in("time-critical renderer", "exact_batch must be >= 1 and exact_growth finite and >= 1");
}

TimeCriticalRenderer::~TimeCriticalRenderer() = default;

void TimeCriticalRenderer::prefetch_time_step(uint32_t step) {
  Impl& I = *impl_;
  if (step == I.engine.time_step()) return;
  if (!I.prefetch || I.prefetch->step() != step || I.prefetch->field() != I.engine.field()) {
    I.prefetch.reset();  // another step's reads: its threads end first
    const uint64_t used = I.cache->stats().resident_bytes;
    const uint64_t room = I.options.ram_budget_bytes > used ? I.options.ram_budget_bytes - used : 0;
    I.prefetch = std::make_unique<BrickCache>(I.engine.store(), I.engine.field(), room, I.options.loader_threads, step);
  }
  // Coarse before fine: each drawn node's brick ancestors, then the node, by level (priority 2^-depth below the drawn
  // nodes' 1e30), so that what is read when the next step comes is a cover of the view at some coarser level (the
  // switch coarsens the cut to it); then what the cut wanted, by its own priority (kept below the drawn nodes').
  std::vector<std::pair<uint64_t, float>> list;
  std::unordered_set<uint64_t> listed;
  for (const auto& [n, priority] : I.last_drawn) {
    if (priority < 1e30f) continue;
    for (uint64_t a = n; a != kNoNode && listed.insert(a).second; a = I.cut.brick_parent(a))
      list.push_back({a, 1e30f * std::ldexp(1.0f, -I.depth(a))});
  }
  for (const auto& [n, priority] : I.last_drawn)
    if (priority < 1e30f && listed.insert(n).second) list.push_back({n, std::min(priority, 1e20f)});
  I.prefetch->request(list);
  I.prefetch_asked = true;
}

void TimeCriticalRenderer::Impl::coarsen_to_resident() {
  // The finest coarsening of the old cut whose drawn nodes all have their bricks in the new step's cache: from the
  // coarsest cut, split every node that was a strict ancestor of an old cut node where each of its brick children is
  // usable: resident, or an old cut node the last frame did not draw (culled: drawn by no one, needs no brick), or
  // itself such an ancestor whose children are usable (it is split in turn).
  const std::vector<uint64_t> old(cut.nodes().begin(), cut.nodes().end());
  std::unordered_set<uint64_t> inner;
  for (uint64_t n : old)
    for (uint64_t p = cut.brick_parent(n); p != kNoNode && inner.insert(p).second; p = cut.brick_parent(p)) {
    }
  const std::unordered_set<uint64_t> old_set(old.begin(), old.end());
  std::unordered_map<uint64_t, bool> usable_memo;
  std::function<bool(uint64_t)> usable = [&](uint64_t n) -> bool {
    if (auto it = usable_memo.find(n); it != usable_memo.end()) return it->second;
    bool ok = cache->resident(n);
    if (!ok && old_set.count(n)) ok = !std::binary_search(last_visible.begin(), last_visible.end(), n);
    if (!ok && inner.count(n)) {
      ok = true;
      for (uint64_t k : cut.brick_children(n)) ok = ok && usable(k);
    }
    usable_memo[n] = ok;
    return ok;
  };
  cut.reset();
  std::vector<uint64_t> todo(cut.nodes().begin(), cut.nodes().end());
  while (!todo.empty()) {
    const uint64_t n = todo.back();
    todo.pop_back();
    if (!inner.count(n)) continue;
    const std::span<const uint64_t> kids = cut.brick_children(n);
    if (!std::all_of(kids.begin(), kids.end(), usable)) continue;
    cut.split(n);
    todo.insert(todo.end(), kids.begin(), kids.end());
  }
}

void TimeCriticalRenderer::switch_time_step() {
  Impl& I = *impl_;
  const uint32_t step = I.engine.time_step();
  I.residency.reset();
  TimeCriticalFrame& sw = I.switch_report;
  sw = TimeCriticalFrame{};
  sw.switched = true;
  sw.switch_cut_before = I.cut.size();
  if (I.prefetch && I.prefetch->step() == step && I.prefetch->field() == I.engine.field()) {
    I.cache = std::move(I.prefetch);
    I.cache->raise_budget(I.options.ram_budget_bytes);
  } else {
    I.prefetch.reset();
    I.cache.reset();  // its threads end before the next cache's start
    I.cache = std::make_unique<BrickCache>(I.engine.store(), I.engine.field(), I.options.ram_budget_bytes,
                                           I.options.loader_threads);
  }
  I.residency = std::make_unique<BrickResidency>(I.engine.store(), I.engine.gpu_slots(), I.cache.get());
  sw.prefetched = I.cache->stats().resident_bricks;
  // A step reached without a prefetch (the slider; the first step played) has nothing in RAM: coarsening would leave
  // the coarsest cut, and a jump is rare enough to be drawn at the tab's cut, read on this thread, instead. A prefetch
  // of this step (playing) has read what it could, coarse bricks first: the cut is coarsened to it.
  if (sw.prefetched > 0) I.coarsen_to_resident();
  sw.switch_cut_after = I.cut.size();
  // The node errors are the new step's (ActiveCut caches them per view).
  I.cut.set_options(I.cut.options());
  I.last_camera.reset();  // the next frame is a moving one
  I.rest_converged = false;
  I.stalled_frames = 0;
  I.exact_limit = 0;
}

bool TimeCriticalRenderer::wait_prefetch(double timeout_seconds) {
  return impl_->prefetch && impl_->prefetch->wait_all(timeout_seconds);
}

Image TimeCriticalRenderer::Impl::step(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                                       bool unlimited, const QualityChoice& choice, TimeCriticalFrame& f) {
  const BrickCacheStats before = cache->stats();
  CutBudget budget;
  const uint64_t atlas = engine.atlas_budget_bricks();
  f.budget_nodes = unlimited ? CutBudget::kUnlimited : choice.max_nodes;
  budget.max_nodes = std::max<uint64_t>(1, std::min(atlas, f.budget_nodes));
  budget.max_new_nodes_per_frame = unlimited ? options.resting_uploads_per_frame : options.uploads_per_frame;
  budget.max_reads_per_frame = unlimited ? options.resting_reads_per_frame : options.reads_per_frame;
  // The cut measures texels in pixels of the image it is drawn into: the scaled one.
  f.scale = unlimited ? 1.0 : choice.scale;
  RenderSettings scaled = settings;
  scaled.width = std::max(1, int(std::lround(settings.width * f.scale)));
  scaled.height = std::max(1, int(std::lround(settings.height * f.scale)));
  if (scaled.width == settings.width && scaled.height == settings.height) f.scale = 1;
  cull_for(settings);
  const auto t_cut = std::chrono::steady_clock::now();
  CutUpdate u =
      cut.update(camera, scaled.width, scaled.height, tf, budget, [&](uint64_t n) { return residency->resident(n); });
  // The cache keeps what the cut draws and has not uploaded yet (most important), then what it wants next. Playing,
  // this step is drawn once: its cache reads nothing new (what it has pending is dropped, so that the workers read
  // the next step's bricks), and what the cut wants goes to the next step's prefetch (last_drawn).
  std::vector<std::pair<uint64_t, float>> requests;
  for (uint64_t n : u.visible)
    if (!residency->on_gpu(n) && (!f.playing || cache->resident(n))) requests.push_back({n, 1e30f});
  if (!f.playing)
    for (size_t i = 0; i < u.wanted.size(); ++i) requests.push_back({u.wanted[i], float(u.wanted_priority[i])});
  cache->request(requests);
  f.requested = requests.size();
  last_drawn.clear();
  for (uint64_t n : u.visible) last_drawn.push_back({n, 1e30f});
  for (size_t i = 0; i < u.wanted.size(); ++i) last_drawn.push_back({u.wanted[i], float(u.wanted_priority[i])});
  last_visible = u.visible;
  f.cut_seconds = seconds_since(t_cut);
  Image image;
  try {
    if (exact_limit > 0) engine.prepare_exact(u.visible, camera, tf, scaled, exact_limit, &f.render);
    image = engine.render_nodes(camera, tf, scaled, u.visible, *residency, &f.render);
  } catch (const AtlasRefused&) {
    // The device allocates less than the budget allowed (the engine now knows how much): the cut merges down to it.
    budget.max_nodes = std::max<uint64_t>(1, std::min(engine.atlas_budget_bricks(), f.budget_nodes));
    u = cut.update(camera, scaled.width, scaled.height, tf, budget, [&](uint64_t n) { return residency->resident(n); });
    if (exact_limit > 0) engine.prepare_exact(u.visible, camera, tf, scaled, exact_limit, &f.render);
    image = engine.render_nodes(camera, tf, scaled, u.visible, *residency, &f.render);
  }
  cache->rethrow_load_error();
  if (f.scale != 1) image = resize_bilinear(image, settings.width, settings.height);
  f.cut_nodes = cut.size();
  f.visible_nodes = u.visible.size();
  f.splits = u.splits;
  f.merges = u.merges;
  const double to_output = double(settings.width) / double(scaled.width);  // output pixels per rendered pixel
  f.max_error = u.max_error * to_output;
  f.mean_error = u.mean_error * to_output;
  f.uploads = f.render.bricks_loaded;
  f.sync_reads = f.render.bricks_read_sync;
  f.converged = u.converged && u.wanted.empty();
  f.cache = stats_since(cache->stats(), before);
  // At rest the cut may want bricks the RAM cache does not admit (its budget is full of bricks of higher priority):
  // nothing splits, merges or loads, so the next frame would be this one again. Twice in a row (a load that finished
  // during this frame is used by the next one) means the budgets allow no better: full quality within them, rather
  // than refining frames forever.
  const bool stalled =
      unlimited && u.splits == 0 && u.merges == 0 && !u.wanted.empty() && f.cache.queued == 0 && f.cache.loading == 0;
  stalled_frames = stalled ? stalled_frames + 1 : 0;
  f.memory_limited = stalled_frames >= 2;
  f.converged = f.converged || f.memory_limited;
  return image;
}

namespace {
// Hybrid: no more nodes can turn exact (all candidates are, the cell budget is full, or hybrid is off or cannot run).
bool exact_complete(const LodRenderStats& st) {
  return !st.hybrid || !st.hybrid_off.empty() || st.exact_nodes >= st.exact_candidates || st.cell_budget_full;
}
}  // namespace

Image TimeCriticalRenderer::frame(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                                  TimeCriticalFrame* report) {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  TimeCriticalFrame f = I.switch_report;  // the step switch's figures, if one came before this frame
  I.switch_report = TimeCriticalFrame{};
  f.playing = I.prefetch_asked;
  I.prefetch_asked = false;
  f.resting = I.last_camera && *I.last_camera == camera && *I.last_tf == tf && *I.last_settings == settings;
  const bool no_target = I.options.target_fps <= 0;
  if (no_target) return full_quality(camera, tf, settings, report);
  // Moving: the controller's budget and the coarse step. At rest: no budget, the cut refines over the next frames;
  // once it has converged, one more frame at the fine step is full quality (and stays so while the view rests).
  const bool fine = f.resting && I.rest_converged;
  I.engine.set_step_voxels(fine ? I.options.resting_step_voxels : I.options.moving_step_voxels);
  f.budget_samples = f.resting ? FrameController::kUnlimited : I.controller.budget();
  // Hybrid: at rest with the cut converged, more nodes turn exact each frame (TimeCriticalOptions::exact_growth); any
  // change starts again. The growth is on the limit, not on the nodes made exact: a cell budget that holds fewer
  // leaves the limit ahead, which costs nothing.
  if (fine && I.engine.hybrid()) {
    const double grown = double(I.exact_limit) * (I.options.exact_growth - 1);
    const uint64_t more = std::max<uint64_t>(I.options.exact_batch, grown >= 1e18 ? uint64_t(1e18) : uint64_t(grown));
    I.exact_limit = I.exact_limit > UINT64_MAX - more ? UINT64_MAX : I.exact_limit + more;
  } else {
    I.exact_limit = 0;
  }
  Image image = I.step(camera, tf, settings, f.resting, I.policy.current(), f);
  I.rest_converged = f.resting && f.converged;
  f.converged = fine && f.converged && exact_complete(f.render);
  f.seconds = seconds_since(t0);
  // Only frames under the budget teach the controller what a sample costs.
  if (!f.resting) {
    const uint64_t samples = I.controller.frame(f.seconds, f.render.samples);
    const bool coarsest = f.cut_nodes <= I.cut.coarsest_size() || f.cut_nodes > f.budget_nodes;
    I.policy.next(samples, f.render.samples, f.cut_nodes, coarsest);
  }
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
  I.cull_for(settings);
  // Refine without drawing until nothing improves: each round asks for the bricks the next splits need and waits.
  for (int round = 0; round < 10000; ++round) {
    CutBudget budget;
    budget.max_nodes = I.engine.atlas_budget_bricks();
    const CutUpdate u = I.cut.update(camera, settings.width, settings.height, tf, budget,
                                     [&](uint64_t n) { return I.residency->resident(n); });
    if (u.converged || (u.splits == 0 && u.merges == 0 && u.wanted.empty())) break;
    std::vector<std::pair<uint64_t, float>> requests;
    for (uint64_t n : u.visible)
      if (!I.residency->on_gpu(n)) requests.push_back({n, 1e30f});
    for (size_t i = 0; i < u.wanted.size(); ++i) requests.push_back({u.wanted[i], float(u.wanted_priority[i])});
    I.cache->request(requests);
    I.cache->wait_all(60);
    I.cache->rethrow_load_error();
    if (u.splits == 0 && u.merges == 0 && !u.wanted.empty() && !I.cache->wait_all(0)) break;  // over the RAM budget
  }
  f.budget_samples = FrameController::kUnlimited;
  I.exact_limit = I.engine.hybrid() ? UINT64_MAX : 0;  // hybrid: every candidate exact within the cell budget
  Image image = I.step(camera, tf, settings, true, QualityChoice{}, f);
  I.rest_converged = f.converged;
  f.seconds = seconds_since(t0);
  f.resting = true;
  I.last_camera = camera, I.last_tf = tf, I.last_settings = settings;
  if (report) *report = f;
  return image;
}

}  // namespace ugvr
