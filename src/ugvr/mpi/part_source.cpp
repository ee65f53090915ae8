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
  // A single-piece .vtu is read whole (no part of it can be read alone yet).
  if (format == InputFormat::VtkXml && extension_lower(path) == ".vtu" && vtu_piece_count(path) > 1)
    return vtu_piece_source(path);
  if (format == InputFormat::Exodus) {
    // Pieces are dealt out to ranks round robin: several per rank even out ranks, and a piece of a few thousand
    // cells or more costs little in reads (one hyperslab per variable) or in the kd-tree's sample.
    return exodus_part_source(path, read.time_step, std::max<uint64_t>(64, 4 * uint64_t(ranks)));
  }
  return nullptr;
}

}  // namespace ugvr::mpi
