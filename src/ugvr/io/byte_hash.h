// The 64-bit hash the time axis compares geometry by (io/time_series.h: geometry_fingerprint; io/step_fields.h: the
// stored geometry keys). FNV-1a over 64-bit words with a final mix, in parallel over 1 MiB chunks combined in order,
// so any thread count gives the same value; fast enough to run per step switch (GB/s).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "ugvr/core/file.h"

namespace ugvr {

inline constexpr uint64_t kFnvOffset = 0xcbf29ce484222325ull, kFnvPrime = 0x100000001b3ull;

inline uint64_t hash_mix(uint64_t h, uint64_t v) {
  h ^= v;
  h *= kFnvPrime;
  return h ^ (h >> 29);
}

uint64_t hash_bytes(const void* data, size_t n);
// The bytes [begin, end) of a file, read (pread) in parts of 1 MiB by the threads that hash them (never the whole range
// at once), hashed four words abreast (another value than hash_bytes of the same bytes; the same for any thread
// count). Throws ugvr::Error naming the file and the offset where the bytes run short: "was truncated while reading"
// when the file shrank after `file` was opened (never SIGBUS: nothing is mapped), "unexpected end of file" when the
// range runs past the size it was opened with.
uint64_t hash_file_range(const InputFile& file, uint64_t begin, uint64_t end);
// `h` mixed with a file's stamp: its path, size and modification time (not its bytes: the mesh keys of formats whose
// mesh files are too large to hash per step switch, io/step_fields.h). Throws ugvr::Error naming the file when its size
// or time cannot be read.
uint64_t hash_file_stamp(uint64_t h, const std::string& path);

}  // namespace ugvr
