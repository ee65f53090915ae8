// Sizes derived from the contents of a binary file (PLOT3D, UGRID headers) are computed saturating, so that an absurd
// header yields "too big" instead of wrapping around to a small number that might happen to equal the file size.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

namespace ugvr {

inline constexpr uint64_t kSaturated = std::numeric_limits<uint64_t>::max();

inline uint64_t sat_add(uint64_t a, uint64_t b) { return a > kSaturated - b ? kSaturated : a + b; }
inline uint64_t sat_mul(uint64_t a, uint64_t b) {
  uint64_t r;
  return __builtin_mul_overflow(a, b, &r) ? kSaturated : r;
}
// A size for a message: its digits, or "more than 2^64" where it saturated.
inline std::string size_text(uint64_t n) { return n == kSaturated ? std::string("more than 2^64") : std::to_string(n); }

}  // namespace ugvr
