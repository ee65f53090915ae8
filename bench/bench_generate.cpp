// Generation throughput and peak memory of the synthetic dataset generator.
//   bench_generate CELLS OUTPUT.vtu [hex|tet|mixed] [none|zlib|lz4] [--delete]
// Prints one JSON line: the grid, seconds, cells/s, MB/s of file written and peak RSS (getrusage ru_maxrss), which
// must stay at a few tens of MiB whatever CELLS is. --delete removes the output afterwards (large benchmarks).
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/gen/generator.h"

using namespace ugvr;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_generate CELLS OUTPUT.vtu [hex|tet|mixed] [none|zlib|lz4] [--delete]\n");
    return 2;
  }
  GenerateOptions o;
  o.cells = std::strtoull(argv[1], nullptr, 10);
  const std::string out = argv[2];
  bool remove_after = false;
  for (int a = 3; a < argc; ++a) {
    const std::string arg = argv[a];
    if (auto kind = parse_gen_cell_kind(arg))
      o.kind = *kind;
    else if (arg == "none")
      o.codec = Codec::None;
    else if (arg == "zlib")
      o.codec = Codec::Zlib;
    else if (arg == "lz4")
      o.codec = Codec::Lz4;
    else if (arg == "--delete")
      remove_after = true;
    else {
      std::fprintf(stderr, "bench_generate: unknown argument '%s'\n", arg.c_str());
      return 2;
    }
  }
  try {
    const GenerateStats s = generate_dataset(o, out);
    if (remove_after) ::unlink(out.c_str());
    const char* codec = o.codec == Codec::None ? "none" : o.codec == Codec::Zlib ? "zlib" : "lz4";
    std::printf(
        "{\"bench\":\"generate\",\"kind\":\"%s\",\"codec\":\"%s\",\"dims\":[%u,%u,%u],\"cells\":%llu,"
        "\"points\":%llu,\"file_bytes\":%llu,\"seconds\":%.3f,\"cells_per_second\":%.0f,\"mb_per_second\":%.1f,"
        "\"peak_rss_bytes\":%llu,\"peak_rss\":\"%s\"}\n",
        std::string(gen_cell_kind_name(o.kind)).c_str(), codec, s.plan.ni, s.plan.nj, s.plan.nk,
        (unsigned long long)s.cells, (unsigned long long)s.points, (unsigned long long)s.bytes, s.seconds,
        double(s.cells) / s.seconds, double(s.bytes) / 1e6 / s.seconds, (unsigned long long)peak_rss_bytes(),
        format_bytes(peak_rss_bytes()).c_str());
  } catch (const Error& e) {
    std::fprintf(stderr, "bench_generate: %s\n", e.what());
    return 1;
  }
  return 0;
}
