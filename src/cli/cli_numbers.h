// Numeric flag values shared by the subcommands: parsed whole (no trailing text), errors naming the flag.
#pragma once

#include <charconv>
#include <cmath>
#include <string>
#include <string_view>

#include "ugvr/core/error.h"

namespace ugvr::cli {

// A finite number; a leading '+' is accepted (from_chars rejects it, and people type it for positive values).
inline double parse_number(std::string_view text, std::string_view flag) {
  double v = 0;
  const char* first = text.data();
  const char* last = first + text.size();
  if (first != last && *first == '+') ++first;
  const auto [end, ec] = std::from_chars(first, last, v);
  if (first == last || ec != std::errc() || end != last || !std::isfinite(v))
    fail_in(flag, "expected a finite number, found \"" + std::string(text) + "\"");
  return v;
}

}  // namespace ugvr::cli
