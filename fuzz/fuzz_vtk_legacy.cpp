// libFuzzer target for the legacy VTK reader: any input must either load or fail with ugvr::Error, never crash, hang
// or allocate without bound. The input is written to an in-memory file (memfd) that the reader opens by its
// /proc/self/fd path, so the real file path (InputFile, buffered tokenizer, positional reads) is exercised.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/reader.h"

namespace {

// One memfd for the whole run, rewritten for every input.
int input_fd() {
  static const int fd = [] {
    ugvr::Progress::set_enabled(false);
    const int f = memfd_create("fuzz_vtk_legacy.vtk", MFD_CLOEXEC);
    if (f < 0) std::abort();
    return f;
  }();
  return fd;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const int fd = input_fd();
  if (ftruncate(fd, 0) != 0) std::abort();
  size_t done = 0;
  while (done < size) {
    const ssize_t n = pwrite(fd, data + done, size - done, off_t(done));
    if (n <= 0) std::abort();
    done += size_t(n);
  }
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  try {
    ugvr::read_vtk_legacy(path);
  } catch (const ugvr::Error&) {
    // Rejected input, reported the way a user would see it: fine.
  }
  return 0;
}
