// Does temporal compression pay? (issue 18: "a step coded against the previous one, where you measure that it pays")
// Reads a store with time steps (format version 6) and, per node and step s >= 1, compares the step's blocks as the
// store keeps them (each coded on its own: quant16, the store's predictor, shuffle and codec) with the same samples
// coded as the difference from step s - 1: both steps quantized on one grid (the field's union range, the store's
// tolerance), the code differences encoded with the same block codec. Masked samples are skipped as the store skips
// them (the mask is shared by the steps).
// Usage: bench_time_delta STORE [MAX_NODES=2000] [--json]
//   MAX_NODES: nodes with a brick measured, evenly spread over the tree (all when fewer).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/store/brick_codec.h"
#include "ugvr/store/brick_store.h"

int main(int argc, char** argv) {
  using namespace ugvr;
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s STORE [MAX_NODES] [--json]\n", argv[0]);
    return 2;
  }
  try {
    const BrickStoreReader store(argv[1]);
    const uint64_t max_nodes = argc > 2 && argv[2][0] != '-' ? std::stoull(argv[2]) : 2000;
    const bool json = std::string(argv[argc - 1]) == "--json";
    if (!store.has_steps()) throw Error(std::string(argv[1]) + ": a store of one time step");
    const BrickStoreLayout& l = store.layout();
    if (l.encoding.samples != SampleEncoding::Quant16 || l.tolerance <= 0)
      throw Error("measured for quant16 stores with a tolerance (the default)");
    std::vector<uint64_t> with_brick;
    for (uint64_t n = 0; n < store.node_count(); ++n)
      if (store.node(n).has_brick()) with_brick.push_back(n);
    const uint64_t stride = std::max<uint64_t>(1, with_brick.size() / max_nodes);
    const uint32_t r = store.resolution();
    const size_t n3 = size_t(r) * r * r;
    std::vector<float> prev(n3), cur(n3), delta(n3);
    std::vector<uint8_t> mask(n3);
    uint64_t intra = 0, coded_delta = 0, blocks = 0;
    for (uint32_t f = 0; f < store.field_count(); ++f) {
      const double lo = l.fields[f].min, step = 2 * l.tolerance * (l.fields[f].max - l.fields[f].min);
      if (!(step > 0)) continue;
      for (uint64_t i = 0; i < with_brick.size(); i += stride) {
        const uint64_t n = with_brick[i];
        store.read_brick(n, f, prev.data(), mask.data(), 0);
        for (uint32_t s = 1; s < store.step_count(); ++s) {
          store.read_brick(n, f, cur.data(), mask.data(), s);
          for (size_t k = 0; k < n3; ++k) {
            const double q1 = std::nearbyint((cur[k] - lo) / step), q0 = std::nearbyint((prev[k] - lo) / step);
            delta[k] = mask[k] ? float((q1 - q0) * step) : 0.0f;
          }
          const EncodedBlock b = encode_brick(l.encoding, r, delta.data(), mask.data(), step, 0.0);
          intra += store.block(n, f, s).size;
          coded_delta += b.bytes.size();
          ++blocks;
          std::swap(prev, cur);
        }
      }
    }
    if (json) {
      std::printf(
          "{\"store\": \"%s\", \"steps\": %u, \"blocks\": %llu, \"intra_bytes\": %llu, \"delta_bytes\": %llu, "
          "\"delta_over_intra\": %.4f}\n",
          argv[1], store.step_count(), (unsigned long long)blocks, (unsigned long long)intra,
          (unsigned long long)coded_delta, blocks ? double(coded_delta) / double(intra) : 0.0);
    } else {
      std::printf(
          "%s: %llu blocks of steps 1..%u: each on its own %llu bytes, as differences from the previous step "
          "%llu bytes (%.3f of it)\n",
          argv[1], (unsigned long long)blocks, store.step_count() - 1, (unsigned long long)intra,
          (unsigned long long)coded_delta, blocks ? double(coded_delta) / double(intra) : 0.0);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_time_delta: %s\n", e.what());
    return 1;
  }
  return 0;
}
