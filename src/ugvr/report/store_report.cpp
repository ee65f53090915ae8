#include "ugvr/report/store_report.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <sstream>
#include <tuple>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/report/report_text.h"

namespace ugvr {

namespace {

using nlohmann::json;

json build_json(const BrickStoreLayout& l, const std::vector<std::string>& names) {
  json b = {{"brick", l.resolution},    {"encoding", sample_encoding_name(l.encoding.samples)},
            {"tolerance", l.tolerance}, {"fields", names},
            {"input", nullptr},         {"error", nullptr},
            {"max_depth", nullptr},     {"ugvr", nullptr},
            {"out_of_core", nullptr},   {"max_leaf_cells", nullptr}};
  const json p = json::parse(l.provenance.empty() ? "{}" : l.provenance, nullptr, false);
  if (p.is_object()) {
    if (p.contains("inputs")) b["input"] = p["inputs"];
    for (const char* key : {"error", "max_depth", "ugvr", "out_of_core", "max_leaf_cells"})
      if (p.contains(key)) b[key] = p[key];
  }
  return b;
}

// Nodes, leaves and nodes with a brick, per level.
struct LevelCounts {
  std::vector<uint64_t> nodes, leaves, bricks;
};

LevelCounts count_levels(const BrickStoreReader& s) {
  LevelCounts c;
  for (const BrickNode& n : s.nodes()) {
    if (n.level >= c.nodes.size()) {
      c.nodes.resize(n.level + 1u);
      c.leaves.resize(n.level + 1u);
      c.bricks.resize(n.level + 1u);
    }
    ++c.nodes[n.level];
    c.leaves[n.level] += n.is_leaf();
    c.bricks[n.level] += n.has_brick();
  }
  return c;
}

uint64_t sum(const std::vector<uint64_t>& v) {
  uint64_t t = 0;
  for (uint64_t x : v) t += x;
  return t;
}

// Per field: the bytes of its blocks, and the largest error the builder measured at a leaf (the store's accuracy at
// its finest level).
json field_json(const BrickStoreReader& s, uint32_t f) {
  const BrickStoreField& field = s.layout().fields[f];
  uint64_t bytes = 0;
  float leaf_error = 0;
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    bytes += s.block(id, f).size;
    if (s.node(id).is_leaf() && s.node(id).has_brick()) leaf_error = std::max(leaf_error, s.stats(id, f).error_max);
  }
  return {{"name", field.name},
          {"location", association_name(field.association)},
          {"encoding", sample_encoding_name(s.layout().encoding.samples)},
          {"range", {field.min, field.max}},
          {"block_bytes", bytes},
          {"leaf_error_max", leaf_error}};
}

json encoding_json(const BrickStoreLayout& l) {
  return {{"samples", sample_encoding_name(l.encoding.samples)},
          {"predictor", predictor_name(l.encoding.predictor)},
          {"shuffle", l.encoding.shuffle},
          {"codec", brick_codec_name(l.encoding.codec)},
          {"level", l.encoding.level},
          {"tolerance", l.tolerance}};
}

// Where the file's bytes go. float32: what the bricks' samples would take uncompressed (R³ floats per field and
// brick), the figure docs/brick-store.md's ratios are against.
json bytes_json(const BrickStoreReader& s, uint64_t block_bytes, uint64_t bricks) {
  const store_format::HeaderRecord& h = s.header();
  const uint64_t r = s.resolution();
  const uint64_t float32 = bricks * s.field_count() * r * r * r * sizeof(float);
  const uint64_t table = h.node_count * h.node_record_size;
  // The leaves' cells (format version 5): their blocks and their index.
  uint64_t cells = s.cells_header().index_size;
  for (uint64_t id = 0; s.has_cells() && id < s.node_count(); ++id) cells += s.cell_block(id).size;
  return {{"file", s.file_size()},
          {"header", h.header_size},
          {"blocks", block_bytes},
          {"node_table", table},
          {"provenance", h.provenance_size},
          {"tf_errors", s.tf_error_header().table_size},         // the transfer-function error table (format version 3)
          {"boundary_faces", s.boundary_header().section_size},  // the boundary faces (format version 4)
          {"cells", cells},
          {"cell_blocks", s.cells_header().block_count},
          {"leaf_cells", s.cells_header().total_cells},
          {"unreferenced", s.file_size() - h.header_size - block_bytes - table - h.provenance_size -
                               s.tf_error_header().table_size - s.boundary_header().section_size - cells},
          {"float32", float32},
          {"ratio", block_bytes ? double(float32) / double(block_bytes) : 0.0}};
}

std::string fmt_ratio(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

// "1 node, 0 leaves, 1 with a brick"
std::string level_line(uint64_t nodes, uint64_t leaves, uint64_t bricks) {
  return fmt_count(nodes) + (nodes == 1 ? " node, " : " nodes, ") + fmt_count(leaves) +
         (leaves == 1 ? " leaf, " : " leaves, ") + fmt_count(bricks) + " with a brick";
}

std::string bytes_text(uint64_t v) { return fmt_count(v) + " bytes (" + format_bytes(v) + ")"; }

}  // namespace

bool is_brick_store_path(const std::string& path) {
  if (extension_lower(path) == ".ugvr") return true;
  uint8_t head[sizeof store_format::kMagic] = {};
  const InputFile f(path);
  return f.read_some_at(0, head, sizeof head) == sizeof head &&
         std::memcmp(head, store_format::kMagic, sizeof head) == 0;
}

nlohmann::json store_report(const BrickStoreReader& s) {
  const BrickStoreLayout& l = s.layout();
  const LevelCounts levels = count_levels(s);
  json fields = json::array();
  uint64_t block_bytes = 0;
  std::vector<std::string> names;
  for (uint32_t f = 0; f < s.field_count(); ++f) {
    fields.push_back(field_json(s, f));
    block_bytes += fields.back()["block_bytes"].get<uint64_t>();
    names.push_back(l.fields[f].name);
  }
  const uint64_t bricks = sum(levels.bricks);
  return {{"format", "ugvr brick store"},
          {"version", s.header().version},
          {"sources", {s.path()}},
          {"bounds", bounds_json(l.data)},
          {"root", bounds_json(l.root)},
          {"brick", l.resolution},
          {"encoding", encoding_json(l)},
          {"fields", fields},
          {"nodes", s.node_count()},
          {"leaves", sum(levels.leaves)},
          {"nodes_with_data", bricks},
          {"depth_max", levels.nodes.size() - 1},
          {"nodes_per_level", levels.nodes},
          {"leaves_per_level", levels.leaves},
          {"nodes_with_data_per_level", levels.bricks},
          {"bytes", bytes_json(s, block_bytes, bricks)},
          // What `ugvr build` was given: the provenance record where the store has one (stores written before it
          // existed have none: input, error and max_depth are then null).
          {"build", build_json(l, names)}};
}

std::string format_store_report_text(const nlohmann::json& r) {
  std::ostringstream o;
  const json& e = r["encoding"];
  o << "format:   " << r["format"].get<std::string>() << ", version " << r["version"] << "\n";
  o << "bounds:   " << fmt_bounds(r["bounds"]) << "\n";
  o << "root:     " << fmt_bounds(r["root"]) << " (the octree's root cell)\n";
  const uint32_t res = r["brick"];
  o << "bricks:   " << res << " x " << res << " x " << res << " samples, " << e["samples"].get<std::string>();
  if (e["samples"] == "quant16") {
    const double tol = e["tolerance"];
    o << (tol > 0 ? " (within " + fmt_num(tol) + " of each field's range)" : " (each brick over its own range)");
  }
  o << ", " << e["predictor"].get<std::string>() << " predictor, " << (e["shuffle"].get<bool>() ? "shuffled, " : "")
    << e["codec"].get<std::string>();
  if (e["level"].get<int>() > 0) o << " level " << e["level"];
  o << "\n";
  o << "octree:   " << level_line(r["nodes"], r["leaves"], r["nodes_with_data"]) << ", depth max " << r["depth_max"]
    << "\n";
  for (size_t lv = 0; lv < r["nodes_per_level"].size(); ++lv) {
    o << "  level " << lv << ": "
      << level_line(r["nodes_per_level"][lv], r["leaves_per_level"][lv], r["nodes_with_data_per_level"][lv]) << "\n";
  }
  const json& b = r["bytes"];
  o << "bytes:    file " << bytes_text(b["file"]) << ": header " << fmt_count(b["header"]) << " bytes, blocks "
    << bytes_text(b["blocks"]) << ", node table " << bytes_text(b["node_table"]);
  if (b["tf_errors"].get<uint64_t>() > 0) o << ", transfer-function error table " << bytes_text(b["tf_errors"]);
  if (b["boundary_faces"].get<uint64_t>() > 0) o << ", boundary faces " << bytes_text(b["boundary_faces"]);
  if (b["cells"].get<uint64_t>() > 0)
    o << ", cells " << bytes_text(b["cells"]) << " (" << fmt_count(b["leaf_cells"]) << " in "
      << fmt_count(b["cell_blocks"]) << " leaves)";
  if (b["unreferenced"].get<uint64_t>() > 0) o << ", " << fmt_count(b["unreferenced"]) << " unreferenced";
  o << "\n          blocks " << fmt_ratio(b["ratio"]) << "x smaller than the bricks as float32 ("
    << format_bytes(b["float32"]) << ")\n";
  o << "fields:\n";
  for (const json& f : r["fields"]) {
    o << "  " << (f["location"] == "vertex" ? "vertex" : "cell  ") << " " << f["name"].get<std::string>() << " ("
      << f["encoding"].get<std::string>() << "): [" << fmt_num(f["range"][0]) << ", " << fmt_num(f["range"][1])
      << "], blocks " << format_bytes(f["block_bytes"]) << ", leaf error max " << fmt_num(f["leaf_error_max"]) << "\n";
  }
  const json& bd = r["build"];
  std::string names;
  for (const json& n : bd["fields"]) names += (names.empty() ? "" : ",") + n.get<std::string>();
  o << "build:    --brick " << bd["brick"] << (bd["encoding"] == "float32" ? " --float32" : "") << " --fields "
    << names;
  if (bd["input"].is_null()) {
    o << "; the store does not record its input, --error or --max-depth (written before stores recorded them)\n";
  } else {
    o << " --error " << fmt_num(bd["error"]) << " --max-depth " << bd["max_depth"]
      << (bd["out_of_core"] == true ? " --out-of-core" : "")
      // Not in the provenance record: a store with cell blocks was built with --cells.
      << (r["bytes"]["cells"].get<uint64_t>() > 0 ? " --cells" : "");
    // Recorded since the cap on a leaf's cells (stores with cells); absent in older ones.
    if (bd["max_leaf_cells"].is_number()) o << " --max-leaf-cells " << bd["max_leaf_cells"];
    o << "\n          from";
    for (const json& in : bd["input"]) o << " " << in.get<std::string>();
    o << " (ugvr " << bd["ugvr"].get<std::string>() << ")\n";
  }
  return o.str();
}

StoreVerification verify_store(const BrickStoreReader& s, size_t max_errors) {
  struct Failure {
    uint64_t node;
    uint32_t field;
    std::string what;
  };
  const uint32_t nf = s.field_count();
  const size_t samples = size_t(s.resolution()) * s.resolution() * s.resolution();
  uint64_t total = 0;
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    for (uint32_t f = 0; f < nf; ++f) total += s.block(id, f).size;
  }
  Progress progress("verifying bricks", total);
  std::atomic<uint64_t> bricks{0}, blocks{0}, bytes{0};
  std::mutex mutex;
  std::vector<Failure> failures;
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, s.node_count()), [&](const tbb::blocked_range<uint64_t>& range) {
    thread_local std::vector<std::byte> block;
    thread_local std::vector<float> decoded;
    decoded.resize(samples);
    for (uint64_t id = range.begin(); id < range.end(); ++id) {
      if (!s.node(id).has_brick()) continue;
      ++bricks;
      for (uint32_t f = 0; f < nf; ++f) {
        const BlockRef ref = s.block(id, f);
        block.resize(ref.size);
        try {
          s.read_block(id, f, block.data());
          s.decode_block(id, f, block, decoded.data(), nullptr);
        } catch (const Error& e) {
          std::lock_guard lock(mutex);
          failures.push_back({id, f, e.what()});
        }
        ++blocks;
        bytes += ref.size;
        progress.add(ref.size);
      }
    }
  });
  progress.finish();

  StoreVerification v;
  v.bricks = bricks;
  v.blocks = blocks;
  v.bytes = bytes;
  v.bad_blocks = failures.size();
  std::sort(failures.begin(), failures.end(),
            [](const Failure& a, const Failure& b) { return std::tie(a.node, a.field) < std::tie(b.node, b.field); });
  for (size_t i = 0; i < failures.size(); ++i) {
    v.bad_bricks += i == 0 || failures[i].node != failures[i - 1].node;
    if (v.errors.size() < max_errors) v.errors.push_back(failures[i].what);
  }
  return v;
}

nlohmann::json verification_json(const StoreVerification& v) {
  return {{"ok", v.ok()},      {"bricks", v.bricks},         {"blocks", v.blocks},
          {"bytes", v.bytes},  {"bad_bricks", v.bad_bricks}, {"bad_blocks", v.bad_blocks},
          {"errors", v.errors}};
}

std::string format_verification_text(const StoreVerification& v) {
  std::ostringstream o;
  if (v.ok()) {
    o << "verify:   all " << fmt_count(v.bricks) << " bricks verified: the header's, the node table's and "
      << fmt_count(v.blocks) << " block checksums match (" << format_bytes(v.bytes) << "), every block decodes\n";
    return o.str();
  }
  o << "verify:   " << fmt_count(v.bad_bricks) << " of " << fmt_count(v.bricks) << " bricks are corrupt ("
    << fmt_count(v.bad_blocks) << " of " << fmt_count(v.blocks) << " blocks)\n";
  for (const std::string& e : v.errors) o << "  " << e << "\n";
  if (v.errors.size() < v.bad_blocks) o << "  ... and " << fmt_count(v.bad_blocks - v.errors.size()) << " more\n";
  return o.str();
}

}  // namespace ugvr
