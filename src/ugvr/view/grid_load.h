// Reads a grid for the viewer after it serves (`ugvr view MESH`: the URL first, the mesh after), on a thread of its
// own, and prepares what the exact engine needs, reporting each stage for the page:
//   1. "read": the caller's loader (the file's reader, or the demo's generator), its progress as the readers report it
//      (core/progress.h: "reading NAME", fraction);
//   2. the fields to show are checked (NaN, missing) and described (ranges, histograms): `Fields` is then ready, and
//      the viewer starts the store's background build from it while
//   3. "walk mesh": the exact engine's walk mesh is built (render/exact/exact_renderer.h); `Done`: the exact engine
//      can draw.
// Nothing here touches OpenGL: the render thread moves the exact engine to a GPU afterwards where that pays.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/io/time_series.h"
#include "ugvr/view/view_protocol.h"

namespace ugvr {
class StepFieldReader;
struct ExactScene;
}  // namespace ugvr

namespace ugvr::view {

class GridLoad {
 public:
  enum class Stage { Reading, Fields, Done, Failed };
  struct State {
    Stage stage = Stage::Reading;
    std::string label;  // the reader's (or the walk mesh's) step now
    double fraction = 0;
    std::string error;  // when Failed: what went wrong, naming the file where the reader did
  };
  // What the fields stage found; valid from Stage::Fields on.
  struct Grid {
    std::shared_ptr<const Dataset> dataset;
    std::vector<FieldInfo> fields;   // as the store names them ("velocity:magnitude"), ranges and histograms
    std::vector<std::string> names;  // the same names, for the build
    Bounds bounds;
  };

  // `load` returns the grid (it may throw: the error becomes State::error); `fields` as ViewServerOptions::fields
  // (empty: default_view_fields). `histogram_bins`: of each field's histogram.
  GridLoad(std::function<std::shared_ptr<const Dataset>()> load, std::vector<std::string> fields, int histogram_bins);
  // A time series shown from step `step`: that step is read (stage Reading), then every other step in turn, one in
  // memory at a time, its fields alone where it has step `step`'s mesh as stored (StepFieldReader::has_mesh_of; they
  // go on one copy of that mesh), else whole (stage Fields is published after: the fields' ranges are the union over
  // the steps, so that the colours mean the same at every step; the histograms are step `step`'s), then the walk mesh
  // is built.
  GridLoad(std::shared_ptr<const TimeSeries> series, uint32_t step, std::vector<std::string> fields,
           int histogram_bins);
  // Waits for the thread: a read under way is not interrupted (the walk mesh is: it stops at its next step).
  ~GridLoad();
  GridLoad(const GridLoad&) = delete;
  GridLoad& operator=(const GridLoad&) = delete;

  State state() const;
  // Valid once state().stage is Fields or Done (the grid does not change afterwards).
  const Grid& grid() const { return grid_; }
  // The exact engine's scene, once state().stage is Done (null before).
  std::shared_ptr<ExactScene> exact() const;

 private:
  void run(const std::function<std::shared_ptr<const Dataset>()>& load, const std::vector<std::string>& fields,
           int bins);

  std::shared_ptr<const TimeSeries> series_;  // null: one dataset
  uint32_t step_ = 0;
  // The series' fields-only reads: it reads the shown step whole (keeping what an OpenFOAM step's fields need of the
  // mesh), the range pass's other steps, and goes to the exact scene for its step switches.
  std::shared_ptr<StepFieldReader> reader_;
  void set(Stage stage, const std::string& label, double fraction);

  std::atomic<bool> cancel_{false};
  mutable std::mutex mutex_;
  State state_;
  Grid grid_;  // written by the thread before it publishes Stage::Fields, read-only afterwards
  std::shared_ptr<ExactScene> exact_;
  std::thread thread_;
};

}  // namespace ugvr::view
