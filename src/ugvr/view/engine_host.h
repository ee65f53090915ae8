// What the viewer's render thread owns (view_server.h): the OpenGL context, the scenes that draw, and each tab's
// renderer (render/renderer.h, interactive: it holds the tab's frame-rate target). The scenes are the brick store for
// the level-of-detail engine (a time-critical session per tab over one shared atlas) and, when the viewer was started
// from a grid, the grid for the exact engine (an adaptive image scale per tab; on the GPU where there is a hardware
// one). While the grid's store is built in the background (background_build.h) only the exact engine draws; when the
// build is done every tab moves to the store, and each tab may then pick either engine (ViewRequest::engine) until
// the grid is freed (ViewServerOptions::free_grid). Out of core, the build's coarse preview (octree/coarse_preview.h:
// levels 0 .. K of the store, written within seconds of the cells) is shown as soon as it exists, until the store is
// done.
//
// Everything here lives and dies on the render thread (the GL context is current on the thread that created it) and
// takes no lock: the server calls it with or without its own lock, as each call's cost allows.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "ugvr/view/background_build.h"
#include "ugvr/view/frame_scheduler.h"
#include "ugvr/view/grid_load.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_server.h"

namespace ugvr {
class GlContext;
struct LodScene;
struct ExactScene;
}  // namespace ugvr

namespace ugvr::view {

class EngineHost {
 public:
  // Creates the GL context and opens options.store; or, with options.dataset or options.load, starts loading the grid
  // (grid_load.h: read, fields, walk mesh) on a thread of its own, and, with options.out_of_core_input, building its
  // store out of core. Quick: the slow work goes on while the viewer serves (poll_load). Throws ugvr::Error (GL, the
  // store).
  explicit EngineHost(ViewServerOptions options);
  ~EngineHost();  // cancels a build still running; then the tabs' renderers, the engines, the GL context
  EngineHost(const EngineHost&) = delete;
  EngineHost& operator=(const EngineHost&) = delete;

  // The scene the tabs are shown now (fields, bounds, the reset camera, the engine). Only once has_scene(): before,
  // while the grid is read and prepared (or its store built out of core) there is nothing to draw.
  const SceneInfo& scene() const { return scene_; }
  bool has_scene() const { return !scene_.engine.empty(); }
  const std::string& gl_renderer() const { return renderer_; }

  // Loading the grid. Cheap (under the server's lock): reports the load's stage, and starts the store's build once
  // the fields are known. `ready`: the exact engine can draw; call finish_load() (without the lock), then the scene is
  // there. `failed`: the load failed (progress says why); the viewer has nothing to show.
  struct LoadReport {
    bool ready = false, failed = false;
    ProgressInfo progress;  // "read" (reading), "build" (the walk mesh and the store's build), "failed"
  };
  std::optional<LoadReport> poll_load();
  // The exact engine over the loaded grid (moved to a hardware GPU where it pays) becomes the scene.
  void finish_load();

  // The background build: while one runs its progress is polled.
  bool building() const { return build_ != nullptr; }
  // Loading: the grid (GridLoad), or the collective renderer not opened yet (see poll_load).
  bool loading() const { return load_ != nullptr || opening_collective(); }
  struct BuildReport {
    BackgroundBuild::Stage stage = BackgroundBuild::Stage::Running;
    ProgressInfo progress;  // for the page: "build" while running, "failed"; nothing to say when done
  };
  // What the build is doing; nullopt when there is none (the store was given, or the build is over).
  std::optional<BuildReport> build_report() const;
  // The progress a tab is shown before the build's first report; nullopt when there is no build.
  std::optional<ProgressInfo> initial_progress() const;
  // Forgets a failed build: the exact engine goes on showing the grid.
  void drop_build();
  // The build is done: opens its store and moves every tab to it, its renderer started afresh (the grid and its exact
  // engine are kept for the tabs that pick them, or freed with free_grid). Slow: reads the store. `opened` false: the
  // store cannot be opened, the exact engine goes on.
  struct Switch {
    bool opened = false;
    ProgressInfo progress;  // "ready" (a new scene() follows), or "failed"
  };
  Switch switch_to_store();
  // Out of core: the build has written a preview (BackgroundBuild::State::preview: the point sketch, then the coarse
  // preview) that is not shown yet, and no store is shown but an earlier preview.
  bool preview_ready() const;
  // Shows the coarse preview while the build goes on (as switch_to_store does, keeping the reset view): every tab's
  // renderer starts afresh on it; the build's progress then says "coarse preview (levels 0–K) while the store is
  // built". switch_to_store replaces it when the build is done. `opened` false: it cannot be opened (progress says
  // why) and the viewer waits for the store as before.
  Switch switch_to_preview();

  // A tab's frame: FrameStatus, and the image, JPEG while moving or refining, PNG once converged (status.png).
  struct Frame {
    FrameStatus status;
    std::shared_ptr<const std::string> image;
    bool interrupted = false;  // keep_going said stop: nothing was drawn, nothing is to be sent
  };
  // Draws `job`'s frame with its tab's renderer, made on the tab's first frame and again whenever the tab picks
  // another engine (job.request.engine; empty: the scene's). `keep_going` (FrameRequest::keep_going): asked between
  // parts of the frame; when it says stop, the frame is abandoned (Frame::interrupted). Throws (ugvr::Error and
  // others).
  Frame render(const FrameJob& job, const std::function<bool()>& keep_going = {});
  // A tab has closed: its renderer goes (it joins its brick cache's threads).
  void forget(uint64_t tab);

 private:
  struct Tab;
  // What every scene takes from the options (camera, transfer function, background, rate, size) around its fields
  // (the first varying one shown) and bounds.
  SceneInfo base_scene(std::vector<FieldInfo> fields, const Bounds& bounds) const;
  SceneInfo lod_scene() const;
  SceneInfo collective_scene(const CollectiveRenderer& opened);
  // `store` (the build's coarse preview, or the store itself) becomes the one shown, to every tab afresh.
  void show_store(std::shared_ptr<LodScene> store);
  std::vector<EngineChoice> engines() const;  // what the tabs may pick now
  bool hybrid_available() const;              // a store that keeps cells: a tab may pick hybrid

  ViewServerOptions options_;
  std::string renderer_;        // GL_RENDERER
  std::string exact_renderer_;  // the exact engine's label: on the CPU, or on the GPU and which
  SceneInfo scene_;
  // Declared in the order they are made; destroyed in reverse (as ~EngineHost spells out).
  std::shared_ptr<GlContext> gl_;
  std::shared_ptr<LodScene> lod_;                  // the store, once there is one
  std::shared_ptr<ExactScene> exact_;              // the grid and its walk mesh (none for a viewer of a store)
  std::map<uint64_t, std::unique_ptr<Tab>> tabs_;  // each tab's renderer and frame counters
  std::unique_ptr<BackgroundBuild> build_;
  std::unique_ptr<GridLoad> load_;  // the grid being read and prepared; null once done (or never)
  // MPI (ViewServerOptions::collective): draws every tab; then there is no GL context, store or grid here.
  std::shared_ptr<Renderer> collective_;
  // The collective renderer is opened on the render loop's first turn (poll_load, finish_load), not in the
  // constructor, so that the URL is printed at once: opening a billion-cell store's 16 pieces takes seconds (their
  // boundary planes, docs/mpi.md). Empty once opened or failed; the failure's message until poll_load reports it.
  std::function<CollectiveRenderer()> pending_collective_;
  // options.collective_build while it runs (before pending_collective_ opens what it built).
  std::unique_ptr<BackgroundBuild> collective_build_;
  std::string collective_error_;
  bool opening_collective() const { return bool(pending_collective_) || !collective_error_.empty(); }
  std::string notice_;          // options.notice: said with every progress of the load
  bool build_started_ = false;  // the store's build was started from the loaded grid
  // The build's previews (the point sketch, then the coarse preview): the last one tried (shown, or failed to open),
  // and the one shown: its depth (0: none, or the store itself is shown) and whether it is the sketch.
  std::string preview_tried_;
  int preview_depth_ = 0;
  bool preview_sketch_ = false;
};

}  // namespace ugvr::view
