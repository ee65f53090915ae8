// libFuzzer target for the UGRID reader. The variant of a UGRID file comes from its name, so the first input byte
// picks the name (ASCII, one of the ten binary suffixes, or no suffix for size detection) and the rest is the file,
// written to a per-process temporary directory. Any input must either load or fail with ugvr::Error, never crash, hang
// or allocate without bound.
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/reader.h"

namespace {

constexpr std::array<const char*, 11> kNames = {"mesh.ugrid",     "mesh.b8.ugrid",  "mesh.lb8.ugrid",  "mesh.b4.ugrid",
                                                "mesh.lb4.ugrid", "mesh.b8l.ugrid", "mesh.lb8l.ugrid", "mesh.r8.ugrid",
                                                "mesh.lr8.ugrid", "mesh.r4.ugrid",  "mesh.lr4.ugrid"};

const std::filesystem::path& temp_dir() {
  static const std::filesystem::path dir = [] {
    ugvr::Progress::set_enabled(false);
    const auto d = std::filesystem::temp_directory_path() / ("fuzz_ugrid-" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string path = (temp_dir() / kNames[data[0] % kNames.size()]).string();
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 1 && std::fwrite(data + 1, 1, size - 1, f) != size - 1) std::abort();
  std::fclose(f);
  try {
    ugvr::read_ugrid(path);
  } catch (const ugvr::Error&) {
    // Rejected input: fine.
  }
  std::remove(path.c_str());
  return 0;
}
