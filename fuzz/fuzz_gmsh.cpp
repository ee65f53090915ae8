// libFuzzer target for the Gmsh reader: any input must either load or fail with ugvr::Error, never crash, hang or
// allocate without bound.
#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ugvr::fuzz::MemFile file("fuzz_gmsh.msh", data, size);
  try {
    ugvr::fuzz::touch_dataset(ugvr::read_gmsh(file.path()));
  } catch (const ugvr::Error&) {
    // Rejected input, reported the way a user would see it: fine.
  }
  return 0;
}
