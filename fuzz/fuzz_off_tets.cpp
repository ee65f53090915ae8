// libFuzzer target for the tetrahedral OFF reader: any input must either load or fail with ugvr::Error, never crash,
// hang or allocate without bound.
#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ugvr::fuzz::MemFile file("fuzz_off_tets.off", data, size);
  try {
    ugvr::fuzz::touch_dataset(ugvr::read_off_tets(file.path()));
  } catch (const ugvr::Error&) {
    // Rejected input, reported the way a user would see it: fine.
  }
  return 0;
}
