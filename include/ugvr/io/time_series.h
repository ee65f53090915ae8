// Time series: a dataset's time axis. Any input has one (a single file is a series of one step); listing it names
// every step (its time, and which file, or which step of a multi-step file, holds it) without reading field data, and
// read_time_step reads one step as an ordinary Dataset. Details and the naming rules: docs/time-series.md.
//
// How a series is named (the INPUT of every subcommand):
//   Exodus II file           every step of the file ("time_whole"); geometry static (coordinates have no time axis)
//   NAME.pvd                 a VTK collection: <DataSet timestep= part= file=/>; entries of one timestep (one per
//                            part) are read together, one block each; timesteps must not decrease in file order
//   NAME.series              ParaView's JSON: {"files": [{"name": ..., "time": ...}, ...]}; times must increase
//   'flow_%04d.vtu'          a numbered series: every file of that directory whose name matches, a printf-style
//   'flow_*.vtu'             %d / %0Nd, or a glob (* and ?); sorted by the number in the name, which is also the step's
//                            time; any readable format
//   GRID SOL1 SOL2 ...       PLOT3D with several solution files (or GRID 'sol_%04d.q'): one grid, static geometry
//   CGNS, EnSight, OpenFOAM  the steps their readers take as ReadOptions::time_step (listed by the readers)
// read_dataset (io/reader.h) reads a series' step ReadOptions::time_step (-1 = the last), so every subcommand takes a
// series as INPUT. Paths inside a .pvd / .series are relative to its directory. Errors (a missing file, bad XML or
// JSON, decreasing times, an empty series) are ugvr::Error naming the series file and the entry.
//
// Geometry: a format that knows its geometry is static says so (Exodus, PLOT3D with one grid, OpenFOAM without
// time-directory polyMesh); otherwise it is detected when steps are read, by geometry_fingerprint (points, cells and
// structure of every block), never assumed.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/reader.h"

namespace ugvr {

enum class SeriesKind { Single, Exodus, Pvd, SeriesJson, Numbered, Plot3d, Cgns, EnSight, OpenFoam };
std::string_view series_kind_name(SeriesKind k);  // "single", "exodus", "pvd", "series", "numbered", "plot3d", ...

enum class SeriesGeometry {
  Static,  // known from the format: one mesh for all steps
  Detect,  // may change: compare geometry_fingerprint of the steps read
};

struct TimeStep {
  double time = 0;
  // The files read for this step: one (a .pvd part, a numbered file, a multi-step file), several (a .pvd step of
  // several parts: one block each), or for PLOT3D the grid then the solution.
  std::vector<std::string> files;
  // The step inside a multi-step file (Exodus, CGNS, EnSight, OpenFOAM: ReadOptions::time_step); -1 = none.
  int64_t reader_step = -1;
};

struct TimeSeries {
  SeriesKind kind = SeriesKind::Single;
  std::string source;  // what named the series (the .pvd, the pattern, the Exodus file), for messages
  std::vector<TimeStep> steps;
  SeriesGeometry geometry = SeriesGeometry::Detect;
  std::string geometry_reason;  // why Static, or what Detect compares
  ReadOptions read;             // the reading options besides the step (raw layout)

  size_t size() const { return steps.size(); }
};

// Whether `inputs` name a series that read_dataset alone cannot read as one file: a .pvd, a .series, a numbered
// pattern, or PLOT3D with more than one solution. (Multi-step files read themselves, by ReadOptions::time_step.)
bool is_series_input(std::span<const std::string> inputs);
// Whether a path is a numbered-series pattern (%d, %0Nd, * or ? in its file name).
bool is_series_pattern(std::string_view path);

// Lists the steps of any input (see above); reads headers and directories, not field data.
TimeSeries list_time_steps(std::span<const std::string> inputs, const ReadOptions& read = {});

// Reads step `step` (0-based; throws ugvr::Error naming the source and the step count when out of range). The result's
// format says which step it is.
Dataset read_time_step(const TimeSeries& series, size_t step);

// A 64-bit hash of everything but the fields: block count, grid kinds, dimensions, points, IBLANK, cell types and
// connectivity. Equal fingerprints: the steps share one mesh (a walk mesh built once serves both).
uint64_t geometry_fingerprint(const Dataset& dataset);

// Writes a VTK collection (.pvd) listing (time, file) per step, files as given (relative to the .pvd's directory);
// atomically (temporary file + rename).
void write_pvd(const std::string& path, const std::vector<std::pair<double, std::string>>& steps);

// Step selection "all", "N", or "A:B[:S]" (A to B inclusive, stride S >= 1) over a series of `count` steps, in order.
// Throws ugvr::Error naming `what` (the flag) for a malformed spec or a step out of range.
std::vector<uint32_t> parse_step_selection(std::string_view spec, size_t count, std::string_view what);

}  // namespace ugvr
