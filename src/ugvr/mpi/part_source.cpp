// Which inputs are read by parts under MPI (part_source.h).
#include "ugvr/mpi/part_source.h"

#include <algorithm>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/io/pvtu_pieces.h"
#include "ugvr/io/vtu_pieces.h"

namespace ugvr::mpi {

uint64_t range_count(uint64_t cells, int ranks) {
  const uint64_t n = uint64_t(std::max(ranks, 1));
  return std::max(n, std::min(std::max<uint64_t>(64, 4 * n), cells / kMinRangeCells));
}

std::unique_ptr<PartSource> open_part_source(const std::string& path, const ReadOptions& read, int ranks) {
  if (is_pvtu_path(path)) return pvtu_part_source(path);
  const InputFormat format = detect_format(std::vector<std::string>{path});
  const std::optional<GridCounts> counts = grid_counts_from_headers(std::vector<std::string>{path});
  const uint64_t ranges = range_count(counts ? counts->cells : 0, ranks);
  if (format == InputFormat::VtkXml && extension_lower(path) == ".vtu") {
    if (vtu_piece_count(path) > 1) return vtu_piece_source(path);
    // A single-piece .vtu otherwise encoded (compressed, base64, ascii) is read whole: a range of it could not be
    // read without decoding what lies before it.
    if (vtu_reads_by_cell_ranges(path)) return vtu_range_source(path, ranges);
    return nullptr;
  }
  if (format == InputFormat::Exodus) return exodus_part_source(path, read.time_step, ranges);
  return nullptr;
}

}  // namespace ugvr::mpi
