// libFuzzer target for the Exodus II reader. netCDF opens files by path and mmaps or re-opens them itself, so the
// input is written to a per-process temporary file (not a memfd) and read_exodus is called on it; the whole input is
// one netCDF file. Only ugvr::Error may escape the reader. libnetcdf is not instrumented: a crash inside it is
// reported by the fuzzer all the same, but its out-of-bounds reads are not seen.
#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ugvr::fuzz::PathFile file("exodus", ".exo", data, size);
  for (int64_t step : {int64_t(-1), int64_t(0)}) {
    try {
      ugvr::fuzz::touch_dataset(ugvr::read_exodus(file.path(), step));
    } catch (const ugvr::Error&) {
      // Malformed input reported properly.
    }
  }
  return 0;
}
