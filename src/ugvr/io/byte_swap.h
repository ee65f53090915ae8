// Byte order: values read from a file written on a machine of the other endianness are reversed in place.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ugvr {

// Reverses the bytes of each of `count` consecutive values of `size` bytes at `data` (size 1: nothing to do).
void swap_bytes(std::byte* data, uint64_t count, size_t size);

}  // namespace ugvr
