// Builds a brick store on a thread of its own while the viewer shows the grid with the exact engine
// (`ugvr view MESH`): the octree build of octree/builder.h, reporting its progress for the page and cancellable.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/octree/builder.h"

namespace ugvr::view {

class BackgroundBuild {
 public:
  enum class Stage { Running, Done, Failed };
  struct State {
    Stage stage = Stage::Running;
    std::string label;  // the builder's step now ("subdivide", "bricks")
    double fraction = 0;
    std::string error;    // when Failed
    bool reused = false;  // Done without building: another process (or viewer) built the same store meanwhile
    // Out of core with OctreeBuildOptions::preview_depth: the coarse preview's store (octree/coarse_preview.h) once
    // it is complete, while the build goes on (empty: none yet); its file is removed when the build ends, so open it
    // while the build is Running. Its levels: 0 .. preview_depth.
    std::string preview;
    int preview_depth = 0;
    // The preview is the point sketch (OctreeBuildOptions::point_sketch: approximate, from the points alone), shown
    // before the coarse preview replaces it.
    bool preview_sketch = false;
    // Done out of core: what the build said of its store that a user should hear (OctreeBuildStats::boundary_note:
    // the exact boundary left out for the memory budget); empty when nothing.
    std::string note;
  };

  // Starts building `fields` of `dataset` into `path` (atomically: a valid store appears there only when done). The
  // dataset must not change while this runs. Two viewers of the same grid share the cache entry: the build holds an
  // exclusive lock on PATH.lock (flock), and a build that finds it held waits (label "waiting for another viewer's
  // build"), then uses the store the other one wrote instead of building it again.
  // `before` (tests) runs on the build's thread before it starts.
  BackgroundBuild(std::shared_ptr<const Dataset> dataset, std::vector<std::string> fields, OctreeBuildOptions options,
                  std::string path, std::function<void()> before = {});
  // The same from a .vtu file that is never held in memory: build_octree_out_of_core (octree/out_of_core.h) within
  // `memory_budget` bytes. `fields` as its selectors (empty: its default). Cancelled at its next progress report.
  // With options.preview_depth, the state reports the coarse preview as soon as it is written (State::preview), then
  // calls options.on_preview if set (tests hold the build there); with options.point_sketch too, the point sketch
  // first (State::preview_sketch), then options.on_sketch.
  struct OutOfCore {
    std::string vtu;
    uint64_t memory_budget = 0;
  };
  BackgroundBuild(OutOfCore input, std::vector<std::string> fields, OctreeBuildOptions options, std::string path,
                  std::function<void()> before = {});
  // The same with the work given: `work(progress)` writes `path` itself (a partitioned store's index after its pieces:
  // the CLI passes mpi/piece_build_ooc.h's build_index_out_of_core, which this module does not reach), reporting to
  // `progress`, which throws at its next report once cancelled. The cache entry's lock and reuse are as above.
  using Work = std::function<void(const Progress::Observer& progress)>;
  BackgroundBuild(Work work, std::string path);
  // Cancels the build if it is still running and waits for its thread (a cancelled build writes nothing).
  ~BackgroundBuild();
  BackgroundBuild(const BackgroundBuild&) = delete;
  BackgroundBuild& operator=(const BackgroundBuild&) = delete;

  State state() const;
  const std::string& path() const { return path_; }

 private:
  // One of `dataset` (in core), `out_of_core.vtu` and `work_`.
  void run(std::shared_ptr<const Dataset> dataset, const OutOfCore& out_of_core, std::vector<std::string> fields,
           OctreeBuildOptions options);

  std::string path_;
  Work work_;
  std::atomic<bool> cancel_{false};
  mutable std::mutex mutex_;
  State state_;
  std::thread thread_;
};

}  // namespace ugvr::view
