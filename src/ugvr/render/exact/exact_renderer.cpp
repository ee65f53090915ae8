#include "ugvr/render/exact/exact_renderer.h"

#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/threads.h"
#include "ugvr/render/field_histogram.h"

namespace ugvr {

namespace {
// Smallest scale while moving: below this the picture says too little to steer by.
constexpr double kMinScale = 0.1;

ExactEngine build_engine(const Dataset& dataset, const ProgressCallback& progress) {
  if (progress && !progress("walk mesh", 0)) fail_in("exact engine", "cancelled");
  ExactEngine engine(dataset);
  if (progress && !progress("walk mesh", 1)) fail_in("exact engine", "cancelled");
  return engine;
}
}  // namespace

ExactScene::ExactScene(std::shared_ptr<const Dataset> data, const ProgressCallback& progress)
    : dataset(std::move(data)), engine(build_engine(*dataset, progress)) {}

ExactScene::ExactScene(std::shared_ptr<const TimeSeries> s, uint32_t i, const ProgressCallback& progress)
    : dataset(std::make_shared<const Dataset>(read_time_step(*s, i))),
      engine(build_engine(*dataset, progress)),
      series(std::move(s)),
      step(i) {
  if (series->geometry == SeriesGeometry::Detect) geometry = geometry_fingerprint(*dataset);
}

void ExactScene::prefetch(uint32_t i) {
  if (!series || i >= series->size() || (ahead && ahead->first == i)) return;
  if (ahead) ahead->second.wait();  // one read at a time
  const std::shared_ptr<const TimeSeries> s = series;
  ahead.emplace(i, std::async(std::launch::async, [s, i] {
                  Prefetched p;
                  p.dataset = std::make_shared<const Dataset>(read_time_step(*s, i));
                  if (s->geometry == SeriesGeometry::Detect) p.fingerprint = geometry_fingerprint(*p.dataset);
                  return p;
                }));
}

void ExactScene::set_step(uint32_t i, const ProgressCallback& progress) {
  if (!series) fail_in("exact engine", "a time step needs a time series (the input has one step)");
  if (i == step) return;
  const auto t0 = std::chrono::steady_clock::now();
  const bool detect = series->geometry == SeriesGeometry::Detect;
  Prefetched read;
  if (ahead && ahead->first == i) {
    auto f = std::move(ahead->second);
    ahead.reset();
    read = f.get();  // rethrows the read's error
  } else {
    read.dataset = std::make_shared<const Dataset>(read_time_step(*series, i));
    if (detect) read.fingerprint = geometry_fingerprint(*read.dataset);
  }
  auto next = std::move(read.dataset);
  const uint64_t fingerprint = read.fingerprint;
  const bool same = !detect || fingerprint == geometry;
  if (!same) {
    // Another mesh, built before anything is replaced (a failure leaves the scene on its step). The GPU engine holds a
    // reference to the old walk mesh, so it goes before the swap and is remade on the new one.
    ExactEngine built = build_engine(*next, progress);
    const bool had_gpu = gpu_engine != nullptr;
    gpu_engine.reset();
    engine = std::move(built);
    if (had_gpu) gpu_engine = std::make_unique<ExactGpuEngine>(engine.walk_mesh(), gpu_gl, gpu_options);
    geometry = fingerprint;
    ++rebuilds;
  } else {
    ++swaps;
  }
  dataset = std::move(next);
  step = i;
  // The values come from the new step's dataset: rebind whatever was bound.
  const std::optional<std::string> selector = bound;
  bound.reset();
  gpu_bound.reset();
  if (selector) bind(*selector);
  last_switch_rebuilt = !same;
  last_switch_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void ExactScene::bind(const std::string& selector) {
  if (bound && *bound == selector) return;
  engine.set_field(*dataset, selector);
  bound = selector;
}

ExactGpuEngine& ExactScene::gpu(std::shared_ptr<const GlContext> gl, const ExactGpuOptions& options) {
  if (!gpu_engine) {
    gpu_engine = std::make_unique<ExactGpuEngine>(engine.walk_mesh(), gl, options);
    gpu_gl = std::move(gl);
    gpu_options = options;
    gpu_bound.reset();
  }
  return *gpu_engine;
}

bool ExactScene::use_gpu_if_it_pays(std::shared_ptr<const GlContext> gl, const ExactGpuOptions& options) {
  if (gpu_engine) return true;
  if (!gpu_unavailable.empty()) return false;
  if (gl->software()) {
    gpu_unavailable = "only a software renderer (" + gl->renderer() + "), slower than the CPU engine";
    return false;
  }
  try {
    gpu(std::move(gl), options);
    return true;
  } catch (const Error& e) {
    gpu_unavailable = e.what();
    return false;
  }
}

void ExactScene::bind_gpu(const std::string& selector) {
  bind(selector);
  if (gpu_bound && *gpu_bound == selector) return;
  gpu_engine->set_values(engine.bound_values(), engine.per_cell());
  gpu_bound = selector;
}

void ExactFrameStats::to_json(nlohmann::json& j) const {
  j["rays"] = render.rays;
  j["rays_hit"] = render.rays_hit;
  j["cell_steps"] = render.cell_steps;
  j["reentries"] = render.reentries;
  j["nonlinear_samples"] = render.nonlinear_samples;
  j["lost_rays"] = render.lost_rays;
}

ExactRenderer::ExactRenderer(std::shared_ptr<ExactScene> scene, bool on_gpu)
    : scene_(std::move(scene)), on_gpu_(on_gpu) {
  if (on_gpu_ && !scene_->gpu_engine) fail_in("exact engine", "no GPU engine in the scene (call ExactScene::gpu)");
  scene_->bind(field_);
}

std::string ExactRenderer::device() const {
  if (on_gpu_) return "GPU, " + scene_->gpu_engine->gl().renderer();
  return "CPU, " + std::to_string(worker_threads()) + " threads";
}

void ExactRenderer::set_field(std::string_view name) {
  scene_->bind(std::string(name));
  field_ = name;
}

const std::string& ExactRenderer::field_name() const {
  scene_->bind(field_);
  return scene_->engine.field_name();
}

FieldRange ExactRenderer::field_range() const {
  scene_->bind(field_);
  return {scene_->engine.field_min(), scene_->engine.field_max()};
}

Bounds ExactRenderer::bounds() const { return scene_->engine.bounds(); }

std::vector<uint64_t> ExactRenderer::value_histogram(double lo, double hi, int bins) const {
  const std::string& selector = field_name();
  std::vector<uint64_t> counts(size_t(std::max(bins, 0)), 0);
  for (const Block& b : scene_->dataset->blocks) {
    const ScalarRef ref = b.fields.scalar(selector);
    const std::vector<uint64_t> block = field_histogram(*ref.field, ref.component, lo, hi, bins);
    for (size_t i = 0; i < counts.size(); ++i) counts[i] += block[i];
  }
  return counts;
}

Frame ExactRenderer::render(const FrameRequest& request) {
  if (request.time_step) scene_->set_step(*request.time_step);
  if (request.settings.field != field_) set_field(request.settings.field);
  scene_->bind(field_);
  const bool resting = last_ && last_->camera == request.camera && last_->tf == request.tf &&
                       last_->settings == request.settings && last_->time_step == request.time_step;
  last_ = request;
  const bool full = request.target_fps <= 0 || resting || request.full_quality;
  const int w = request.settings.width, h = request.settings.height;
  auto detail = std::make_shared<ExactFrameStats>();
  Frame f;
  f.stats.engine = "exact";
  f.stats.resting = resting;
  f.stats.scale = full ? 1.0 : scale_;
  RenderSettings rs = request.settings;
  rs.width = std::max(1, int(std::lround(w * f.stats.scale)));
  rs.height = std::max(1, int(std::lround(h * f.stats.scale)));
  Image image;
  if (on_gpu_) {
    scene_->bind_gpu(field_);
    image = scene_->gpu_engine->render(request.camera, request.tf, rs, scene_->engine.tolerance_abs(request.tf),
                                       &detail->render);
  } else {
    image = scene_->engine.render(request.camera, request.tf, rs, &detail->render);
  }
  f.stats.seconds = detail->render.render_seconds;
  if (full) {
    f.image = std::move(image);
  } else {
    f.image = resize_bilinear(image, w, h);
    if (f.stats.seconds > 0) {
      // Time grows with the pixel count: scale by the square root of the ratio, damped against timing noise.
      const double ideal = f.stats.scale * std::sqrt((1.0 / request.target_fps) / f.stats.seconds);
      scale_ = std::clamp(0.5 * (scale_ + ideal), kMinScale, 1.0);
    }
  }
  f.stats.converged = full;
  f.stats.samples = detail->render.cell_steps;
  f.stats.detail = std::move(detail);
  return f;
}

void ExactRenderer::describe(nlohmann::json& j) const {
  const ExactEngine& e = scene_->engine;
  const uint64_t cells = e.cell_count();
  j["cells"] = cells;
  j["points"] = e.point_count();
  j["build_seconds"] = e.build_seconds();
  j["engine_bytes"] = e.memory_bytes();
  j["engine_bytes_per_cell"] = cells ? double(e.memory_bytes()) / double(cells) : 0.0;
  j["device"] = device();
  if (scene_->series) {
    j["time_steps"] = scene_->series->size();
    j["time_step"] = scene_->step;
    j["time_step_swaps"] = scene_->swaps;
    j["time_step_rebuilds"] = scene_->rebuilds;
  }
  if (!on_gpu_ && !scene_->gpu_unavailable.empty()) j["gpu_unavailable"] = scene_->gpu_unavailable;
  if (on_gpu_) {
    const ExactGpuEngine& g = *scene_->gpu_engine;
    j["device_bytes"] = g.device_bytes();
    j["device_mesh_bytes"] = g.mesh_device_bytes();
    j["device_bytes_per_cell"] = cells ? double(g.device_bytes()) / double(cells) : 0.0;
    j["device_mesh_bytes_per_cell"] = cells ? double(g.mesh_device_bytes()) / double(cells) : 0.0;
    j["boundary_bin_seconds"] = g.last_bin_seconds();
    j["gpu_seconds"] = g.last_gpu_seconds();
  }
}

std::string ExactRenderer::summary(const FrameStats& last) const {
  const ExactEngine& e = scene_->engine;
  const auto* d = dynamic_cast<const ExactFrameStats*>(last.detail.get());
  const ExactRenderStats st = d ? d->render : ExactRenderStats{};
  char buf[256];
  std::snprintf(buf, sizeof buf, "%llu cells, build %.3f s, %llu of %llu rays hit, engine %s%s%s",
                (unsigned long long)e.cell_count(), e.build_seconds(), (unsigned long long)st.rays_hit,
                (unsigned long long)st.rays, format_bytes(e.memory_bytes()).c_str(), on_gpu_ ? ", on the GPU " : "",
                on_gpu_ ? format_bytes(scene_->gpu_engine->device_bytes()).c_str() : "");
  std::string s = buf;
  if (st.lost_rays > 0) s += "\nwarning: " + std::to_string(st.lost_rays) + " rays were abandoned on a degenerate walk";
  return s;
}

}  // namespace ugvr
