// Cost of the volume-weighted histogram (render/field_histogram.h) against the unweighted one it replaced as the
// default transfer function's input on a mesh: the same field, bins and range, the two alternated RUNS times each.
//   bench_volume_histogram FILE... [--field NAME] [--runs 5] [--bins 128]
// Prints one JSON line: cells, points, the medians in seconds (wall), their ratio, and both histograms' peak bins.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ugvr/io/reader.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/field_histogram.h"

using namespace ugvr;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <class F>
double seconds(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

size_t peak(const std::vector<uint64_t>& c) { return size_t(std::max_element(c.begin(), c.end()) - c.begin()); }

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  std::string field;
  int runs = 5, bins = 128;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--field" && i + 1 < argc) {
      field = argv[++i];
    } else if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--bins" && i + 1 < argc) {
      bins = std::atoi(argv[++i]);
    } else {
      files.push_back(a);
    }
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: bench_volume_histogram FILE... [--field NAME] [--runs 5] [--bins 128]\n");
    return 2;
  }
  const Dataset ds = read_dataset(files);
  const Block& block = ds.blocks.front();
  const ScalarRef ref = block.fields.scalar(field.empty() ? default_field_names(block, 1).front() : field);
  const Range r = ref.field->range(ref.component);
  std::vector<double> plain, weighted;
  std::vector<uint64_t> hp, hw;
  for (int i = 0; i < runs; ++i) {
    plain.push_back(seconds([&] { hp = field_histogram(*ref.field, ref.component, r.min, r.max, bins); }));
    weighted.push_back(
        seconds([&] { hw = volume_histogram(block.grid, *ref.field, ref.component, r.min, r.max, bins); }));
  }
  std::printf(
      "{\"cells\": %llu, \"points\": %llu, \"field\": \"%s\", \"runs\": %d, \"unweighted_s\": %.6f, "
      "\"weighted_s\": %.6f, \"ratio\": %.2f, \"peak_bin_unweighted\": %zu, \"peak_bin_weighted\": %zu}\n",
      (unsigned long long)grid_cell_count(block.grid), (unsigned long long)grid_point_count(block.grid),
      ref.field->name().c_str(), runs, median(plain), median(weighted), median(weighted) / median(plain), peak(hp),
      peak(hw));
  return 0;
}
