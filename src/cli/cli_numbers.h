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

// The level-of-detail engine's device and memory flags, the same for `ugvr render` and `ugvr view`: --gpu,
// --gpu-memory (the atlas of bricks) and --ram-memory (decoded bricks; `ram_use` says whose).
inline void add_gpu_memory_flags(CLI::App& cmd, std::string& gpu, uint64_t& gpu_memory, uint64_t& ram_memory,
                                 const std::string& ram_use) {
  cmd.add_option("--gpu", gpu, "EGL device index, or auto (first GPU, else Mesa's llvmpipe)")
      ->default_str("auto")
      ->type_name("DEVICE");
  add_byte_size_option(cmd, "--gpu-memory", gpu_memory, "GPU memory for bricks (e.g. 512MiB, 4GiB)", "2GiB");
  add_byte_size_option(cmd, "--ram-memory", ram_memory, "RAM for decoded bricks (e.g. 256MiB, 4GiB), " + ram_use,
                       "1GiB");
}

}  // namespace ugvr::cli
