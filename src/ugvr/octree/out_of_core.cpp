#include "ugvr/octree/out_of_core.h"

#include <tbb/concurrent_vector.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/core/temp_files.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/grid/topology.h"
#include "ugvr/octree/build_parts.h"
#include "ugvr/octree/cell_box_overlap.h"
#include "ugvr/octree/coarse_preview.h"
#include "ugvr/octree/data_points.h"
#include "ugvr/octree/downsample.h"
#include "ugvr/octree/leaf_points.h"
#include "ugvr/octree/node_cells.h"
#include "ugvr/octree/node_error.h"
#include "ugvr/octree/point_sketch.h"
#include "ugvr/octree/soup_boundary.h"
#include "ugvr/octree/split.h"
#include "ugvr/octree/step_values.h"
#include "ugvr/octree/time_steps.h"
#include "ugvr/octree/vtu_cells.h"
#include "ugvr/store/brick_pad.h"

namespace ugvr {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Where a leaf's records come from over the steps of a store with time. A single-step build, and the first step,
// route them down from the root; the first of several steps keeps each leaf's file (its records as routed) as
// "leaf-<id>" in the scratch folder, and every later step takes a leaf's records from that file with its own values
// put in (octree/step_values.h), the tree given: no interior node streams anything then.
struct StepLeaves {
  bool keep = false;                   // the first of several steps: keep each leaf's file
  const StepValues* values = nullptr;  // a later step: each leaf from its kept file with these values
  SoupLayout kept_layout;              // a later step: the kept files' (the first step's)
  bool last = false;                   // the last step: each kept file removed once its leaf is done
};

std::string kept_leaf_path(const std::filesystem::path& temp, uint64_t id) {
  return (temp / ("leaf-" + std::to_string(id))).string();
}

// Per-thread scratch: the split test's table, the sampler's, and a one-cell mesh for the flatness test.
struct Scratch {
  VoxelSpread table;
  BrickScratch sampler;
  UnstructuredMesh one_cell;
  std::vector<float> values;
};

class OutOfCoreBuild {
 public:
  struct Result {
    BrickSamples brick;
    std::vector<FieldError> errors;
  };

  // `tree` empty: the tree is shaped by the split rule as the cells stream through (node ids given at split time);
  // else the tree to fill (a store's later time steps: the first step's tree, ids and all), whose leaves' records
  // are the first step's with `leaves.values` put in.
  OutOfCoreBuild(const OctreeBuildOptions& options, const VtuCellSource& source, const BrickLattice& lattice,
                 BrickStoreWriter& writer, const std::filesystem::path& temp, size_t preload_bytes, Progress& progress,
                 std::span<const uint64_t> boundary_faces, std::span<const OctreeNode> tree = {},
                 StepLeaves leaves = {})
      : o_(options),
        layout_(source.layout()),
        slots_(source.slots()),
        fields_(source.fields()),
        lattice_(lattice),
        writer_(writer),
        temp_(temp),
        preload_bytes_(preload_bytes),
        progress_(progress),
        boundary_faces_(boundary_faces),
        F_(uint32_t(fields_.size())),
        fixed_tree_(!tree.empty()),
        leaves_(leaves) {
    if (fixed_tree_ != (leaves_.values != nullptr))
      throw Error("internal: a given tree is filled from kept leaves and a step's values, nothing else");
    for (const BrickStoreField& f : fields_) thresholds_.push_back(o_.error * (f.max - f.min));
    if (fixed_tree_) {
      nodes_.assign(tree.begin(), tree.end());
    } else {
      nodes_.push_back(OctreeNode{});
    }
    errors_.grow_to_at_least(nodes_.size() * F_);
    tf_errors_.grow_to_at_least(nodes_.size() * F_);
  }

  // `input`: the node's records routed from its parent; for a later step's leaf, its kept file (a later step's
  // interior node reads nothing).
  std::unique_ptr<Result> process(uint64_t id, const std::string& input) {
    const OctreeNode node = nodes_[id];
    const std::array<uint32_t, 3> ijk{node.i, node.j, node.k};
    const Bounds box = lattice_.node_box(node.level, ijk);
    Scratch& scratch = scratch_.local();

    // Stream the file through the split test, keeping the records while they fit (a leaf needs them all). A fixed
    // tree's interior node needs neither (its children gather their own), and its leaves take their records from
    // their kept files, in memory when they fit, else to a file of this step's (`file` then).
    std::vector<std::byte> kept;
    std::string file = input;
    bool complete = true, split = fixed_tree_ && !node.is_leaf();
    if (!split && leaves_.values) {
      complete = gather_leaf(id, input, kept, file);
    } else if (!split) {
      scratch.table.begin(box, o_.resolution, thresholds_, o_.error == 0);
      SoupReader reader(file, layout_);
      const std::byte* rec = nullptr;
      // The leaves' cells capped (OctreeBuildOptions::max_leaf_cells): the in-core builder counts the same records
      // (the cells overlapping the node), so both split the same nodes.
      const uint64_t cap = !fixed_tree_ && o_.leaf_cells && node.level < deepest_level(o_) ? o_.max_leaf_cells : 0;
      uint64_t records = 0;
      while (reader.next(rec)) {
        const SoupCell cell(rec, layout_);
        if (!fixed_tree_ && node.level < o_.max_depth && !is_flat(cell, scratch)) split = feed(cell, scratch);
        if (cap != 0 && ++records > cap) split = true;
        if (split) break;
        if (complete && kept.size() + cell.bytes() <= preload_bytes_) {
          kept.insert(kept.end(), rec, rec + cell.bytes());
        } else {
          complete = false;
        }
      }
    }
    auto r = std::make_unique<Result>();
    std::vector<ErrorSum> sums(F_);
    std::vector<ErrorHistogram> pairs;
    auto reset_sums = [&] {
      pairs.clear();
      for (uint32_t f = 0; f < F_ && o_.tf_errors; ++f) pairs.emplace_back(fields_[f].min, fields_[f].max);
      for (uint32_t f = 0; f < F_; ++f) {
        sums[f] = ErrorSum{};
        if (o_.tf_errors) sums[f].pairs = &pairs[f];
      }
    };
    reset_sums();
    // The interpolant check (split.h, InterpolantCheck) needs the leaf's brick: a node the voxel rule keeps whole is
    // sampled as a leaf first, and split after all if its brick departs from the cells' interpolant.
    const bool check = !fixed_tree_ && o_.error > 0 && node.level < o_.max_depth;
    if (!split) {
      bool pieces = false;
      std::unique_ptr<LocalMesh> welded;  // the leaf's mesh, kept for its cell block
      if (complete || node.level >= kMaxOctreeLevel) {
        if (!complete) kept = load(file);
        welded = sample_leaf(node, box, kept, scratch, *r, sums);
      } else {
        // More cells than this worker's share of the budget: the brick in pieces (see sample_in_pieces), its error
        // at the data points the pieces wrote, each once (octree/leaf_points.h).
        pieces = true;
        std::vector<std::byte>().swap(kept);
        init_brick(r->brick);
        const std::string points = (temp_ / ("points-" + std::to_string(id))).string();
        {
          LeafPointWriter writer(points, F_);
          sample_in_pieces(node, box, OwnedRegion{box}, file, 0, r->brick, writer);
          writer.close();
        }
        leaf_samples_ += r->brick.mask.size();
        valid_samples_ += r->brick.valid;
        pad_brick(o_.resolution, F_, r->brick.values.data(), r->brick.mask.data());
        BrickPointMeasure measure(r->brick, box);
        for_each_leaf_point(points, F_, [&](Vec3d p, const float* exact) { measure.add(p, exact, sums); });
        std::filesystem::remove(points);
      }
      if (check && interpolant_exceeds(r->brick, box, pieces ? nullptr : &kept, file, scratch)) {
        split = true;
        leaf_samples_ -= r->brick.mask.size();  // what sampling this leaf added (other threads add theirs)
        valid_samples_ -= r->brick.valid;
        r = std::make_unique<Result>();
        reset_sums();
      } else {
        leaves_in_pieces_ += pieces;
        // Sampled, and a leaf for good: its cells, from the mesh it was sampled from or, when sampled in pieces, all
        // of its records at once (one block per leaf; see the header).
        if (o_.leaf_cells) {
          std::vector<std::byte>().swap(kept);  // welded already: the records are not needed for the block
          if (welded) {
            write_cells(id, *welded);
          } else {
            // Beyond the worker's share (its records, then its mesh, topology and block): one such block at a time,
            // so that the excess is that of the largest such leaf, not of one per worker.
            const std::lock_guard lock(big_block_mutex_);
            {
              std::vector<std::byte> all = load(file);
              welded = weld(all);
            }
            write_cells(id, *welded);
          }
        }
        welded.reset();
        done_with_leaf_files(id, input, file);
        for (const ErrorSum& s : sums) r->errors.push_back(s.result());
        progress_.add(kVolumeUnits >> std::min(3 * int(node.level), 62));
      }
    }
    if (split) {
      std::vector<std::byte>().swap(kept);
      std::array<std::string, 8> files;
      uint8_t mask = node.child_mask;
      uint64_t first = node.first_child;
      if (!fixed_tree_) {
        files = route("node-" + std::to_string(id), box, file);
        std::filesystem::remove(file);
        mask = 0;
        for (int o = 0; o < 8; ++o) mask |= uint8_t(!files[size_t(o)].empty()) << o;
        first = add_children(id, node, mask);
      }
      std::array<std::unique_ptr<Result>, 8> kids;
      tbb::task_group group;
      uint64_t child = first;
      for (int o = 0; o < 8; ++o) {
        if (!(mask >> o & 1)) continue;
        if (fixed_tree_) files[size_t(o)] = kept_leaf_path(temp_, child);  // read only if the child is a leaf
        group.run([this, &kids, &files, o, child] { kids[size_t(o)] = process(child, files[size_t(o)]); });
        ++child;
      }
      group.wait();
      std::array<const BrickSamples*, 8> bricks{};
      for (int o = 0; o < 8; ++o)
        if (kids[size_t(o)]) bricks[size_t(o)] = &kids[size_t(o)]->brick;
      downsample_children(o_.resolution, F_, bricks, r->brick);
      pad_brick(o_.resolution, F_, r->brick.values.data(), r->brick.mask.data());
      measure_against_children(r->brick, bricks, sums);
      add_interior_node_errors(sums, kids, r->errors);
    }
    write_node_brick(writer_, id, r->brick, F_);
    for (uint32_t f = 0; f < F_; ++f) {
      errors_[id * F_ + f] = r->errors[f];
      if (o_.tf_errors) tf_errors_[id * F_ + f] = make_tf_error_entry(pairs[f], fields_[f].min, fields_[f].max);
    }
    return r;
  }

  std::vector<OctreeNode> nodes() const { return {nodes_.begin(), nodes_.end()}; }
  std::vector<FieldError> errors() const { return {errors_.begin(), errors_.begin() + ptrdiff_t(nodes_.size() * F_)}; }
  std::vector<store_format::TfErrorEntry> tf_errors() const {
    return {tf_errors_.begin(), tf_errors_.begin() + ptrdiff_t(nodes_.size() * F_)};
  }
  uint64_t leaf_samples() const { return leaf_samples_; }
  uint64_t valid_samples() const { return valid_samples_; }
  uint64_t leaves_in_pieces() const { return leaves_in_pieces_; }
  double sampler_seconds() const { return double(sampler_ns_) * 1e-9; }
  uint64_t cell_blocks() const { return cell_blocks_; }
  uint64_t leaf_cells() const { return leaf_cells_; }
  uint64_t cell_bytes() const { return cell_bytes_; }
  double cell_seconds() const { return double(cell_ns_) * 1e-9; }

  // Progress counts the root's volume in these units; a leaf at level L adds its share.
  static constexpr uint64_t kVolumeUnits = uint64_t(1) << 62;

 private:
  // The children a split makes (those of `mask`, the octants its cells reached): a block of consecutive ids, taken now.
  uint64_t add_children(uint64_t id, const OctreeNode& node, uint8_t mask) {
    const int count = std::popcount(mask);
    const uint64_t first = uint64_t(nodes_.grow_by(size_t(count)) - nodes_.begin());
    errors_.grow_to_at_least((first + uint64_t(count)) * F_);
    tf_errors_.grow_to_at_least((first + uint64_t(count)) * F_);
    nodes_[id].first_child = first;
    nodes_[id].child_mask = mask;
    uint64_t child = first;
    for (int o = 0; o < 8; ++o) {
      if (!(mask >> o & 1)) continue;
      OctreeNode& c = nodes_[child++];
      c.parent = id;
      c.level = uint8_t(node.level + 1);
      c.i = 2 * node.i + uint32_t(o & 1);
      c.j = 2 * node.j + uint32_t((o >> 1) & 1);
      c.k = 2 * node.k + uint32_t((o >> 2) & 1);
    }
    return first;
  }

  // A later step's leaf: the records the first step routed to it (its kept file) with this step's values put in. In
  // memory when they fit the worker's share, as a routed leaf's records are kept (so the same leaves are sampled in
  // pieces); else written, a share at a time, to a file of this step's, `file`, for sample_in_pieces to stream.
  bool gather_leaf(uint64_t id, const std::string& kept_file, std::vector<std::byte>& kept, std::string& file) {
    SoupReader in(kept_file, leaves_.kept_layout);
    std::unique_ptr<SoupWriter> out;  // once the records are over the share
    std::vector<std::byte> share;
    auto write_share = [&] {
      if (!out) {
        file = (temp_ / ("step-leaf-" + std::to_string(id))).string();
        out = std::make_unique<SoupWriter>(file, layout_);
      }
      leaves_.values->put_into(share);
      for (size_t at = 0; at < share.size();) {
        const SoupCell cell(share.data() + at, layout_);
        out->add(cell);
        at += cell.bytes();
      }
      share.clear();
    };
    const std::byte* rec = nullptr;
    while (in.next(rec)) {
      const SoupCell cell(rec, leaves_.kept_layout);
      if (!share.empty() && share.size() + layout_.record_bytes(cell.vertex_count()) > preload_bytes_) write_share();
      append_record_geometry(cell, layout_, share);
    }
    if (!out) {
      leaves_.values->put_into(share);
      kept = std::move(share);
      return true;
    }
    write_share();
    out->close();
    return false;
  }

  // A finished leaf's files: its routed file kept for the later steps (the first of several), or removed; a later
  // step's own file removed, and the kept one too at the last step.
  void done_with_leaf_files(uint64_t id, const std::string& input, const std::string& file) {
    if (leaves_.values) {
      if (file != input) std::filesystem::remove(file);
      if (leaves_.last) std::filesystem::remove(input);
    } else if (leaves_.keep) {
      std::filesystem::rename(input, kept_leaf_path(temp_, id));
    } else {
      std::filesystem::remove(input);
    }
  }

  bool is_flat(const SoupCell& cell, Scratch& s) const {
    UnstructuredMesh& m = s.one_cell;
    const int n = cell.vertex_count();
    m.points.resize(size_t(n));
    m.connectivity.resize(size_t(n));
    for (int i = 0; i < n; ++i) m.points[size_t(i)] = cell.position(i), m.connectivity[size_t(i)] = uint32_t(i);
    m.cell_types.assign(1, cell.type());
    m.cell_offsets.assign({0, uint64_t(n)});
    return is_flat_cell(m, 0);
  }

  // The cell's data points into the split test (octree/data_points.h: vertices for vertex scalars, the centroid for
  // cell scalars); true once the node must split.
  bool feed(const SoupCell& cell, Scratch& s) {
    s.values.resize(F_);
    const int n = cell.vertex_count();
    Vec3d corners[kMaxCellVertices];
    for (int i = 0; i < n; ++i) corners[i] = to_double(cell.position(i));
    if (s.table.add_cell_edges(cell.type(), corners)) return true;
    if (layout_.vertex_fields > 0) {
      for (int i = 0; i < n; ++i) {
        for (uint32_t f = 0; f < F_; ++f) {
          s.values[f] = slots_[f].association == Association::Vertex ? cell.vertex_value(slots_[f].index, i) : NAN;
        }
        if (s.table.add(to_double(cell.position(i)), s.values.data())) return true;
      }
    }
    if (layout_.cell_fields > 0) {
      Vec3d sum{};
      for (int i = 0; i < n; ++i) sum = sum + to_double(cell.position(i));
      for (uint32_t f = 0; f < F_; ++f) {
        s.values[f] = slots_[f].association == Association::Cell ? cell.cell_value(slots_[f].index) : NAN;
      }
      if (s.table.add(sum * (1.0 / double(n)), s.values.data())) return true;
    }
    return false;
  }

  // Each cell of `file` to the files of the children it overlaps, as cells_overlapping_boxes decides in core.
  std::array<std::string, 8> route(const std::string& stem, const Bounds& region, const std::string& file) {
    std::array<std::string, 8> names;
    std::array<std::unique_ptr<SoupWriter>, 8> writers;
    const Vec3d size = region.size();
    auto box_lo = [&](int axis, uint32_t i) { return region.lo[axis] + size[axis] * (double(i) / 2.0); };
    SoupReader reader(file, layout_);
    const std::byte* rec = nullptr;
    Vec3d v[kMaxCellVertices];
    while (reader.next(rec)) {
      const SoupCell cell(rec, layout_);
      const int n = cell.vertex_count();
      Bounds bb;
      for (int i = 0; i < n; ++i) bb.add(v[i] = to_double(cell.position(i)));
      const double margin = kOverlapMargin * length(bb.size());
      for (uint32_t o = 0; o < 8; ++o) {
        const uint32_t x = o & 1, y = (o >> 1) & 1, z = (o >> 2) & 1;
        Bounds b;
        b.lo = {box_lo(0, x), box_lo(1, y), box_lo(2, z)};
        b.hi = {box_lo(0, x + 1), box_lo(1, y + 1), box_lo(2, z + 1)};
        const Bounds e = expanded(b, margin);
        if (bb.lo.x > e.hi.x || bb.lo.y > e.hi.y || bb.lo.z > e.hi.z || bb.hi.x < e.lo.x || bb.hi.y < e.lo.y ||
            bb.hi.z < e.lo.z) {
          continue;
        }
        if (!cell_box_overlap(cell.type(), v, e)) continue;
        if (!writers[o]) {
          names[o] = (temp_ / (stem + "-" + std::to_string(o))).string();
          writers[o] = std::make_unique<SoupWriter>(names[o], layout_);
        }
        writers[o]->add(cell);
      }
    }
    for (auto& w : writers)
      if (w) w->close();
    return names;
  }

  std::vector<std::byte> load(const std::string& file) const {
    std::vector<std::byte> kept;
    SoupReader reader(file, layout_);
    const std::byte* rec = nullptr;
    while (reader.next(rec)) kept.insert(kept.end(), rec, rec + SoupCell(rec, layout_).bytes());
    return kept;
  }

  // Records welded back into a mesh (octree/coarse_preview.h): vertices by id, cells in the order of their ids (as in
  // core, so that the sampler's tie rule, the lowest cell id, picks the same cell), each scalar a float field of it.
  using LocalMesh = WeldedSoup;
  std::unique_ptr<LocalMesh> weld(const std::vector<std::byte>& kept) const {
    return weld_soup_records(kept, layout_, slots_, fields_);
  }

  void sample(const LocalMesh& local, int level, std::array<uint32_t, 3> ijk, Scratch& scratch, BrickSamples& out) {
    const BrickSampler sampler(local.mesh, local.refs, o_.sampler);
    const auto t0 = std::chrono::steady_clock::now();
    BrickSamplerStats st;
    sampler.sample(lattice_, level, ijk, local.cells, scratch.sampler, out, &st);
    sampler_ns_ += uint64_t(seconds_since(t0) * 1e9);
  }

  // Samples a leaf from its records; returns the welded mesh (for its cell block).
  std::unique_ptr<LocalMesh> sample_leaf(const OctreeNode& node, const Bounds& box, const std::vector<std::byte>& kept,
                                         Scratch& scratch, Result& r, std::vector<ErrorSum>& sums) {
    std::unique_ptr<LocalMesh> local = weld(kept);
    sample(*local, node.level, {node.i, node.j, node.k}, scratch, r.brick);
    leaf_samples_ += r.brick.mask.size();
    valid_samples_ += r.brick.valid;
    const OctreeDataPoints data(local->mesh, local->refs);
    std::vector<uint64_t> points;
    data.points_inside(local->cells, box, points);
    pad_brick(o_.resolution, F_, r.brick.values.data(), r.brick.mask.data());
    measure_against_points(r.brick, box, data, points, sums);
    return local;
  }

  // The leaf's cell block (octree/node_cells.h), from its welded mesh: the leaf's own topology, and the whole mesh's
  // boundary faces to tell the boundary from the faces that lead to cells of other nodes. The same block as in core.
  // A later step's leaf (the first step's records with this step's values, welded alike) writes only its values of
  // the same cells, in the block's order (gather_welded_cells numbers the points as gather_node_values does).
  void write_cells(uint64_t id, const LocalMesh& local) {
    if (local.ids.empty()) return;
    const auto t0 = std::chrono::steady_clock::now();
    if (leaves_.values) {
      std::vector<uint64_t> all(local.mesh.cell_count());
      std::iota(all.begin(), all.end(), uint64_t(0));
      const EncodedCells e = writer_.encode_cell_values(gather_node_values(local.mesh, local.refs, all));
      writer_.append_cell_values(id, e);
      cell_bytes_ += e.bytes.size();
      cell_ns_ += uint64_t(seconds_since(t0) * 1e9);
      return;
    }
    EncodedCells e;
    {
      const MeshTopology topology = build_topology(local.mesh);
      e = writer_.encode_cells(gather_welded_cells(local.mesh, topology, local.refs, local.ids, boundary_faces_));
    }
    writer_.append_cells(id, e);
    cell_blocks_ += 1;
    leaf_cells_ += e.cells;
    cell_bytes_ += e.bytes.size();
    cell_ns_ += uint64_t(seconds_since(t0) * 1e9);
  }

  void init_brick(BrickSamples& b) const {
    const size_t n = size_t(o_.resolution) * o_.resolution * o_.resolution;
    b.resolution = o_.resolution;
    b.field_count = F_;
    b.values.assign(F_ * n, 0.0f);
    b.mask.assign(n, 0);
    b.valid = 0;
  }

  // A leaf too large for memory, sampled in pieces: its cells are routed to the eight halves of `region` (and those
  // halves split again while too large), and the leaf's whole lattice is sampled once per piece with that piece's
  // cells only, keeping the samples inside the piece. A point inside a piece lies only in cells that overlap it, so
  // it gets what sampling the whole leaf would give it, bit for bit; points outside find no candidate in their
  // buckets and cost next to nothing, so the work stays about that of the leaf. Pieces are not nodes of the tree.
  // Each piece also writes the data points in `owned` (its part of the leaf's box, octree/leaf_points.h) to `points`,
  // each once, for the leaf's error.
  void sample_in_pieces(const OctreeNode& node, const Bounds& region, const OwnedRegion& owned, const std::string& file,
                        int depth, BrickSamples& out, LeafPointWriter& points) {
    const std::array<std::string, 8> files = route("piece-" + std::to_string(pieces_++), region, file);
    const Vec3d size = region.size();
    auto box_lo = [&](int axis, uint32_t i) { return region.lo[axis] + size[axis] * (double(i) / 2.0); };
    const uint32_t R = o_.resolution;
    const size_t n = size_t(R) * R * R;
    Scratch& scratch = scratch_.local();
    BrickSamples piece;
    for (uint32_t o = 0; o < 8; ++o) {
      if (files[o].empty()) continue;
      Bounds sub;  // as route() computed it
      sub.lo = {box_lo(0, o & 1), box_lo(1, (o >> 1) & 1), box_lo(2, (o >> 2) & 1)};
      sub.hi = {box_lo(0, (o & 1) + 1), box_lo(1, ((o >> 1) & 1) + 1), box_lo(2, ((o >> 2) & 1) + 1)};
      std::vector<std::byte> kept;
      bool complete = true;
      {
        SoupReader reader(files[o], layout_);
        const std::byte* rec = nullptr;
        while (complete && reader.next(rec)) {
          const size_t bytes = SoupCell(rec, layout_).bytes();
          if (kept.size() + bytes > preload_bytes_) complete = false;
          kept.insert(kept.end(), rec, rec + bytes);
        }
      }
      // Pieces stop halving after 16 levels (cells so large that each overlaps every piece): then all are loaded.
      // The halves meet where route() put their common face: the lower half's hi, the upper half's lo.
      const OwnedRegion sub_owned = owned.octant(o, {box_lo(0, 1), box_lo(1, 1), box_lo(2, 1)});
      if (!complete && depth < 16) {
        std::vector<std::byte>().swap(kept);
        sample_in_pieces(node, sub, sub_owned, files[o], depth + 1, out, points);
      } else {
        if (!complete) kept = load(files[o]);
        {
          const std::unique_ptr<LocalMesh> local = weld(kept);
          std::vector<std::byte>().swap(kept);
          sample(*local, node.level, {node.i, node.j, node.k}, scratch, piece);
          write_owned_points(*local, sub_owned, points);
        }
        std::array<std::vector<uint8_t>, 3> inside;
        for (int a = 0; a < 3; ++a) {
          const uint64_t m0 = uint64_t(a == 0 ? node.i : (a == 1 ? node.j : node.k)) * (R - 1);
          for (uint32_t x = 0; x < R; ++x) {
            const double c = lattice_.coordinate(a, node.level, m0 + x);
            inside[size_t(a)].push_back(c >= sub.lo[a] && c <= sub.hi[a]);
          }
        }
        for (uint32_t z = 0; z < R; ++z)
          for (uint32_t y = 0; y < R; ++y)
            for (uint32_t x = 0; x < R; ++x) {
              if (!inside[0][x] || !inside[1][y] || !inside[2][z]) continue;
              const size_t si = x + size_t(R) * (y + size_t(R) * z);
              if (!piece.mask[si]) continue;
              out.valid += !out.mask[si];
              out.mask[si] = 1;
              for (uint32_t f = 0; f < F_; ++f) out.values[f * n + si] = piece.values[f * n + si];
            }
      }
      std::filesystem::remove(files[o]);
    }
  }

  // InterpolantCheck (split.h) on a leaf's brick, over its records: `kept` (all of them) or, when null, streamed from
  // `file`.
  bool interpolant_exceeds(const BrickSamples& brick, const Bounds& box, const std::vector<std::byte>* kept,
                           const std::string& file, Scratch& scratch) {
    std::vector<float> values(size_t(F_) * kMaxCellVertices);
    std::vector<const float*> per_field(F_);
    Vec3d corners[kMaxCellVertices];
    auto exceeds = [&](const SoupCell& cell) {
      if (is_flat(cell, scratch)) return false;
      const int n = cell.vertex_count();
      for (int i = 0; i < n; ++i) corners[i] = to_double(cell.position(i));
      for (uint32_t f = 0; f < F_; ++f) {
        per_field[f] = nullptr;
        if (slots_[f].association != Association::Vertex) continue;
        for (int i = 0; i < n; ++i) values[f * kMaxCellVertices + size_t(i)] = cell.vertex_value(slots_[f].index, i);
        per_field[f] = values.data() + f * kMaxCellVertices;
      }
      return cell_interpolant_exceeds(brick, box, cell.type(), corners, per_field, thresholds_);
    };
    if (kept) {
      for (size_t at = 0; at < kept->size();) {
        const SoupCell cell(kept->data() + at, layout_);
        if (exceeds(cell)) return true;
        at += cell.bytes();
      }
      return false;
    }
    SoupReader reader(file, layout_);
    const std::byte* rec = nullptr;
    while (reader.next(rec))
      if (exceeds(SoupCell(rec, layout_))) return true;
    return false;
  }

  // The data points of a piece's welded mesh (each once: vertices by id) that lie in `owned`, to `points`.
  void write_owned_points(const LocalMesh& local, const OwnedRegion& owned, LeafPointWriter& points) const {
    const OctreeDataPoints data(local.mesh, local.refs);
    std::vector<uint64_t> ids;
    data.points_inside(local.cells, owned.box, ids);
    std::vector<float> values(F_);
    for (uint64_t p : ids) {
      const Vec3d position = data.position(p);
      if (!owned.contains(position)) continue;
      for (uint32_t f = 0; f < F_; ++f) values[f] = data.value(p, f);
      points.add(position, values.data());
    }
  }

  using Slot = VtuCellSource::Slot;
  const OctreeBuildOptions& o_;
  SoupLayout layout_;
  std::vector<Slot> slots_;
  std::vector<BrickStoreField> fields_;
  const BrickLattice& lattice_;
  BrickStoreWriter& writer_;
  std::filesystem::path temp_;
  size_t preload_bytes_;
  Progress& progress_;
  std::span<const uint64_t> boundary_faces_;  // the mesh's, pack_face(cell id, face), ascending (leaf_cells only)
  uint32_t F_;
  bool fixed_tree_;  // the tree is given (see the constructor)
  StepLeaves leaves_;
  std::vector<double> thresholds_;
  tbb::concurrent_vector<OctreeNode> nodes_;
  tbb::concurrent_vector<FieldError> errors_;                     // node x field
  tbb::concurrent_vector<store_format::TfErrorEntry> tf_errors_;  // node x field
  tbb::enumerable_thread_specific<Scratch> scratch_;
  std::atomic<uint64_t> leaf_samples_{0}, valid_samples_{0}, sampler_ns_{0}, pieces_{0}, leaves_in_pieces_{0};
  std::atomic<uint64_t> cell_blocks_{0}, leaf_cells_{0}, cell_bytes_{0}, cell_ns_{0};
  std::mutex big_block_mutex_;  // the cell blocks of leaves sampled in pieces, one at a time
};

// The coarse preview's store (or the point sketch's): at `chosen`, kept; or at "<output>.preview", registered for the
// signal handler and removed when the build ends however it ends (core/temp_files.h). One left by a SIGKILL is removed
// when the next build of the same output starts (made after the build's ScratchFolder, which refuses a second live
// build).
class PreviewFile {
 public:
  PreviewFile(const std::string& chosen, const std::string& output, const char* suffix = ".preview")
      : path_(chosen.empty() ? output + suffix : chosen), temporary_(chosen.empty()) {
    if (!temporary_) return;
    std::error_code ec;
    std::filesystem::remove(path_, ec);
    registration_ = TempRegistration(path_, false);
  }
  ~PreviewFile() {
    if (!temporary_) return;
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  PreviewFile(const PreviewFile&) = delete;
  PreviewFile& operator=(const PreviewFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  bool temporary_;
  TempRegistration registration_;
};

// The cells of `source` into the root's soup file. The points and vertex scalars are held while the records are
// written, within soup_point_budget (out_of_core.h).
uint64_t write_root_soup(VtuCellSource& source, const std::string& root_file, uint64_t memory_budget,
                         const std::string& temp, const std::string& label, const Progress::Observer& observer,
                         const VtuCellSource::CellFilter& keep = {}) {
  Progress progress(label, source.file_cell_count(), observer);
  SoupWriter soup(root_file, source.layout());
  const uint64_t cells = source.write_soup(soup, soup_point_budget(memory_budget), temp, &progress, keep);
  soup.close();
  return cells;
}

// The mesh boundary as the build holds it: its triangles, for the store's boundary section once the tree is known,
// and (leaf cells only) its faces, 8 bytes each, for the leaves' cell blocks.
struct HeldBoundary {
  std::vector<MeshFaceTriangle> triangles;
  std::vector<uint64_t> faces;
  uint64_t bytes() const { return triangles.size() * sizeof(MeshFaceTriangle) + faces.size() * sizeof(uint64_t); }
};

// The boundary's triangles (octree/soup_boundary.h), found while the budget is free and held through the build;
// assigned to the nodes once the tree is known. Their node lists take about 150 bytes a triangle at the end (the
// section, and each triangle in double precision while it is tested against boxes): more than half of the budget,
// and the store keeps the stencil's boundary, with a note saying so (stats.boundary_note).
HeldBoundary find_boundary(const std::string& root_file, const SoupLayout& layout, uint64_t cells,
                           const OctreeBuildOptions& options, uint64_t memory_budget, const std::string& temp,
                           OctreeBuildStats& stats) {
  HeldBoundary held;
  if (options.boundary_faces_per_node == 0 && !options.leaf_cells) return held;
  const auto boundary_start = std::chrono::steady_clock::now();
  SoupBoundaryStats bst;
  held.triangles = soup_boundary_triangles(root_file, layout, cells, memory_budget, temp, options.progress, &bst,
                                           options.leaf_cells ? &held.faces : nullptr);
  if (options.boundary_faces_per_node == 0) held.triangles = {};
  const uint64_t need = held.triangles.size() * uint64_t(150);
  if (need > memory_budget / 2) {
    stats.boundary_note = "the mesh boundary's " + std::to_string(held.triangles.size()) + " triangles need about " +
                          format_bytes(need) +
                          ", over half of the memory budget: the store keeps the stencil's boundary (a budget of " +
                          std::to_string((2 * need >> 20) + 1) + " MiB or more keeps the exact one)";
    held.triangles = {};
  }
  stats.boundary_seconds = seconds_since(boundary_start);
  return held;
}

// What the budget pays for besides cells: the program and its store writer (about 48 MiB), and per worker the file
// buffers of a split (9 soup buffers of 1 MiB and their slack) and the bricks of the subtree in progress (8 per
// level, R³ (4F + 1) bytes each). The rest is shared by the workers, each of which may hold one node's records: a
// twelfth of its share, as sampling them takes up to about 10 times their size (the records with their vector's
// slack, the welded mesh, the sampler's prepared cells, about 400 bytes a cell, and its buckets, and what the
// allocator keeps between leaves; measured on 100M tetrahedra); at least 64 KiB.
size_t records_per_worker(const OctreeBuildOptions& options, size_t field_count, uint64_t memory_budget,
                          uint64_t held_bytes) {
  const auto workers = uint64_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  const uint64_t brick_bytes =
      uint64_t(options.resolution) * options.resolution * options.resolution * (4 * uint64_t(field_count) + 1);
  const uint64_t reserve =
      (uint64_t(48) << 20) + workers * ((uint64_t(18) << 20) + 8 * uint64_t(deepest_level(options) + 1) * brick_bytes);
  const uint64_t held = reserve + held_bytes;
  const uint64_t available = memory_budget > held ? memory_budget - held : 0;
  return size_t(std::max<uint64_t>(available / (12 * workers), uint64_t(64) << 10));
}

// The boundary's triangles assigned to the finished tree's nodes (the store's boundary section); frees them.
StoreBoundary place_boundary(HeldBoundary& held, const Bounds& root, std::span<const OctreeNode> nodes,
                             const OctreeBuildOptions& options, OctreeBuildStats& stats) {
  held.faces = {};
  const auto boundary_start = std::chrono::steady_clock::now();
  BoundaryFaceStats bst;
  StoreBoundary boundary = store_boundary_faces(held.triangles, root, nodes, options.boundary_faces_per_node, &bst);
  held.triangles = {};
  stats.boundary_bytes = boundary.bytes();
  stats.boundary_triangles = bst.triangles;
  stats.boundary_overflow_nodes = bst.overflow_nodes;
  stats.boundary_seconds += seconds_since(boundary_start);
  return boundary;
}

// What a finished OutOfCoreBuild counted, into the stats (added: a store with time sums its steps).
void add_build_counts(const OutOfCoreBuild& build, const VtuCellSource& source, OctreeBuildStats& stats) {
  stats.leaf_samples += build.leaf_samples();
  stats.valid_samples += build.valid_samples();
  stats.leaves_in_pieces += build.leaves_in_pieces();
  stats.point_passes += source.passes();
  stats.sampler_seconds += build.sampler_seconds();
  stats.cell_blocks += build.cell_blocks();
  stats.leaf_cells += build.leaf_cells();
  stats.cell_bytes += build.cell_bytes();
  stats.cell_seconds += build.cell_seconds();
}

// A subset's given bounds and ranges against the file's own (both the whole file's, unless it changed since the plan).
void check_subset_matches(const std::string& vtu_path, const OutOfCoreSubset& subset, const VtuCellSource& source) {
  const Bounds& b = source.bounds();
  if (!(b.lo == subset.bounds.lo) || !(b.hi == subset.bounds.hi))
    fail_in(vtu_path, subset.name + ": the file's bounds differ from the plan's (was it changed since?)");
  const std::vector<BrickStoreField>& f = source.fields();
  if (f.size() != subset.fields.size())
    fail_in(vtu_path, subset.name + ": the plan selected " + std::to_string(subset.fields.size()) +
                          " field(s), the file gives " + std::to_string(f.size()));
  for (size_t i = 0; i < f.size(); ++i)
    if (f[i].name != subset.fields[i].name || f[i].association != subset.fields[i].association ||
        f[i].min != subset.fields[i].min || f[i].max != subset.fields[i].max)
      fail_in(vtu_path, subset.name + ": field '" + f[i].name +
                            "' differs from the plan's (name, association or "
                            "range; was the file changed since?)");
}

OctreeBuildStats build_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                   const OctreeBuildOptions& options, uint64_t memory_budget, const std::string& path,
                                   const OutOfCoreSubset* subset);

}  // namespace

uint64_t soup_point_budget(uint64_t memory_budget) {
  const uint64_t base = uint64_t(48) << 20;
  return std::max((memory_budget > base ? memory_budget - base : 0) / 2, uint64_t(1) << 20);
}

uint64_t out_of_core_scratch_floor(uint64_t cells, const SoupLayout& layout) {
  return 2 * cells * uint64_t(layout.record_bytes(4));
}

uint64_t scratch_free_bytes(const std::string& folder) {
  if (const char* v = std::getenv(kScratchFreeBytesEnv); v && *v) {
    const std::string text(v);
    if (!std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }) || text.size() > 19)
      throw Error(std::string("$") + kScratchFreeBytesEnv + ": \"" + text + "\" is not a byte count");
    return std::stoull(text);
  }
  std::error_code ec;
  const std::filesystem::space_info space = std::filesystem::space(folder, ec);
  if (ec) fail_in(folder, "cannot read its free space: " + ec.message());
  return space.available;
}

void check_out_of_core_scratch(const std::string& input, uint64_t cells, uint64_t needed, uint64_t available,
                               const std::string& scratch_folder) {
  if (available >= needed) return;
  const std::filesystem::path in(input);
  const std::string index = (in.parent_path() / in.stem()).string() + ".json";
  throw Error(input + ": an out-of-core build of its " + std::to_string(cells) + " cells needs at least " +
              format_bytes(needed) + " of scratch space in " + scratch_folder +
              " (its cell soup and the files of its " + "first split), and " + format_bytes(available) +
              " is free there: free space, write the store to a " +
              "larger disk (the scratch folder is made next to the output), or build it in pieces, one piece's " +
              "scratch at a time (`ugvr build " + input + " --pieces 16 --out-of-core -o " + index +
              "`, then view or render the index)");
}

OctreeBuildStats build_octree_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                          const OctreeBuildOptions& options, uint64_t memory_budget,
                                          const std::string& path) {
  return build_out_of_core(vtu_path, selectors, options, memory_budget, path, nullptr);
}

OctreeBuildStats build_octree_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                          const OctreeBuildOptions& options, uint64_t memory_budget,
                                          const std::string& path, const OutOfCoreSubset& subset) {
  if (options.preview_depth > 0 || options.point_sketch)
    throw Error(subset.name + ": a coarse preview or a point sketch is not made for part of a mesh; leave them out");
  return build_out_of_core(vtu_path, selectors, options, memory_budget, path, &subset);
}

namespace {

OctreeBuildStats build_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                   const OctreeBuildOptions& options, uint64_t memory_budget, const std::string& path,
                                   const OutOfCoreSubset* subset) {
  validate_build_options(options);
  if (options.preview_depth < 0 || options.preview_depth > kMaxPreviewDepth)
    throw Error("the coarse preview's depth " + std::to_string(options.preview_depth) + " is out of range 0.." +
                std::to_string(kMaxPreviewDepth));
  const auto start = std::chrono::steady_clock::now();
  std::optional<tbb::global_control> threads;
  if (options.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));
  // "<path>.cells": one predictable name; removed however the build ends, on SIGINT / SIGTERM too, and, after a
  // SIGKILL, by the next build of the same output (core/temp_files.h).
  const ScratchFolder scratch(path);
  const std::filesystem::path temp_path(scratch.path());

  VtuCellSource source(vtu_path, selectors);
  // A piece (subset) holds an unknown part of the cells until its soup is written: the whole file's floor would
  // refuse pieces that fit, so only a whole build is checked here.
  if (!subset)
    check_out_of_core_scratch(vtu_path, source.file_cell_count(),
                              out_of_core_scratch_floor(source.file_cell_count(), source.layout()),
                              scratch_free_bytes(temp_path.string()), temp_path.string());
  OctreeBuildStats stats;
  // The point sketch (octree/point_sketch.h) before the cells: from the points alone, what a viewer shows within
  // seconds. Its lattice and layout are the store's (vertex fields only: their ranges are known already).
  std::optional<PreviewFile> sketch;
  if (options.point_sketch && options.preview_depth > 0 && point_sketch_possible(source.slots())) {
    const int K = point_sketch_depth(source.point_count(), options.resolution, options.preview_depth);
    if (K > 0) {
      BrickLattice sketch_lattice;
      sketch_lattice.root = octree_root(source.bounds());
      sketch_lattice.resolution = options.resolution;
      const BrickStoreLayout sketch_layout =
          store_layout(options, source.fields(), sketch_lattice.root, source.bounds(), true);
      sketch.emplace(options.sketch_path, path, ".sketch");
      const uint64_t base = uint64_t(48) << 20;
      const PointSketchStats ss = write_point_sketch(
          source, sketch_lattice, sketch_layout, K,
          std::max((memory_budget > base ? memory_budget - base : 0) / 4, uint64_t(1) << 20), sketch->path());
      stats.sketch_depth = K;
      stats.sketch_seconds = ss.seconds;
      stats.sketch_bytes = ss.store_bytes;
      if (options.on_sketch) options.on_sketch(sketch->path(), K);
    }
  }
  const std::string root_file = (temp_path / "root").string();
  const uint64_t cells = write_root_soup(source, root_file, memory_budget, temp_path.string(), "cells to disk",
                                         options.progress, subset ? subset->keep : VtuCellSource::CellFilter{});
  if (subset) {
    check_subset_matches(vtu_path, *subset, source);
    if (cells == 0) fail_in(path, subset->name + " holds no cells (more pieces than the mesh can fill)");
  }
  const Bounds data_bounds = source.bounds();
  BrickLattice lattice;
  lattice.root = octree_root(data_bounds);
  lattice.resolution = options.resolution;
  const BrickStoreLayout layout = store_layout(options, source.fields(), lattice.root, data_bounds, true);

  // The coarse preview (octree/coarse_preview.h) first, while the budget is free: what a viewer shows within seconds.
  std::optional<PreviewFile> preview;
  if (options.preview_depth > 0) {
    preview.emplace(options.preview_path, path);
    CoarsePreviewOptions po;
    po.depth = options.preview_depth;
    po.sampler = options.sampler;
    po.progress = options.progress;
    // The records of one chunk take up to about 10 times their size while sampled (as a leaf's, below): a twelfth of
    // what the budget leaves beside the program and the preview's bricks.
    const uint64_t held =
        (uint64_t(48) << 20) + coarse_preview_brick_bytes(po.depth, options.resolution, uint32_t(layout.fields.size()));
    po.chunk_bytes = size_t(std::max<uint64_t>((memory_budget > held ? memory_budget - held : 0) / 12, 64 << 10));
    const CoarsePreviewStats ps =
        write_coarse_preview(root_file, source.layout(), source.slots(), lattice, layout, po, preview->path());
    stats.preview_seconds = ps.seconds;
    stats.preview_nodes = ps.nodes;
    stats.preview_bytes = ps.store_bytes;
    if (options.on_preview) options.on_preview(preview->path());
  }

  // Found while the budget is free; the leaves' cell blocks need the boundary's faces, held through the build too.
  HeldBoundary boundary_held =
      find_boundary(root_file, source.layout(), cells, options, memory_budget, temp_path.string(), stats);
  BrickStoreWriter writer(path, layout);
  const size_t preload = records_per_worker(options, layout.fields.size(), memory_budget, boundary_held.bytes());
  stats.cells = cells;
  // here: writing the cells to disk
  stats.subdivide_seconds = seconds_since(start) - stats.preview_seconds - stats.sketch_seconds;
  const auto bricks_start = std::chrono::steady_clock::now();
  std::vector<OctreeNode> nodes;
  {
    Progress progress("bricks", OutOfCoreBuild::kVolumeUnits, options.progress);
    OutOfCoreBuild build(options, source, lattice, writer, temp_path, preload, progress, boundary_held.faces);
    build.process(0, root_file);
    nodes = build.nodes();
    add_build_counts(build, source, stats);
    const StoreBoundary boundary = place_boundary(boundary_held, lattice.root, nodes, options, stats);
    writer.commit(nodes, build.errors(),
                  options.tf_errors ? build.tf_errors() : std::vector<store_format::TfErrorEntry>{}, &boundary);
  }
  stats.brick_seconds = seconds_since(bricks_start);
  count_tree_shape(nodes, stats);
  stats.store_bytes = std::filesystem::file_size(path);
  if (options.tf_errors)
    stats.tf_error_table_bytes = stats.nodes * layout.fields.size() * sizeof(store_format::TfErrorEntry);
  stats.seconds = seconds_since(start);
  const BrickStoreReader store(path);
  for (uint64_t id = 0; id < store.node_count(); ++id) stats.bricks += store.node(id).has_brick();
  return stats;
}

}  // namespace

}  // namespace ugvr

namespace ugvr {

namespace {

// What a store with time holds beside one step's build, from the second step on: the first step's tree (twice: the
// build's copy) and, until the commit, the writer's node tables of the steps written (block offsets, sizes,
// checksums, value ranges, errors and transfer-function error entries: 68 bytes a node and field and 16 a node;
// 96 a node and field counts both, with slack).
uint64_t held_for_steps(uint64_t nodes, uint64_t fields, size_t steps_written) {
  constexpr uint64_t kStepTableBytes = 96;
  return 2 * nodes * sizeof(OctreeNode) + uint64_t(steps_written) * nodes * fields * kStepTableBytes;
}

// Why --error > 0 is refused, and what builds instead, as commands that run: the in-core build (with the largest
// selected step's file, which it holds one at a time, named), --error 0, or one store per step from its .vtu file
// (`--time-step N` with a series is not an out-of-core input).
std::string error_above_0_advice(const TimeSeries& series, std::span<const uint32_t> steps,
                                 std::span<const std::string> files, double error) {
  auto size_of = [](const std::string& file) {  // 0 for a file that cannot be read: the refusal comes first
    std::error_code ec;
    const uintmax_t bytes = std::filesystem::file_size(file, ec);
    return ec ? uintmax_t(0) : bytes;
  };
  size_t largest = 0;
  for (size_t k = 1; k < files.size(); ++k)
    if (size_of(files[k]) > size_of(files[largest])) largest = k;
  char e[32];
  std::snprintf(e, sizeof e, "%g", error);
  const std::string mib = std::to_string((size_of(files[largest]) + (1 << 19)) >> 20);
  std::string advice =
      series.source + ": --out-of-core --time builds at --error 0 only: above 0 the store's tree is the union of the " +
      "steps' trees, each shaped by its own step's values, which out of core would take a pass over every step " +
      "before the first brick. Either leave out --out-of-core (the in-core build holds one step at a time, its mesh " +
      "and the tree's cell lists; the largest selected step is " + files[largest] + ", " + mib + " MiB), or give " +
      "--error 0 (the tree split by the geometry alone, one store for every step), or build one store per step out " +
      "of core from its .vtu file: ugvr build " + files[0] + " --out-of-core --error " + e + " -o " +
      std::filesystem::path(files[0]).replace_extension(".ugvr").string();
  if (steps.size() > 1)
    advice += " (step " + std::to_string(steps[0]) + "), and likewise for the other " +
              std::to_string(steps.size() - 1) + " step(s)";
  return advice;
}

bool is_vtu_step(const TimeStep& step) {
  if (step.files.size() != 1 || step.reader_step >= 0) return false;
  std::string ext = std::filesystem::path(step.files[0]).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".vtu";
}

}  // namespace

bool out_of_core_steps_possible(const TimeSeries& series, std::span<const uint32_t> steps) {
  for (uint32_t s : steps)
    if (s >= series.size() || !is_vtu_step(series.steps[s])) return false;
  return !steps.empty();
}

std::string out_of_core_step_file(const TimeSeries& series, uint32_t step) {
  const TimeStep& t = series.steps.at(step);
  if (is_vtu_step(t)) return t.files[0];
  std::string what = t.files.empty() ? std::string("no file") : t.files[0];
  if (t.files.size() > 1) what += " and " + std::to_string(t.files.size() - 1) + " more part(s)";
  if (t.reader_step >= 0) what += " (step " + std::to_string(t.reader_step) + " of a multi-step file)";
  throw Error(series.source + ": time step " + std::to_string(step) + " is " + what +
              ": the out-of-core build streams steps that are one .vtu file each (build in core: leave out "
              "--out-of-core)");
}

OctreeBuildStats build_octree_out_of_core_steps(const TimeSeries& series, std::span<const uint32_t> steps,
                                                std::span<const std::string> selectors,
                                                const OctreeBuildOptions& options, uint64_t memory_budget,
                                                const std::string& path) {
  validate_build_options(options);
  check_step_selection(series, steps);
  std::vector<std::string> files;
  for (uint32_t s : steps) files.push_back(out_of_core_step_file(series, s));  // every step checked before any work
  if (options.error > 0) throw Error(error_above_0_advice(series, steps, files, options.error));
  if (options.preview_depth > 0 || options.point_sketch)
    throw Error(series.source + ": --preview and --sketch are not made for a store with time (--time); leave them out");

  const auto start = std::chrono::steady_clock::now();
  std::optional<tbb::global_control> threads;
  if (options.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));
  const ScratchFolder scratch(path);  // "<path>.cells", removed however the build ends (core/temp_files.h)
  const std::filesystem::path temp_path(scratch.path());
  const std::string root_file = (temp_path / "root").string();
  const size_t S = steps.size();

  OctreeBuildStats stats;
  stats.time_steps = uint32_t(S);
  std::vector<std::string> names(selectors.begin(), selectors.end());
  uint64_t geometry = 0;
  BrickLattice lattice;
  lattice.resolution = options.resolution;
  std::optional<BrickStoreWriter> writer;
  HeldBoundary boundary_held;
  std::vector<OctreeNode> tree;  // the first step's, filled by every later step
  double soup_seconds = 0, brick_seconds = 0;
  // One step at a time. The first: its cells to a soup (its points and values held a slice at a time), routed down
  // the tree it shapes (the geometric split rule at --error 0), each leaf's file kept. Every later step: its values
  // to files (no soup), and each leaf's records the kept ones with those values put in, on the first step's node ids.
  const std::string values_prefix = (temp_path / "values-").string();
  SoupLayout first_layout;
  for (size_t k = 0; k < S; ++k) {
    const std::string label = step_label(series, steps, k);
    const auto soup_start = std::chrono::steady_clock::now();
    VtuCellSource source(files[k], names);
    if (names.empty())  // the fields the first step picked, kept for every step (a field constant at first stays)
      for (const BrickStoreField& f : source.fields()) names.push_back(f.name);
    std::optional<StepValues> values;
    if (k == 0) {
      const uint64_t cells = write_root_soup(source, root_file, memory_budget, temp_path.string(),
                                             label + ": cells to disk", options.progress);
      soup_seconds += seconds_since(soup_start);
      geometry = source.geometry_hash();
      first_layout = source.layout();
      stats.cells = cells;
      lattice.root = octree_root(source.bounds());
      BrickStoreLayout layout = store_layout(options, source.fields(), lattice.root, source.bounds(), true);
      for (uint32_t s : steps) layout.times.push_back(series.steps[s].time);
      boundary_held =
          find_boundary(root_file, source.layout(), cells, options, memory_budget, temp_path.string(), stats);
      writer.emplace(path, layout);
    } else {
      {
        Progress progress(label + ": values to disk", source.file_cell_count(), options.progress);
        source.write_values(values_prefix, &progress);
      }
      soup_seconds += seconds_since(soup_start);
      if (source.geometry_hash() != geometry)
        fail_geometry_differs(series, steps[k], steps[0], "points and cells hashed as they were read");
      values.emplace(values_prefix, source.layout(), source.point_count(), source.file_cell_count());
    }
    std::vector<store_format::StepFieldRange> ranges;
    for (const BrickStoreField& f : source.fields()) ranges.push_back({f.min, f.max});
    writer->begin_step(uint32_t(k), ranges);
    const size_t preload =
        records_per_worker(options, source.fields().size(), memory_budget,
                           boundary_held.bytes() + held_for_steps(tree.size(), source.fields().size(), k));
    const auto bricks_start = std::chrono::steady_clock::now();
    Progress progress(label + ": bricks", OutOfCoreBuild::kVolumeUnits, options.progress);
    StepLeaves leaves;
    leaves.keep = k == 0 && S > 1;
    leaves.values = values ? &*values : nullptr;
    leaves.kept_layout = first_layout;
    leaves.last = k + 1 == S;
    OutOfCoreBuild build(options, source, lattice, *writer, temp_path, preload, progress, boundary_held.faces, tree,
                         leaves);
    build.process(0, k == 0 ? root_file : kept_leaf_path(temp_path, 0));
    progress.finish();
    if (k == 0) tree = build.nodes();
    add_build_counts(build, source, stats);
    writer->end_step(build.errors(), options.tf_errors ? build.tf_errors() : std::vector<store_format::TfErrorEntry>{});
    brick_seconds += seconds_since(bricks_start);
  }
  const StoreBoundary boundary = place_boundary(boundary_held, lattice.root, tree, options, stats);
  writer->commit(tree, {}, {}, &boundary);
  count_tree_shape(tree, stats);
  stats.first_step_nodes = stats.nodes;
  stats.read_seconds = soup_seconds;
  stats.subdivide_seconds = soup_seconds;  // out of core the tree is shaped as the first step's bricks are made
  stats.brick_seconds = brick_seconds;
  stats.store_bytes = std::filesystem::file_size(path);
  if (options.tf_errors)
    stats.tf_error_table_bytes = S * stats.nodes * writer->layout().fields.size() * sizeof(store_format::TfErrorEntry);
  stats.seconds = seconds_since(start);
  const BrickStoreReader store(path);
  for (uint64_t id = 0; id < store.node_count(); ++id) stats.bricks += store.node(id).has_brick();
  return stats;
}

}  // namespace ugvr
