#include "ugvr/io/byte_hash.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "ugvr/core/error.h"

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

// The file's bytes [at, at + n) into `out`, or an error naming the file and the offset where they ran short: the
// file was opened with more bytes than it has now (truncated or rewritten meanwhile), or `n` runs past its end.
void read_part(const InputFile& file, uint64_t at, std::byte* out, size_t n) {
  const size_t got = file.read_some_at(at, out, n);
  if (got == n) return;
  if (at + n > file.size())
    fail_at_offset(file.path(), at,
                   "unexpected end of file: needed " + std::to_string(n) + " bytes, the file has " +
                       std::to_string(at > file.size() ? 0 : file.size() - at) + " left");
  fail_in(file.path(), "was truncated while reading: expected " + std::to_string(n) + " bytes at offset " +
                           std::to_string(at) + ", found " + std::to_string(got) + " (it was " +
                           std::to_string(file.size()) + " bytes when opened)");
}

}  // namespace

uint64_t hash_file_range(const InputFile& file, uint64_t begin, uint64_t end) {
  uint64_t h = hash_mix(kFnvOffset, end - begin);
  if (end <= begin) return h;
  // Read (pread), not mapped: a mapped file that shrinks underneath raises SIGBUS, which ends the process, where a
  // short read is an error naming the file. Each part is read by the thread that hashes it, into that thread's
  // buffer, so the copy out of the page cache runs in parallel and the hash reads the part from cache.
  constexpr size_t kPart = size_t(1) << 20;
  constexpr uint64_t kPartsPerWindow = 8;
  const uint64_t n = end - begin;
  const size_t parts = size_t((n + kPart - 1) / kPart);
  std::vector<uint64_t> part_hash(parts);
  // Sized on first use to the largest part a thread reads: a key's small arrays (the offsets of a small piece) do
  // not allocate and clear a MiB per thread.
  tbb::enumerable_thread_specific<std::vector<std::byte>> buffers;
  tbb::parallel_for(size_t(0), parts, [&](size_t i) {
    std::vector<std::byte>& buffer = buffers.local();
    const uint64_t at = begin + uint64_t(i) * kPart;
    const size_t len = size_t(std::min<uint64_t>(kPart, end - at));
    if (buffer.size() < len) buffer.resize(len);
    read_part(file, at, buffer.data(), len);
    part_hash[i] = hash_four_lanes(reinterpret_cast<const unsigned char*>(buffer.data()), len);
  });
  // Combined as windows of 8 parts (8 MiB), each its length and its parts in order: the value the mapped version of
  // this function gave, so keys do not change with how the bytes are fetched.
  for (size_t w = 0; w < parts; w += kPartsPerWindow) {
    const uint64_t window_begin = uint64_t(w) * kPart;
    uint64_t wh = hash_mix(kFnvOffset, std::min<uint64_t>(kPartsPerWindow * kPart, n - window_begin));
    for (size_t i = w; i < std::min<size_t>(parts, w + kPartsPerWindow); ++i) wh = hash_mix(wh, part_hash[i]);
    h = hash_mix(h, wh);
  }
  return h;
}

uint64_t hash_file_stamp(uint64_t h, const std::string& path) {
  std::error_code size_error, time_error;
  const uintmax_t size = std::filesystem::file_size(path, size_error);
  const auto mtime = std::filesystem::last_write_time(path, time_error).time_since_epoch().count();
  if (size_error || time_error)
    fail_in(path, "cannot read its size and time: " + (size_error ? size_error : time_error).message());
  h = hash_mix(h, hash_bytes(path.data(), path.size()));
  return hash_mix(hash_mix(h, uint64_t(size)), uint64_t(mtime));
}

}  // namespace ugvr
