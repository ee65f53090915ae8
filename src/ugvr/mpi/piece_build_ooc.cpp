#include "ugvr/mpi/piece_build_ooc.h"

#include <algorithm>
#include <chrono>
#include <filesystem>

#include "ugvr/core/error.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/piece_record.h"
#include "ugvr/octree/build_parts.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/octree/vtu_cells.h"

namespace ugvr {

OutOfCorePiecePlan plan_pieces_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                           int pieces, uint32_t resolution, int ghost_level, uint64_t memory_budget,
                                           const Progress::Observer& observer) {
  const auto t0 = std::chrono::steady_clock::now();
  check_piece_count(pieces);
  VtuCellSource source(vtu_path, selectors);
  OutOfCorePiecePlan out;
  out.plan = plan_frame(source.bounds(), resolution, ghost_level);
  // The points of the sampled cells' corners are found a slice at a time, within the share the soup's points get.
  const uint64_t point_budget = soup_point_budget(memory_budget);
  std::vector<Vec3d> samples;
  {
    Progress progress("kd split sample", source.file_cell_count(), observer);
    out.cells = source.for_each_sampled_cell(
        split_sample_stride(source.file_cell_count()), point_budget, &progress,
        [&](uint64_t, CellType, std::span<const Vec3f> corners) { samples.push_back(centroid_of(corners)); });
  }
  out.split_samples = samples.size();
  out.plan.tree = build_kd_tree(std::move(samples), pieces);
  out.plan.cells.assign(size_t(pieces), 0);
  out.plan.ghost_cells.assign(size_t(pieces), 0);
  out.fields = source.fields();  // the cell fields' ranges are known after the pass over the cells
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

OctreeBuildStats build_piece_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                         OutOfCorePiecePlan& plan, int k, const OctreeBuildOptions& options,
                                         uint64_t memory_budget, const std::string& path) {
  if (k < 0 || k >= plan.plan.tree.parts()) throw Error("internal: piece " + std::to_string(k) + " is not in the plan");
  OutOfCoreSubset subset;
  subset.name = "piece " + std::to_string(k);
  subset.bounds = plan.plan.bounds;
  subset.fields = plan.fields;
  uint64_t held = 0, owned = 0;
  subset.keep = [&](const VtuCellSource::StreamedCell& c) {
    const std::span<const Vec3f> corners(c.positions, size_t(c.n));
    Bounds b;
    for (const Vec3f& p : corners) b.add(to_double(p));
    if (!piece_holds(plan.plan, k, b)) return false;
    ++held;
    // A cell whose centroid lies in the box meets it: the owned cells are among the held ones.
    owned += plan.plan.tree.part_of(centroid_of(corners)) == k;
    return true;
  };
  const OctreeBuildStats stats = build_octree_out_of_core(vtu_path, selectors, options, memory_budget, path, subset);
  plan.plan.cells[size_t(k)] = owned;
  plan.plan.ghost_cells[size_t(k)] = held - owned;
  return stats;
}

PieceIndex build_index_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors, int pieces,
                                   int ghost_level, OctreeBuildOptions options, uint64_t memory_budget,
                                   const std::string& index_path, const Progress::Observer& progress,
                                   const BuildWarning& warn) {
  // Steps: the plan, then each piece.
  const double steps = double(pieces) + 1;
  auto report = [&](double step, const std::string& what, double fraction) {
    if (progress) progress(what, (step + std::clamp(fraction, 0.0, 1.0)) / steps);
  };
  // Without `progress` the steps report as they do alone (core/progress.h).
  Progress::Observer plan_progress;
  if (progress) plan_progress = [&](const std::string& label, double f) { report(0, "planning: " + label, f); };
  OutOfCorePiecePlan plan = plan_pieces_out_of_core(vtu_path, selectors, pieces, options.resolution, ghost_level,
                                                    memory_budget, plan_progress);
  std::filesystem::create_directories(piece_folder(index_path));
  options.inputs = {vtu_path};
  const std::string provenance = store_layout(options, {}, plan.plan.root, plan.plan.bounds, true).provenance;
  const std::string input_path = std::filesystem::weakly_canonical(vtu_path).string();
  const std::vector<std::string> fields(selectors.begin(), selectors.end());
  for (int k = 0; k < pieces; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string path =
        (std::filesystem::path(index_path).parent_path() / piece_store_name(index_path, k)).string();
    PieceRecord record = planned_piece_record(plan.plan, k, input_path, provenance, fields);
    std::string why;
    if (const std::optional<PieceRecord> kept = kept_piece(path, record, &why)) {
      plan.plan.cells[size_t(k)] = kept->cells;
      plan.plan.ghost_cells[size_t(k)] = kept->ghost_cells;
      report(1 + k, "piece " + std::to_string(k + 1) + " of " + std::to_string(pieces) + ": kept", 1);
      continue;
    }
    const std::string name = "piece " + std::to_string(k + 1) + " of " + std::to_string(pieces) + ": ";
    if (progress)
      options.progress = [&, name, k](const std::string& label, double f) { report(1 + k, name + label, f); };
    const OctreeBuildStats s = build_piece_out_of_core(vtu_path, selectors, plan, k, options, memory_budget, path);
    if (warn && !s.boundary_note.empty()) warn(name + s.boundary_note);
    record.cells = plan.plan.cells[size_t(k)];
    record.ghost_cells = plan.plan.ghost_cells[size_t(k)];
    record.nodes = s.nodes;
    record.store_bytes = std::filesystem::file_size(path);
    record.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    write_piece_record(path, record);
  }
  const PieceIndex index = make_piece_index(plan.fields, plan.plan, index_path, options.resolution);
  write_piece_index(index_path, index);
  return index;
}

}  // namespace ugvr
