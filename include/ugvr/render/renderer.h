// The one interface every engine implements, and every front end (the CLI, the viewer, benchmarks, later Python and
// MPI) draws through: bind a field, say what the data covers, render a frame request into an image and one typed stats
// struct. Engines: the exact CPU ray caster (render/exact/exact_renderer.h) and the level-of-detail GPU ray caster,
// one cut per frame or as a time-critical session (render/lod/lod_renderer.h); renderer_factory.h makes them by name.
//
// A renderer is used from one thread at a time (a LOD renderer from the thread its GL context is current on).
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/vec.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

// What one frame shows.
struct FrameRequest {
  Camera camera;
  TransferFunction tf;
  // Image size, mode, clip plane, ...; settings.field names the field to draw (a FieldSet selector for a mesh, a
  // store's field name; empty: the renderer's default, its first field).
  RenderSettings settings;
  // Interactive renderers hold this frame rate while the view moves, by drawing less (a coarser cut, a smaller
  // image), and converge to full quality once the view rests; 0: every frame at full quality. Renderers that are not
  // interactive draw every frame at full quality and ignore it.
  double target_fps = 0;
  // Converge in this frame (refine, wait for data) whatever the target.
  bool full_quality = false;
  // Level of detail: the sample step at rest, in voxels of each node (0: the renderer's own option); while the view
  // moves an interactive renderer steps at least a voxel. The exact engine integrates cells exactly and ignores it.
  double step_voxels = 0;
  // Reserved for time series (the [time] issue): a renderer without time steps rejects a value here.
  std::optional<uint32_t> time_step;
  // Playing a time series: the step likely drawn next. An interactive renderer of a time store starts reading its
  // bricks for the nodes this frame drew, in the background, so that the switch costs no disk read; others ignore it.
  std::optional<uint32_t> prefetch_time_step;
  // Interactive front ends (the viewer): a long frame (a resting one: full quality, exact cells) is abandoned as soon
  // as this returns false, because the view it shows has changed meanwhile; the renderer then throws FrameInterrupted
  // and leaves its session ready for the next request. It is asked between parts of the image (bands of rows on the
  // GPU, tiles on the CPU, pieces of a partitioned store), from any thread: it must be cheap and thread-safe (an
  // atomic load). Empty (the default): the frame is drawn whole, in one dispatch, exactly as before.
  std::function<bool()> keep_going;
};

// A frame abandoned because FrameRequest::keep_going returned false. Not a failure: nothing is drawn or reported.
class FrameInterrupted : public Error {
 public:
  FrameInterrupted() : Error("the frame was interrupted: its view changed while it was drawn") {}
};

// What an engine reports beyond the common figures (its counters and timings), written into --stats JSON.
struct EngineFrameStats {
  virtual ~EngineFrameStats() = default;
  virtual void to_json(nlohmann::json& j) const = 0;
};

// Every engine's figures for one frame.
struct FrameStats {
  std::string engine;     // "exact" or "lod"
  double seconds = 0;     // wall time, to the image in host memory
  bool converged = true;  // full quality for this request (false while an interactive renderer moves or refines)
  bool resting = false;   // interactive: the request is the one the previous frame showed
  double scale = 1;       // drawn at scale x the requested size, then magnified
  uint64_t samples = 0;   // volume samples (LOD) or cells entered (exact), over all rays
  // Level of detail (zero for the exact engine).
  uint64_t cut_nodes = 0, visible_nodes = 0;
  double texel_error = 0, max_texel_error = 0;  // screen size of a texel, mean and max, in pixels
  uint64_t ram_bytes = 0, ram_budget = 0;       // decoded bricks in RAM (an interactive session's cache)
  uint64_t gpu_bytes = 0, gpu_budget = 0;       // bricks in the GPU atlas
  uint64_t pending = 0;                         // bricks the refinement waits for
  std::shared_ptr<const EngineFrameStats> detail;
  // The common keys, then the engine's own.
  void to_json(nlohmann::json& j) const;
};

struct Frame {
  Image image;
  FrameStats stats;
};

struct FieldRange {
  double min = 0, max = 1;  // over the data, NaN excluded
};

// Long work inside a renderer (building the exact engine's walk mesh, waiting for bricks) reports here; returning
// false cancels it (ugvr::Error "cancelled"). Per renderer, unlike the process-wide progress bar (core/progress.h).
using ProgressCallback = std::function<bool(std::string_view stage, double fraction)>;

class Renderer {
 public:
  virtual ~Renderer() = default;
  // "exact" or "lod".
  virtual std::string_view engine() const = 0;
  // What draws: "CPU, N threads", or the GL renderer (GL_RENDERER).
  virtual std::string device() const = 0;
  // Binds a field (see FrameRequest::settings.field). Throws ugvr::Error listing the fields there are.
  virtual void set_field(std::string_view name) = 0;
  virtual const std::string& field_name() const = 0;
  virtual FieldRange field_range() const = 0;
  virtual Bounds bounds() const = 0;
  // Counts of the bound field's values in `bins` equal bins over [lo, hi] (values outside count in the end bins, NaN
  // is skipped), from what this renderer draws: a mesh's values, a store's coarse levels. The default transfer
  // function is built from it (default_transfer_function.h). Empty when the renderer cannot say. Under MPI a
  // collective call that gives every rank the same counts.
  virtual std::vector<uint64_t> value_histogram(double lo, double hi, int bins) const {
    (void)lo, (void)hi, (void)bins;
    return {};
  }
  // The box of the bound field's data that `tf` makes more than `threshold` opaque (render/visible_bounds.h: a mesh's
  // cells, a store's coarse nodes): empty Bounds when none is; nullopt when the renderer cannot say. The default
  // camera with the auto transfer function frames it. Under MPI a collective call that gives every rank the same box.
  virtual std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const {
    (void)tf, (void)threshold;
    return std::nullopt;
  }
  // The weights visible_bounds is made from, flattened (render/visible_bounds.h, VisibleWeights::flat): binned over
  // `over`, of the pieces whose centre lies in `own` (an MPI rank's kd-tree box), so that ranks add theirs up into
  // one process's. Empty when the renderer cannot say. Not a collective call.
  virtual std::vector<double> visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                              const Bounds& own) const {
    (void)tf, (void)threshold, (void)over, (void)own;
    return {};
  }
  // Renders request.settings.width x height, binding request.settings.field first when it differs. Throws
  // ugvr::Error for a request the engine cannot draw (a time step without a series, a cut over the GPU budget...).
  virtual Frame render(const FrameRequest& request) = 0;
  // Facts that do not change per frame, for --stats: cells and engine memory, or the store's nodes and the GL version.
  virtual void describe(nlohmann::json& j) const = 0;
  // The engine's part of `ugvr render`'s closing line, from its last frame.
  virtual std::string summary(const FrameStats& last) const = 0;
};

// Throws when a request asks for what no engine supports yet (a time step).
void check_supported(const FrameRequest& request, std::string_view engine);

}  // namespace ugvr
