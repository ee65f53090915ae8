// libFuzzer target for the EnSight Gold reader. The input is three files: bytes 0..3 and 4..7 (little-endian
// uint32, each taken modulo what is left + 1) give the lengths of the .case part and the geometry part; the rest is
// one variable file. They are written as f.case, f.geo and f.var into a per-process temporary directory (a case
// names its files, so a memfd will not do) and read through the case file. Seeds (scripts/fuzz.sh) are the shared
// samples with their case files rewritten to name f.geo and f.var. Only ugvr::Error may escape the reader.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/reader.h"

namespace {

const std::string& temp_dir() {
  static const std::string dir = [] {
    ugvr::Progress::set_enabled(false);
    const auto d = std::filesystem::temp_directory_path() / ("ugvr-fuzz-ensight-" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d.string();
  }();
  return dir;
}

void write(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  if (!out) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 8) return 0;
  uint32_t lengths[2];
  std::memcpy(lengths, data, 8);
  data += 8;
  size -= 8;
  const size_t case_size = lengths[0] % (size + 1);
  const size_t geo_size = lengths[1] % (size - case_size + 1);
  const std::string case_path = temp_dir() + "/f.case";
  write(case_path, data, case_size);
  write(temp_dir() + "/f.geo", data + case_size, geo_size);
  write(temp_dir() + "/f.var", data + case_size + geo_size, size - case_size - geo_size);
  for (const int64_t step : {int64_t(-1), int64_t(0)}) {
    try {
      ugvr::fuzz::touch_dataset(ugvr::read_ensight(case_path, step));
    } catch (const ugvr::Error&) {
      // Malformed input reported properly.
    }
  }
  return 0;
}
