// libFuzzer target for the VTK XML reader. The input is one file, handed to read_vtk_xml as an in-memory file (memfd,
// opened through /proc/self/fd) so that the reader's real path (markup scan, positional reads of appended data) is
// exercised. A .pvtu input names its pieces relative to /proc/self/fd/: those opens either fail or find some other
// open file, and both must end in ugvr::Error or a valid result. Only ugvr::Error may escape the reader.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
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
  MemFile file("vtk-xml", data, size);
  try {
    const ugvr::Dataset ds = ugvr::read_vtk_xml(file.path());
    // Touch what was read so that inconsistencies between counts and storage would show under ASan.
    volatile uint64_t sink = ds.point_count() + ds.cell_count();
    for (const ugvr::Block& b : ds.blocks) {
      for (const ugvr::Field& f : b.fields) sink = sink + uint64_t(f.range().max != 0);
      if (const auto* mesh = std::get_if<ugvr::UnstructuredMesh>(&b.grid)) {
        for (uint32_t v : mesh->connectivity) sink = sink + uint64_t(mesh->points[v].x != 0);
      }
    }
    (void)sink;
  } catch (const ugvr::Error&) {
    // Malformed input reported properly: the expected outcome for most inputs.
  }
  return 0;
}
