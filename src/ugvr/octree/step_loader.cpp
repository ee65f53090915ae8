#include "ugvr/octree/step_loader.h"

#include <algorithm>
#include <utility>

#include "ugvr/octree/time_steps.h"

namespace ugvr {

StepDatasetLoader::StepDatasetLoader(const TimeSeries& series, std::span<const uint32_t> steps, bool whole_reads)
    : series_(std::make_shared<const TimeSeries>(series)),
      steps_(steps.begin(), steps.end()),
      force_whole_(whole_reads),
      reader_(series_) {}

bool StepDatasetLoader::holds_mesh_of(uint32_t step) const {
  if (reader_.static_by_format()) return true;
  if (mesh_keys_.empty()) return false;
  const std::optional<std::vector<uint64_t>> keys = reader_.geometry_keys(step);
  return keys && std::find(mesh_keys_.begin(), mesh_keys_.end(), *keys) != mesh_keys_.end();
}

const Dataset& StepDatasetLoader::load(size_t k) {
  if (holding_ && k == last_k_) return held_;
  if (!holding_ || force_whole_ || !holds_mesh_of(steps_[k])) {
    load_whole(k);
    return held_;
  }
  // The previous step's fields go before this step's are read: one step's fields beside the mesh.
  for (Block& b : held_.blocks) b.fields = FieldSet();
  StepFields fields = reader_.read(steps_[k]);
  held_ = with_grids_of(std::move(held_), std::move(fields));
  ++fields_only_reads_;
  last_k_ = k;
  return held_;
}

void StepDatasetLoader::load_whole(size_t k) {
  // The mesh's fingerprint, taken from the mesh held before it is dropped (a series read fields-only never needs it).
  if (holding_ && !fingerprint_) fingerprint_ = geometry_fingerprint(held_);
  held_ = Dataset();
  holding_ = false;
  // read_whole reads as read_time_step does, and keeps what a later fields-only read of the step's format needs (an
  // OpenFOAM, EnSight, PLOT3D or CGNS mesh's layout).
  Dataset step = force_whole_ ? read_time_step(*series_, steps_[k]) : reader_.read_whole(steps_[k]);
  ++whole_reads_;
  if (!fingerprint_) {
    mesh_k_ = k;  // the first step read: the mesh
  } else if (geometry_fingerprint(step) != *fingerprint_) {
    fail_geometry_differs(*series_, steps_[k], steps_[mesh_k_], "geometry fingerprint");
  }
  held_ = std::move(step);
  holding_ = true;
  last_k_ = k;
  if (force_whole_ || reader_.static_by_format()) return;
  // This step's files hold the mesh: later steps with the same keys read their fields alone.
  std::optional<std::vector<uint64_t>> keys = reader_.geometry_keys(steps_[k]);
  if (keys && std::find(mesh_keys_.begin(), mesh_keys_.end(), *keys) == mesh_keys_.end())
    mesh_keys_.push_back(std::move(*keys));
}

}  // namespace ugvr
