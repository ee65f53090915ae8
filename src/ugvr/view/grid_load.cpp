#include "ugvr/view/grid_load.h"

#include <algorithm>
#include <exception>
#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/exact/exact_renderer.h"
#include "ugvr/render/field_histogram.h"
#include "ugvr/view/view_store.h"

namespace ugvr::view {

GridLoad::GridLoad(std::function<std::shared_ptr<const Dataset>()> load, std::vector<std::string> fields,
                   int histogram_bins) {
  thread_ = std::thread([this, load = std::move(load), fields = std::move(fields), histogram_bins] {
    run(load, fields, histogram_bins);
  });
}

GridLoad::GridLoad(std::shared_ptr<const TimeSeries> series, uint32_t step, std::vector<std::string> fields,
                   int histogram_bins)
    : series_(std::move(series)), step_(step), reader_(std::make_shared<StepFieldReader>(series_)) {
  auto load = [r = reader_, step] { return std::make_shared<const Dataset>(r->read_whole(step)); };
  thread_ = std::thread([this, load = std::move(load), fields = std::move(fields), histogram_bins] {
    run(load, fields, histogram_bins);
  });
}

GridLoad::~GridLoad() {
  cancel_ = true;
  if (thread_.joinable()) thread_.join();
}

GridLoad::State GridLoad::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

std::shared_ptr<ExactScene> GridLoad::exact() const {
  std::lock_guard lock(mutex_);
  return exact_;
}

void GridLoad::set(Stage stage, const std::string& label, double fraction) {
  std::lock_guard lock(mutex_);
  state_.stage = stage;
  state_.label = label;
  state_.fraction = fraction;
}

void GridLoad::run(const std::function<std::shared_ptr<const Dataset>()>& load, const std::vector<std::string>& fields,
                   int bins) {
  try {
    // The readers report to the process-wide observer only (they have no caller-given one); nothing else of the viewer
    // runs a Progress while the grid is read (the store's build starts after it, with an observer of its own).
    Progress::set_observer([this](const std::string& label, double fraction) {
      std::lock_guard lock(mutex_);
      if (state_.stage == Stage::Reading) state_.label = label, state_.fraction = fraction;
    });
    std::shared_ptr<const Dataset> dataset;
    try {
      dataset = load();
    } catch (...) {
      Progress::set_observer({});
      throw;
    }
    Progress::set_observer({});
    if (!dataset) throw Error("the grid loader returned nothing");
    if (cancel_) return;

    Grid grid;
    grid.dataset = dataset;
    const std::vector<std::string> selectors = fields.empty() ? default_view_fields(*dataset) : fields;
    {
      // Validates the fields (NaN, missing) before anything is built from them.
      const OctreeInput input = prepare_octree_input(*dataset, selectors);
      for (size_t i = 0; i < input.fields.size(); ++i) {
        const BrickStoreField& f = input.fields[i];
        const ScalarRef& ref = input.scalars[i];
        grid.fields.push_back({f.name, f.min, f.max, volume_histogram(*input.mesh, *ref.field, ref.component, bins)});
        grid.names.push_back(f.name);
      }
      grid.bounds = input.bounds;
    }
    if (series_) {
      // The global colour range: every other step read in turn (one in memory at a time, as `ugvr render --time`
      // does), its ranges united into the shown step's. Progress says which step. A step with the shown step's mesh
      // as stored has its fields read alone, put on a copy of the shown step's grids (`carrier`: copied once, then
      // moved from step to step) for prepare_octree_input; another mesh is read whole.
      StepFieldReader& values = *reader_;
      std::optional<Dataset> carrier;
      for (uint32_t i = 0; i < series_->size() && !cancel_; ++i) {
        if (i == step_) continue;
        set(Stage::Reading, "time range: step " + std::to_string(i + 1) + " of " + std::to_string(series_->size()),
            double(i) / double(series_->size()));
        Dataset other;
        const bool fields_only = values.has_mesh_of(i, step_);
        if (fields_only) {
          other =
              carrier ? with_grids_of(std::move(*carrier), values.read(i)) : with_grids_of(*dataset, values.read(i));
        } else {
          other = read_time_step(*series_, i);
        }
        const OctreeInput input = prepare_octree_input(other, grid.names);
        for (size_t f = 0; f < input.fields.size(); ++f) {
          grid.fields[f].min = std::min(grid.fields[f].min, input.fields[f].min);
          grid.fields[f].max = std::max(grid.fields[f].max, input.fields[f].max);
        }
        if (fields_only) carrier = std::move(other);
      }
      if (cancel_) return;
    }
    grid_ = std::move(grid);
    set(Stage::Fields, "walk mesh", 0);

    const ProgressCallback walk_progress = [this](std::string_view, double fraction) {
      std::lock_guard lock(mutex_);
      state_.fraction = fraction;
      return !cancel_.load();
    };
    auto exact = std::make_shared<ExactScene>(dataset, walk_progress);
    if (series_) {
      // A series' scene over the step already read (ExactScene(series, step) would read it again).
      exact->series = series_;
      exact->step = step_;
      exact->use_step_reader(reader_);
      if (series_->geometry == SeriesGeometry::Detect) exact->geometry = geometry_fingerprint(*dataset);
    }
    std::lock_guard lock(mutex_);
    exact_ = std::move(exact);
    state_.stage = Stage::Done;
    state_.fraction = 1;
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    state_.stage = Stage::Failed;
    state_.error = e.what();
  }
}

}  // namespace ugvr::view
