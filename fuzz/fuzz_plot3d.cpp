// libFuzzer target for the PLOT3D reader. The input is split in two files: byte 0..3 (little-endian uint32) give the
// length of the grid part; its top bit set means "no solution file" (geometry only). The grid part follows, the rest
// is the solution (Q) file. Both are handed to read_plot3d as in-memory files (memfd, opened through /proc/self/fd),
// so that the reader's real file path (sizes, positional reads) is exercised. Only ugvr::Error may escape the reader.
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace {

// An anonymous in-memory file holding `size` bytes; closed on destruction.
class MemFile {
 public:
  MemFile(const char* name, const uint8_t* data, size_t size) {
    fd_ = memfd_create(name, MFD_CLOEXEC);
    if (fd_ < 0) __builtin_trap();
    for (size_t done = 0; done < size;) {
      const ssize_t w = write(fd_, data + done, size - done);
      if (w <= 0) __builtin_trap();
      done += size_t(w);
    }
  }
  ~MemFile() { close(fd_); }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;
  std::string path() const { return "/proc/self/fd/" + std::to_string(fd_); }

 private:
  int fd_ = -1;
};

}  // namespace

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
    const ugvr::Dataset ds = ugvr::read_plot3d(grid.path(), grid_only ? std::string() : q.path());
    // Touch what was read so that inconsistencies between counts and storage would show under ASan.
    volatile uint64_t sink = ds.point_count() + ds.cell_count();
    for (const ugvr::Block& b : ds.blocks) {
      for (const ugvr::Field& f : b.fields) sink = sink + uint64_t(f.range().max != 0);
    }
    (void)sink;
  } catch (const ugvr::Error&) {
    // Malformed input reported properly: the expected outcome for most inputs.
  }
  return 0;
}
