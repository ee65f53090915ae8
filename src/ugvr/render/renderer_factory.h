// Makes a renderer (render/renderer.h) by engine name, from files or from scenes already open.
//
// Errors a caller should attribute to one of its options (an unknown engine, a GPU that is not there, a field the
// data lacks, a cut spec that does not parse) are OptionError naming the option ("engine", "gpu", "field", "cut"), so
// each front end can say it in its own words (`--gpu` on the command line, `gpu=` in Python).
#pragma once
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/exact/exact_renderer.h"
#include "ugvr/render/lod/lod_renderer.h"
#include "ugvr/render/renderer.h"

namespace ugvr {

class OptionError : public Error {
 public:
  OptionError(std::string option_name, const std::string& message) : Error(message), option(std::move(option_name)) {}
  std::string option;  // "engine", "gpu", "field", "cut", ...
};

struct RendererOptions {
  std::string engine = "auto";  // "exact" (a mesh), "lod" (a .ugvr brick store), "auto": lod for a store, else exact
  // A session that holds FrameRequest::target_fps (the LOD engine: time-critical; the exact engine: adaptive scale).
  bool interactive = false;
  std::string field;  // bound at once (empty: the first field)
  // Exact engine: "cpu", "gpu" (the EGL device `gpu` names, llvmpipe included) or "auto" (a hardware GPU when there
  // is one and the mesh fits its memory, else the CPU engine, which outruns llvmpipe: docs/exact-engine.md).
  std::string device = "auto";
  ExactGpuOptions exact_gpu;
  // A GL context to use rather than open one (the viewer's, so that its engines share one context).
  std::shared_ptr<const GlContext> gl_context;
  // Level of detail.
  std::string gpu = "auto";           // EGL device index, or auto (the first GPU, else Mesa's llvmpipe)
  LodOptions lod;                     // GPU memory for bricks, sample step
  CutSpec cut;                        // not interactive: the cut every frame draws
  TimeCriticalOptions time_critical;  // interactive
  // Long work (reading aside): the walk mesh, ... Returning false cancels.
  ProgressCallback progress;
};

// The device names RendererOptions::device takes.
const std::vector<std::string>& device_names();
// The engine names RendererOptions::engine takes.
const std::vector<std::string>& engine_names();
bool is_brick_store(const std::string& path);  // a .ugvr, or a file with the store's signature (a build's preview)

// What open_renderer opened besides the renderer.
struct OpenedInput {
  std::vector<std::string> warnings;  // the reader's (ignored cells, padding, ...)
  // A mesh's dataset as read, whole (under MPI too, where each rank draws its part of it): what the viewer's
  // histograms are counted from. Set by mpi::open_renderer; null for a store.
  std::shared_ptr<const Dataset> dataset;
};

// Opens `inputs` (a mesh in any readable format, a PLOT3D grid + solution, or one .ugvr store) and makes the
// renderer options.engine names. Throws ugvr::Error (OptionError for an option's fault).
std::unique_ptr<Renderer> open_renderer(const std::vector<std::string>& inputs, const ReadOptions& read,
                                        const RendererOptions& options, OpenedInput* opened = nullptr);

// Renderers over scenes that are already open (several renderers may share one: the viewer's tabs).
std::unique_ptr<Renderer> make_renderer(std::shared_ptr<ExactScene> scene, const RendererOptions& options);
std::unique_ptr<Renderer> make_renderer(std::shared_ptr<LodScene> scene, const RendererOptions& options);

}  // namespace ugvr
