#include "ugvr/octree/builder.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <unordered_set>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/octree/boundary_faces.h"
#include "ugvr/octree/build_parts.h"
#include "ugvr/octree/data_points.h"
#include "ugvr/octree/downsample.h"
#include "ugvr/octree/node_cells.h"
#include "ugvr/octree/node_error.h"
#include "ugvr/octree/split.h"
#include "ugvr/octree/step_loader.h"
#include "ugvr/octree/subdivide.h"
#include "ugvr/octree/time_steps.h"
#include "ugvr/store/brick_pad.h"

namespace ugvr {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Pass 2: the bricks, bottom-up. process(id) returns the node's brick (padded), its data points and its error, for
// its parent; the node's blocks are in the store by then.
class BrickPass {
 public:
  struct Result {
    BrickSamples brick;
    std::vector<uint64_t> points;    // data points inside the node, sorted
    std::vector<FieldError> errors;  // per field, monotone over the subtree
  };

  BrickPass(OctreeShape& shape, const BrickLattice& lattice, const BrickSampler& sampler, const OctreeDataPoints& data,
            std::span<const BrickStoreField> fields, bool tf_errors, BrickStoreWriter& writer, Progress& progress,
            const std::atomic<bool>* cancel, bool keep_cells = false)
      : tf_errors_on_(tf_errors),
        keep_cells_(keep_cells),
        shape_(shape),
        fields_(fields),
        lattice_(lattice),
        sampler_(sampler),
        data_(data),
        writer_(writer),
        cancel_(cancel),
        progress_(progress),
        F_(uint32_t(data.field_count())),
        errors_(shape.nodes.size() * F_),
        tf_errors_(tf_errors ? shape.nodes.size() * F_ : 0) {}

  std::unique_ptr<Result> process(uint64_t id) {
    if (cancel_ && cancel_->load(std::memory_order_relaxed)) throw Error("octree build cancelled");
    const OctreeNode node = shape_.nodes[id];
    const std::array<uint32_t, 3> ijk{node.i, node.j, node.k};
    const Bounds box = lattice_.node_box(node.level, ijk);
    auto r = std::make_unique<Result>();
    std::vector<ErrorSum> sums(F_);
    std::vector<ErrorHistogram> pairs;  // for the transfer-function error table
    if (tf_errors_on_) {
      pairs.reserve(F_);
      for (uint32_t f = 0; f < F_; ++f) pairs.emplace_back(fields_[f].min, fields_[f].max);
      for (uint32_t f = 0; f < F_; ++f) sums[f].pairs = &pairs[f];
    }
    if (node.is_leaf()) {
      std::vector<uint64_t>& cells = shape_.leaf_cells[id];
      const auto t0 = std::chrono::steady_clock::now();
      BrickSamplerStats st;
      sampler_.sample(lattice_, node.level, ijk, cells, scratch_.local(), r->brick, &st);
      sampler_ns_ += uint64_t(seconds_since(t0) * 1e9);
      leaf_samples_ += st.samples;
      valid_samples_ += r->brick.valid;
      data_.points_inside(cells, box, r->points);
      // No longer needed (unless the next time step samples them too): keeps memory to the subtrees in progress.
      if (!keep_cells_) std::vector<uint64_t>().swap(cells);
      pad_brick(r->brick.resolution, F_, r->brick.values.data(), r->brick.mask.data());
      measure_against_points(r->brick, box, data_, r->points, sums);
      for (const ErrorSum& s : sums) r->errors.push_back(s.result());
    } else {
      std::array<std::unique_ptr<Result>, 8> kids;
      tbb::task_group group;
      uint64_t child = node.first_child;
      for (int o = 0; o < 8; ++o) {
        if (!(node.child_mask >> o & 1)) continue;
        group.run([this, &kids, o, child] { kids[size_t(o)] = process(child); });
        ++child;
      }
      group.wait();
      std::array<const BrickSamples*, 8> bricks{};
      size_t point_count = 0;
      for (int o = 0; o < 8; ++o) {
        if (!kids[size_t(o)]) continue;
        bricks[size_t(o)] = &kids[size_t(o)]->brick;
        point_count += kids[size_t(o)]->points.size();
      }
      downsample_children(lattice_.resolution, F_, bricks, r->brick);
      // A data point in this node lies in some child's closed box, which its cell overlaps: the union of the
      // children's points is the node's own set.
      r->points.reserve(point_count);
      for (const auto& k : kids)
        if (k) r->points.insert(r->points.end(), k->points.begin(), k->points.end());
      std::sort(r->points.begin(), r->points.end());
      r->points.erase(std::unique(r->points.begin(), r->points.end()), r->points.end());
      pad_brick(r->brick.resolution, F_, r->brick.values.data(), r->brick.mask.data());
      measure_against_children(r->brick, bricks, sums);
      measure_against_points(r->brick, box, data_, r->points, sums);
      add_interior_node_errors(sums, kids, r->errors);
    }
    write_node_brick(writer_, id, r->brick, F_);
    std::copy(r->errors.begin(), r->errors.end(), errors_.begin() + ptrdiff_t(id * F_));
    for (uint32_t f = 0; f < F_ && tf_errors_on_; ++f) {
      tf_errors_[id * F_ + f] = make_tf_error_entry(pairs[f], fields_[f].min, fields_[f].max);
    }
    bricks_ += r->brick.valid > 0;
    progress_.add(1);
    return r;
  }

  const std::vector<FieldError>& errors() const { return errors_; }
  const std::vector<store_format::TfErrorEntry>& tf_errors() const { return tf_errors_; }
  uint64_t leaf_samples() const { return leaf_samples_; }
  uint64_t valid_samples() const { return valid_samples_; }
  uint64_t bricks() const { return bricks_; }
  double sampler_seconds() const { return double(sampler_ns_) * 1e-9; }

 private:
  bool tf_errors_on_;
  bool keep_cells_;
  OctreeShape& shape_;
  std::span<const BrickStoreField> fields_;
  const BrickLattice& lattice_;
  const BrickSampler& sampler_;
  const OctreeDataPoints& data_;
  BrickStoreWriter& writer_;
  const std::atomic<bool>* cancel_;
  Progress& progress_;
  uint32_t F_;
  std::vector<FieldError> errors_;                     // node x field; each node writes its own entries
  std::vector<store_format::TfErrorEntry> tf_errors_;  // likewise
  tbb::enumerable_thread_specific<BrickScratch> scratch_;
  std::atomic<uint64_t> leaf_samples_{0}, valid_samples_{0}, bricks_{0}, sampler_ns_{0};
};

// A node's place in the tree, (level, i, j, k): what the time steps' trees are merged by.
struct NodeKey {
  uint32_t level, i, j, k;
  bool operator==(const NodeKey&) const = default;
};
struct NodeKeyHash {
  size_t operator()(const NodeKey& n) const {
    uint64_t h = n.level;
    for (uint32_t v : {n.i, n.j, n.k}) h = (h ^ v) * 0x100000001b3ull;
    return size_t(h ^ (h >> 29));
  }
};
NodeKey key_of(const OctreeNode& n) { return {n.level, n.i, n.j, n.k}; }

}  // namespace

Bounds octree_root(const Bounds& data) {
  const Vec3d size = data.size();
  const double side = std::max(size.x, std::max(size.y, size.z));
  Bounds root;
  root.lo = data.lo;
  root.hi = data.lo + Vec3d{side, side, side};
  return root;
}

int deepest_level(const OctreeBuildOptions& options) {
  if (!options.leaf_cells || options.max_leaf_cells == 0) return options.max_depth;
  return std::min(options.max_depth + kLeafCellsExtraDepth, kMaxOctreeLevel);
}

void validate_build_options(const OctreeBuildOptions& o) {
  if (o.resolution < kMinBrickResolution || o.resolution > kMaxBrickResolution) {
    throw Error("--brick must be between " + std::to_string(kMinBrickResolution) + " and " +
                std::to_string(kMaxBrickResolution) + " (got " + std::to_string(o.resolution) + ")");
  }
  if (o.max_depth < 0 || o.max_depth > kMaxOctreeLevel) {
    throw Error("--max-depth must be between 0 and " + std::to_string(kMaxOctreeLevel) + " (got " +
                std::to_string(o.max_depth) + ")");
  }
  if (!(o.error >= 0) || !std::isfinite(o.error)) {
    throw Error("--error must be a finite number >= 0 (got " + std::to_string(o.error) + ")");
  }
  if (o.threads < 0) throw Error("--threads must be >= 0 (got " + std::to_string(o.threads) + ")");
}

OctreeBuildStats build_octree(const OctreeInput& input, const OctreeBuildOptions& options, const std::string& path) {
  validate_build_options(options);
  const auto start = std::chrono::steady_clock::now();
  std::optional<tbb::global_control> threads;
  if (options.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));

  const UnstructuredMesh& mesh = *input.mesh;
  BrickLattice lattice;
  lattice.root = octree_root(input.bounds);
  lattice.resolution = options.resolution;
  const OctreeDataPoints data(mesh, input.scalars);
  const SplitTest split(data, input.fields, options.error, options.resolution);

  OctreeBuildStats stats;
  stats.cells = mesh.cell_count();
  const BrickSampler sampler(mesh, input.scalars, options.sampler);
  std::optional<InterpolantCheck> interpolant;
  if (options.error > 0) interpolant.emplace(data, sampler, lattice, split.thresholds());
  OctreeShape shape;
  {
    Progress progress("subdivide", uint64_t(deepest_level(options)) + 1, options.progress);
    shape = subdivide_octree(mesh, lattice, split, options.max_depth, &progress, interpolant ? &*interpolant : nullptr,
                             options.leaf_cells ? options.max_leaf_cells : 0, deepest_level(options));
  }
  stats.subdivide_seconds = seconds_since(start);
  count_tree_shape(shape.nodes, stats);
  // The face topology, when the leaves keep their cells: built once for them and the boundary faces.
  std::optional<MeshTopology> topology;
  if (options.leaf_cells) topology.emplace(build_topology(mesh));

  const BrickStoreLayout layout = store_layout(options, input.fields, lattice.root, input.bounds, false);
  BrickStoreWriter writer(path, layout);
  if (options.leaf_cells) {
    // Before the bricks, which drop each leaf's cell list once sampled.
    const auto cells_start = std::chrono::steady_clock::now();
    const LeafCellStats cs = write_leaf_cells(writer, mesh, *topology, input.scalars, shape.nodes, shape.leaf_cells);
    stats.cell_blocks = cs.blocks;
    stats.leaf_cells = cs.cells;
    stats.cell_bytes = cs.bytes;
    stats.cell_seconds = seconds_since(cells_start);
  }
  const auto bricks_start = std::chrono::steady_clock::now();
  {
    Progress progress("bricks", stats.nodes, options.progress);
    if (options.cancel && options.cancel->load()) throw Error("octree build cancelled");
    BrickPass pass(shape, lattice, sampler, data, input.fields, options.tf_errors, writer, progress, options.cancel);
    pass.process(0);
    stats.leaf_samples = pass.leaf_samples();
    stats.valid_samples = pass.valid_samples();
    stats.bricks = pass.bricks();
    stats.sampler_seconds = pass.sampler_seconds();
    BoundaryFaceStats bst;
    const StoreBoundary boundary = store_boundary_faces(
        mesh, lattice.root, shape.nodes, options.boundary_faces_per_node, &bst, topology ? &*topology : nullptr);
    stats.boundary_bytes = boundary.bytes();
    stats.boundary_triangles = bst.triangles;
    stats.boundary_overflow_nodes = bst.overflow_nodes;
    stats.boundary_seconds = bst.seconds;
    writer.commit(shape.nodes, pass.errors(), pass.tf_errors(), &boundary);
  }
  stats.brick_seconds = seconds_since(bricks_start);
  stats.store_bytes = std::filesystem::file_size(path);
  if (options.tf_errors)
    stats.tf_error_table_bytes = stats.nodes * layout.fields.size() * sizeof(store_format::TfErrorEntry);
  stats.seconds = seconds_since(start);
  return stats;
}

}  // namespace ugvr

namespace ugvr {

OctreeBuildStats build_octree_steps(const TimeSeries& series, std::span<const uint32_t> steps,
                                    std::span<const std::string> selectors, const OctreeBuildOptions& options,
                                    const std::string& path) {
  validate_build_options(options);
  check_step_selection(series, steps);
  const auto start = std::chrono::steady_clock::now();
  std::optional<tbb::global_control> threads;
  if (options.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));
  const size_t S = steps.size();
  OctreeBuildStats stats;
  stats.time_steps = uint32_t(S);
  auto step_name = [&](size_t k) { return step_label(series, steps, k); };
  // One step's dataset (the first read whole, later ones' fields read onto its mesh where their files hold it:
  // octree/step_loader.h) and what the builder takes from it.
  struct Loaded {
    const Dataset* dataset = nullptr;
    OctreeInput input;
  };
  StepDatasetLoader loader(series, steps, options.whole_step_reads);
  std::vector<std::string> names(selectors.begin(), selectors.end());
  auto load = [&](size_t k, Loaded& out) {
    out = {};
    const auto t0 = std::chrono::steady_clock::now();
    {
      Progress progress(step_name(k) + ": read", 1, options.progress);
      out.dataset = &loader.load(k);
      progress.finish();
    }
    out.input = prepare_octree_input(*out.dataset, names);
    if (names.empty())  // the fields the first step picked, kept for every step (a field constant at first stays)
      for (const BrickStoreField& fd : out.input.fields) names.push_back(fd.name);
    stats.read_seconds += seconds_since(t0);
  };

  Loaded cur;
  std::vector<std::vector<store_format::StepFieldRange>> ranges(S);
  auto keep_ranges = [&](size_t k) {
    for (const BrickStoreField& fd : cur.input.fields) ranges[k].push_back({fd.min, fd.max});
  };
  BrickLattice lattice;
  lattice.resolution = options.resolution;
  OctreeShape shape;
  Bounds bounds;
  // Pass 1 (--error > 0): every step's own tree, merged: a node splits in the union where it is interior in any
  // step's tree. At --error 0 the split rule is geometric (octree/split.h): one tree serves every step.
  const auto subdivide_start = std::chrono::steady_clock::now();
  std::unordered_set<NodeKey, NodeKeyHash> interior;
  const size_t shape_steps = options.error > 0 ? S : 1;
  for (size_t k = 0; k < shape_steps; ++k) {
    load(k, cur);
    keep_ranges(k);
    if (k == 0) {
      bounds = cur.input.bounds;
      lattice.root = octree_root(bounds);
    }
    const OctreeDataPoints data(*cur.input.mesh, cur.input.scalars);
    const SplitTest split(data, cur.input.fields, options.error, options.resolution);
    const BrickSampler sampler(*cur.input.mesh, cur.input.scalars, options.sampler);
    std::optional<InterpolantCheck> interpolant;
    if (options.error > 0) interpolant.emplace(data, sampler, lattice, split.thresholds());
    Progress progress(step_name(k) + ": subdivide", uint64_t(deepest_level(options)) + 1, options.progress);
    OctreeShape own = subdivide_octree(*cur.input.mesh, lattice, split, options.max_depth, &progress,
                                       interpolant ? &*interpolant : nullptr,
                                       options.leaf_cells ? options.max_leaf_cells : 0, deepest_level(options));
    if (k == 0) stats.first_step_nodes = own.nodes.size();
    if (shape_steps == 1) {
      shape = std::move(own);
    } else {
      for (const OctreeNode& n : own.nodes)
        if (!n.is_leaf()) interior.insert(key_of(n));
    }
  }
  if (shape_steps > 1) {
    Progress progress("union of the steps' trees", uint64_t(deepest_level(options)) + 1, options.progress);
    shape = subdivide_octree_where(
        *cur.input.mesh, lattice, deepest_level(options),
        [&](const OctreeNode& n) { return interior.count(key_of(n)) != 0; }, &progress);
    std::unordered_set<NodeKey, NodeKeyHash>().swap(interior);
  }
  stats.subdivide_seconds = seconds_since(subdivide_start);
  stats.cells = cur.input.mesh->cell_count();
  count_tree_shape(shape.nodes, stats);

  // The layout with the first step's ranges; each step sets its own (begin_step) and the header gets their union.
  BrickStoreLayout layout = store_layout(options, cur.input.fields, lattice.root, bounds, false);
  for (size_t k = 0; k < S; ++k) layout.times.push_back(series.steps[steps[k]].time);
  BrickStoreWriter writer(path, layout);
  std::optional<MeshTopology> topology;
  StoreBoundary boundary;
  const auto bricks_start = std::chrono::steady_clock::now();
  // Pass 2: each step's bricks on the shared tree. The step still loaded (the last of pass 1) is not read again when
  // it is the one needed.
  size_t loaded = shape_steps - 1;
  for (size_t k = 0; k < S; ++k) {
    if (k != loaded) {
      load(k, cur);
      if (ranges[k].empty()) keep_ranges(k);
      loaded = k;
    }
    const UnstructuredMesh& mesh = *cur.input.mesh;
    if (k == 0) {
      // Shared by every step: the boundary faces and the leaves' cells (with the first step's values) of the first
      // step's mesh.
      if (options.leaf_cells) {
        topology.emplace(build_topology(mesh));
        const auto cells_start = std::chrono::steady_clock::now();
        const LeafCellStats cs =
            write_leaf_cells(writer, mesh, *topology, cur.input.scalars, shape.nodes, shape.leaf_cells);
        stats.cell_blocks = cs.blocks;
        stats.leaf_cells = cs.cells;
        stats.cell_bytes = cs.bytes;
        stats.cell_seconds = seconds_since(cells_start);
      }
      BoundaryFaceStats bst;
      boundary = store_boundary_faces(mesh, lattice.root, shape.nodes, options.boundary_faces_per_node, &bst,
                                      topology ? &*topology : nullptr);
      stats.boundary_bytes = boundary.bytes();
      stats.boundary_triangles = bst.triangles;
      stats.boundary_overflow_nodes = bst.overflow_nodes;
      stats.boundary_seconds = bst.seconds;
    }
    writer.begin_step(uint32_t(k), ranges[k]);
    if (k > 0 && options.leaf_cells) {
      // A later step's values of the leaves' cells, before the pass drops the leaves' cell lists.
      const auto cells_start = std::chrono::steady_clock::now();
      stats.cell_bytes += write_leaf_cell_values(writer, mesh, cur.input.scalars, shape.nodes, shape.leaf_cells).bytes;
      stats.cell_seconds += seconds_since(cells_start);
    }
    const OctreeDataPoints data(mesh, cur.input.scalars);
    const BrickSampler sampler(mesh, cur.input.scalars, options.sampler);
    Progress progress(step_name(k) + ": bricks", stats.nodes, options.progress);
    if (options.cancel && options.cancel->load()) throw Error("octree build cancelled");
    BrickPass pass(shape, lattice, sampler, data, cur.input.fields, options.tf_errors, writer, progress, options.cancel,
                   /*keep_cells=*/k + 1 < S);
    pass.process(0);
    progress.finish();
    if (k == 0) {
      stats.leaf_samples = pass.leaf_samples();
      stats.valid_samples = pass.valid_samples();
      stats.bricks = pass.bricks();
    }
    stats.sampler_seconds += pass.sampler_seconds();
    writer.end_step(pass.errors(), pass.tf_errors());
  }
  writer.commit(shape.nodes, {}, {}, &boundary);
  stats.fields_only_reads = loader.fields_only_reads();
  stats.whole_reads = loader.whole_reads();
  stats.brick_seconds = seconds_since(bricks_start);
  stats.store_bytes = std::filesystem::file_size(path);
  if (options.tf_errors)
    stats.tf_error_table_bytes = S * stats.nodes * layout.fields.size() * sizeof(store_format::TfErrorEntry);
  stats.seconds = seconds_since(start);
  return stats;
}

}  // namespace ugvr
