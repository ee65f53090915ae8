// Parts of an Exodus II file, for a reader that takes only some of its cells: under mpirun each rank reads the cell
// ranges of the pieces it owns (src/ugvr/mpi/part_source.h, docs/mpi.md "Reading only a rank's part"). Cells are
// numbered as read_exodus numbers them: the volume blocks' elements, block after block.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

struct ExodusCellRange {
  uint64_t first = 0, count = 0;
  // Widen the nodes read to node 1 / to the last node (the first / the last piece of a file: see read_exodus_cells).
  bool from_first_node = false, to_last_node = false;
};

// The volume blocks' layout from the dimensions and the connect variables' attributes alone (no coordinates, no
// connectivity): the cell each kept block starts at, in order, and the cells of all of them. Throws ugvr::Error as
// read_exodus does for a file it would refuse.
struct ExodusLayout {
  std::vector<uint64_t> block_starts;
  uint64_t cells = 0;
};
ExodusLayout read_exodus_layout(const std::string& path);

// `pieces` cell ranges (fewer for fewer cells) of about equal counts: cut evenly, each cut moved to the nearest block
// boundary within 1/8 of a range, so small blocks are joined into ranges and large blocks cut, the ranges even to
// within 1/8 (ranks dealt them round robin read alike), and a range falls between blocks where that is cheap.
std::vector<ExodusCellRange> exodus_cell_ranges(const ExodusLayout& layout, uint64_t pieces);

// read_exodus of the cells in `range` only, for time step `time_step` (-1: the last): one unstructured block with
// those cells (block_id and the element variables included), the nodes they use, read in runs of node numbers (one
// netCDF hyperslab per run and variable; used nodes under 64 apart share a run; widened as `range` asks), and the
// nodal variables on those nodes. Fields and their types are the whole read's (an element variable that this range's
// blocks lack is 0 there, as in a whole read). Throws ugvr::Error naming the file, as read_exodus does, and for a
// range beyond the volume cells.
// `node_numbers`, when given, receives each point's 0-based node number in the file (a whole read's point index).
Dataset read_exodus_cells(const std::string& path, int64_t time_step, const ExodusCellRange& range,
                          std::vector<uint32_t>* node_numbers = nullptr);

}  // namespace ugvr
