// ugvr's public API: everything a program (and the Python and MPI front ends) needs to read a grid, build its brick
// store, and render either with any engine. The types it uses are declared in the headers it includes, all under
// include/ugvr; nothing in src/ is visible to a program using the library.
//
//   #include <ugvr/ugvr.h>
//   auto renderer = ugvr::open_renderer({"wing.vtu"}, {});           // the exact engine, in core
//   ugvr::FrameRequest request = ugvr::default_request(*renderer, 800, 600);
//   ugvr::write_image("wing.png", renderer->render(request).image);
//
//   ugvr::build_store({"wing.vtu"}, "wing.ugvr", {});                // the octree of bricks, out of core if large
//   ugvr::RendererConfig lod;
//   lod.interactive = true;                                          // time-critical: holds request.target_fps
//   auto fast = ugvr::open_renderer({"wing.ugvr"}, lod);
//
// Errors are ugvr::Error (core/error.h) with a message naming the file and offset, or the option, at fault.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/vec.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/renderer.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

// The library's version, "MAJOR.MINOR.PATCH".
const char* version();

// ---- Data in: read_dataset(paths, ReadOptions) (io/reader.h) reads every supported format into a Dataset.

// ---- Brick stores (`ugvr build`): the adaptive octree of bricks the level-of-detail engine draws.
struct StoreOptions {
  std::vector<std::string> fields;  // scalars to store ("NAME", "NAME:x", "NAME:magnitude"); empty: the first varying
  uint32_t brick = 32;              // samples per brick axis
  int max_depth = 8;                // deepest octree level (root = 0)
  double error = 0.01;              // split threshold relative to each field's range (0: every data point its voxel)
  bool float32 = false;             // lossless float samples instead of 16 bits
  int threads = 0;                  // worker threads (0: all cores)
  uint64_t memory_bytes = uint64_t(1) << 30;  // a .vtu larger than 40 % of this is built out of core
  bool out_of_core = false;                   // stream the cells through temporary files whatever the size
  const std::atomic<bool>* cancel = nullptr;  // set from another thread to stop (then throws; nothing is written)
  // This build's progress (stage, fraction done), about 10 times a second per stage, from a worker thread; returning
  // false stops the build like `cancel`.
  ProgressCallback progress;
};

struct StoreSummary {
  std::vector<std::string> fields;  // as the store names them
  uint64_t cells = 0, nodes = 0, leaves = 0, bricks = 0, bytes = 0;
  int max_level = 0;
  bool out_of_core = false;
  double seconds = 0;
};

// Builds the store of `inputs` (files, as read_dataset takes them) at `output` (.ugvr; written to a temporary file and
// renamed when complete).
StoreSummary build_store(const std::vector<std::string>& inputs, const std::string& output, const StoreOptions& options,
                         const ReadOptions& read = {});
// The same from a dataset in memory.
StoreSummary build_store_from_dataset(const Dataset& dataset, const std::string& output, const StoreOptions& options);

// ---- Renderers (render/renderer.h): the exact CPU engine for a mesh, the level-of-detail GPU engine for a store.
struct RendererConfig {
  std::string engine = "auto";  // "exact", "lod", or "auto": lod for a .ugvr store, else exact
  bool interactive = false;     // hold FrameRequest::target_fps, converging to full quality at rest
  std::string field;            // bound at once (empty: the first field whose range is not constant)
  // Level of detail.
  std::string gpu = "auto";                       // EGL device index, or auto: the first GPU, else Mesa's llvmpipe
  uint64_t gpu_memory_bytes = uint64_t(2) << 30;  // bricks on the GPU
  uint64_t ram_memory_bytes = uint64_t(1) << 30;  // interactive: decoded bricks in RAM
  double step_voxels = 0.5;                       // sample step at rest, in voxels of each node
  std::string cut = "pixels:1";                   // not interactive: "leaves", "error:E" or "pixels:P"
  ProgressCallback progress;                      // long work (the exact engine's walk mesh); false cancels
};

// Opens `inputs` (a mesh in any readable format, a PLOT3D grid + solution, or one .ugvr store). Throws ugvr::Error;
// an option at fault is named in the message ("gpu: ...", "field: ...").
std::unique_ptr<Renderer> open_renderer(const std::vector<std::string>& inputs, const RendererConfig& config,
                                        const ReadOptions& read = {});
// The exact engine over a dataset in memory (shared: the renderer keeps it alive).
std::unique_ptr<Renderer> make_renderer(std::shared_ptr<const Dataset> dataset, const RendererConfig& config);

// The request `ugvr render` makes without flags: a three-quarter oblique view, +z up, framed on what the transfer
// function leaves visible (default_camera in render/camera.h on the box of render/visible_bounds.h: the whole data
// when nothing or nearly everything is; or a preset, +x -x +y -y +z -z iso, on the data), the "auto" transfer function
// over the bound field's range (viridis; the histogram's dominant mode, if any, transparent, else the linear opacity
// ramp: src/ugvr/render/default_transfer_function.h), opacity unit distance = bounds diagonal / 10, so that the first
// image shows the inside of the data rather than an opaque slab or a haze of its most common value.
FrameRequest default_request(const Renderer& renderer, int width, int height, std::string_view view = "");

}  // namespace ugvr
