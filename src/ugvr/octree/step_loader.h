// The steps of a series as the in-core build of a store with time reads them (build_octree_steps; docs/time-series.md,
// "Stores with time"): the first step loaded is read whole and its mesh is kept; a later step whose files hold that
// mesh as stored (io/step_fields.h: Exodus by its format; .vtu, .pvtu, .vtk, OpenFOAM, EnSight, PLOT3D, CGNS by their
// geometry keys) has its fields read alone and put on the mesh kept, so its points and connectivity are neither read
// nor decoded nor fingerprinted again. A step without such a read is read whole and must have the first one's geometry
// (geometry_fingerprint), or the load fails naming both steps; its keys then count as the mesh's too.
// Memory: the mesh and one step's fields; a step's fields are dropped before the next step's are read.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"

namespace ugvr {

class StepDatasetLoader {
 public:
  // `steps`: indices into the series, as build_octree_steps takes them. `whole_reads`: read every step whole (the
  // reads before fields-only ones existed, kept so that tests can compare the stores both give).
  StepDatasetLoader(const TimeSeries& series, std::span<const uint32_t> steps, bool whole_reads = false);

  // The k-th selected step's dataset; valid until the next load. Throws ugvr::Error when the step's geometry differs
  // from the first loaded step's (the message says to build one store per step) or a read fails.
  const Dataset& load(size_t k);

  // Steps read fields-only and whole so far (a step loaded twice counts twice).
  uint32_t fields_only_reads() const { return fields_only_reads_; }
  uint32_t whole_reads() const { return whole_reads_; }

 private:
  bool holds_mesh_of(uint32_t step) const;
  void load_whole(size_t k);

  std::shared_ptr<const TimeSeries> series_;
  std::vector<uint32_t> steps_;
  bool force_whole_;
  StepFieldReader reader_;
  Dataset held_;  // the mesh, with the fields of the step loaded last
  bool holding_ = false;
  size_t mesh_k_ = 0;                             // the step the mesh was first read from (errors name it)
  size_t last_k_ = 0;                             // the step whose fields are held
  std::optional<uint64_t> fingerprint_;           // of the mesh, taken when a later step is first read whole
  std::vector<std::vector<uint64_t>> mesh_keys_;  // the geometry keys known to hold the mesh
  uint32_t fields_only_reads_ = 0, whole_reads_ = 0;
};

}  // namespace ugvr
