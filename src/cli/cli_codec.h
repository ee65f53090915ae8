// The --compress option shared by the subcommands that write .vtu files.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "ugvr/io/codec.h"

namespace ugvr::cli {

// Binds --compress to a string checked against the codec names; parse_codec_name() turns it into the Codec.
inline CLI::Option* add_compress_option(CLI::App& cmd, std::string& name) {
  return cmd.add_option("--compress", name, "Compression of the appended data")
      ->check(CLI::IsMember({"none", "zlib", "lz4"}, CLI::ignore_case))
      ->default_val("none");
}

inline Codec parse_codec_name(const std::string& name) {
  if (name == "zlib") return Codec::Zlib;
  if (name == "lz4") return Codec::Lz4;
  return Codec::None;
}

}  // namespace ugvr::cli
