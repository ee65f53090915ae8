#include "ugvr/io/byte_swap.h"

#include <cstring>
#include <utility>

namespace ugvr {

namespace {

template <class U>
void swap_each(std::byte* data, uint64_t count) {
  for (uint64_t i = 0; i < count; ++i) {
    U v;
    std::memcpy(&v, data + i * sizeof(U), sizeof(U));
    if constexpr (sizeof(U) == 2) v = __builtin_bswap16(v);
    if constexpr (sizeof(U) == 4) v = __builtin_bswap32(v);
    if constexpr (sizeof(U) == 8) v = __builtin_bswap64(v);
    std::memcpy(data + i * sizeof(U), &v, sizeof(U));
  }
}

}  // namespace

void swap_bytes(std::byte* data, uint64_t count, size_t size) {
  switch (size) {
    case 0:
    case 1: return;
    case 2: return swap_each<uint16_t>(data, count);
    case 4: return swap_each<uint32_t>(data, count);
    case 8: return swap_each<uint64_t>(data, count);
    default: break;
  }
  for (uint64_t i = 0; i < count; ++i) {
    std::byte* v = data + i * size;
    for (size_t a = 0, b = size - 1; a < b; ++a, --b) std::swap(v[a], v[b]);
  }
}

}  // namespace ugvr
