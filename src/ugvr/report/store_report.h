// What `ugvr info STORE.ugvr` reports about a brick store (lod/brick_store.h), as JSON (the --json output, and what
// tests assert on) and as text; and what --verify checks: every block read back against its checksum and decoded.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ugvr/store/brick_store.h"

namespace ugvr {

// Whether `path` is meant as a brick store: it starts with the store's magic number, or is named .ugvr (so that a
// damaged store is reported as such, not as an unknown format).
bool is_brick_store_path(const std::string& path);

// Keys: format ("ugvr brick store"), version, sources [path], bounds {min, max} (the dataset's), root {min, max}
// (the octree's root cell), brick (R), encoding {samples, predictor, shuffle, codec, level, tolerance}, fields[]
// {name, location, encoding, range: [min, max], block_bytes, leaf_error_max}, nodes, leaves, nodes_with_data,
// depth_max, nodes_per_level[], leaves_per_level[], nodes_with_data_per_level[], bytes {file, header, blocks,
// node_table, unreferenced, float32, ratio}, build {brick, encoding, tolerance, fields, input, error, max_depth}: the
// last three null, as the format does not record them.
nlohmann::json store_report(const BrickStoreReader& store);
std::string format_store_report_text(const nlohmann::json& report);

struct StoreVerification {
  uint64_t bricks = 0, blocks = 0, bytes = 0;  // what was read
  uint64_t bad_bricks = 0, bad_blocks = 0;
  std::vector<std::string> errors;  // the first few, in node order, each naming the file, byte offset, node and field

  bool ok() const { return bad_blocks == 0; }
};

// Reads every block of every brick (in parallel), checks its crc32 against the node table and decodes it. The
// header's and node table's checksums were checked when the store was opened. Keeps the first `max_errors` messages.
StoreVerification verify_store(const BrickStoreReader& store, size_t max_errors = 10);
// Keys: ok, bricks, blocks, bytes, bad_bricks, bad_blocks, errors[].
nlohmann::json verification_json(const StoreVerification& v);
// One line (and one per error kept): "verify:   all 1,203 bricks verified (...)".
std::string format_verification_text(const StoreVerification& v);

}  // namespace ugvr
