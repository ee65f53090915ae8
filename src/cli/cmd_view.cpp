// `ugvr view FILE | STORE.ugvr | --demo`: serves the browser viewer (src/ugvr/view/view_server.h) until SIGINT or
// SIGTERM. A grid file that is not a brick store gets one built in the background (kept in the cache directory,
// view_store.h, so the next `ugvr view` of the same file starts from it), shown meanwhile by the exact engine.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "cli/cli_numbers.h"
#include "cli/commands.h"
#include "cli/demo_scene.h"
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/time_series.h"
#include "ugvr/mpi/piece_build_ooc.h"
#include "ugvr/mpi/piece_index.h"
#include "ugvr/mpi/piece_renderer.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/render/scaled_while_moving.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/view/memory_budget.h"
#include "ugvr/view/scratch_pieces.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_server.h"
#include "ugvr/view/view_store.h"
#ifdef UGVR_HAVE_MPI
#include <tbb/global_control.h>

#include "ugvr/mpi/mpi_session.h"
#include "ugvr/mpi/mpi_view.h"
#endif

namespace ugvr::cli {
namespace {

// The built-in demo: the generated mixed-cell wing (`ugvr generate --kind mixed`), small enough to build in seconds.
constexpr uint64_t kDemoCells = 200'000;

struct Options {
  std::vector<std::string> inputs, fields;
  std::string store_path, camera, tf;
  bool demo = false;
  bool free_grid = false;
  ReadOptions read;
  OctreeBuildOptions build;
  std::string host = "127.0.0.1", size = "512", gpu = "auto", fps = "10";
  int port = 0;
  uint64_t gpu_memory = uint64_t(2) << 30;
  uint64_t ram_memory = uint64_t(1) << 30;
  uint64_t memory_budget = 0;     // --memory-budget (view/memory_budget.h); 0: not given
  uint64_t tabs_memory = 0;       // --tabs-memory (view/tab_memory.h); 0: the memory budget
  double play = 0;                // --play: steps a second a new tab starts playing at (0: paused)
  std::string engine = "hybrid";  // --engine: what draws a store that keeps cells (ViewServerOptions::hybrid)
  int threads = 0;                // --threads: under mpirun, each rank's worker threads (0: every core)
};

bool is_store(const std::vector<std::string>& inputs) {
  return inputs.size() == 1 && std::filesystem::path(inputs[0]).extension() == ".ugvr";
}

// view::store_opens, saying why a store that exists is built again.
bool store_opens(const std::string& path) {
  std::string why;
  if (view::store_opens(path, &why)) return true;
  if (!why.empty()) std::fprintf(stderr, "ugvr view: rebuilding %s (%s)\n", path.c_str(), why.c_str());
  return false;
}

// Serves `vo` until SIGINT or SIGTERM (or the grid fails to load). `note`: said once serving (what draws the frames).
void serve(view::ViewServerOptions vo, const std::string& note = "") {
  // Blocked before any thread starts, so that every thread inherits the mask and only sigwait below sees them.
  // SIGUSR1 is the viewer's own: the grid could not be loaded (on_failure below).
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGUSR1);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  // A grid that cannot be loaded leaves the viewer nothing to show: it says why in the page and here, then exits
  // non-zero (a script or a user waiting on it learns it failed; a page already open keeps the message).
  auto failure = std::make_shared<std::string>();
  auto failure_mutex = std::make_shared<std::mutex>();
  vo.on_failure = [failure, failure_mutex](const std::string& message) {
    {
      std::lock_guard lock(*failure_mutex);
      *failure = message;
    }
    ::kill(::getpid(), SIGUSR1);
  };

  view::ViewServer server(std::move(vo));
  // Printed even with --quiet: it is the command's output (scripts read the URL from it).
  std::printf("ugvr view: serving %s (%s)\n", server.url().c_str(), server.renderer().c_str());
  std::fflush(stdout);
  if (!note.empty()) std::fprintf(stderr, "ugvr view: %s\n", note.c_str());
  int sig = 0;
  sigwait(&signals, &sig);
  if (sig == SIGUSR1) {
    // Time for the pages to receive the "failed" progress before the sockets close.
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    server.stop();
    std::lock_guard lock(*failure_mutex);
    throw Error(*failure);
  }
  std::fprintf(stderr, "ugvr view: stopping\n");
  server.stop();
}

// The collective paths' renderer (under MPI, or a partitioned store in one process): the GPU and its budget given.
RendererOptions collective_renderer_options(const Options& o) {
  RendererOptions ro;
  ro.gpu = o.gpu;
  ro.lod.atlas_budget_bytes = o.gpu_memory;
  return ro;
}

// A partitioned store's part of the page's scene (engine_host.cpp, collective_scene): the fields its index lists,
// and its pieces, whose coarse levels the histograms are read from.
void describe_pieces(const PieceIndex& index, view::CollectiveRenderer& c) {
  c.fields.clear();
  for (const BrickStoreField& f : index.fields) c.fields.push_back(f.name);
  for (int k = 0; k < index.count(); ++k) c.histogram_stores.push_back(index.store_path(k));
}

#ifdef UGVR_HAVE_MPI
// `mpirun -np N ugvr view INPUT` (docs/mpi.md, "The viewer on a cluster"): rank 0 serves `vo` with every frame drawn
// by all ranks (mpi/mpi_view.h); the other ranks draw what it broadcasts until it says quit. What the collective
// renderer cannot do is refused here, before anything is read.
void run_view_mpi(const Options& o, view::ViewServerOptions vo) {
  const std::string advice = "under MPI the viewer shows a partitioned store's index, a brick store or a mesh";
  if (o.demo) fail_in("--demo", advice + " (build the demo with `ugvr generate` first)");
  if (is_series_input(o.inputs)) fail_in("INPUT", "time series are not shown under MPI yet; " + advice);
  if (!o.store_path.empty() || o.free_grid)
    fail_in(o.free_grid ? "--free-grid" : "--store",
            "no store is built under MPI: a mesh is drawn by the exact engine, every rank its part");
  // Each rank's threads for the whole job (ranks sharing a node's cores should not each take all of them).
  std::optional<tbb::global_control> thread_limit;
  if (o.threads > 0) thread_limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  const RendererOptions ro = collective_renderer_options(o);
  if (mpi::rank() > 0) {
    // Signals end the job through rank 0, which tells every rank to quit: a follower killed by mpirun's forwarded
    // SIGTERM while rank 0 still broadcasts would make the stop an abort.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    Progress::set_enabled(false);
    mpi::follow_view(o.inputs, o.read, ro);
    return;
  }
  vo.collective = [inputs = o.inputs, read = o.read, ro] {
    view::CollectiveRenderer c;
    OpenedInput opened;
    c.renderer = mpi::open_view_leader(inputs, read, ro, &c.fields, &opened);
    c.histogram_dataset = opened.dataset;
    if (inputs.size() == 1 && is_piece_index(inputs[0])) {
      describe_pieces(read_piece_index(inputs[0]), c);
    } else if (inputs.size() == 1 && is_brick_store(inputs[0])) {
      c.histogram_stores = inputs;
    }
    return c;
  };
  // A move stops a resting frame on every rank (mpi/mpi_frame_stop.h): no rest delay needed.
  vo.collective_interruptible = true;
  serve(std::move(vo), "MPI: " + std::to_string(mpi::size()) +
                           " ranks draw every frame (one engine; no MIP or time steps under MPI: docs/mpi.md); "
                           "rank 0 is pid " +
                           std::to_string(::getpid()) + " (SIGINT or SIGTERM to it stops every rank)");
}
#endif

// The partitioned store at `index_path` served in one process: every piece drawn here, as `ugvr render INDEX` draws
// them (piece_renderer.h), through the same collective path as under MPI (the tabs' one renderer, one cut per frame,
// the image scaled down while the view moves: render/scaled_while_moving.h). `build`: the index is built first
// (ViewServerOptions::collective_build, its progress in the page), else it exists and a bad one fails here, before
// serving.
void serve_pieces(const Options& o, view::ViewServerOptions vo, const std::string& index_path, int pieces,
                  std::function<void(const Progress::Observer&)> build = {}) {
  if (!build) pieces = read_piece_index(index_path).count();
  vo.collective = [index_path, ro = collective_renderer_options(o)] {
    const PieceIndex index = read_piece_index(index_path);
    view::CollectiveRenderer c;
    describe_pieces(index, c);
    c.renderer = std::make_shared<ScaledWhileMovingRenderer>(open_piece_renderer(index, {}, ro));
    return c;
  };
  vo.collective_build = std::move(build);
  vo.store = index_path;  // the build's cache entry
  // In one process a resting frame stops between (and inside) pieces when the view moves on: no rest delay needed.
  vo.collective_interruptible = true;
  serve(std::move(vo), "a partitioned store: its " + std::to_string(pieces) +
                           " pieces drawn in this process, one after another (mpirun -np N shares them out)");
}

// `ugvr view INDEX.json` in one process (docs/mpi.md, "The viewer on a cluster"). Nothing is built: a store of a
// billion cells is opened where its pieces were written.
void run_view_pieces(const Options& o, view::ViewServerOptions vo) {
  if (!o.store_path.empty() || o.free_grid)
    fail_in(o.free_grid ? "--free-grid" : "--store", "a partitioned store's index is shown as built: nothing to build");
  serve_pieces(o, std::move(vo), o.inputs[0], 0);
}

// A .vtu over the memory budget whose one out-of-core build's scratch would not fit the cache's disk but whose pieces
// do (view/scratch_pieces.h): its partitioned store, built in the cache one piece at a time (as `ugvr build --pieces
// N --out-of-core` builds it) unless an earlier view built it, then shown as an index is. `why`: why out of core.
void view_in_pieces(const Options& o, view::ViewServerOptions vo, const std::vector<std::string>& fields,
                    uint64_t budget, const std::string& why, const view::ScratchPieces& sp) {
  OctreeBuildOptions build = o.build;  // the LOD engine draws the pieces: no cells
  build.leaf_cells = false;
  build.threads = 0;
  const std::string index = view::cached_index_path(o.inputs, fields, build, sp.pieces, view::kScratchPiecesGhostLevel);
  if (is_piece_index(index)) {
    std::fprintf(stderr, "ugvr view: %s: showing the partitioned store built earlier, %s\n", why.c_str(),
                 index.c_str());
    return serve_pieces(o, std::move(vo), index, 0);
  }
  vo.notice = why + "; " + sp.why;
  std::fprintf(stderr, "ugvr view: %s, into %s\n", vo.notice.c_str(), index.c_str());
  serve_pieces(o, std::move(vo), index, sp.pieces,
               [vtu = o.inputs[0], fields, pieces = sp.pieces, build, budget, index](const Progress::Observer& p) {
                 build_index_out_of_core(vtu, fields, pieces, view::kScratchPiecesGhostLevel, build, budget, index, p,
                                         print_warning);
               });
}

void run_view(const Options& o) {
  if (o.port < 0 || o.port > 65535) fail_in("--port", "must be in [0, 65535] (0: a free port)");
  if (o.demo == !o.inputs.empty()) fail_in("INPUT", "give a grid file, a .ugvr store or --demo (one of them)");
  view::ViewServerOptions vo;
  vo.host = o.host;
  vo.port = uint16_t(o.port);
  vo.gpu = o.gpu;
  vo.gpu_memory = o.gpu_memory;
  if (o.engine != "hybrid" && o.engine != "lod")
    fail_in("--engine", "\"" + o.engine + "\" is not lod or hybrid (the store's voxels, or its cells exact at rest)");
  vo.hybrid = o.engine == "hybrid";
  vo.ram_per_session = o.ram_memory;
  vo.tabs_memory = o.tabs_memory ? o.tabs_memory : o.memory_budget;  // 0: the server's default, the same budget
  vo.free_grid = o.free_grid;
  const ImageSize size = parse_size(o.size, "--size");
  if (size.width < view::kMinViewSide || size.width > view::kMaxViewSide || size.height < view::kMinViewSide ||
      size.height > view::kMaxViewSide)
    fail_in("--size", "each side must be in [" + std::to_string(view::kMinViewSide) + ", " +
                          std::to_string(view::kMaxViewSide) + "]");
  vo.width = size.width, vo.height = size.height;
  vo.fps = parse_number(o.fps, "--fps");
  if (!(o.play >= 0) || o.play > view::kMaxFps)
    fail_in("--play", "must be in [0, " + std::to_string(int(view::kMaxFps)) + "] steps a second (0: paused)");
  vo.play_rate = o.play;
  if (!(vo.fps >= 0) || vo.fps > view::kMaxFps)
    fail_in("--fps", "must be in [0, " + std::to_string(int(view::kMaxFps)) + "]");
  validate_build_options(o.build);
  // The demo starts from its own view (demo_scene.h) unless told otherwise; with other --fields its transfer function
  // would not fit.
  const bool demo_view = o.demo && o.fields.empty();
  if (!o.camera.empty()) {
    vo.camera = read_camera(o.camera);
  } else if (demo_view) {
    vo.camera = camera_from_json(nlohmann::json::parse(kDemoCameraJson), "demo camera");
  }
  if (demo_view) {
    vo.background = kDemoBackground;
    if (o.tf.empty()) vo.tf = parse_paraview_presets(kDemoTfJson, "demo transfer function").at(0);
  }
  // No --tf (or --tf auto): the page starts from the auto transfer function, framed on what it leaves visible.
  vo.auto_tf = !vo.tf && (o.tf.empty() || o.tf == "auto");
  if (!o.tf.empty() && o.tf != "auto") {
    if (std::filesystem::is_regular_file(o.tf)) {
      vo.tf = read_paraview_preset(o.tf);
      vo.tf->opacity_unit_distance = read_preset_unit_distance(o.tf).value_or(0);  // 0: the viewer's default
    } else {
      try {
        builtin_preset(o.tf);
      } catch (const Error& e) {
        fail_in("--tf", std::string("neither a file nor a preset: ") + e.what());
      }
      vo.preset = o.tf;  // rescaled to the field's range by the viewer
    }
  }

#ifdef UGVR_HAVE_MPI
  if (mpi::active()) return run_view_mpi(o, std::move(vo));
#endif
  if (o.threads != 0) fail_in("--threads", "is for `mpirun ... ugvr view` (each rank's threads)");
  if (o.inputs.size() == 1 && is_piece_index(o.inputs[0])) return run_view_pieces(o, std::move(vo));

  // A time series of several steps (a .pvd, .series, numbered files, or a multi-step file such as Exodus): the exact
  // engine alone, with a time slider (no store: a store holds one step).
  std::shared_ptr<const TimeSeries> series;
  if (!o.demo && !is_store(o.inputs)) {
    if (is_series_input(o.inputs)) {
      series = std::make_shared<const TimeSeries>(list_time_steps(o.inputs, o.read));
    } else {
      try {
        series = std::make_shared<const TimeSeries>(list_time_steps(o.inputs, o.read));
      } catch (const Error&) {
        // Not listable: read as one dataset below, whose load reports the error in the page.
      }
    }
    if (series && series->size() < 2) series.reset();
  }
  if (series) {
    // --time-step N starts there (default: the first step, the start of playback).
    const int64_t step = o.read.time_step < 0 ? 0 : o.read.time_step;
    if (step >= int64_t(series->size()))
      fail_in("--time-step", std::to_string(step) + " is out of range: " + series->source + " has " +
                                 std::to_string(series->size()) + " steps");
    vo.series = series;
    vo.time_step = uint32_t(step);
    vo.fields = o.fields;
    std::fprintf(stderr, "ugvr view: %s: %zu time steps (%s), shown by the exact engine from step %lld\n",
                 series->source.c_str(), series->size(), std::string(series_kind_name(series->kind)).c_str(),
                 static_cast<long long>(step));
  } else if (is_store(o.inputs)) {
    vo.store = o.inputs[0];
  } else {
    vo.build = o.build;
    vo.build.inputs = o.inputs.empty() ? std::vector<std::string>{"ugvr view --demo"} : o.inputs;
    // Every core: on 2 cores, leaving one to the exact preview's frames halved the build (measured: issue 24), and the
    // preview's frames are few and short at a reduced scale while the view moves.
    vo.build.threads = 0;
    GenerateOptions demo;
    demo.cells = kDemoCells, demo.kind = GenCellKind::Mixed;
    // The demo shows the wing and its vortex street by pressure (as scripts/demo.sh renders it); velocity is there to
    // pick.
    const std::vector<std::string> fields =
        o.demo && o.fields.empty() ? std::vector<std::string>{kDemoField, "velocity"} : o.fields;
    // Never in core unless it fits: the estimate is made before anything is read (view/memory_budget.h). A grid over
    // the budget is built out of core with its leaves' cells (`ugvr build --out-of-core --cells`): there is no exact
    // preview then, and the cells let the hybrid engine converge to the exact image at rest (docs/hybrid.md). Decided
    // before the cache name, which changes with the cells (view::cached_store_path).
    std::string budget_source;
    uint64_t budget = 0;
    view::InCoreEstimate need;
    if (!o.demo) {
      budget = view::view_memory_budget(o.memory_budget ? std::optional<uint64_t>(o.memory_budget) : std::nullopt,
                                        &budget_source);
      need = view::estimate_in_core(o.inputs);
      vo.build.leaf_cells = need.bytes > budget;
    }
    vo.store = !o.store_path.empty() ? o.store_path
               : o.demo
                   ? view::cached_store_path("demo", "generate mixed " + std::to_string(demo.cells), fields, vo.build)
                   : view::cached_store_path(o.inputs, fields, vo.build);
    if (o.store_path.empty()) {
      uint64_t cached = 0;
      for (const view::CachedStore& s : view::cached_stores(view::view_cache_dir())) cached += s.bytes;
      if (cached > view::kCacheReminderBytes)
        std::fprintf(stderr, "note: the store cache %s holds %s (`ugvr cache` lists it; --prune SIZE, --clear)\n",
                     view::view_cache_dir().c_str(), format_bytes(cached).c_str());
    }
    if (store_opens(vo.store)) {
      std::fprintf(stderr, "ugvr view: showing the brick store built earlier, %s\n", vo.store.c_str());
    } else if (o.demo) {
      vo.fields = fields;
      vo.load = [demo] { return std::make_shared<Dataset>(generate_in_memory(demo)); };
      std::fprintf(stderr, "ugvr view: building the brick store %s in the background\n", vo.store.c_str());
    } else {
      vo.fields = fields;
      if (need.bytes <= budget) {
        vo.load = [inputs = o.inputs, read = o.read] { return std::make_shared<Dataset>(read_dataset(inputs, read)); };
        std::fprintf(stderr, "ugvr view: building the brick store %s in the background\n", vo.store.c_str());
      } else {
        const std::string why = view::over_budget_reason(need, budget, budget_source);
        view::require_out_of_core_input(o.inputs, why,
                                        std::string("--memory-budget or $") + view::kViewMemoryBudgetEnv);
        if (o.store_path.empty()) {  // the scratch goes next to the store: in the cache
          const std::string cache = view::view_cache_dir();
          std::filesystem::create_directories(cache);
          const view::ScratchPieces sp = view::pieces_for_scratch(need.cells, fields.size(), vo.build.resolution,
                                                                  scratch_free_bytes(cache), cache);
          if (sp.pieces > 1) return view_in_pieces(o, std::move(vo), fields, budget, why, sp);
        }
        vo.out_of_core_input = o.inputs[0];
        vo.out_of_core_budget = budget;
        vo.notice = why +
                    ": no exact preview; the store is built out of core with its cells, shown first as a sketch "
                    "from the points (large meshes), then as a coarse preview (exact at rest once built)";
        std::fprintf(stderr, "ugvr view: %s\n", vo.notice.c_str());
        std::fprintf(stderr, "ugvr view: building the brick store %s out of core\n", vo.store.c_str());
      }
    }
  }

  serve(std::move(vo));
}

}  // namespace

void register_view(CLI::App& app) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "Serve an interactive browser viewer at http://127.0.0.1:PORT/ until interrupted: of a brick store, or of any "
      "readable grid (its store is built in the background and kept in the cache directory; the exact engine shows "
      "the grid meanwhile), or of the built-in demo");
  cmd->add_option(
         "INPUT", opts->inputs,
         "A brick store (.ugvr), a grid file (.vtu .vtk .vts .msh .ugrid .e .cgns .case ...), an OpenFOAM case "
         "directory, or a PLOT3D grid file then its solution file")
      ->expected(0, 2)
      ->check(CLI::ExistingPath);
  add_read_options(*cmd, opts->read);
  cmd->add_flag("--demo", opts->demo, "Show the built-in demo dataset (a generated mixed-cell wing, 200k cells)");
  cmd->add_option("--fields", opts->fields,
                  "Fields to build, comma-separated: NAME, NAME:x|y|z|k or NAME:magnitude (default: every field that "
                  "is not constant, at most 4)")
      ->delimiter(',');
  cmd->add_option("--store", opts->store_path,
                  "Where to build the grid's brick store (default: the cache directory, $UGVR_CACHE_DIR or "
                  "~/.cache/ugvr, reused while the input is unchanged)");
  cmd->add_flag("--free-grid", opts->free_grid,
                "Free the grid and its exact engine once its store is built and shown (saves their memory; the page "
                "then offers only the level-of-detail engine)");
  cmd->add_option("--memory-budget", opts->memory_budget,
                  "RAM the viewer may hold a grid in (e.g. 8GiB; default: half of the machine's memory, or "
                  "$UGVR_VIEW_MEMORY_BUDGET): a grid estimated larger is not read, its store is built out of core "
                  "(.vtu), shown as a coarse preview within seconds of its cells, whole when done")
      ->transform(CLI::AsSizeValue(true));
  cmd->add_option("--error", opts->build.error, "Build: split threshold relative to each field's range")
      ->check(CLI::Range(0.0, 1.0))
      ->default_val(opts->build.error);
  cmd->add_option("--max-depth", opts->build.max_depth, "Build: deepest octree level")
      ->check(CLI::Range(0, kMaxOctreeLevel))
      ->default_val(opts->build.max_depth);
  cmd->add_option("--camera", opts->camera, "Initial view: a camera JSON file as `ugvr render --camera` reads");
  cmd->add_option("--tf", opts->tf,
                  "Initial transfer function: a ParaView preset JSON file (points in data values, as `ugvr render --tf "
                  "FILE --keep-range`), or a built-in preset name");
  cmd->add_option("--port", opts->port, "TCP port (default 0: a free port)");
  cmd->add_option("--host", opts->host,
                  "Address to listen on (default 127.0.0.1); any other needs the printed URL's random token")
      ->default_str("127.0.0.1");
  cmd->add_option("--size", opts->size, "Initial image size: N or WxH, sides in [16, 4096] (the page then sets it)")
      ->default_str("512");
  add_gpu_memory_flags(*cmd, opts->gpu, opts->gpu_memory, opts->ram_memory,
                       "per browser tab: what a resting view can refine to");
  cmd->add_option("--tabs-memory", opts->tabs_memory,
                  "RAM all browser tabs together may hold: each tab's canvas, outgoing queue and RAM brick cache "
                  "(e.g. 4GiB; default: --memory-budget). A tab that does not fit is refused; later tabs get less "
                  "than --ram-memory when it runs short")
      ->transform(CLI::AsSizeValue(true));
  cmd->add_option("--play", opts->play,
                  "A time series: every new tab starts playing the steps, looping, at this many a second (the page's "
                  "pause button stops it)")
      ->type_name("RATE");
  cmd->add_option("--threads", opts->threads,
                  "Under mpirun: each rank's worker threads (default: every core; ranks sharing a machine's cores "
                  "should divide them)")
      ->check(CLI::Range(1, 4096));
  cmd->add_option("--fps", opts->fps, "Frame-rate target while interacting (0: every frame at full quality)")
      ->default_str("10");
  cmd->add_option("--engine", opts->engine,
                  "What new tabs draw a brick store with: hybrid (a store built with --cells: voxels while moving, "
                  "exact cells batch by batch at rest, docs/hybrid.md) or lod (voxels only); each tab may pick the "
                  "other")
      ->default_str("hybrid");
  cmd->callback([opts] { run_view(*opts); });
}

}  // namespace ugvr::cli
