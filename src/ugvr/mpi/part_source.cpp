// Which inputs are read by parts under MPI (part_source.h).
#include "ugvr/mpi/part_source.h"

#include <algorithm>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/io/pvtu_pieces.h"
#include "ugvr/io/vtu_pieces.h"

namespace ugvr::mpi {

std::unique_ptr<PartSource> open_part_source(const std::string& path, const ReadOptions& read, int ranks) {
  if (is_pvtu_path(path)) return pvtu_part_source(path);
  const InputFormat format = detect_format(std::vector<std::string>{path});
  // Cell ranges are dealt out to ranks round robin: several per rank even the ranks out, and a range of a few
  // thousand cells or more costs little in reads (one hyperslab or byte range per array) or in the kd-tree's sample.
  const uint64_t ranges = std::max<uint64_t>(64, 4 * uint64_t(ranks));
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
