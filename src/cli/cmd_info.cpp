#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/json_file.h"
#include "ugvr/core/memory.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/time_series_report.h"
#include "ugvr/mpi/piece_index.h"
#include "ugvr/report/dataset_report.h"
#include "ugvr/report/store_report.h"
#include "ugvr/store/brick_store.h"

namespace ugvr::cli {

CLI::Option* add_input(CLI::App& cmd, std::vector<std::string>& inputs) {
  return cmd
      .add_option("INPUT", inputs,
                  "Input file (.vtu .pvtu .vts .vti .vtr .vtk ...), an OpenFOAM case directory, a PLOT3D grid file "
                  "then its solution file(s), or a time series: NAME.pvd, NAME.series, or a numbered pattern "
                  "'flow_%04d.vtu' / 'flow_*.vtu' (quoted; docs/time-series.md)")
      ->required()
      ->expected(1, 1 << 20)
      ->check(CLI::Validator(
          [](std::string& path) {
            std::error_code ec;
            if (std::filesystem::exists(path, ec) || is_series_pattern(path)) return std::string();
            return "Path does not exist: " + path;
          },
          "PATH"));
}

void add_read_options(CLI::App& cmd, ReadOptions& o) {
  cmd.add_option("--time-step", o.time_step,
                 "Time series (Exodus, .pvd, .series, numbered files, PLOT3D solutions, CGNS, EnSight, OpenFOAM "
                 "time directories) or brick store built with --time: the step to read (0-based; -1 = last; `ugvr "
                 "info` lists them)")
      ->default_val(-1);
  cmd.add_option("--raw-dims", o.raw.dims, "Raw volume: point dimensions NX NY NZ");
  cmd.add_option("--raw-type", o.raw.type, "Raw volume: value type")
      ->check(CLI::IsMember({"int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"}))
      ->default_val("float32");
  cmd.add_option("--raw-spacing", o.raw.spacing, "Raw volume: voxel spacing SX SY SZ");
  cmd.add_option("--raw-origin", o.raw.origin, "Raw volume: origin OX OY OZ");
  cmd.add_flag("--raw-big-endian", o.raw.big_endian, "Raw volume: values are big-endian");
  cmd.add_option("--raw-header", o.raw.header_bytes, "Raw volume: bytes to skip before the values");
}

namespace {

// `ugvr info STORE.ugvr [--verify]`: the store's header and node table (opening validates both), then, with
// --verify, every block against its checksum. A corrupt store fails after the report, naming the first bad block.
// Bytes of the blocks of a time store's steps after the first, their cells' values blocks too (store_report counts
// step 0's).
uint64_t later_steps_block_bytes(const BrickStoreReader& store) {
  uint64_t bytes = 0;
  for (uint32_t s = 1; s < store.step_count(); ++s) {
    for (uint64_t n = 0; n < store.node_count(); ++n) {
      for (uint32_t f = 0; f < store.field_count(); ++f) bytes += store.block(n, f, s).size;
      bytes += store.cell_values_block(n, s).size;
    }
  }
  return bytes;
}

// A time store's steps (format version 6): {"count", "section_bytes", "later_blocks_bytes", "steps": [{"index",
// "time", "ranges": {FIELD: [min, max]}}]}; the text, one line per step.
nlohmann::json store_steps_json(const BrickStoreReader& store) {
  nlohmann::json steps = nlohmann::json::array();
  for (uint32_t s = 0; s < store.step_count(); ++s) {
    nlohmann::json ranges = nlohmann::json::object();
    for (uint32_t f = 0; f < store.field_count(); ++f) {
      const store_format::StepFieldRange r = store.step_range(s, f);
      ranges[store.layout().fields[f].name] = {r.min, r.max};
    }
    steps.push_back({{"index", s}, {"time", store.step_time(s)}, {"ranges", ranges}});
  }
  return {{"count", store.step_count()},
          {"section_bytes", store.steps_header().section_size},
          {"later_blocks_bytes", later_steps_block_bytes(store)},
          {"steps", steps}};
}

std::string format_store_steps_text(const BrickStoreReader& store) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "time:     %u step%s, t = %g .. %g (one octree; each step its own bricks)\n",
                store.step_count(), store.step_count() == 1 ? "" : "s", store.step_time(0),
                store.step_time(store.step_count() - 1));
  std::string text = buf;
  if (store.step_count() > 1)
    text += "          steps 1 to " + std::to_string(store.step_count() - 1) + ": blocks " +
            format_bytes(later_steps_block_bytes(store)) + ", steps section " +
            format_bytes(store.steps_header().section_size) + " (the bytes: line above is step 0's)\n";
  for (uint32_t s = 0; s < store.step_count(); ++s) {
    std::snprintf(buf, sizeof buf, "  step %u: t = %g", s, store.step_time(s));
    text += buf;
    for (uint32_t f = 0; f < store.field_count(); ++f) {
      const store_format::StepFieldRange r = store.step_range(s, f);
      std::snprintf(buf, sizeof buf, ", %s [%g, %g]", store.layout().fields[f].name.c_str(), r.min, r.max);
      text += buf;
    }
    text += "\n";
  }
  return text;
}

void store_info(const std::string& path, bool json, bool verify) {
  BrickStoreReader store(path);
  nlohmann::json report = store_report(store);
  if (store.has_steps()) {
    report["time"] = store_steps_json(store);
    // The later steps' blocks and the section are this format's, not unreferenced bytes.
    nlohmann::json& b = report["bytes"];
    const uint64_t steps_bytes =
        report["time"]["section_bytes"].get<uint64_t>() + report["time"]["later_blocks_bytes"].get<uint64_t>();
    b["unreferenced"] = b["unreferenced"].get<uint64_t>() - std::min(b["unreferenced"].get<uint64_t>(), steps_bytes);
    b["steps"] = steps_bytes;
  }
  std::optional<StoreVerification> v;
  if (verify) {
    // Every step's bricks (verify_store reads the store's current step).
    for (uint32_t s = 0; s < store.step_count(); ++s) {
      store.set_step(s);
      StoreVerification one = verify_store(store);
      if (!v) {
        v = std::move(one);
        continue;
      }
      v->bricks += one.bricks, v->blocks += one.blocks, v->bytes += one.bytes;
      v->bad_bricks += one.bad_bricks, v->bad_blocks += one.bad_blocks;
      for (std::string& e : one.errors)
        if (v->errors.size() < 10) v->errors.push_back("time step " + std::to_string(s) + ": " + e);
    }
    store.set_step(0);
    report["verify"] = verification_json(*v);
  }
  if (json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    std::fputs(format_store_report_text(report).c_str(), stdout);
    if (store.has_steps()) std::fputs(format_store_steps_text(store).c_str(), stdout);
    if (v) std::fputs(format_verification_text(*v).c_str(), stdout);
  }
  std::fflush(stdout);  // the report whole before the error, where both go to one pipe
  if (v && !v->ok()) {
    throw Error("verification failed: " + std::to_string(v->bad_bricks) + " of " + std::to_string(v->bricks) +
                " bricks corrupt; first: " + v->errors.front());
  }
}

// `ugvr info INDEX.json`: a partitioned store's index (docs/mpi.md): its pieces, boxes, cells and stores, each store
// opened (a missing or damaged one fails naming its file); --verify checks every piece's bricks.
void piece_index_info(const std::string& path, bool json, bool verify) {
  const PieceIndex index = read_piece_index(path);
  nlohmann::json report = read_json_file(path);
  report["index"] = path;
  uint64_t bytes = 0, cells = 0, ghost = 0, nodes = 0;
  for (int k = 0; k < index.count(); ++k) {
    const BrickStoreReader store(index.store_path(k));
    if (verify) {
      const StoreVerification v = verify_store(store);
      if (!v.ok()) fail_in(index.store_path(k), "piece " + std::to_string(k) + ": " + v.errors.front());
    }
    report["pieces"][size_t(k)]["nodes"] = store.nodes().size();
    nodes += store.nodes().size();
    bytes += index.pieces[size_t(k)].store_bytes;
    cells += index.pieces[size_t(k)].cells;
    ghost += index.pieces[size_t(k)].ghost_cells;
  }
  if (json) {
    std::printf("%s\n", report.dump(2).c_str());
    return;
  }
  auto box = [](const Bounds& b) {
    auto c = [](double v) { return std::isfinite(v) ? std::to_string(v) : std::string(v < 0 ? "-inf" : "inf"); };
    return "[" + c(b.lo.x) + ", " + c(b.hi.x) + "] x [" + c(b.lo.y) + ", " + c(b.hi.y) + "] x [" + c(b.lo.z) + ", " +
           c(b.hi.z) + "]";
  };
  std::printf("partitioned store (index version %d): %s\n", kPieceIndexVersion, path.c_str());
  std::printf("  pieces: %d (kd-tree, balanced by cells), %llu cells, %llu ghost cells (%.1f%%), %llu nodes, %s\n",
              index.count(), (unsigned long long)cells, (unsigned long long)ghost,
              cells ? 100.0 * double(ghost) / double(cells) : 0.0, (unsigned long long)nodes,
              format_bytes(bytes).c_str());
  std::printf("  bounds: %s\n  brick: %u, ghost margin: %g (exact from level %d)\n", box(index.bounds).c_str(),
              index.brick, index.ghost_margin, index.ghost_level);
  for (const BrickStoreField& f : index.fields)
    std::printf("  field %s (%s): %g .. %g\n", f.name.c_str(), f.association == Association::Vertex ? "vertex" : "cell",
                f.min, f.max);
  for (int k = 0; k < index.count(); ++k) {
    const PieceInfo& p = index.pieces[size_t(k)];
    std::printf("  piece %d: %s, %llu cells + %llu ghost, %llu nodes, %s, box %s\n", k, p.store.c_str(),
                (unsigned long long)p.cells, (unsigned long long)p.ghost_cells,
                (unsigned long long)report["pieces"][size_t(k)]["nodes"].get<uint64_t>(),
                format_bytes(p.store_bytes).c_str(), box(p.box).c_str());
  }
  if (verify) std::printf("  verified: every piece's bricks\n");
}

}  // namespace

void register_info(CLI::App& app) {
  struct Options {
    std::vector<std::string> inputs;
    bool json = false;
    bool topology = false;
    bool verify = false;
    ReadOptions read;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "info",
      "Describe a dataset (format, grid, cell counts, bounds, fields, memory) or a .ugvr brick store (fields, octree "
      "levels, bytes, encoding; --verify checks every brick)");
  add_input(*cmd, opts->inputs);
  add_read_options(*cmd, opts->read);
  cmd->add_flag("--json", opts->json, "Print the report as JSON");
  cmd->add_flag("--topology", opts->topology, "Also build face connectivity (boundary and non-manifold faces)");
  cmd->add_flag("--verify", opts->verify,
                "Brick store: read every brick, check its checksum and decode it; fails naming the first bad one");
  cmd->callback([opts] {
    if (opts->inputs.size() == 1 && is_piece_index(opts->inputs[0])) {
      if (opts->topology) throw Error(opts->inputs[0] + ": --topology describes a mesh, not a partitioned store");
      piece_index_info(opts->inputs[0], opts->json, opts->verify);
      return;
    }
    // A directory (an OpenFOAM case) is no store; is_brick_store_path would try to open it as a file.
    if (opts->inputs.size() == 1 && !std::filesystem::is_directory(opts->inputs[0]) &&
        is_brick_store_path(opts->inputs[0])) {
      if (opts->topology) throw Error(opts->inputs[0] + ": --topology describes a mesh, not a brick store");
      store_info(opts->inputs[0], opts->json, opts->verify);
      return;
    }
    if (opts->verify) throw Error(opts->inputs[0] + ": --verify checks a brick store (.ugvr), not a mesh");
    const auto t0 = std::chrono::steady_clock::now();
    const Dataset ds = read_dataset(opts->inputs, opts->read);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    nlohmann::json report = dataset_report(ds, seconds, {.topology = opts->topology});
    // The time axis: listed from headers and directories, not read (a single file is one step, not shown).
    const TimeSeries series = list_time_steps(opts->inputs, opts->read);
    if (series.kind != SeriesKind::Single) report["time"] = time_series_json(series);
    if (opts->json) {
      std::printf("%s\n", report.dump(2).c_str());
    } else {
      std::fputs(format_report_text(report).c_str(), stdout);
      if (report.contains("time")) std::fputs(format_time_series_text(report["time"]).c_str(), stdout);
    }
  });
}

}  // namespace ugvr::cli
