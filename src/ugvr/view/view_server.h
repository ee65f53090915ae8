// `ugvr view`'s server: HTTP + WebSocket (Boost.Beast) on one I/O thread, and one render thread that owns the OpenGL
// context, the level-of-detail engine and one time-critical renderer per browser tab.
//
// HTTP: GET / (index.html), /app.js, /style.css from the embedded page (web_assets.h); GET /ws upgrades to the
// WebSocket of view_protocol.h. Loopback by default; when bound to another address every request for the page and
// the socket must carry ?token=TOKEN (random, 128 bits), which url() includes. A WebSocket upgrade whose Origin is not
// this server's own page is refused (another web site open in the same browser must not drive the viewer).
//
// Scheduling. Each session (tab) holds only its LATEST requested view: a camera, size, transfer function or settings
// message overwrites the previous request, so stale requests are dropped, never queued. The render thread visits the
// sessions round-robin and renders one frame per turn for a session that (a) has said hello, (b) has no frame still
// on its way to the client, and (c) wants one: its view changed since its last frame, or the last frame was not yet
// converged (progressive refinement), or it asked for full quality. (b) is the back-pressure: a slow client gets
// fewer frames, never a queue, and cannot hold up the others. Frames are JPEG while moving or refining, PNG once the
// cut has converged at the resting step; each is preceded by a status text message.
// Frame budgets are shared: while N tabs stream frames, each tab's controller targets N × its frame rate, so that
// every tab gets about the rate it asked for instead of each measuring only its own frames and all falling behind.
//
// Every HTTP response carries a Content-Security-Policy allowing only the page's own scripts, styles, images and
// socket.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/time_series.h"
#include "ugvr/octree/builder.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
class Renderer;
}

namespace ugvr::view {

struct FrameJob;  // frame_scheduler.h

// `mpirun -np N ugvr view` (docs/mpi.md, "The viewer on a cluster"): the renderer every tab draws with, one that
// draws each frame on all ranks together (mpi/mpi_view.h), and the fields the page may pick.
struct CollectiveRenderer {
  std::shared_ptr<Renderer> renderer;
  std::vector<std::string> fields;
  // Stores whose coarse levels give the fields' histograms, summed (a store, or a partitioned store's pieces: they
  // share the whole data's field ranges, so their bins agree); read by rank 0 alone.
  std::vector<std::string> histogram_stores;
  // A mesh: the dataset rank 0 read (whole, as every rank does before keeping its part), whose fields' values give
  // the histograms, as the single-process viewer's grid does.
  std::shared_ptr<const Dataset> histogram_dataset;
};

struct ViewServerOptions {
  // The .ugvr brick store to show. With `dataset` set, the store does not exist yet: it is built there in the
  // background (background_build.h) from `fields` with `build`, and the exact engine shows the dataset meanwhile
  // (render/exact/exact_renderer.h); when the build is done every tab switches to the store, keeping its view, and
  // may switch back to the exact engine ("engine" message) unless `free_grid`.
  //
  // The server listens first and loads after: the dataset's fields, its exact engine's walk mesh and the store's
  // build are all prepared on threads of their own while the page already shows their progress ("progress"
  // messages); the first scene message comes when an engine can draw.
  std::string store;
  std::shared_ptr<const Dataset> dataset;
  // Instead of `dataset`: called on a thread of its own once the server listens, to read the grid (its progress is
  // the readers' own, core/progress.h). What it throws reaches the page and `on_failure`.
  std::function<std::shared_ptr<const Dataset>()> load;
  // Instead of `dataset` or `load`: a .vtu file that is not read in memory (it would not fit): its store is built out
  // of core (octree/out_of_core.h) within `out_of_core_budget` bytes, and nothing draws until it is done.
  std::string out_of_core_input;
  // Instead of `dataset` or `load`: a time series of more than one step (io/time_series.h), shown by the exact engine
  // only (a brick store holds one step, so none is built), starting at step `time_step`. Each tab picks its step
  // ("time" message); the colour range is the union over every step, read one at a time before the first image.
  std::shared_ptr<const TimeSeries> series;
  uint32_t time_step = 0;
  uint64_t out_of_core_budget = 0;
  std::string notice;  // said in the page with every progress while loading (why the store path alone, ...)
  // Called (on the render thread) when the grid cannot be loaded (a bad file): the viewer has nothing to show.
  std::function<void(const std::string& message)> on_failure;
  std::vector<std::string> fields;  // with `dataset`: field selectors to build (empty: default_view_fields)
  // With `dataset`: free the grid and its exact engine once the store is shown (every tab then has only the
  // level-of-detail engine). Kept by default, so that each tab can switch between the engines; the cost is the
  // dataset and its walk mesh in RAM (and on a hardware GPU the exact engine's buffers), docs/viewer.md.
  bool free_grid = false;
  OctreeBuildOptions build;
  std::optional<Camera> camera;        // the initial (and reset) view; none: default_camera (render/camera.h)
  std::optional<TransferFunction> tf;  // the initial transfer function (SceneInfo::tf)
  std::string preset = "viridis";      // the initial colour map when there is no `tf`
  // Without `tf`: start from the "auto" transfer function of the first field shown (default_transfer_function.h, from
  // its histogram) and, without `camera`, frame the reset view on what it leaves visible (render/visible_bounds.h),
  // as `ugvr render` with no flags. `ugvr view` without --tf sets it; off: `preset`'s linear ramp, the whole domain.
  bool auto_tf = false;
  std::optional<std::array<double, 4>> background;  // the initial background (SceneInfo::background)
  std::function<void()> before_build;               // tests: runs on the build's thread before the build starts
  std::function<void()> opening_store;  // tests: runs on the render thread, unlocked, before it opens the built store
  size_t max_sessions = 16;             // WebSocket connections at once; more are refused (HTTP 503)
  std::string host = "127.0.0.1";       // address to listen on
  uint16_t port = 0;                    // 0: a free port
  std::string gpu = "auto";             // GlContext device
  uint64_t gpu_memory = uint64_t(2) << 30;  // atlas budget (shared by the sessions)
  // A store that keeps its leaves' cells (`ugvr build --cells`): new tabs are drawn by the hybrid engine
  // (docs/hybrid.md: voxels while moving, exact cells batch by batch at rest); false: by the level-of-detail engine
  // (`ugvr view --engine lod`). Either way a tab may pick the other ("engine" message).
  bool hybrid = true;
  uint64_t exact_batch = 64;  // hybrid: nodes turning exact per resting frame (TimeCriticalOptions::exact_batch)
  uint64_t ram_per_session = uint64_t(1) << 30;  // each session's RAM brick cache (less when tabs_memory is short)
  // Every tab's allocations together (tab_memory.h): outgoing queue, canvas, RAM brick cache. 0: the viewer's memory
  // budget (memory_budget.h: $UGVR_VIEW_MEMORY_BUDGET, else half of physical memory).
  uint64_t tabs_memory = 0;
  int width = 512, height = 512;  // the page's initial canvas size (scene message)
  double fps = 10;                // initial frame-rate target of each session
  double play_rate = 0;           // a time series: > 0 starts every new tab playing at this many steps a second
  std::string token;              // forced token (tests); empty: random when not loopback
  // MPI: called on the render thread instead of opening `store` or loading a grid; its renderer draws every tab, as
  // the only engine (no build, no histograms, no degree of interest). Empty: the single-process viewer.
  std::function<CollectiveRenderer()> collective;
  // With `collective`: what it opens is built first, on a thread of its own (background_build.h, its cache entry
  // `store`: the partitioned store `ugvr view` builds in its cache when one out-of-core build's scratch does not fit
  // the disk, view/scratch_pieces.h), its progress said in the page after `notice`; `collective` is called once it
  // is done. Reports (label, fraction) to the progress it is given, which throws once the viewer stops.
  std::function<void(const std::function<void(const std::string&, double)>& progress)> collective_build;
  // Whether the collective renderer's resting frames may be cut short by a move (FrameRequest::keep_going): the pieces
  // of an index drawn in this process and the ranks of an MPI job (they agree to stop together: mpi/mpi_frame_stop.h)
  // say yes. A collective renderer that cannot be cut short leaves it false: then a resting frame waits a moment
  // after a moving one instead (FrameScheduler::set_rest_delay).
  bool collective_interruptible = false;
  // Tests: called on the render thread when a frame's work begins, with the question the renderer will ask between
  // parts of it (empty for a frame that is not cut short: a moving one).
  std::function<void(const FrameJob&, const std::function<bool()>&)> on_frame_start;
};

class ViewServer {
 public:
  // Opens the store (or starts loading the grid) on the render thread, then listens. Throws ugvr::Error (store, GPU,
  // address in use); an error in loading the grid, or in opening the collective renderer (which happens on the
  // render loop's first turn, after listening starts), comes later (on_failure, and a "failed" progress message).
  explicit ViewServer(ViewServerOptions options);
  ~ViewServer();  // stop()
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  uint16_t port() const;
  const std::string& token() const;  // empty when none is required
  std::string url() const;           // http://HOST:PORT/[?token=TOKEN]
  std::string renderer() const;      // GL_RENDERER of the render thread's context
  // The latest progress message of loading the grid or building its store (empty: none); tests.
  std::string progress() const;
  // Stops serving: closes the listener and the sessions and joins the threads. Idempotent.
  void stop();

  // What the tab that moved its camera or edited its transfer function last shows now (the Python API's
  // Viewer.camera / Viewer.tf); with no such tab, what a new tab starts from.
  struct View {
    Camera camera;
    TransferFunction tf;
  };
  View current_view() const;
  // Moves every open tab, and every tab opened from now on, to `camera` and/or `tf` (points in data values; a unit
  // distance <= 0: the viewer's default). The pages are told ("view" message) and follow; every tab draws again.
  void set_view(const std::optional<Camera>& camera, const std::optional<TransferFunction>& tf);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ugvr::view
