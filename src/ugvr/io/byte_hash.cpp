#include "ugvr/io/byte_hash.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <vector>

namespace ugvr {

uint64_t hash_bytes(const void* data, size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  constexpr size_t kChunk = size_t(1) << 20;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  // Chunk hashes are combined in chunk order, so the result does not depend on the thread count.
  std::vector<uint64_t> parts(chunks);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    const size_t b = c * kChunk, e = std::min(n, b + kChunk);
    uint64_t h = kFnvOffset;
    size_t i = b;
    for (; i + 8 <= e; i += 8) {
      uint64_t w;
      std::memcpy(&w, p + i, 8);
      h = hash_mix(h, w);
    }
    for (; i < e; ++i) h = hash_mix(h, p[i]);
    parts[c] = h;
  });
  uint64_t h = hash_mix(kFnvOffset, n);
  for (uint64_t part : parts) h = hash_mix(h, part);
  return h;
}

namespace {

// hash_bytes' chunk loop over four interleaved words at a time: four independent multiply chains instead of one, so
// the multiplier's latency does not bound the speed (about 3x on this machine's cores).
uint64_t hash_four_lanes(const unsigned char* p, size_t n) {
  uint64_t h[4] = {kFnvOffset, kFnvOffset ^ 1, kFnvOffset ^ 2, kFnvOffset ^ 3};
  size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    uint64_t w[4];
    std::memcpy(w, p + i, 32);
    for (int l = 0; l < 4; ++l) h[l] = hash_mix(h[l], w[l]);
  }
  uint64_t out = hash_mix(hash_mix(hash_mix(hash_mix(kFnvOffset, h[0]), h[1]), h[2]), h[3]);
  for (; i < n; ++i) out = hash_mix(out, p[i]);
  return out;
}

uint64_t hash_wide(const std::byte* data, size_t n) {
  constexpr size_t kChunk = size_t(1) << 20;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<uint64_t> parts(chunks);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    const size_t b = c * kChunk;
    parts[c] = hash_four_lanes(reinterpret_cast<const unsigned char*>(data) + b, std::min(n, b + kChunk) - b);
  });
  uint64_t h = hash_mix(kFnvOffset, n);
  for (uint64_t part : parts) h = hash_mix(h, part);
  return h;
}

}  // namespace

uint64_t hash_file_range(const InputFile& file, uint64_t begin, uint64_t end) {
  // Large enough that the parallel hash of a chunk has work for every thread, small enough to stay in cache.
  constexpr uint64_t kChunk = uint64_t(8) << 20;
  uint64_t h = hash_mix(kFnvOffset, end - begin);
  if (end <= begin) return h;
  // Mapped, the bytes are hashed where the page cache holds them instead of being copied out first (a third of the
  // time for a cached file); read in chunks where mapping fails.
  const int fd = ::open(file.path().c_str(), O_RDONLY | O_CLOEXEC);
  const uint64_t page = uint64_t(::sysconf(_SC_PAGESIZE));
  const uint64_t map_begin = begin / page * page;
  void* map = fd < 0 || end > file.size()
                  ? MAP_FAILED
                  : ::mmap(nullptr, size_t(end - map_begin), PROT_READ, MAP_SHARED, fd, off_t(map_begin));
  if (fd >= 0) ::close(fd);
  if (map != MAP_FAILED) {
    ::madvise(map, size_t(end - map_begin), MADV_SEQUENTIAL);
    const auto* bytes = static_cast<const std::byte*>(map) + (begin - map_begin);
    for (uint64_t at = 0; at < end - begin; at += kChunk)
      h = hash_mix(h, hash_wide(bytes + at, size_t(std::min(kChunk, end - begin - at))));
    ::munmap(map, size_t(end - map_begin));
    return h;
  }
  std::vector<std::byte> buffer(size_t(std::min(kChunk, end - begin)));
  for (uint64_t at = begin; at < end;) {
    const size_t n = size_t(std::min(kChunk, end - at));
    file.read_at(at, buffer.data(), n);
    h = hash_mix(h, hash_wide(buffer.data(), n));
    at += n;
  }
  return h;
}

}  // namespace ugvr
