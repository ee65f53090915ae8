// libFuzzer target for the PLOT3D reader. The input is split in two files: byte 0..3 (little-endian uint32) give the
// length of the grid part; its top bit set means "no solution file" (geometry only). The grid part follows, the rest
// is the solution (Q) file. Both are handed to read_plot3d as in-memory files (memfd, opened through /proc/self/fd),
// so that the reader's real file path (sizes, positional reads) is exercised. Only ugvr::Error may escape the reader.
#include <algorithm>
#include <cstring>

#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

using ugvr::fuzz::MemFile;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 4) return 0;
  uint32_t split;
  std::memcpy(&split, data, 4);
  const bool grid_only = (split & 0x80000000u) != 0;
  data += 4;
  size -= 4;
  const size_t grid_size = std::min<size_t>(split & 0x7fffffffu, size);
  MemFile grid("plot3d-grid", data, grid_size);
  MemFile q("plot3d-q", data + grid_size, size - grid_size);
  try {
    ugvr::fuzz::touch_dataset(ugvr::read_plot3d(grid.path(), grid_only ? std::string() : q.path()));
  } catch (const ugvr::Error&) {
    // Malformed input reported properly: the expected outcome for most inputs.
  }
  return 0;
}
