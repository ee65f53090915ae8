#include "ugvr/mpi/piece_record.h"

#include <sys/stat.h>

#include <bit>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"
#include "ugvr/core/json_file.h"

namespace ugvr {

std::string split_signature(const KdTree& tree) {
  uint64_t h = 0xcbf29ce484222325ull;
  auto mix = [&h](double v) {
    uint64_t bits = std::bit_cast<uint64_t>(v);
    for (int i = 0; i < 8; ++i, bits >>= 8) h = (h ^ (bits & 0xff)) * 0x100000001b3ull;
  };
  for (const Bounds& b : tree.boxes)
    for (int a = 0; a < 3; ++a) mix(b.lo[a]), mix(b.hi[a]);
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

PieceRecord planned_piece_record(const PiecePlan& plan, int k, const std::string& input, const std::string& build,
                                 const std::vector<std::string>& fields) {
  PieceRecord r;
  r.piece = k;
  r.pieces = plan.tree.parts();
  r.split = split_signature(plan.tree);
  r.ghost_level = plan.ghost_level;
  r.ghost_margin = plan.ghost_margin;
  r.input = input;
  struct stat st {};
  if (::stat(input.c_str(), &st) != 0) fail_in(input, "cannot read its size and time");
  r.input_bytes = uint64_t(st.st_size);
  r.input_mtime_ns = int64_t(st.st_mtim.tv_sec) * 1000000000 + int64_t(st.st_mtim.tv_nsec);
  r.build = build;
  r.fields = fields;
  return r;
}

std::string piece_record_path(const std::string& store_path) { return store_path + ".built.json"; }

void write_piece_record(const std::string& store_path, const PieceRecord& r) {
  const nlohmann::json j = {{"piece", r.piece},
                            {"pieces", r.pieces},
                            {"split", r.split},
                            {"ghost_level", r.ghost_level},
                            {"ghost_margin", r.ghost_margin},
                            {"input", r.input},
                            {"input_bytes", r.input_bytes},
                            {"input_mtime_ns", r.input_mtime_ns},
                            {"build", r.build},
                            {"fields", r.fields},
                            {"cells", r.cells},
                            {"ghost_cells", r.ghost_cells},
                            {"nodes", r.nodes},
                            {"store_bytes", r.store_bytes},
                            {"seconds", r.seconds}};
  write_json_file(piece_record_path(store_path), j);
}

std::optional<PieceRecord> kept_piece(const std::string& store_path, const PieceRecord& planned, std::string* why) {
  why->clear();
  const std::string path = piece_record_path(store_path);
  if (!std::filesystem::exists(path)) return std::nullopt;
  PieceRecord r;
  try {
    const nlohmann::json j = read_json_file(path);
    r.piece = j.at("piece").get<int>();
    r.pieces = j.at("pieces").get<int>();
    r.split = j.at("split").get<std::string>();
    r.ghost_level = j.at("ghost_level").get<int>();
    r.ghost_margin = j.at("ghost_margin").get<double>();
    r.input = j.at("input").get<std::string>();
    r.input_bytes = j.at("input_bytes").get<uint64_t>();
    r.input_mtime_ns = j.at("input_mtime_ns").get<int64_t>();
    r.build = j.at("build").get<std::string>();
    r.fields = j.at("fields").get<std::vector<std::string>>();
    r.cells = j.at("cells").get<uint64_t>();
    r.ghost_cells = j.at("ghost_cells").get<uint64_t>();
    r.nodes = j.at("nodes").get<uint64_t>();
    r.store_bytes = j.at("store_bytes").get<uint64_t>();
    r.seconds = j.at("seconds").get<double>();
  } catch (const std::exception& e) {
    *why = path + " is damaged (" + e.what() + ")";
    return std::nullopt;
  }
  auto differs = [&](const char* what) {
    *why = path + ": its " + what + " differs from this build's";
    return std::nullopt;
  };
  if (r.piece != planned.piece || r.pieces != planned.pieces) return differs("piece number or count");
  if (r.split != planned.split) return differs("kd split");
  if (r.ghost_level != planned.ghost_level || r.ghost_margin != planned.ghost_margin) return differs("ghost layer");
  if (r.input != planned.input || r.input_bytes != planned.input_bytes || r.input_mtime_ns != planned.input_mtime_ns)
    return differs("input file (path, size or modification time)");
  if (r.build != planned.build || r.fields != planned.fields) return differs("build options or fields");
  std::error_code ec;
  const uint64_t bytes = std::filesystem::file_size(store_path, ec);
  if (ec || bytes != r.store_bytes) {
    *why = store_path + (ec ? " is missing" : " is not the size its record says");
    return std::nullopt;
  }
  return r;
}

}  // namespace ugvr
