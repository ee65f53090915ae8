// Numeric flag values shared by the subcommands: parsed whole (no trailing text), errors naming the flag; byte sizes
// with their units.
#pragma once

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <cstdint>
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

// A byte-size flag (e.g. 512MiB, 4GiB; binary units), its default shown as written.
inline CLI::Option* add_byte_size_option(CLI::App& cmd, const std::string& name, uint64_t& bytes,
                                         const std::string& description, const std::string& default_size) {
  return cmd.add_option(name, bytes, description)->transform(CLI::AsSizeValue(true))->default_str(default_size);
}

}  // namespace ugvr::cli
