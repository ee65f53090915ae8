// Transfer-function edit cost of the transfer-function-aware error (render/lod/tf_error.h): the time to recompute
// every node's error from the store's error table when the transfer function changes (the cut selections do it once
// per change, not per frame).
//   bench_tf_error STORE.ugvr [FIELD=first] [EDITS=21]
// Each edit moves a steep opacity ramp (from 0.05 to 0.8 over 10 % of the field's range, unit distance = the data's
// diagonal / 200) to another place and recomputes; prints one JSON
// line: nodes, whether the store has the table, the median and max seconds over the edits after the first (which
// also allocates), the fraction of nodes with error 0 (transparent or uniform: never split) at the last edit, and the
// size of a still frame's "pixels:1" cut (512², default view, a 0-to-0.8 ramp at 45-55 % of the range) with and
// without the transfer-function weight.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/lod/lod_cut.h"
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
  std::vector<double> seconds, cpu;
  // This thread's CPU time: on a loaded shared machine the wall time measures the load as much as the code.
  auto thread_cpu = [] {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
  };
  for (int e = 0; e < edits; ++e) {
    const double at = f.min + (f.max - f.min) * (0.05 + 0.8 * double(e) / double(edits - 1));
    TransferFunction tf;
    tf.color_points = {{f.min, {0.2, 0.3, 0.9}}, {f.max, {0.9, 0.8, 0.1}}};
    // Nowhere transparent and the colour varying everywhere: no node is settled by its value range alone, every one
    // goes through its table (the slowest case).
    tf.opacity_points = {{f.min, 0.05}, {at, 0.05}, {at + 0.1 * (f.max - f.min), 0.8}, {f.max, 0.8}};
    tf.opacity_unit_distance = length(store.layout().data.size()) / 200;
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = thread_cpu();
    errors.update(tf);
    cpu.push_back(thread_cpu() - c0);
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  // What the weight does to a still frame's cut: "pixels:1" at 512² from the default view, for the last edit's
  // transfer function and for one whose ramp sits at the middle of the range, with and without the weight.
  auto cut_of = [&](double at, bool weighted) {
    TransferFunction tf;
    tf.color_points = {{f.min, {0.2, 0.3, 0.9}}, {f.max, {0.9, 0.8, 0.1}}};
    tf.opacity_points = {{f.min, 0.0}, {at, 0.0}, {at + 0.1 * (f.max - f.min), 0.8}, {f.max, 0.8}};
    tf.opacity_unit_distance = length(store.layout().data.size()) / 200;
    CutOptions o;
    o.field = uint32_t(field);
    o.tf_error = weighted;
    return select_cut(store, parse_cut_spec("pixels:1"), reset_camera(store.layout().data), 512, 512, tf, o);
  };
  const double mid = f.min + 0.45 * (f.max - f.min);
  const Cut with = cut_of(mid, true), without = cut_of(mid, false);
  std::vector<double> timed(seconds.begin() + 1, seconds.end());
  std::sort(timed.begin(), timed.end());
  std::vector<double> timed_cpu(cpu.begin() + 1, cpu.end());
  std::sort(timed_cpu.begin(), timed_cpu.end());
  uint64_t zero = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) zero += errors.error(id) == 0;
  std::printf(
      "{\"store\":\"%s\",\"field\":\"%s\",\"nodes\":%llu,\"table\":%s,\"edits\":%zu,\"median_s\":%.6f,\"max_s\":%.6f,"
      "\"median_cpu_s\":%.6f,"
      "\"zero_error_fraction\":%.4f,\"cut_pixels1_weighted\":%zu,\"cut_pixels1_unweighted\":%zu,"
      "\"cut_mean_level_weighted\":%.2f,\"cut_mean_level_unweighted\":%.2f}\n",
      argv[1], f.name.c_str(), (unsigned long long)store.node_count(), store.has_tf_errors() ? "true" : "false",
      timed.size(), timed[timed.size() / 2], timed.back(), timed_cpu[timed_cpu.size() / 2],
      double(zero) / double(store.node_count()), with.nodes.size(), without.nodes.size(), with.mean_level,
      without.mean_level);
  return 0;
}
