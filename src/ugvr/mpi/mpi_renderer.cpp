#include "ugvr/mpi/mpi_renderer.h"

#include <mpi.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "ugvr/core/error.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/mpi_compositor.h"
#include "ugvr/mpi/mpi_frame_stop.h"
#include "ugvr/mpi/mpi_part_read.h"
#include "ugvr/mpi/mpi_session.h"
#include "ugvr/mpi/piece_index.h"
#include "ugvr/mpi/piece_renderer.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/visible_bounds.h"

namespace ugvr::mpi {
namespace {

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// How a rank got its part of a mesh: the whole input read (every format) or only the pieces it owns of an input read by
// parts (part_source.h: a .pvtu, Exodus; mpi_part_read.h). Figures for --stats; a store has none.
struct ReadFigures {
  std::string how;           // "whole" or PartSource::kind() ("pvtu-part", "exodus-blocks"); empty for a store
  uint64_t cells_total = 0;  // the mesh's volume cells
  uint64_t cells_read = 0;   // decoded from the input by this rank
  uint64_t cells_kept = 0;   // in the rank's part (its engine's cells)
  double seconds = 0;        // reading, cutting and the part's walk mesh, the split's exchanges included
};

// The whole mesh's figures a part does not know by itself: its bounds (the default camera) and each field's range
// (the default transfer function), the same on every rank.
struct WholeMesh {
  std::optional<Bounds> bounds;
  std::map<std::string, FieldRange> ranges;
};

// The compositing renderer's own figures (--stats), then the rank's engine's.
struct MpiFrameStats : EngineFrameStats {
  int ranks = 1;
  std::string compositor;
  double render_seconds_max = 0, render_seconds_min = 0;  // the ranks' engine time: the slowest decides
  double composite_seconds = 0;                           // rank 0's time in the compositor
  // Per rank (rank order): the engine's render time (wall and this process's CPU: on an oversubscribed machine the
  // CPU time is the rank's own work), its samples (the exact engine: cells entered, a measure of work that no load
  // changes), the bytes its structures hold (the exact engine's walk mesh and field: its part under MPI; 0 where
  // the engine does not say) and the process's peak resident set so far.
  std::vector<double> rank_render_seconds, rank_render_cpu_seconds, rank_samples, rank_engine_bytes,
      rank_peak_rss_bytes;
  // How each rank read its part (ReadFigures): cells decoded from the input, cells kept, seconds.
  std::string read;
  uint64_t cells_total = 0;
  std::vector<double> rank_cells_read, rank_cells_kept, rank_read_seconds;
  std::shared_ptr<const EngineFrameStats> rank0;
  void to_json(nlohmann::json& j) const override {
    if (rank0) rank0->to_json(j);
    j["mpi"] = {{"ranks", ranks},
                {"compositor", compositor},
                {"render_seconds_max", render_seconds_max},
                {"render_seconds_min", render_seconds_min},
                {"composite_seconds", composite_seconds},
                {"rank_render_seconds", rank_render_seconds},
                {"rank_render_cpu_seconds", rank_render_cpu_seconds},
                {"rank_samples", rank_samples},
                {"rank_engine_bytes", rank_engine_bytes},
                {"rank_peak_rss_bytes", rank_peak_rss_bytes}};
    if (!read.empty()) {
      j["mpi"]["read"] = read;
      j["mpi"]["cells_total"] = cells_total;
      j["mpi"]["rank_cells_read"] = rank_cells_read;
      j["mpi"]["rank_cells_kept"] = rank_cells_kept;
      j["mpi"]["rank_read_seconds"] = rank_read_seconds;
    }
  }
};

// UGVR_MPI_SLOW_RANK=R:SECONDS[:FILE] (the tests' slow rank): rank R starts drawing its part of a full-quality frame
// SECONDS late, asking `keep_going` (when the frame has one) every few milliseconds meanwhile, as an engine asks
// between the parts of a long frame. With FILE, only a frame that starts while FILE exists, which it removes first: a
// test creates FILE, and its disappearance tells the test that the held frame is under way.
void hold_if_slow_rank(const FrameRequest& request, const std::function<bool()>& keep_going) {
  const char* spec = std::getenv("UGVR_MPI_SLOW_RANK");
  if (!spec || !request.full_quality) return;
  const std::string text = spec;
  const size_t colon = text.find(':');
  if (colon == std::string::npos)
    fail_in("UGVR_MPI_SLOW_RANK", "\"" + text + "\" is not RANK:SECONDS or RANK:SECONDS:FILE");
  if (std::atoi(text.c_str()) != rank()) return;
  const size_t file_colon = text.find(':', colon + 1);
  const double seconds = std::atof(text.substr(colon + 1, file_colon - colon - 1).c_str());
  if (file_colon != std::string::npos && std::remove(text.substr(file_colon + 1).c_str()) != 0) return;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    if (keep_going && !keep_going()) throw FrameInterrupted();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

class MpiRenderer final : public Renderer {
 public:
  // `parts`: each rank holds only its part of the data (a .pvtu read by parts, a partitioned store's pieces); else
  // every rank holds the whole (a mesh read whole and restricted to the rank's box afterwards, a store).
  MpiRenderer(std::unique_ptr<Renderer> local, KdTree tree, ReadFigures read = {}, WholeMesh whole = {},
              bool parts = false)
      : local_(std::move(local)),
        tree_(std::move(tree)),
        read_(std::move(read)),
        whole_(std::move(whole)),
        parts_(parts) {
    nlohmann::json j;
    local_->describe(j);
    if (j.contains("engine_bytes") && j["engine_bytes"].is_number()) engine_bytes_ = j["engine_bytes"].get<double>();
  }
  ~MpiRenderer() override {
    if (stop_comm_ != MPI_COMM_NULL && active()) MPI_Comm_free(&stop_comm_);
  }
  MpiRenderer(const MpiRenderer&) = delete;
  MpiRenderer& operator=(const MpiRenderer&) = delete;
  std::string_view engine() const override { return local_->engine(); }
  std::string device() const override { return local_->device() + ", " + std::to_string(size()) + " MPI ranks"; }
  void set_field(std::string_view name) override { local_->set_field(name); }
  const std::string& field_name() const override { return local_->field_name(); }
  FieldRange field_range() const override {
    const auto it = whole_.ranges.find(local_->field_name());
    return it != whole_.ranges.end() ? it->second : local_->field_range();
  }
  Bounds bounds() const override { return whole_.bounds ? *whole_.bounds : local_->bounds(); }
  // The ranks MUST draw with one transfer function, and the default one is made from these counts: parts' counts are
  // summed over the ranks; where every rank holds the whole data, rank 0's are every rank's (the same numbers, but
  // broadcast so that nothing rank-local, a rank's restricted mesh say, can make them differ).
  std::vector<uint64_t> value_histogram(double lo, double hi, int bins) const override {
    std::vector<uint64_t> counts = local_->value_histogram(lo, hi, bins);
    // A rank without counts (a field its store does not hold) takes part with zeros, so the collective sizes agree.
    unsigned long long n = counts.size(), most = 0;
    MPI_Allreduce(&n, &most, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
    if (most == 0) return {};
    counts.resize(size_t(most), 0);
    std::vector<unsigned long long> buffer(counts.begin(), counts.end());
    if (parts_) {
      MPI_Allreduce(MPI_IN_PLACE, buffer.data(), int(most), MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    } else {
      MPI_Bcast(buffer.data(), int(most), MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
    }
    return std::vector<uint64_t>(buffer.begin(), buffer.end());
  }
  // The ranks MUST frame one camera: the boxes of the ranks' parts are united (min/max over the ranks); a rank that
  // cannot say takes part with an empty box, and when none can the answer is nullopt on every rank. Where every rank
  // holds the whole data the union is each rank's box (restricted meshes cover their boxes, and their union the mesh).
  //
  // The box is weighted (render/visible_bounds.h): the ranks' weights, each of the pieces its kd-tree box owns, binned
  // over the whole data's bounds, are added up (sum, min, max over contiguous ranges of VisibleWeights::flat), so
  // every rank gets one process's box. A renderer without weights on some rank: the ranks' boxes united, as before.
  std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const override {
    const Bounds over = bounds();
    std::vector<double> w = local_->visible_weights(tf, threshold, over, tree_.boxes[size_t(rank())]);
    int all_weigh = w.size() == VisibleWeights::kFlatSize ? 1 : 0;
    MPI_Allreduce(MPI_IN_PLACE, &all_weigh, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (all_weigh) {
      const int bins = int(VisibleWeights::kAxisBins), extent = bins + 3;
      MPI_Allreduce(MPI_IN_PLACE, w.data(), bins, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, w.data() + bins, extent, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, w.data() + bins + extent, extent, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
      return VisibleWeights::from_flat(over, w)->box();
    }
    const std::optional<Bounds> mine = local_->visible_bounds(tf, threshold);
    const Bounds b = mine.value_or(Bounds{});
    // lo and -hi reduced with MIN in one call: an empty box (+inf, -inf) leaves the others' as they are.
    double box[7] = {b.lo.x, b.lo.y, b.lo.z, -b.hi.x, -b.hi.y, -b.hi.z, mine ? 0.0 : 1.0};
    MPI_Allreduce(MPI_IN_PLACE, box, 7, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    if (box[6] != 0) return std::nullopt;  // no rank could say
    Bounds all;
    all.lo = {box[0], box[1], box[2]};
    all.hi = {-box[3], -box[4], -box[5]};
    return all;
  }
  void describe(nlohmann::json& j) const override {
    local_->describe(j);
    j["mpi_ranks"] = size();
  }
  std::string summary(const FrameStats& last) const override {
    const auto* s = dynamic_cast<const MpiFrameStats*>(last.detail.get());
    FrameStats local = last;
    local.detail = s ? s->rank0 : nullptr;
    std::string out = local_->summary(local);
    if (s)
      out += ", " + std::to_string(s->ranks) + " ranks (render " + std::to_string(s->render_seconds_min) + "-" +
             std::to_string(s->render_seconds_max) + " s, " + s->compositor + " " +
             std::to_string(s->composite_seconds) + " s)";
    return out;
  }

  Frame render(const FrameRequest& request) override {
    if (const char* fail = std::getenv("UGVR_MPI_FAIL_RANK"); fail && std::atoi(fail) == rank())
      fail_in("UGVR_MPI_FAIL_RANK", "rank " + std::to_string(rank()) + " fails on purpose");
    // A maximum intensity projection composes by the maximum of the ranks' values, not by blending their colours.
    if (request.settings.mode == RenderMode::Mip)
      throw OptionError("mode", "mip is not supported under MPI yet (ranks' maxima would need max compositing)");
    const auto t0 = std::chrono::steady_clock::now();
    FrameRequest mine = request;
    mine.settings.background = {0, 0, 0, 0};
    mine.settings.early_termination_opacity = 1;  // opacity in front of this box is unknown here
    mine.target_fps = 0;
    // The compositing needs every rank's part, so no rank stops its part alone: with keep_going the ranks agree
    // (mpi_frame_stop.h) and either all composite or all throw FrameInterrupted. Without it (`ugvr render`) nothing
    // of the agreement runs: the frame is exactly as before.
    std::optional<FrameStop> stop;
    if (request.keep_going) stop.emplace(stop_comm(), request.keep_going);
    mine.keep_going = nullptr;
    if (stop) mine.keep_going = [&stop] { return stop->keep_going(); };
    const double cpu0 = process_cpu_seconds();
    Frame local;
    try {
      hold_if_slow_rank(request, mine.keep_going);
      local = local_->render(mine);
    } catch (const FrameInterrupted&) {
      // Only rank 0's Stop (or the question that makes rank 0 say it) stops a part: the agreement below says Stop.
      if (!stop) throw;
    }
    if (stop && stop->agree_to_stop()) throw FrameInterrupted();
    const double cpu_seconds = process_cpu_seconds() - cpu0;
    const int width = request.settings.width, height = request.settings.height;
    if (local.image.width != width || local.image.height != height)
      fail_in("mpi", "a rank drew " + std::to_string(local.image.width) + "x" + std::to_string(local.image.height) +
                         ", not the requested size");
    double seconds[2] = {local.stats.seconds, -local.stats.seconds}, extremes[2] = {0, 0};
    MPI_Allreduce(seconds, extremes, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    unsigned long long samples = local.stats.samples, total_samples = 0;
    MPI_Allreduce(&samples, &total_samples, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);

    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);  // ru_maxrss in KiB on Linux
    constexpr int kFigures = 8;
    const double mine_figures[kFigures] = {local.stats.seconds,
                                           cpu_seconds,
                                           double(local.stats.samples),
                                           engine_bytes_,
                                           double(usage.ru_maxrss) * 1024.0,
                                           double(read_.cells_read),
                                           double(read_.cells_kept),
                                           read_.seconds};
    std::vector<double> all_figures(rank() == 0 ? kFigures * size_t(size()) : 0);
    MPI_Gather(mine_figures, kFigures, MPI_DOUBLE, all_figures.data(), kFigures, MPI_DOUBLE, 0, MPI_COMM_WORLD);

    const std::vector<int> order = tree_.visibility_order(request.camera);
    auto stats = std::make_shared<MpiFrameStats>();
    stats->ranks = size();
    stats->compositor = compositor_name();
    stats->render_seconds_max = extremes[0], stats->render_seconds_min = -extremes[1];
    stats->rank0 = local.stats.detail;
    for (size_t i = 0; i < all_figures.size(); i += kFigures) {
      stats->rank_render_seconds.push_back(all_figures[i]);
      stats->rank_render_cpu_seconds.push_back(all_figures[i + 1]);
      stats->rank_samples.push_back(all_figures[i + 2]);
      stats->rank_engine_bytes.push_back(all_figures[i + 3]);
      stats->rank_peak_rss_bytes.push_back(all_figures[i + 4]);
      stats->rank_cells_read.push_back(all_figures[i + 5]);
      stats->rank_cells_kept.push_back(all_figures[i + 6]);
      stats->rank_read_seconds.push_back(all_figures[i + 7]);
    }
    stats->read = read_.how;
    stats->cells_total = read_.cells_total;
    std::vector<float> blended = composite(premultiplied(local.image), width, height, order, &stats->composite_seconds);

    Frame frame;
    frame.stats = local.stats;
    frame.stats.samples = total_samples;
    frame.stats.detail = stats;
    if (rank() == 0) frame.image = apply_background(blended, width, height, request.settings.background);
    frame.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return frame;
  }

 private:
  std::unique_ptr<Renderer> local_;
  KdTree tree_;
  ReadFigures read_;
  WholeMesh whole_;
  bool parts_ = false;
  double engine_bytes_ = 0;
  // The frames' stop agreement talks on a communicator of its own (MPI_Comm_dup of the world, on the first frame that
  // has keep_going: every rank gets that frame), so that no other message or collective can match its own.
  MPI_Comm stop_comm_ = MPI_COMM_NULL;
  MPI_Comm stop_comm() {
    if (stop_comm_ == MPI_COMM_NULL) MPI_Comm_dup(MPI_COMM_WORLD, &stop_comm_);
    return stop_comm_;
  }
};

// An input read by parts on several ranks (a .pvtu, Exodus: part_source.h): each rank reads only the pieces it owns,
// keeps the cells its box needs (mpi_part_read.h) and draws its part, clipped to its box, as the whole-read path's
// restrict_to_box does; the whole mesh's bounds and ranges come from the read.
std::unique_ptr<Renderer> open_part(const PartSource& source, RendererOptions options, OpenedInput* opened,
                                    std::vector<std::string>& fields) {
  const auto t0 = std::chrono::steady_clock::now();
  PartRead part = read_part(source, options.field, 4);
  fields = part.fields;
  if (options.field.empty() && !fields.empty()) options.field = fields.front();
  // The viewer's histograms are counted from this: a part here, so the viewer reads whole meshes (MeshRead::Whole).
  if (opened) opened->warnings = part.dataset->warnings, opened->dataset = part.dataset;
  auto scene = std::make_shared<ExactScene>(part.dataset, options.progress);
  scene->engine.set_clip_box(part.tree.boxes[size_t(rank())]);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ReadFigures figures{part.source, part.cells_total, part.cells_read, part.cells_kept, seconds};
  WholeMesh whole{part.bounds, std::move(part.ranges)};
  return std::make_unique<MpiRenderer>(make_renderer(scene, options), std::move(part.tree), figures, std::move(whole),
                                       true);
}

}  // namespace

std::unique_ptr<Renderer> open_renderer(const std::vector<std::string>& inputs, const ReadOptions& read,
                                        RendererOptions options, OpenedInput* opened, std::vector<std::string>* fields,
                                        MeshRead mesh_read) {
  std::vector<std::string> unused;
  if (!fields) fields = &unused;
  if (options.interactive) throw OptionError("fps", "interactive rendering (--fps, --path) is not supported under MPI");
  if (inputs.size() == 1 && is_piece_index(inputs[0])) {
    // A partitioned store: rank r of R draws the kd subtree of pieces [r N/R, (r+1) N/R), whose union is a box, and
    // the ranks composite in the order of the tree cut above those subtrees.
    const PieceIndex index = read_piece_index(inputs[0]);
    for (const BrickStoreField& f : index.fields) fields->push_back(f.name);
    const int n = index.count(), ranks = size();
    if (n % ranks != 0 || (ranks & (ranks - 1)) != 0)
      fail_in(inputs[0], std::to_string(ranks) + " ranks cannot share its " + std::to_string(n) +
                             " pieces: the rank count must be a power of two that divides the piece count");
    KdTree ranks_tree = group_tree(index.tree, ranks);
    std::vector<int> mine;
    for (int k = rank() * (n / ranks); k < (rank() + 1) * (n / ranks); ++k) mine.push_back(k);
    return std::make_unique<MpiRenderer>(open_piece_renderer(index, std::move(mine), options), std::move(ranks_tree),
                                         ReadFigures{}, WholeMesh{}, true);
  }
  const bool store = inputs.size() == 1 && is_brick_store(inputs[0]);
  const bool lod = options.engine == "lod" || (options.engine == "auto" && store);
  if (lod) {
    if (!store) throw OptionError("engine", "the lod engine renders one brick store (.ugvr, made by `ugvr build`)");
    auto gl = std::shared_ptr<GlContext>();
    try {
      gl = std::make_shared<GlContext>(options.gpu);
    } catch (const Error& e) {
      throw OptionError("gpu", e.what());
    }
    auto scene = std::make_shared<LodScene>(inputs[0], std::move(gl), options.lod);
    // Balanced by the octree's leaves: they are small where the data is detailed, so equal counts are about equal
    // numbers of bricks to draw.
    const BrickStoreReader& reader = scene->engine.store();
    for (const BrickStoreField& f : reader.layout().fields) fields->push_back(f.name);
    std::vector<Vec3d> centres;
    for (uint64_t n = 0; n < reader.nodes().size(); ++n)
      if (reader.nodes()[n].is_leaf()) centres.push_back(reader.bounds(n).center());
    KdTree tree = build_kd_tree(std::move(centres), size());
    scene->engine.set_clip_box(tree.boxes[size_t(rank())]);
    return std::make_unique<MpiRenderer>(make_renderer(scene, options), std::move(tree));
  }
  if (store) throw OptionError("engine", "a brick store (.ugvr) renders with the lod engine");
  if (options.device == "gpu") throw OptionError("device", "under MPI the exact engine renders on the CPU");
  options.device = "cpu";
  const char* whole = std::getenv("UGVR_MPI_WHOLE_MESH");
  const bool whole_mesh = whole && std::string_view(whole) == "1";
  if (size() > 1 && !whole_mesh && mesh_read == MeshRead::PartWherePossible && inputs.size() == 1)
    if (const std::unique_ptr<PartSource> source = open_part_source(inputs[0], read, size()))
      return open_part(*source, std::move(options), opened, *fields);
  const auto t0 = std::chrono::steady_clock::now();
  auto dataset = std::make_shared<Dataset>(read_dataset(inputs, read));
  if (opened) opened->warnings = dataset->warnings, opened->dataset = dataset;
  if (!dataset->blocks.empty()) *fields = default_field_names(dataset->blocks[0], 4);
  if (options.field.empty() && !fields->empty()) options.field = fields->front();
  auto scene = std::make_shared<ExactScene>(std::move(dataset), options.progress);
  ReadFigures figures{"whole", scene->engine.cell_count(), scene->engine.cell_count(), 0, 0};
  KdTree tree = build_kd_tree(cell_centroids(scene->engine.walk_mesh()), size());
  // Each rank keeps only the cells that meet its box: its rays enter at its part's faces instead of walking the
  // cells in front of the box (and the rank holds about 1/N of the walk mesh). The tree above is built from the whole
  // mesh first, identically on every rank. One rank keeps all (its box is infinite), as before. UGVR_MPI_WHOLE_MESH=1
  // keeps the whole mesh on every rank (the clip box alone): the benchmark's baseline (bench/run_mpi_exact.sh).
  if (size() > 1 && !whole_mesh)
    scene->engine.restrict_to_box(tree.boxes[size_t(rank())]);
  else
    scene->engine.set_clip_box(tree.boxes[size_t(rank())]);
  figures.cells_kept = scene->engine.cell_count();
  figures.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return std::make_unique<MpiRenderer>(make_renderer(scene, options), std::move(tree), figures);
}

}  // namespace ugvr::mpi
