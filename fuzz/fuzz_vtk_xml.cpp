// libFuzzer target for the VTK XML reader. The input is one file, handed to read_vtk_xml as an in-memory file (memfd,
// opened through /proc/self/fd) so that the reader's real path (markup scan, positional reads of appended data) is
// exercised. A .pvtu input names its pieces relative to /proc/self/fd/: those opens either fail or find some other
// open file, and both must end in ugvr::Error or a valid result. Only ugvr::Error may escape the reader.
#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

using ugvr::fuzz::MemFile;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  MemFile file("vtk-xml", data, size);
  try {
    ugvr::fuzz::touch_dataset(ugvr::read_vtk_xml(file.path()));
  } catch (const ugvr::Error&) {
    // Malformed input reported properly: the expected outcome for most inputs.
  }
  return 0;
}
