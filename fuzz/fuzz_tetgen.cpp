// libFuzzer target for the TetGen reader. The input is split in two files: bytes 0..3 (little-endian uint32, taken
// modulo the rest's size + 1) give the length of the .node part, the rest is the .ele part. TetGen meshes are two
// files found by name (x.node beside x.ele), so they are written side by side into a per-process temporary directory
// and read by path (a memfd has no sibling). Only ugvr::Error may escape the reader.
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
    const auto d = std::filesystem::temp_directory_path() / ("ugvr-fuzz-tetgen-" + std::to_string(getpid()));
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
  if (size < 4) return 0;
  uint32_t split;
  std::memcpy(&split, data, 4);
  data += 4;
  size -= 4;
  const size_t node_size = split % (size + 1);
  const std::string node = temp_dir() + "/x.node";
  write(node, data, node_size);
  write(temp_dir() + "/x.ele", data + node_size, size - node_size);
  try {
    ugvr::fuzz::touch_dataset(ugvr::read_tetgen(node));
  } catch (const ugvr::Error&) {
    // Malformed input reported properly.
  }
  return 0;
}
