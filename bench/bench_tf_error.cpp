// Transfer-function edit cost of the transfer-function-aware error (render/lod/tf_error.h): the time to recompute
// every node's error from the store's error table when the transfer function changes (the cut selections do it once
// per change, not per frame).
//   bench_tf_error STORE.ugvr [FIELD=first] [EDITS=21]
// Each edit moves a steep opacity ramp (from 0.05 to 0.8 over 10 % of the field's range, unit distance = the data's
// diagonal / 200) to another place and recomputes; prints one JSON
// line: nodes, whether the store has the table, the median and max seconds over the edits after the first (which
// also allocates), and the fraction of nodes with error 0 (transparent or uniform: never split) at the last edit.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ugvr/render/lod/tf_error.h"
#include "ugvr/store/brick_store.h"

using namespace ugvr;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_tf_error STORE.ugvr [FIELD] [EDITS=21]\n");
    return 2;
  }
  const BrickStoreReader store(argv[1]);
  int field = 0;
  if (argc > 2 && std::string(argv[2]) != "-") field = store.field_index(argv[2]);
  if (field < 0) {
    std::fprintf(stderr, "no field %s\n", argv[2]);
    return 2;
  }
  const int edits = argc > 3 ? std::max(2, std::atoi(argv[3])) : 21;
  const BrickStoreField& f = store.layout().fields[size_t(field)];
  TfNodeErrors errors(store, uint32_t(field));
  std::vector<double> seconds;
  for (int e = 0; e < edits; ++e) {
    const double at = f.min + (f.max - f.min) * (0.05 + 0.8 * double(e) / double(edits - 1));
    TransferFunction tf;
    tf.color_points = {{f.min, {0.2, 0.3, 0.9}}, {f.max, {0.9, 0.8, 0.1}}};
    // Nowhere transparent and the colour varying everywhere: no node is settled by its value range alone, every one
    // goes through its table (the slowest case).
    tf.opacity_points = {{f.min, 0.05}, {at, 0.05}, {at + 0.1 * (f.max - f.min), 0.8}, {f.max, 0.8}};
    tf.opacity_unit_distance = length(store.layout().data.size()) / 200;
    const auto t0 = std::chrono::steady_clock::now();
    errors.update(tf);
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::vector<double> timed(seconds.begin() + 1, seconds.end());
  std::sort(timed.begin(), timed.end());
  uint64_t zero = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) zero += errors.error(id) == 0;
  std::printf(
      "{\"store\":\"%s\",\"field\":\"%s\",\"nodes\":%llu,\"table\":%s,\"edits\":%zu,\"median_s\":%.6f,\"max_s\":%.6f,"
      "\"zero_error_fraction\":%.4f}\n",
      argv[1], f.name.c_str(), (unsigned long long)store.node_count(), store.has_tf_errors() ? "true" : "false",
      timed.size(), timed[timed.size() / 2], timed.back(), double(zero) / double(store.node_count()));
  return 0;
}
