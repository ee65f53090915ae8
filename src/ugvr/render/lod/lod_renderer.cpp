#include "ugvr/render/lod/lod_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>

#include "ugvr/core/memory.h"
#include "ugvr/render/banded_dispatch.h"
#include "ugvr/render/field_histogram.h"
#include "ugvr/render/visible_bounds.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

namespace {

// A store field name from a renderer's selector. "" is the first field whose range is not constant (the store's first
// when none varies): a constant field draws a blank-looking image. A vector's name alone ("velocity") is its magnitude
// ("velocity:magnitude", the name `ugvr build` gives it), as on a mesh (FieldSet::scalar). Any other name is the
// store's own, checked by LodEngine::set_field.
std::string resolve_field(const LodEngine& engine, const std::string& name) {
  const BrickStoreReader& store = engine.store();
  if (name.empty()) {
    for (const BrickStoreField& f : store.layout().fields)
      if (f.max > f.min) return f.name;
    return store.layout().fields.front().name;
  }
  const std::string magnitude = name + ":magnitude";
  if (store.field_index(name) < 0 && store.field_index(magnitude) >= 0) return magnitude;
  return name;
}

void bind_field(LodEngine& engine, const std::string& name) {
  const std::string field = resolve_field(engine, name);
  if (engine.field_name() != field) engine.set_field(field);
}

nlohmann::json unlimited_or(uint64_t v) {
  return v == std::numeric_limits<uint64_t>::max() ? nlohmann::json(nullptr) : nlohmann::json(v);
}

// How much of the frame was exact (hybrid rendering), as the object "hybrid"; nothing when hybrid is off.
void hybrid_json(const LodRenderStats& st, nlohmann::json& j) {
  if (!st.hybrid) return;
  nlohmann::json h;
  h["off"] = st.hybrid_off.empty() ? nlohmann::json(nullptr) : nlohmann::json(st.hybrid_off);
  h["candidates"] = st.exact_candidates;
  h["focus_excluded"] = st.focus_excluded;
  h["exact_nodes"] = st.exact_nodes;
  h["exact_fraction"] = st.cut_nodes ? double(st.exact_nodes) / double(st.cut_nodes) : 0.0;
  h["exact_cells"] = st.exact_cells;
  h["cell_bytes"] = st.cell_bytes;
  h["cell_budget_bytes"] = st.cell_budget_bytes;
  h["cell_budget_full"] = st.cell_budget_full;
  h["cells_prepared"] = st.cells_prepared;
  h["cells_swapped"] = st.cells_swapped;
  h["cells_seconds"] = st.cells_seconds;
  h["cell_steps"] = st.cell_steps;
  j["hybrid"] = std::move(h);
}

}  // namespace

LodScene::LodScene(const std::string& store_path, std::shared_ptr<const GlContext> context, LodOptions lod_options)
    : gl(std::move(context)), options(lod_options), engine(store_path, *gl, lod_options) {}

void LodFrameStats::to_json(nlohmann::json& j) const {
  const LodRenderStats& st = render;
  j["cut"] = cut_spec_name(cut);
  j["cut_nodes"] = st.cut_nodes;
  j["loop_limit_rays"] = st.loop_limit_rays;
  j["loop_limit_voxel_rays"] = st.loop_limit_voxel_rays;
  j["face_passes"] = st.face_passes;
  j["cut_max_level"] = st.max_level;
  j["cut_mean_level"] = st.mean_level;
  j["culled_frustum"] = st.culled_frustum;
  j["culled_tf"] = st.culled_tf;
  j["budget_limited"] = st.budget_limited;
  j["bricks_loaded_last_frame"] = st.bricks_loaded;
  j["uploaded_bytes"] = st.uploaded_bytes;      // texels, and with tricubic the coefficients and margins
  j["neighbour_reads"] = st.neighbour_reads;    // tricubic: neighbours read for the prefilter (docs/tricubic.md)
  j["cubic_prefilters"] = st.cubic_prefilters;  // tricubic: bricks prefiltered, and those the coefficient cache had
  j["cubic_cache_hits"] = st.cubic_cache_hits;
  j["cubic_cache_bytes"] = st.cubic_cache_bytes;
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
  hybrid_json(st, j);
}

void InteractiveLodFrameStats::to_json(nlohmann::json& j) const {
  const TimeCriticalFrame& f = frame;
  j["seconds"] = f.seconds;
  j["resting"] = f.resting;
  j["converged"] = f.converged;
  j["memory_limited"] = f.memory_limited;
  j["scale"] = f.scale;
  j["budget_samples"] = unlimited_or(f.budget_samples);
  j["budget_nodes"] = unlimited_or(f.budget_nodes);
  j["cut_nodes"] = f.cut_nodes;
  j["visible_nodes"] = f.visible_nodes;
  j["splits"] = f.splits;
  j["merges"] = f.merges;
  j["max_texel_error"] = f.max_error;
  j["mean_texel_error"] = f.mean_error;
  j["uploads"] = f.uploads;
  j["uploaded_bytes"] = f.render.uploaded_bytes;  // texels, and with tricubic the coefficients and margins
  j["sync_reads"] = f.sync_reads;
  j["requested"] = f.requested;
  j["ram_hits"] = f.cache.hits;
  j["ram_misses"] = f.cache.misses;
  j["disk_reads"] = f.cache.loads_completed;
  j["disk_bytes"] = f.cache.bytes_read;
  j["ram_evictions"] = f.cache.evictions;
  j["ram_over_budget"] = f.cache.over_budget;
  j["ram_resident_bytes"] = f.cache.resident_bytes;
  j["gpu_seconds"] = f.render.gpu_seconds;
  j["gpu_timer_seconds"] = f.render.gpu_timer_seconds;
  j["samples"] = f.render.samples;
  // Where the frame's time went besides the draw: the cut's update, the bricks' upload (with reads on this thread),
  // the read-back; and, playing a time store, the step switch (docs/time-series.md).
  j["cut_seconds"] = f.cut_seconds;
  j["load_seconds"] = f.render.load_seconds;
  j["readback_seconds"] = f.render.readback_seconds;
  j["playing"] = f.playing;
  if (f.switched) {
    j["prefetched"] = f.prefetched;
    j["switch_cut_before"] = f.switch_cut_before;
    j["switch_cut_after"] = f.switch_cut_after;
  }
  hybrid_json(f.render, j);
}

// --- shared by both forms

void LodRendererBase::set_field(std::string_view name) {
  bind_field(scene_->engine, std::string(name));
  field_ = name;
}

const std::string& LodRendererBase::field_name() const {
  bind_field(scene_->engine, field_);
  return scene_->engine.field_name();
}

FieldRange LodRendererBase::field_range() const {
  bind_field(scene_->engine, field_);
  return {scene_->engine.field_min(), scene_->engine.field_max()};
}

std::vector<uint64_t> LodRendererBase::value_histogram(double lo, double hi, int bins) const {
  const BrickStoreReader& store = scene_->engine.store();
  const int field = store.field_index(field_name());
  if (field < 0) return {};
  return store_histogram(store, uint32_t(field), lo, hi, bins, kCoarseHistogramLevel);
}

std::optional<Bounds> LodRendererBase::visible_bounds(const TransferFunction& tf, double threshold) const {
  return visible_node_bounds(scene_->engine.store(), field_name(), tf, threshold);
}

std::vector<double> LodRendererBase::visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                                     const Bounds& own) const {
  const BrickStoreReader& store = scene_->engine.store();
  const int field = store.field_index(field_name());
  if (field < 0) return {};
  return visible_node_weights(store, uint32_t(field), tf, threshold, kVisibleLevel, over, own).flat();
}

void LodRendererBase::describe(nlohmann::json& j) const {
  j["renderer"] = scene_->gl->renderer();
  j["gl_version"] = scene_->gl->version();
  j["nodes"] = scene_->engine.node_count();
  j["brick_resolution"] = scene_->engine.resolution();
}

LodEngine& LodRendererBase::bind_request(const FrameRequest& request) {
  check_supported(request, "lod");
  if (request.settings.field != field_) set_field(request.settings.field);
  bind_field(scene_->engine, field_);  // another renderer of the scene may have bound another
  // A time store's step (a store of one step has step 0 alone: the engine refuses others); kept until a request names
  // another.
  if (request.time_step) time_step_ = *request.time_step;
  scene_->engine.set_time_step(time_step_);
  return scene_->engine;
}

// --- one cut per frame

LodRenderer::LodRenderer(std::shared_ptr<LodScene> scene, CutSpec cut) : LodRendererBase(std::move(scene)), cut_(cut) {}

Frame LodRenderer::render(const FrameRequest& request) {
  LodEngine& engine = bind_request(request);
  // The scene may be shared with a renderer that changed the step.
  engine.set_step_voxels(request.step_voxels > 0 ? request.step_voxels : scene_->options.step_voxels);
  auto detail = std::make_shared<LodFrameStats>();
  detail->cut = cut_;
  Frame f;
  const ScopedKeepGoing keep(engine, request.keep_going);
  f.image = engine.render(request.camera, request.tf, request.settings, cut_, &detail->render);
  const LodRenderStats& st = detail->render;
  f.stats.engine = std::string(this->engine());
  f.stats.seconds = st.render_seconds;
  f.stats.samples = st.samples;
  f.stats.cut_nodes = st.cut_nodes;
  f.stats.visible_nodes = st.cut_nodes;
  f.stats.gpu_bytes = st.atlas_bytes;
  f.stats.gpu_budget = scene_->options.atlas_budget_bytes;
  f.stats.detail = std::move(detail);
  return f;
}

std::string LodRenderer::summary(const FrameStats& last) const {
  const auto* d = dynamic_cast<const LodFrameStats*>(last.detail.get());
  const LodRenderStats st = d ? d->render : LodRenderStats{};
  char buf[512];
  std::snprintf(buf, sizeof buf, "cut %s: %llu nodes (levels <= %d, mean %.2f%s), GPU %.3f s, atlas %s, %s",
                cut_spec_name(cut_).c_str(), (unsigned long long)st.cut_nodes, st.max_level, st.mean_level,
                st.budget_limited ? ", limited by --gpu-memory" : "", st.gpu_seconds,
                format_bytes(st.atlas_bytes).c_str(), scene_->gl->renderer().c_str());
  std::string out = buf;
  if (st.hybrid) {
    // How much is exact (hybrid rendering): nodes, of the candidates (visible nodes with cells), cells, memory.
    if (!st.hybrid_off.empty()) {
      out += "; no exact cells: " + st.hybrid_off;
    } else {
      std::snprintf(buf, sizeof buf,
                    "; exact %llu of %llu nodes with cells (%.1f%% of the cut), %llu cells, %s of %s%s",
                    (unsigned long long)st.exact_nodes, (unsigned long long)st.exact_candidates,
                    st.cut_nodes ? 100.0 * double(st.exact_nodes) / double(st.cut_nodes) : 0.0,
                    (unsigned long long)st.exact_cells, format_bytes(st.cell_bytes).c_str(),
                    format_bytes(st.cell_budget_bytes).c_str(),
                    st.cell_budget_full ? ", cell budget full (--gpu-cell-memory)" : "");
      out += buf;
      if (st.focus_excluded) out += ", " + std::to_string(st.focus_excluded) + " outside --focus / --roi resampled";
    }
  }
  if (st.loop_limit_rays > st.loop_limit_voxel_rays)
    out += "\nwarning: " + std::to_string(st.loop_limit_rays - st.loop_limit_voxel_rays) +
           " rays were cut short by the device's loop limit (llvmpipe: 65,535 loop iterations per 8 rays); their "
           "pixels hold what they had gathered (docs/hybrid.md, \"llvmpipe's loop limit\")";
  if (st.loop_limit_voxel_rays > 0)
    out += "\nnote: " + std::to_string(st.loop_limit_voxel_rays) +
           " exact rays were cut short by the device's loop limit (llvmpipe) and drawn from the voxels instead";
  return out;
}

// --- time-critical session

InteractiveLodRenderer::InteractiveLodRenderer(std::shared_ptr<LodScene> scene, TimeCriticalOptions options)
    : LodRendererBase(std::move(scene)), options_(options) {}

InteractiveLodRenderer::~InteractiveLodRenderer() = default;

Frame InteractiveLodRenderer::render(const FrameRequest& request) {
  LodEngine& engine = bind_request(request);
  const std::string field = engine.field_name();
  const double step = request.step_voxels > 0 ? request.step_voxels : options_.resting_step_voxels;
  // The session's RAM cache holds one time step's bricks (brick_cache.h): a new step swaps them (taking the prefetched
  // ones) and keeps the cut; a new field or sample step starts a new session.
  if (session_ && session_field_ == field && session_step_ == step && session_time_step_ != engine.time_step()) {
    session_->switch_time_step();
    session_time_step_ = engine.time_step();
  }
  if (!session_ || session_field_ != field || session_step_ != step || session_time_step_ != engine.time_step()) {
    TimeCriticalOptions tc = options_;
    tc.target_fps = request.target_fps;
    if (request.step_voxels > 0) {
      tc.resting_step_voxels = step;
      tc.moving_step_voxels = std::max(options_.moving_step_voxels, step);
    }
    session_.reset();  // its cache's threads end before the next one starts
    session_ = std::make_unique<TimeCriticalRenderer>(engine, tc);
    session_field_ = field, session_step_ = step, session_fps_ = request.target_fps;
    session_time_step_ = engine.time_step();
  }
  if (request.target_fps != session_fps_) session_->set_target_fps(request.target_fps);
  session_fps_ = request.target_fps;

  auto detail = std::make_shared<InteractiveLodFrameStats>();
  detail->brick_resolution = engine.resolution();
  TimeCriticalFrame& tf = detail->frame;
  Frame f;
  // Interrupted (FrameInterrupted from the engine's dispatch), the session keeps its cut and its last shown view: the
  // next request is a move from that view.
  const ScopedKeepGoing keep(engine, request.keep_going);
  f.image = request.full_quality ? session_->full_quality(request.camera, request.tf, request.settings, &tf)
                                 : session_->frame(request.camera, request.tf, request.settings, &tf);
  FrameStats& s = f.stats;
  s.engine = std::string(this->engine());
  s.seconds = tf.seconds;
  s.converged = tf.converged || request.full_quality;
  s.resting = tf.resting;
  s.scale = tf.scale;
  s.samples = tf.render.samples;
  s.cut_nodes = tf.cut_nodes, s.visible_nodes = tf.visible_nodes;
  s.texel_error = tf.mean_error, s.max_texel_error = tf.max_error;
  s.ram_bytes = tf.cache.resident_bytes, s.ram_budget = options_.ram_budget_bytes;
  s.gpu_bytes = tf.render.atlas_bytes, s.gpu_budget = scene_->options.atlas_budget_bytes;
  s.pending = tf.cache.queued + tf.cache.loading;
  s.detail = std::move(detail);
  if (request.prefetch_time_step && *request.prefetch_time_step < engine.store().step_count())
    session_->prefetch_time_step(*request.prefetch_time_step);
  return f;
}

bool InteractiveLodRenderer::wait_prefetch(double timeout_seconds) {
  return session_ && session_->wait_prefetch(timeout_seconds);
}

std::string InteractiveLodRenderer::summary(const FrameStats& last) const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "cut %llu nodes, texel error %.3f, %s", (unsigned long long)last.cut_nodes,
                last.texel_error, scene_->gl->renderer().c_str());
  return buf;
}

}  // namespace ugvr
