// libFuzzer target for the NRRD reader: the input is one attached-data NRRD file. A detached "data file" resolves
// relative to /proc/self/fd/ and normally fails cleanly. Only ugvr::Error may escape the reader.
#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ugvr::fuzz::MemFile file("nrrd", data, size);
  try {
    ugvr::fuzz::touch_dataset(ugvr::read_nrrd(file.path()));
  } catch (const ugvr::Error&) {
    // Malformed input reported properly.
  }
  return 0;
}
