// Shared pieces of the libFuzzer targets: inputs are handed to the readers as real files (memfd, opened through
// /proc/self/fd) so that the readers' own file path (sizes, positional and buffered reads) is what gets fuzzed, and
// what a reader returns is touched so that a count that disagrees with its storage shows up under ASan.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "ugvr/core/progress.h"
#include "ugvr/grid/dataset.h"

namespace ugvr::fuzz {

// An anonymous in-memory file holding `size` bytes; closed on destruction.
class MemFile {
 public:
  MemFile(const char* name, const uint8_t* data, size_t size) {
    Progress::set_enabled(false);
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

// The input as a real file at a per-process path (TMPDIR or /tmp), for readers whose library opens files by name
// itself (netCDF, libcgns): a memfd's /proc path would not do for them. Removed on destruction.
class PathFile {
 public:
  PathFile(const char* name, const char* extension, const uint8_t* data, size_t size) {
    Progress::set_enabled(false);
    const char* dir = std::getenv("TMPDIR");
    path_ = std::string(dir && *dir ? dir : "/tmp") + "/ugvr-fuzz-" + name + "-" + std::to_string(getpid()) + extension;
    FILE* f = std::fopen(path_.c_str(), "wb");
    if (!f) __builtin_trap();
    if (size && std::fwrite(data, 1, size, f) != size) __builtin_trap();
    std::fclose(f);
  }
  ~PathFile() { std::remove(path_.c_str()); }
  PathFile(const PathFile&) = delete;
  PathFile& operator=(const PathFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Reads every point a cell names and every field's range.
inline void touch_dataset(const Dataset& ds) {
  volatile uint64_t sink = ds.point_count() + ds.cell_count();
  for (const Block& b : ds.blocks) {
    for (const Field& f : b.fields) sink = sink + uint64_t(f.range().max != 0);
    if (const auto* mesh = std::get_if<UnstructuredMesh>(&b.grid)) {
      for (uint32_t v : mesh->connectivity) sink = sink + uint64_t(mesh->points[v].x != 0);
    }
  }
  (void)sink;
}

}  // namespace ugvr::fuzz
