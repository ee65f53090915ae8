// Whether `ugvr view` may hold a grid in memory: the in-core cost of its exact preview (the dataset as read, its
// walk mesh, and the in-core build of its store beside them) estimated before anything is read, against a budget.
// Over the budget the viewer never reads the grid: it builds the store out of core and shows that alone.
//
// The estimate, from what can be known without reading the data:
//  - where the input's headers say its point and cell counts (io/reader.h grid_counts_from_headers: .vtu, .pvtu,
//    Exodus, CGNS, OpenFOAM), those counts at kViewBytesPerCell and kViewBytesPerPoint (measured: bench/README.md,
//    "first image"); compression does not matter;
//  - anything else: kViewBytesPerInputByte times the input's size on disk (the files, a directory's files), which
//    would undercount compressed files: those of the formats above are counted instead; of the others only NRRD
//    may be compressed (gzip encoding).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace ugvr::view {

// Measured on a generated tetrahedral mesh (`ugvr generate --cells 10000000 --kind tet`: 10.0M cells, 1.7M points,
// 323 MiB): the resident peak of `ugvr view` (the grid, its walk mesh and the in-core build of its store, to the
// end) was 2.83 GB, 283 bytes a cell with its share of the points, 8.4 bytes per byte of the file (bench/README.md,
// "first image"); a point's own share (its position and a few fields) is set apart so that meshes with more points
// per cell (hexahedra) are not undercounted. The viewer's fixed cost (the GL context of llvmpipe, the server, the
// first buffers) is set apart too: 300,000 tetrahedra peaked at 218 MB and 300,000 hexahedra at 253 MB, where the
// per-cell terms alone said 84 and 102 MB (the ninth session's note); 130 MB of fixed cost and 259 bytes a cell
// give the 10M-cell peak and both of these within 11 %.
inline constexpr double kViewFixedBytes = 130e6;
inline constexpr double kViewBytesPerCell = 259, kViewBytesPerPoint = 64;
inline constexpr double kViewBytesPerInputByte = 8.5;

// The default budget: this fraction of the machine's physical memory (core/memory.h), leaving the rest to the
// system, the page's browser and other programs.
inline constexpr double kViewMemoryFraction = 0.5;
// Overrides the default (a byte size as the flags take it: 12GiB, 800MB, 1048576); `--memory-budget` overrides it.
inline constexpr const char* kViewMemoryBudgetEnv = "UGVR_VIEW_MEMORY_BUDGET";

struct InCoreEstimate {
  uint64_t bytes = 0;              // what the viewer would hold
  uint64_t input_bytes = 0;        // the input's size on disk
  uint64_t cells = 0, points = 0;  // from the input's headers; 0: unknown (the estimate is from the size)
  std::string basis;               // how it was estimated, for the message ("10000000 cells, 1790000 points")
};
// Throws ugvr::Error naming a file that cannot be read.
InCoreEstimate estimate_in_core(const std::vector<std::string>& inputs);

// "the grid would take about 26.3 GiB in memory (99890616 cells, ...), over the memory budget of 11.7 GiB (SOURCE)":
// why a grid is not read whole (`ugvr view`, `ugvr render`, `ugvr.render`).
std::string over_budget_reason(const InCoreEstimate& need, uint64_t budget, const std::string& source);
// Only a single .vtu is built out of core: any other input over the budget throws ugvr::Error naming it, `why` and
// the advice (convert it, or raise the budget with `raise`, e.g. "--memory-budget or $UGVR_VIEW_MEMORY_BUDGET").
void require_out_of_core_input(const std::vector<std::string>& inputs, const std::string& why,
                               const std::string& raise);

// "8GiB" and the like, as the byte-size flags take them (CLI::AsSizeValue(true)): a count with an optional unit, KiB
// MiB GiB TiB in powers of 1024, k M G T (with or without B) in powers of 1000. Throws ugvr::Error naming `what`.
uint64_t parse_byte_size(const std::string& text, const std::string& what);

// The budget: `flag` if given, else $UGVR_VIEW_MEMORY_BUDGET, else kViewMemoryFraction of physical memory.
// `source` says which ("--memory-budget", the variable, "half of the machine's 23.4 GiB").
uint64_t view_memory_budget(std::optional<uint64_t> flag, std::string* source = nullptr);

}  // namespace ugvr::view
