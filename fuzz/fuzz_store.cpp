// libFuzzer target for the brick store reader: the input is a whole .ugvr file. Opening validates the header, field
// records, node table, TF-error table and the time steps' section (checksums and every constrained value); then every
// brick of every time step (format version 6) and every cell block is decoded. Most mutations stop at a checksum; seeds
// from `ugvr build` with the checksums intact reach the validation of values. Only ugvr::Error may escape.
#include <vector>

#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/store/brick_store.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ugvr::fuzz::MemFile file("store", data, size);
  try {
    const ugvr::BrickStoreReader store(file.path());
    const uint64_t r = store.resolution();
    std::vector<float> samples(r * r * r);
    std::vector<uint8_t> mask(r * r * r);
    volatile float sink = 0;
    for (uint32_t t = 0; t < store.step_count() && t < 8; ++t) {
      sink = sink + float(store.step_time(t));
      for (uint64_t n = 0; n < store.node_count() && n < 64; ++n)
        for (uint32_t f = 0; f < store.field_count(); ++f) {
          try {
            store.read_brick(n, f, samples.data(), mask.data(), t);
            sink = sink + samples[0] + float(mask[r * r * r - 1]) + float(store.step_range(t, f).max);
          } catch (const ugvr::Error&) {
            // A node without a brick, or a corrupt block: reported properly.
          }
        }
    }
    // The leaves' cells (format version 5): each block checked as it is read.
    for (uint64_t n = 0; store.has_cells() && n < store.node_count() && n < 64; ++n) {
      if (store.cell_block(n).offset == 0) continue;
      try {
        const ugvr::NodeCells cells = store.read_cells(n);
        sink = sink + cells.points[0].x + float(cells.connectivity.back());
      } catch (const ugvr::Error&) {
        // A corrupt block: reported properly.
      }
    }
    (void)sink;
  } catch (const ugvr::Error&) {
    // Malformed input reported properly.
  }
  return 0;
}
