// libFuzzer target for the CGNS reader. libcgns opens files by path (ADF or HDF5) and reads them itself, so the
// input is written to a per-process temporary file (not a memfd) and read_cgns is called on it; the whole input is one
// CGNS file. Only ugvr::Error may escape the reader. libcgns and libhdf5 are not instrumented: a crash inside them is
// reported by the fuzzer all the same, but their out-of-bounds reads are not seen.
#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ugvr::fuzz::PathFile file("cgns", ".cgns", data, size);
  for (int64_t step : {int64_t(-1), int64_t(0)}) {
    try {
      ugvr::fuzz::touch_dataset(ugvr::read_cgns(file.path(), step));
    } catch (const ugvr::Error&) {
      // Malformed input reported properly.
    }
  }
  return 0;
}
