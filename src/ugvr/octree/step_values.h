// A later time step's values, what the out-of-core build of a store with time streams for every step after the first
// (octree/out_of_core.h): the geometry is the first step's (checked by hash), so a leaf's records of that step are
// the first step's records of the leaf, kept in the scratch folder, with these values put in place of the first's.
//
// Layout: one flat file per selected scalar, native byte order (temporary files, never moved between machines),
//   "<prefix>v<k>"  vertex scalar k (its soup slot): one f32 per point of the .vtu, by point index;
//   "<prefix>c<k>"  cell scalar k: one f32 per cell of the .vtu, by the cell's index in the file (the soup's cell id),
//                   0 at the cells the build drops (lower-dimensional ones);
// so 4 (Fv points + Fc cells) bytes a step, about a fortieth of its soup for hexahedra with one vertex scalar. They
// are written as the .vtu is streamed (VtuCellSource::write_values), one scalar after another with no slicing, and
// read back by runs of the ids a batch of records names (the page cache keeps them: a few MB for millions of points).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/octree/soup.h"

namespace ugvr {

std::string step_vertex_values_path(const std::string& prefix, uint32_t field);
std::string step_cell_values_path(const std::string& prefix, uint32_t field);

// Appends floats to one of those files (truncating one that exists). Throws ugvr::Error naming the file on failure.
class ValueFileWriter {
 public:
  explicit ValueFileWriter(std::string path) : file_(std::move(path), "temporary value file") {}

  void append(const float* values, size_t count) { file_.append(values, count * sizeof(float)); }
  void append_zeros(uint64_t count);
  // Flushes and closes; the destructor closes without reporting errors.
  void close() { file_.close(); }

 private:
  BufferedFileWriter file_;
};

// Appends `cell` to `out` in `layout` (which may be another step's: a field can be a vertex field in one step and a
// cell field in the next), its geometry copied and its values left for StepValues::put_into (zero until then).
void append_record_geometry(const SoupCell& cell, const SoupLayout& layout, std::vector<std::byte>& out);

// One step's value files, opened for reading by any number of threads at once.
class StepValues {
 public:
  // `points`, `cells`: the .vtu's counts (each file's length, checked); `layout`: the step's records'.
  StepValues(const std::string& prefix, const SoupLayout& layout, uint64_t points, uint64_t cells);
  ~StepValues();
  StepValues(const StepValues&) = delete;
  StepValues& operator=(const StepValues&) = delete;

  // Overwrites the values of every record in `records` (records laid end to end, as a node's file holds them) with
  // this step's: its vertex scalars at each record's vertex ids, its cell scalars at each record's cell id. Reads
  // only the values those ids name; holds about 4 bytes per corner and 4 (Fv + 1) per distinct vertex beside them.
  // Throws ugvr::Error naming the file when an id is beyond it (records of another mesh).
  void put_into(std::span<std::byte> records) const;

 private:
  static InputFile open_values(const std::string& path, uint64_t count);

  SoupLayout layout_;
  uint64_t points_ = 0, cells_ = 0;
  std::vector<InputFile> vertex_files_, cell_files_;
};

}  // namespace ugvr
