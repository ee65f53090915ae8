// Load throughput and peak memory of a reader.
//   bench_load INPUT [INPUT2]
// Prints one JSON line: seconds, MB/s of file, cells/s, in-memory dataset bytes, peak RSS and their ratio.
// Run it as its own process per measurement so peak RSS is that of the load alone.
#include <sys/stat.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "ugvr/core/memory.h"
#include "ugvr/io/reader.h"

using namespace ugvr;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_load INPUT [SOLUTION]\n");
    return 2;
  }
  std::vector<std::string> inputs(argv + 1, argv + argc);
  uint64_t file_bytes = 0;
  for (const auto& p : inputs) {
    struct stat st {};
    if (stat(p.c_str(), &st) == 0) file_bytes += uint64_t(st.st_size);
  }
  const uint64_t rss_before = current_rss_bytes();
  const auto t0 = std::chrono::steady_clock::now();
  const Dataset ds = read_dataset(inputs);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const uint64_t mem = ds.memory_bytes(), peak = peak_rss_bytes();
  std::printf(
      "{\"bench\":\"load\",\"input\":\"%s\",\"file_bytes\":%llu,\"seconds\":%.3f,\"mb_per_second\":%.1f,"
      "\"cells\":%llu,\"cells_per_second\":%.0f,\"dataset_bytes\":%llu,\"rss_before_bytes\":%llu,"
      "\"peak_rss_bytes\":%llu,\"peak_over_dataset\":%.3f}\n",
      inputs[0].c_str(), (unsigned long long)file_bytes, seconds, double(file_bytes) / 1e6 / seconds,
      (unsigned long long)ds.cell_count(), double(ds.cell_count()) / seconds, (unsigned long long)mem,
      (unsigned long long)rss_before, (unsigned long long)peak, double(peak) / double(mem));
  return 0;
}
