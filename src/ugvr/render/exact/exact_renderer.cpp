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
#include "ugvr/render/banded_dispatch.h"
#include "ugvr/render/field_histogram.h"
#include "ugvr/render/visible_bounds.h"

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
    : ExactScene(s, i, std::make_shared<StepFieldReader>(s), progress) {}

ExactScene::ExactScene(std::shared_ptr<const TimeSeries> s, uint32_t i, std::shared_ptr<StepFieldReader> reader,
                       const ProgressCallback& progress)
    : dataset(std::make_shared<Dataset>(reader->read_whole(i))),
      engine(build_engine(*dataset, progress)),
      series(std::move(s)),
      step(i),
      step_reader_(std::move(reader)),
      dataset_spare_(true) {
  if (series->geometry == SeriesGeometry::Detect) geometry = geometry_fingerprint(*dataset);
}

namespace {

bool holds(const std::vector<std::vector<uint64_t>>& known, const std::optional<std::vector<uint64_t>>& keys) {
  return keys && std::find(known.begin(), known.end(), *keys) != known.end();
}

// Step `i` read as set_step takes it: fields only where the mesh is known to be the one held (`mesh_keys`: the stored
// geometry keys known to hold it), else whole (made non-const, so that its grids may later move to another step's
// fields) and fingerprinted where the series detects its geometry.
ExactScene::Prefetched read_step(const TimeSeries& series, StepFieldReader& reader, uint32_t i,
                                 const std::vector<std::vector<uint64_t>>& mesh_keys) {
  ExactScene::Prefetched p;
  if (reader.static_by_format()) {
    p.fields = reader.read(i);
    return p;
  }
  const bool detect = series.geometry == SeriesGeometry::Detect;
  // Keys decide wherever the mesh's files have them: a series that detects its geometry, and one static by its format
  // whose reads would all read the same mesh file again (PLOT3D's grid, unchanged since it was read).
  if (!mesh_keys.empty()) {
    p.keys = reader.geometry_keys(i);
    if (holds(mesh_keys, p.keys)) {
      p.fields = reader.read(i);
      return p;
    }
  }
  p.dataset = std::make_shared<Dataset>(reader.read_whole(i));
  if (detect) p.fingerprint = geometry_fingerprint(*p.dataset);
  return p;
}

}  // namespace

StepFieldReader& ExactScene::step_reader() {
  if (!step_reader_) step_reader_ = std::make_shared<StepFieldReader>(series);
  return *step_reader_;
}

const std::vector<std::vector<uint64_t>>& ExactScene::mesh_keys() {
  if (!mesh_keys_) {
    mesh_keys_.emplace();
    if (auto keys = step_reader().geometry_keys(step)) mesh_keys_->push_back(std::move(*keys));
  }
  return *mesh_keys_;
}

void ExactScene::prefetch(uint32_t i) {
  if (!series || i >= series->size() || (ahead && ahead->first == i)) return;
  if (ahead) ahead->second.wait();  // one read at a time
  const std::shared_ptr<const TimeSeries> s = series;
  step_reader();
  std::shared_ptr<StepFieldReader> reader = step_reader_;
  ahead.emplace(i, std::async(std::launch::async,
                              [s, reader, i, known = mesh_keys()] { return read_step(*s, *reader, i, known); }));
}

void ExactScene::set_step(uint32_t i, const ProgressCallback& progress) {
  if (!series) fail_in("exact engine", "a time step needs a time series (the input has one step)");
  if (i == step) return;
  const auto t0 = std::chrono::steady_clock::now();
  Prefetched read;
  if (ahead && ahead->first == i) {
    auto f = std::move(ahead->second);
    ahead.reset();
    read = f.get();  // rethrows the read's error
    // Read for the mesh held then: another step shown since (and rebuilt) makes it a step to read again.
    if (read.fields && !step_reader().static_by_format() && !holds(mesh_keys(), read.keys)) read = Prefetched{};
  }
  if (!read.fields && !read.dataset) read = read_step(*series, step_reader(), i, mesh_keys());
  const bool same = take_step(std::move(read), progress);
  step = i;
  // The values come from the new step's dataset: rebind whatever was bound.
  const std::optional<std::string> selector = bound;
  bound.reset();
  gpu_bound.reset();
  if (selector) bind(*selector);
  last_switch_rebuilt = !same;
  last_switch_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool ExactScene::take_step(Prefetched read, const ProgressCallback& progress) {
  if (read.fields) {
    // The mesh held is the step's: its grids go to the step's fields, moved when nobody else holds this dataset (the
    // object was made non-const here, so moving out of it through the const pointer is sound), else copied.
    Dataset next = dataset_spare_ && dataset.use_count() == 1
                       ? with_grids_of(std::move(const_cast<Dataset&>(*dataset)), std::move(*read.fields))
                       : with_grids_of(*dataset, std::move(*read.fields));
    dataset = std::make_shared<Dataset>(std::move(next));
    dataset_spare_ = true;
    ++swaps;
    ++fields_only;
    return true;
  }
  const bool same = series->geometry != SeriesGeometry::Detect || read.fingerprint == geometry;
  if (!same) {
    // Another mesh, built before anything is replaced (a failure leaves the scene on its step). The GPU engine holds a
    // reference to the old walk mesh, so it goes before the swap and is remade on the new one.
    ExactEngine built = build_engine(*read.dataset, progress);
    const bool had_gpu = gpu_engine != nullptr;
    gpu_engine.reset();
    engine = std::move(built);
    if (had_gpu) gpu_engine = std::make_unique<ExactGpuEngine>(engine.walk_mesh(), gpu_gl, gpu_options);
    geometry = read.fingerprint;
    mesh_keys_.reset();  // the new step's, when next needed (unless read below)
    ++rebuilds;
  } else {
    ++swaps;
  }
  // Keys of files now known to hold the mesh: later steps stored as they are read without it.
  if (read.keys && !holds(mesh_keys_.value_or(std::vector<std::vector<uint64_t>>{}), read.keys)) {
    if (!mesh_keys_) mesh_keys_.emplace();
    mesh_keys_->push_back(std::move(*read.keys));
  }
  dataset = std::move(read.dataset);
  dataset_spare_ = true;
  return same;
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
  j["cpu_traced_rays"] = render.cpu_traced_rays;
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
  // Volume-weighted (field_histogram.h): the blocks' weights and counts summed, then scaled once, so that a block
  // counts by its volume, not by its number of points.
  const std::string& selector = field_name();
  std::vector<uint64_t> counts(size_t(std::max(bins, 0)), 0);
  std::vector<double> weights(counts.size(), 0.0);
  for (const Block& b : scene_->dataset->blocks) {
    const ScalarRef ref = b.fields.scalar(selector);
    const std::vector<uint64_t> block = field_histogram(*ref.field, ref.component, lo, hi, bins);
    const std::vector<double> w = volume_weights(b.grid, *ref.field, ref.component, lo, hi, bins);
    for (size_t i = 0; i < counts.size(); ++i) counts[i] += block[i], weights[i] += w[i];
  }
  return weighted_counts(weights, counts);
}

std::optional<Bounds> ExactRenderer::visible_bounds(const TransferFunction& tf, double threshold) const {
  scene_->bind(field_);
  return visible_cell_bounds(scene_->engine, tf, threshold);
}

std::vector<double> ExactRenderer::visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                                   const Bounds& own) const {
  scene_->bind(field_);
  return visible_cell_weights(scene_->engine, tf, threshold, over, own).flat();
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
  try {
    if (on_gpu_) {
      scene_->bind_gpu(field_);
      const ScopedKeepGoing keep(*scene_->gpu_engine, request.keep_going);
      image = scene_->gpu_engine->render(request.camera, request.tf, rs, scene_->engine.tolerance_abs(request.tf),
                                         &detail->render);
    } else {
      const ScopedKeepGoing keep(scene_->engine, request.keep_going);
      image = scene_->engine.render(request.camera, request.tf, rs, &detail->render);
    }
  } catch (const FrameInterrupted&) {
    last_.reset();  // not shown: the next request is not "resting" on it
    throw;
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
    j["time_step_fields_only"] = scene_->fields_only;
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
  if (st.cpu_traced_rays > 0)
    s += "\nnote: " + std::to_string(st.cpu_traced_rays) +
         " rays traced on the CPU: the device's loop limit (llvmpipe) cut them short on the GPU";
  return s;
}

}  // namespace ugvr
