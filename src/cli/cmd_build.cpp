#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "cli/cli_numbers.h"
#include "cli/commands.h"
#include "cli/dataset_input.h"
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/time_series.h"
#include "ugvr/mpi/piece_build.h"
#include "ugvr/mpi/piece_build_ooc.h"
#include "ugvr/mpi/piece_record.h"
#include "ugvr/octree/build_parts.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/coarse_preview.h"
#include "ugvr/octree/out_of_core.h"
#ifdef UGVR_HAVE_MPI
#include "ugvr/mpi/mpi_piece_build.h"
#include "ugvr/mpi/mpi_session.h"
#endif

namespace ugvr::cli {

namespace {

// One built piece, as `--json` lists it and as the text output prints it.
nlohmann::json piece_summary(int k, const std::string& path, const PiecePlan& plan, const OctreeBuildStats& s,
                             double seconds, bool json) {
  if (!json)
    std::printf("piece %d: %s, %llu cells + %llu ghost, %llu nodes, %s in %.2f s, peak RSS %s\n", k, path.c_str(),
                (unsigned long long)plan.cells[size_t(k)], (unsigned long long)plan.ghost_cells[size_t(k)],
                (unsigned long long)s.nodes, format_bytes(s.store_bytes).c_str(), seconds,
                format_bytes(peak_rss_bytes()).c_str());
  // A piece built out of core at a small budget leaves out the exact boundary: said as a whole build says it.
  if (!s.boundary_note.empty()) std::fprintf(stderr, "warning: piece %d: %s\n", k, s.boundary_note.c_str());
  return {{"piece", k},
          {"store", path},
          {"cells", plan.cells[size_t(k)]},
          {"ghost_cells", plan.ghost_cells[size_t(k)]},
          {"nodes", s.nodes},
          {"store_bytes", s.store_bytes},
          {"leaves_in_pieces", s.leaves_in_pieces},
          {"point_passes", s.point_passes},
          {"boundary_triangles", s.boundary_triangles},
          {"seconds", seconds},
          {"peak_rss_bytes", peak_rss_bytes()}};
}

// `--pieces N`: the kd split, then this rank's pieces one after another (rank r of R builds r, r + R, ...); rank 0
// writes the index when every rank is done. In core: from the mesh read once. Out of core (a single .vtu, with
// --out-of-core or when it is large for --memory, as for a whole store): the plan and every piece streamed from the
// file (mpi/piece_build_ooc.h), each rank counting its pieces' cells, summed before the index is written.
template <class Options>
void build_pieces(Options& o) {
  check_piece_count(o.pieces);
  if (extension_lower(o.output) != ".json")
    throw Error(o.output + ": with --pieces the output is the index, a .json file (the stores go in NAME.d/)");
  if (!o.preview.empty() || !o.sketch.empty())
    throw Error("--preview and --sketch are not made with --pieces (a preview or sketch of each piece is not built)");
  const bool vtu = o.input.files.size() == 1 && extension_lower(o.input.files[0]) == ".vtu";
  if (o.out_of_core && !vtu)
    throw Error(o.input.files[0] + ": --out-of-core reads a single .vtu file (with --pieces too)");
  const bool out_of_core = o.out_of_core || (vtu && std::filesystem::file_size(o.input.files[0]) > o.memory / 5 * 2);
  int rank = 0, ranks = 1;
#ifdef UGVR_HAVE_MPI
  rank = mpi::rank(), ranks = mpi::size();
  if (rank != 0) Progress::set_enabled(false);
#endif
  if (out_of_core && !o.out_of_core && rank == 0)
    std::fprintf(stderr, "note: building the pieces out of core (the input is large for --memory)\n");
  if (o.float32) o.build.encoding.samples = SampleEncoding::Float32;
  o.build.tf_errors = !o.no_tf_errors;
  o.build.inputs = o.input.files;
  validate_build_options(o.build);
  const auto t0 = std::chrono::steady_clock::now();
  auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  // In core: the mesh and its plan. Out of core: the plan alone.
  std::optional<Dataset> ds;
  std::optional<OctreeInput> input;
  std::optional<OutOfCorePiecePlan> streamed;
  PiecePlan plan;
  double read_seconds = 0, plan_seconds = 0;
  uint64_t cells = 0;
  if (out_of_core) {
    streamed =
        plan_pieces_out_of_core(o.input.files[0], o.fields, o.pieces, o.build.resolution, o.ghost_level, o.memory);
    plan = streamed->plan;
    plan_seconds = streamed->seconds;
    cells = streamed->cells;
  } else {
    ds = read_dataset_input(o.input);
    input = prepare_octree_input(*ds, o.fields);
    read_seconds = since(t0);
    const auto t1 = std::chrono::steady_clock::now();
    plan = plan_pieces(*input, o.pieces, o.build.resolution, o.ghost_level);
    plan_seconds = since(t1);
    cells = input->mesh->cell_count();
  }
  std::filesystem::create_directories(piece_folder(o.output));
  nlohmann::json built = nlohmann::json::array();
  // How each piece is made, recorded beside its store (mpi/piece_record.h): what --resume compares.
  const std::string provenance = store_layout(o.build, {}, plan.root, plan.bounds, out_of_core).provenance;
  const std::string input_path = std::filesystem::weakly_canonical(o.input.files[0]).string();
  for (int k = rank; k < o.pieces; k += ranks) {
    const auto tk = std::chrono::steady_clock::now();
    const std::string path = (std::filesystem::path(o.output).parent_path() / piece_store_name(o.output, k)).string();
    PieceRecord record = planned_piece_record(plan, k, input_path, provenance, o.fields);
    if (o.resume) {
      std::string why;
      if (const std::optional<PieceRecord> kept = kept_piece(path, record, &why)) {
        plan.cells[size_t(k)] = kept->cells;
        plan.ghost_cells[size_t(k)] = kept->ghost_cells;
        if (!o.json)
          std::printf("piece %d: %s, kept from an earlier run (%llu cells + %llu ghost, %s)\n", k, path.c_str(),
                      (unsigned long long)kept->cells, (unsigned long long)kept->ghost_cells,
                      format_bytes(kept->store_bytes).c_str());
        built.push_back({{"piece", k},
                         {"store", path},
                         {"cells", kept->cells},
                         {"ghost_cells", kept->ghost_cells},
                         {"nodes", kept->nodes},
                         {"store_bytes", kept->store_bytes},
                         {"seconds", kept->seconds},
                         {"resumed", true}});
        continue;
      }
      if (!why.empty()) std::fprintf(stderr, "note: building piece %d again: %s\n", k, why.c_str());
    }
    OctreeBuildStats s;
    if (streamed) {
      s = build_piece_out_of_core(o.input.files[0], o.fields, *streamed, k, o.build, o.memory, path);
      plan.cells[size_t(k)] = streamed->plan.cells[size_t(k)];
      plan.ghost_cells[size_t(k)] = streamed->plan.ghost_cells[size_t(k)];
    } else {
      s = build_piece(*input, plan, k, o.build, path);
    }
    const double seconds = since(tk);
    record.cells = plan.cells[size_t(k)];
    record.ghost_cells = plan.ghost_cells[size_t(k)];
    record.nodes = s.nodes;
    record.store_bytes = std::filesystem::file_size(path);
    record.seconds = seconds;
    write_piece_record(path, record);
    built.push_back(piece_summary(k, path, plan, s, seconds, o.json));
  }
#ifdef UGVR_HAVE_MPI
  if (streamed) mpi::sum_piece_counts(plan);  // collective: also waits for every rank's pieces
  mpi::barrier();                             // every piece written before the index names them
#endif
  uint64_t total_bytes = 0;
  if (rank == 0) {
    const PieceIndex index =
        make_piece_index(streamed ? streamed->fields : input->fields, plan, o.output, o.build.resolution);
    write_piece_index(o.output, index);
    for (const PieceInfo& p : index.pieces) total_bytes += p.store_bytes;
  }
  if (o.json) {
    const nlohmann::json j = {{"output", o.output},
                              {"rank", rank},
                              {"ranks", ranks},
                              {"pieces", o.pieces},
                              {"out_of_core", out_of_core},
                              {"cells", cells},
                              {"split_samples", streamed ? streamed->split_samples : cells},
                              {"ghost_margin", plan.ghost_margin},
                              {"ghost_level", plan.ghost_level},
                              {"read_seconds", read_seconds},
                              {"plan_seconds", plan_seconds},
                              {"built", built},
                              {"store_bytes_total", total_bytes},
                              {"seconds", since(t0)},
                              {"peak_rss_bytes", peak_rss_bytes()}};
    std::printf("%s\n", j.dump().c_str());
  } else if (rank == 0) {
    std::printf("wrote %s: %d pieces%s, %s in all, ghost margin %.4g, in %.2f s (read %.2f s, kd split %.2f s)\n",
                o.output.c_str(), o.pieces, out_of_core ? " out of core" : "", format_bytes(total_bytes).c_str(),
                plan.ghost_margin, since(t0), read_seconds, plan_seconds);
  }
}

}  // namespace

void register_build(CLI::App& app) {
  struct Options {
    DatasetInput input;
    std::vector<std::string> fields;
    std::string output;
    OctreeBuildOptions build;
    uint64_t memory = uint64_t(1) << 30;
    bool float32 = false, json = false, out_of_core = false, no_tf_errors = false, resume = false;
    int pieces = 0, ghost_level = 0;
    std::string time;     // --time: the steps of a store with time
    std::string preview;  // --preview: the coarse preview's store, out of core
    std::string sketch;   // --sketch: the point sketch's store, out of core
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "build",
      "Voxelize a mesh into an adaptive octree of bricks (a .ugvr brick store) for level-of-detail rendering: nodes "
      "split until the data points inside them that differ by more than --error get voxels of their own");
  add_dataset_input(*cmd, opts->input);
  cmd->add_option("-o,--output", opts->output, "Output brick store (.ugvr)")->required();
  cmd->add_option("--fields", opts->fields,
                  "Scalars to store, comma-separated: NAME, NAME:x|y|z|k or NAME:magnitude (default: the first field "
                  "that is not constant)")
      ->delimiter(',');
  cmd->add_option("--brick", opts->build.resolution, "Samples per brick axis")
      ->check(CLI::Range(kMinBrickResolution, kMaxBrickResolution))
      ->default_val(opts->build.resolution);
  cmd->add_option("--max-depth", opts->build.max_depth, "Deepest octree level (root = 0)")
      ->check(CLI::Range(0, kMaxOctreeLevel))
      ->default_val(opts->build.max_depth);
  cmd->add_option("--error", opts->build.error,
                  "Split threshold, relative to each field's range: data points differing by more get voxels of their "
                  "own (0: every data point does)")
      ->check(CLI::Range(0.0, 1.0))
      ->default_val(opts->build.error);
  add_byte_size_option(
      *cmd, "--memory", opts->memory,
      "Memory budget (e.g. 512MiB, 4GiB); the in-core build holds the mesh and only warns when its peak exceeds it",
      "1GiB");
  cmd->add_option("--threads", opts->build.threads, "Worker threads (0: all cores)")
      ->check(CLI::NonNegativeNumber)
      ->default_val(0);
  cmd->add_flag("--float32", opts->float32,
                "Store samples losslessly as float32 (default: 16 bits, within 7.6e-6 of each field's range)");
  cmd->add_flag("--out-of-core", opts->out_of_core,
                "Stream the cells through temporary files next to the output instead of loading the mesh (one .vtu "
                "input, with --pieces too, or with --time a series of .vtu steps at --error 0; chosen by itself when "
                "the (first step's) .vtu is larger than 40% of --memory)");
  cmd->add_flag("--json", opts->json, "Print the summary as one JSON object (for benchmarks)");
  cmd->add_option(
         "--pieces", opts->pieces,
         "Partition into N stores (a power of two up to 4096) by a kd-tree balanced by cells, each with a ghost "
         "layer, named by the index -o OUT.json (docs/mpi.md); under mpirun rank r builds pieces r, r+R, ...; "
         "with --out-of-core each piece streamed from the .vtu in bounded memory, one piece's scratch at a time")
      ->check(CLI::Range(1, kMaxPieces));
  cmd->add_flag("--resume", opts->resume,
                "With --pieces: keep the pieces an earlier, interrupted run of the same command finished (each "
                "store's record NAME.d/piece-K.ugvr.built.json names the split, ghost layer, input file and options "
                "it was made with; any difference builds the piece again) and build the rest");
  cmd->add_option("--ghost-level", opts->ghost_level,
                  "With --pieces: the coarsest level whose samples inside each piece equal the whole store's; the "
                  "ghost layer is two voxels of that level (0: every level, the widest layer)")
      ->default_val(0);
  cmd->add_flag("--cells", opts->build.leaf_cells,
                "Also keep each leaf's cells (the mesh's own cells overlapping it, for exact rendering per node; "
                "in core and --out-of-core)");
  cmd->add_option("--max-leaf-cells", opts->build.max_leaf_cells,
                  "With --cells: a node overlapping more cells splits, up to 3 levels past --max-depth, so that each "
                  "leaf's cell block stays small (out of core: within the worker's share of --memory; hybrid: within "
                  "the GPU cell budget); 0: no cap")
      ->default_val(opts->build.max_leaf_cells);
  cmd->add_option("--time", opts->time,
                  "A time series: one store holding steps all|N|A:B[:S] (inclusive, stride S), sharing the octree "
                  "(static geometry only; docs/time-series.md)");
  cmd->add_option("--preview", opts->preview,
                  "Out of core: also write a coarse preview store there (levels 0..K of the final store, K up to 3 as "
                  "--memory allows), within seconds of the cells being on disk (octree/coarse_preview.h)");
  cmd->add_option(
      "--sketch", opts->sketch,
      "Out of core: also write a point sketch store there before the cells are read (levels 0..K, "
      "approximate: each lattice point the mean of the mesh's points nearest to it; vertex fields and about "
      "a million points or more; octree/point_sketch.h)");
  cmd->add_flag("--no-tf-errors", opts->no_tf_errors,
                "Leave out the transfer-function error table (44 bytes per node and field; renderers then rank nodes "
                "by texel size alone)");
  cmd->callback([opts] {
    if (opts->ghost_level != 0 && opts->pieces == 0) throw Error("--ghost-level applies with --pieces only");
    if (opts->resume && opts->pieces == 0)
      throw Error("--resume applies with --pieces only (a whole store is one file)");
    if (opts->pieces > 0 && !opts->time.empty())
      throw Error("--pieces and --time: partitioned stores hold one step; build one index per step");
    if (opts->pieces > 0) {
      build_pieces(*opts);
      return;
    }
    if (extension_lower(opts->output) != ".ugvr") throw Error(opts->output + ": the output must be a .ugvr file");
    if (opts->float32) opts->build.encoding.samples = SampleEncoding::Float32;
    opts->build.tf_errors = !opts->no_tf_errors;
    opts->build.inputs = opts->input.files;  // recorded in the store
    validate_build_options(opts->build);
    const bool vtu = opts->input.files.size() == 1 && extension_lower(opts->input.files[0]) == ".vtu";
    const bool timed = !opts->time.empty();
    if (timed && opts->input.read.time_step >= 0)
      throw Error("--time and --time-step: give one (--time N selects a single step too)");
    if (opts->out_of_core && !vtu && !timed)
      throw Error(opts->input.files[0] +
                  ": --out-of-core reads a single .vtu file (or, with --time, a series of them)");
    std::optional<TimeSeries> series;
    std::vector<uint32_t> steps;
    if (timed) {
      series = list_time_steps(opts->input.files, opts->input.read);
      steps = parse_step_selection(opts->time, series->size(), "--time");
    }
    // Chosen by itself when the (first step's) .vtu is larger than 40% of --memory: the in-core build's 2.5x peak
    // would not fit. A series only at --error 0, which is all the out-of-core build of a series does.
    auto large = [&](const std::string& file) { return std::filesystem::file_size(file) > opts->memory / 5 * 2; };
    const bool out_of_core =
        timed ? opts->out_of_core || (opts->build.error == 0 && out_of_core_steps_possible(*series, steps) &&
                                      large(out_of_core_step_file(*series, steps[0])))
              : opts->out_of_core || (vtu && large(opts->input.files[0]));
    if (!opts->preview.empty()) {
      if (!out_of_core) throw Error("--preview " + opts->preview + ": a preview is made by out-of-core builds only");
      if (extension_lower(opts->preview) != ".ugvr") throw Error(opts->preview + ": the preview must be a .ugvr file");
      const uint32_t fields = uint32_t(std::max<size_t>(opts->fields.size(), 1));
      opts->build.preview_depth = std::max(1, coarse_preview_depth_for(opts->memory, opts->build.resolution, fields));
      opts->build.preview_path = opts->preview;
    }
    if (!opts->sketch.empty()) {
      if (!out_of_core) throw Error("--sketch " + opts->sketch + ": a sketch is made by out-of-core builds only");
      if (extension_lower(opts->sketch) != ".ugvr") throw Error(opts->sketch + ": the sketch must be a .ugvr file");
      const uint32_t fields = uint32_t(std::max<size_t>(opts->fields.size(), 1));
      // Its depth is bounded by the preview's (which is then made too, at a temporary path unless --preview).
      if (opts->build.preview_depth == 0)
        opts->build.preview_depth = std::max(1, coarse_preview_depth_for(opts->memory, opts->build.resolution, fields));
      opts->build.point_sketch = true;
      opts->build.sketch_path = opts->sketch;
    }
    OctreeBuildStats s;
    std::string names;
    if (timed && out_of_core) {
      if (!opts->out_of_core) std::fprintf(stderr, "note: building out of core (a step is large for --memory)\n");
      s = build_octree_out_of_core_steps(*series, steps, opts->fields, opts->build, opts->memory, opts->output);
      const BrickStoreReader store(opts->output);
      for (const BrickStoreField& f : store.layout().fields) names += (names.empty() ? "" : ",") + f.name;
    } else if (timed) {
      s = build_octree_steps(*series, steps, opts->fields, opts->build, opts->output);
      const BrickStoreReader store(opts->output);
      for (const BrickStoreField& f : store.layout().fields) names += (names.empty() ? "" : ",") + f.name;
    } else if (out_of_core) {
      if (!opts->out_of_core) std::fprintf(stderr, "note: building out of core (the input is large for --memory)\n");
      s = build_octree_out_of_core(opts->input.files[0], opts->fields, opts->build, opts->memory, opts->output);
      const BrickStoreReader store(opts->output);
      for (const BrickStoreField& f : store.layout().fields) names += (names.empty() ? "" : ",") + f.name;
    } else {
      const Dataset ds = read_dataset_input(opts->input);
      const OctreeInput input = prepare_octree_input(ds, opts->fields);
      s = build_octree(input, opts->build, opts->output);
      for (const BrickStoreField& f : input.fields) names += (names.empty() ? "" : ",") + f.name;
    }
    const double samples_per_second = s.brick_seconds > 0 ? double(s.leaf_samples) / s.brick_seconds : 0.0;
    if (opts->json) {
      const nlohmann::json j = {{"output", opts->output},
                                {"fields", names},
                                {"brick", opts->build.resolution},
                                {"max_depth", opts->build.max_depth},
                                {"max_leaf_cells", opts->build.leaf_cells ? opts->build.max_leaf_cells : 0},
                                {"error", opts->build.error},
                                {"encoding", opts->float32 ? "float32" : "quant16"},
                                {"cells", s.cells},
                                {"out_of_core", out_of_core},
                                {"nodes", s.nodes},
                                {"leaves", s.leaves},
                                {"nodes_with_data", s.bricks},
                                {"depth_avg", s.mean_leaf_level},
                                {"depth_max", s.max_level},
                                {"nodes_per_level", s.nodes_per_level},
                                {"leaf_samples", s.leaf_samples},
                                {"valid_samples", s.valid_samples},
                                {"leaves_in_pieces", s.leaves_in_pieces},
                                {"point_passes", s.point_passes},
                                {"sampler_thread_seconds", s.sampler_seconds},
                                {"subdivide_seconds", s.subdivide_seconds},
                                {"brick_seconds", s.brick_seconds},
                                {"seconds", s.seconds},
                                {"samples_per_second", samples_per_second},
                                {"store_bytes", s.store_bytes},
                                {"tf_error_table_bytes", s.tf_error_table_bytes},
                                {"boundary_bytes", s.boundary_bytes},
                                {"boundary_triangles", s.boundary_triangles},
                                {"boundary_seconds", s.boundary_seconds},
                                {"cell_blocks", s.cell_blocks},
                                {"leaf_cells", s.leaf_cells},
                                {"cell_bytes", s.cell_bytes},
                                {"cell_seconds", s.cell_seconds},
                                {"time_steps", s.time_steps},
                                {"read_seconds", s.read_seconds},
                                {"first_step_nodes", s.first_step_nodes},
                                {"step_reads_fields_only", s.fields_only_reads},
                                {"step_reads_whole", s.whole_reads},
                                {"preview_depth", opts->build.preview_depth},
                                {"preview_seconds", s.preview_seconds},
                                {"preview_nodes", s.preview_nodes},
                                {"preview_bytes", s.preview_bytes},
                                {"sketch_depth", s.sketch_depth},
                                {"sketch_seconds", s.sketch_seconds},
                                {"sketch_bytes", s.sketch_bytes},
                                {"peak_rss_bytes", peak_rss_bytes()}};
      std::printf("%s\n", j.dump().c_str());
    } else {
      std::printf(
          "wrote %s: %llu nodes (%llu leaves, %llu with data), depth avg %.2f max %d, %s, %s %ux%ux%u bricks, %s in "
          "%.2f s (subdivide %.2f s, bricks %.2f s, %.3g samples/s), peak RSS %s\n",
          opts->output.c_str(), (unsigned long long)s.nodes, (unsigned long long)s.leaves, (unsigned long long)s.bricks,
          s.mean_leaf_level, s.max_level, names.c_str(), opts->float32 ? "float32" : "quant16", opts->build.resolution,
          opts->build.resolution, opts->build.resolution, format_bytes(s.store_bytes).c_str(), s.seconds,
          s.subdivide_seconds, s.brick_seconds, samples_per_second, format_bytes(peak_rss_bytes()).c_str());
      if (s.preview_nodes > 0)
        std::printf("  coarse preview %s: levels 0..%d, %llu nodes, %s, %.2f s\n", opts->preview.c_str(),
                    opts->build.preview_depth, (unsigned long long)s.preview_nodes,
                    format_bytes(s.preview_bytes).c_str(), s.preview_seconds);
      if (s.sketch_depth > 0)
        std::printf("  point sketch %s: levels 0..%d, %s, %.2f s\n", opts->sketch.c_str(), s.sketch_depth,
                    format_bytes(s.sketch_bytes).c_str(), s.sketch_seconds);
      else if (opts->build.point_sketch)
        std::printf("  no point sketch: it needs vertex fields only and about a million points or more\n");
      if (s.time_steps > 0)
        std::printf("  %u time step(s) on one tree (the first step's own: %llu nodes), reading %.2f s\n", s.time_steps,
                    (unsigned long long)s.first_step_nodes, s.read_seconds);
      if (s.fields_only_reads + s.whole_reads > 0)
        std::printf("  step reads: %u fields-only (onto the mesh held), %u whole\n", s.fields_only_reads,
                    s.whole_reads);
    }
    if (!s.boundary_note.empty()) std::fprintf(stderr, "warning: %s\n", s.boundary_note.c_str());
    if (!out_of_core && peak_rss_bytes() > opts->memory) {
      std::fprintf(stderr,
                   "warning: peak memory %s exceeded --memory %s: this build holds the mesh and its cell lists in "
                   "memory\n",
                   format_bytes(peak_rss_bytes()).c_str(), format_bytes(opts->memory).c_str());
    }
  });
}

}  // namespace ugvr::cli
