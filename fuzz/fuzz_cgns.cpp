// libFuzzer target for the CGNS reader. libcgns opens files by path (ADF or HDF5) and reads them itself, so the
// input is written to a per-process temporary file (not a memfd) and read_cgns is called on it; the whole input is one
// CGNS file. Only ugvr::Error may escape the reader. libcgns and libhdf5 are not instrumented: a crash inside them is
// reported by the fuzzer all the same, but their out-of-bounds reads are not seen.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace {

std::string temp_path() {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir && *dir ? dir : "/tmp") + "/ugvr-fuzz-cgns-" + std::to_string(getpid()) + ".cgns";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = temp_path();
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) __builtin_trap();
  if (size && std::fwrite(data, 1, size, f) != size) __builtin_trap();
  std::fclose(f);
  for (int64_t step : {int64_t(-1), int64_t(0)}) {
    try {
      const ugvr::Dataset ds = ugvr::read_cgns(path, step);
      volatile uint64_t sink = ds.point_count() + ds.cell_count();
      for (const ugvr::Field& fld : ds.blocks.at(0).fields) sink = sink + uint64_t(fld.range().max != 0);
      (void)sink;
    } catch (const ugvr::Error&) {
      // Malformed input reported properly.
    }
  }
  std::remove(path.c_str());
  return 0;
}
