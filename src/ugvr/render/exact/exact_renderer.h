// The exact engine (exact_engine.h) behind the renderer interface (render/renderer.h).
//
// One ExactScene (a dataset and its walk mesh, built once) can serve several renderers: the viewer gives every tab its
// own, with its own adaptive image scale, over one walk mesh. The scene's engine binds one field at a time; a
// renderer binds the field its request names before drawing, so tabs on different fields take turns.
//
// Time series (io/time_series.h): a scene made from a series shows one step at a time. FrameRequest::time_step switches
// it: the step is read, and when its geometry is the mesh's (known static by the format, or equal geometry
// fingerprints) only the field values are swapped on the walk mesh built once; a step with other geometry rebuilds the
// walk mesh (and the GPU engine's copy). A scene without a series rejects a time step.
//
// Interactive (a request with target_fps > 0): while the view moves, frames are drawn at a reduced scale that follows
// the frame-rate target (sqrt(target time / measured time), damped, in [0.1, 1]) and magnified; the frame after the
// view comes to rest, or one asked for at full quality, is the full-size exact image (converged).
#pragma once
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/exact/exact_gpu_engine.h"
#include "ugvr/render/renderer.h"

namespace ugvr {

struct ExactScene {
  // Builds the walk mesh (seconds for millions of cells); `progress` sees the stage and may cancel.
  explicit ExactScene(std::shared_ptr<const Dataset> dataset, const ProgressCallback& progress = {});
  // The scene of a series, showing step `step` (read here, through the series' StepFieldReader, which keeps what later
  // fields-only reads need of the mesh: an OpenFOAM case's layout).
  ExactScene(std::shared_ptr<const TimeSeries> series, uint32_t step, const ProgressCallback& progress = {});
  std::shared_ptr<const Dataset> dataset;
  ExactEngine engine;
  std::optional<std::string> bound;  // the selector bound now
  void bind(const std::string& selector);

  // The series and the step shown (null: one dataset, no time axis).
  std::shared_ptr<const TimeSeries> series;
  uint32_t step = 0;
  uint64_t geometry = 0;  // geometry_fingerprint of the dataset (computed only where the series must detect it)
  // What the step switches did: field swaps on the same walk mesh (`fields_only` of them read without the mesh:
  // io/step_fields.h), walk-mesh rebuilds, and the last switch's seconds (reading the step included) and whether it
  // rebuilt.
  uint64_t swaps = 0, rebuilds = 0, fields_only = 0;
  double last_switch_seconds = 0;
  bool last_switch_rebuilt = false;
  // Shows step `i` (no-op when shown); throws ugvr::Error without a series or for a step out of range. A step whose
  // mesh is known to be the one shown (static by format, or stored geometry keys equal to the mesh's) is read fields
  // only and put on the mesh held; any other is read whole and compared by geometry fingerprint.
  void set_step(uint32_t i, const ProgressCallback& progress = {});
  // Reads step `i` (fields only, or whole and fingerprinted, as set_step would) on another thread, so that set_step(i)
  // finds it read: playback reads the next step while this one renders. One step ahead; another prefetch waits for
  // this one first. A read error surfaces in set_step(i).
  void prefetch(uint32_t i);
  // The series' fields-only reads (made on first use: the viewer sets `series` after constructing the scene); a pass
  // over other steps' values (`ugvr render --time all`'s range) shares it, and with it the mesh's kept layout.
  StepFieldReader& step_reader();
  // Makes `reader` the scene's: the reader that read the scene's dataset whole (read_whole) keeps its mesh's layout.
  void use_step_reader(std::shared_ptr<StepFieldReader> reader) { step_reader_ = std::move(reader); }
  struct Prefetched {
    std::optional<std::vector<uint64_t>> keys;  // the step's stored geometry keys, where its files have them
    std::optional<StepFields> fields;           // read without the mesh (static by format, or `keys` matched)
    std::shared_ptr<const Dataset> dataset;     // read whole otherwise
    uint64_t fingerprint = 0;
  };
  std::optional<std::pair<uint32_t, std::future<Prefetched>>> ahead;

  // The GPU engine over the same walk mesh, made on first use; its field follows the CPU engine's binding.
  std::unique_ptr<ExactGpuEngine> gpu_engine;
  std::optional<std::string> gpu_bound;     // the selector whose values the GPU holds
  std::string gpu_unavailable;              // why `--device auto` stayed on the CPU (empty: it did not try)
  std::shared_ptr<const GlContext> gpu_gl;  // what the GPU engine was made with, to remake it for a new mesh
  ExactGpuOptions gpu_options;
  // Makes the GPU engine on `gl` (throws ugvr::Error when the mesh does not fit or GL fails).
  ExactGpuEngine& gpu(std::shared_ptr<const GlContext> gl, const ExactGpuOptions& options);
  // `--device auto`: the GPU engine on `gl` when it is hardware and the mesh fits there (llvmpipe is slower than the
  // CPU engine). Otherwise records why in gpu_unavailable, once (a scene that failed does not try again), and
  // returns false: the CPU engine serves. Never throws.
  bool use_gpu_if_it_pays(std::shared_ptr<const GlContext> gl, const ExactGpuOptions& options);
  void bind_gpu(const std::string& selector);

 private:
  ExactScene(std::shared_ptr<const TimeSeries> series, uint32_t step, std::shared_ptr<StepFieldReader> reader,
             const ProgressCallback& progress);
  // Stored geometry key lists known to hold the mesh shown (those of a step read whole with the mesh's fingerprint
  // join them, and in a series static by its format, PLOT3D's, those of any step read whole); nullopt until first
  // needed, then those of the step shown.
  const std::vector<std::vector<uint64_t>>& mesh_keys();
  // Takes a read step: on the mesh held (returns true) or, with other geometry, a rebuilt walk mesh (false).
  bool take_step(Prefetched read, const ProgressCallback& progress);

  std::shared_ptr<StepFieldReader> step_reader_;
  std::optional<std::vector<std::vector<uint64_t>>> mesh_keys_;
  bool dataset_spare_ = false;  // `dataset` was made here, non-const: its grids may move to the next step's
};

// The exact engine's own figures for --stats.
struct ExactFrameStats : EngineFrameStats {
  ExactRenderStats render;
  void to_json(nlohmann::json& j) const override;
};

class ExactRenderer final : public Renderer {
 public:
  // On the CPU engine, or on the scene's GPU engine (made with scene->gpu() before).
  explicit ExactRenderer(std::shared_ptr<ExactScene> scene, bool on_gpu = false);
  std::string_view engine() const override { return "exact"; }
  std::string device() const override;
  void set_field(std::string_view name) override;
  const std::string& field_name() const override;
  FieldRange field_range() const override;
  Bounds bounds() const override;
  // Over the scene's dataset (the shown step of a series; the whole mesh read, not the part a rank keeps).
  std::vector<uint64_t> value_histogram(double lo, double hi, int bins) const override;
  // Over the cells the engine holds (a rank's part under MPI, which MpiRenderer unites).
  std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const override;
  std::vector<double> visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                      const Bounds& own) const override;
  Frame render(const FrameRequest& request) override;
  void describe(nlohmann::json& j) const override;
  std::string summary(const FrameStats& last) const override;

 private:
  std::shared_ptr<ExactScene> scene_;
  bool on_gpu_ = false;
  std::string field_;                 // this renderer's selector ("" until set: the dataset's first field)
  double scale_ = 0.5;                // interactive image scale while moving
  std::optional<FrameRequest> last_;  // the request the previous frame showed (resting = the same again)
};

}  // namespace ugvr
