// The speed of hashing a file's bytes as the stored geometry keys do (io/byte_hash.h: hash_file_range), for the
// choice between mapping the file and reading it (issue 18 [time]: a file truncated while mapped ends the process).
//   bench_file_hash FILE [--rounds N (7)]
// Hashes the whole file N times (the first round warms the page cache and is not counted unless N is 1) and prints
// one JSON line: bytes, the median seconds of a round, GB/s at that median, and the hash (equal across builds when
// the hash's value did not change).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/byte_hash.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s FILE [--rounds N]\n", argv[0]);
    return 2;
  }
  int rounds = 7;
  for (int i = 2; i + 1 < argc; ++i)
    if (!std::strcmp(argv[i], "--rounds")) rounds = std::max(1, std::atoi(argv[++i]));
  try {
    const ugvr::InputFile file(argv[1]);
    std::vector<double> seconds;
    uint64_t hash = 0;
    for (int r = 0; r < rounds + (rounds > 1 ? 1 : 0); ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      hash = ugvr::hash_file_range(file, 0, file.size());
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (r > 0 || rounds == 1) seconds.push_back(s);
    }
    std::sort(seconds.begin(), seconds.end());
    const size_t m = seconds.size();
    const double median = m % 2 ? seconds[m / 2] : 0.5 * (seconds[m / 2 - 1] + seconds[m / 2]);
    std::printf(
        "{\"bench\":\"file_hash\",\"bytes\":%llu,\"rounds\":%zu,\"median_s\":%.4f,\"gb_per_s\":%.2f,"
        "\"hash\":\"%016llx\"}\n",
        static_cast<unsigned long long>(file.size()), m, median, double(file.size()) / median / 1e9,
        static_cast<unsigned long long>(hash));
  } catch (const ugvr::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
