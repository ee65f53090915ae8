// Replays inputs through the fuzz targets without libFuzzer, so that CI (gcc, the release and the ASan/UBSan builds)
// runs every target on its seeds and on deterministic mutations of them: the regression corpus of issue 23.
//
//   ugvr_fuzz_replay TARGET [--mutate N] FILE|DIR...
//
// Every fuzz_*.cpp is compiled into this one binary with its LLVMFuzzerTestOneInput renamed ugvr_replay_<target>
// (tests/CMakeLists.txt; the list is replay_targets.inc). With --mutate N, each input also runs truncated at eighths
// of its length and with N single-byte changes and N 32-bit header words set to 0, -1 and INT32_MAX (positions from a
// fixed linear congruential sequence, so a failure reproduces). A crash or sanitizer report fails the run; inputs the
// readers refuse with ugvr::Error are what is expected.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#define UGVR_REPLAY_TARGET(name) extern "C" int ugvr_replay_##name(const uint8_t* data, size_t size);
#include "replay_targets.inc"
#undef UGVR_REPLAY_TARGET

namespace {

using Target = int (*)(const uint8_t*, size_t);

std::vector<uint8_t> read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

uint64_t lcg(uint64_t& state) {
  state = state * 6364136223846793005ull + 1442695040888963407ull;
  return state >> 33;
}

uint64_t replay(Target target, const std::vector<uint8_t>& input, int mutations, uint64_t seed) {
  uint64_t runs = 1;
  target(input.data(), input.size());
  if (mutations <= 0 || input.empty()) return runs;
  for (int k = 0; k < 8; ++k, ++runs) target(input.data(), input.size() * size_t(k) / 8);
  uint64_t state = seed;
  std::vector<uint8_t> m;
  for (int i = 0; i < mutations; ++i) {
    m = input;
    const size_t at = size_t(lcg(state) % m.size());
    switch (lcg(state) % 4) {
      case 0: m[at] ^= uint8_t(1u << (lcg(state) % 8)); break;
      case 1: m[at] = 0; break;
      case 2: m[at] = 0xFF; break;
      default: m[at] = uint8_t(lcg(state));
    }
    target(m.data(), m.size());
    ++runs;
  }
  const size_t words = std::min<size_t>(input.size() / 4, 64);  // the first 256 bytes: where headers keep counts
  for (int i = 0; i < mutations && words > 0; ++i) {
    m = input;
    const size_t at = 4 * size_t(lcg(state) % words);
    const int32_t values[3] = {0, -1, INT32_MAX};
    std::memcpy(&m[at], &values[lcg(state) % 3], 4);
    target(m.data(), m.size());
    ++runs;
  }
  return runs;
}

}  // namespace

int main(int argc, char** argv) {
  const std::map<std::string, Target> targets = {
#define UGVR_REPLAY_TARGET(name) {#name, ugvr_replay_##name},
#include "replay_targets.inc"
#undef UGVR_REPLAY_TARGET
  };
  if (argc < 3 || !targets.count(argv[1])) {
    std::fprintf(stderr, "usage: %s TARGET [--mutate N] FILE|DIR...\ntargets:", argv[0]);
    for (const auto& [name, fn] : targets) std::fprintf(stderr, " %s", name.c_str());
    std::fprintf(stderr, "\n");
    return 2;
  }
  const Target target = targets.at(argv[1]);
  int mutations = 0;
  std::vector<std::filesystem::path> inputs;
  for (int i = 2; i < argc; ++i) {
    if (std::strcmp(argv[i], "--mutate") == 0 && i + 1 < argc) {
      mutations = std::atoi(argv[++i]);
      continue;
    }
    const std::filesystem::path p(argv[i]);
    if (std::filesystem::is_directory(p)) {
      for (const auto& e : std::filesystem::recursive_directory_iterator(p))
        if (e.is_regular_file()) inputs.push_back(e.path());
    } else if (std::filesystem::exists(p)) {
      inputs.push_back(p);
    }
  }
  std::sort(inputs.begin(), inputs.end());
  uint64_t runs = 0, seed = 1;
  for (const auto& p : inputs) runs += replay(target, read_file(p), mutations, seed++);
  std::printf("%s: %zu inputs, %llu runs, no crash\n", argv[1], inputs.size(), static_cast<unsigned long long>(runs));
  return inputs.empty() ? 3 : 0;
}
