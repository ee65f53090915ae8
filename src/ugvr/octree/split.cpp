#include "ugvr/octree/split.h"

#include <algorithm>
#include <cmath>

#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/octree/cell_box_overlap.h"
#include "ugvr/octree/node_error.h"
#include "ugvr/store/brick_pad.h"

namespace ugvr {

void VoxelSpread::begin(const Bounds& box, uint32_t R, std::span<const double> thresholds, bool geometric) {
  const size_t voxels = size_t(R) * R * R;
  const size_t F = thresholds.size();
  if (stamp_.size() != voxels || lo_.size() != F * voxels) {
    stamp_.assign(voxels, 0);
    first_.resize(voxels);
    distinct_.resize(voxels);
    lo_.resize(F * voxels);
    hi_.resize(F * voxels);
    call_ = 0;
  }
  if (++call_ == 0) {  // wrapped: forget every stamp
    std::fill(stamp_.begin(), stamp_.end(), 0);
    call_ = 1;
  }
  box_ = box;
  R_ = R;
  thresholds_ = thresholds;
  geometric_ = geometric;
  double longest = 0;
  for (int a = 0; a < 3; ++a) {
    const double extent = box.hi[a] - box.lo[a];
    scale_[a] = extent > 0 ? double(R - 1) / extent : 0.0;
    longest = std::max(longest, extent);
  }
  min_edge_ = 2 * longest / double(R - 1);
}

bool VoxelSpread::add_cell_edges(CellType type, const Vec3d* v) const {
  if (!geometric_) return false;
  const double min_sq = min_edge_ * min_edge_;
  for (const auto& e : cell_edges(type)) {
    const Vec3d a = v[e[0]], b = v[e[1]];
    const Vec3d d = b - a;
    const double len_sq = dot(d, d);
    if (len_sq == 0 || len_sq >= min_sq) continue;
    if (box_contains(box_, a) || box_contains(box_, b)) return true;
  }
  return false;
}

bool VoxelSpread::add(Vec3d pos, const float* values) {
  if (!box_contains(box_, pos)) return false;
  auto voxel_index = [&](int a) {
    const double u = std::round((pos[a] - box_.lo[a]) * scale_[a]);
    return uint32_t(std::clamp(u, 0.0, double(R_ - 1)));
  };
  const size_t voxels = stamp_.size();
  const size_t v = voxel_index(0) + size_t(R_) * (voxel_index(1) + size_t(R_) * voxel_index(2));
  const size_t F = thresholds_.size();
  if (stamp_[v] != call_) {
    stamp_[v] = call_;
    first_[v] = pos;
    distinct_[v] = 0;
    for (size_t f = 0; f < F; ++f) {
      lo_[f * voxels + v] = std::isnan(values[f]) ? INFINITY : values[f];
      hi_[f * voxels + v] = std::isnan(values[f]) ? -INFINITY : values[f];
    }
    return false;
  }
  if (!(pos == first_[v])) distinct_[v] = 1;
  bool spread = geometric_;
  for (size_t f = 0; f < F; ++f) {
    if (std::isnan(values[f])) continue;
    float& lo = lo_[f * voxels + v];
    float& hi = hi_[f * voxels + v];
    lo = std::min(lo, values[f]), hi = std::max(hi, values[f]);
    if (double(hi) - double(lo) > thresholds_[f]) spread = true;
  }
  return distinct_[v] && spread;
}

InterpolantCheck::InterpolantCheck(const OctreeDataPoints& points, const BrickSampler& sampler,
                                   const BrickLattice& lattice, std::span<const double> thresholds)
    : points_(points), sampler_(sampler), lattice_(lattice), thresholds_(thresholds) {}

bool InterpolantCheck::exceeds(int level, std::array<uint32_t, 3> ijk, std::span<const uint64_t> cells,
                               BrickScratch& scratch) const {
  const size_t F = thresholds_.size();
  bool any_vertex_field = false;
  for (size_t f = 0; f < F; ++f) any_vertex_field |= points_.association(f) == Association::Vertex;
  if (!any_vertex_field) return false;
  BrickSamples brick;
  sampler_.sample(lattice_, level, ijk, cells, scratch, brick);
  if (brick.valid == 0) return false;
  pad_brick(brick.resolution, uint32_t(F), brick.values.data(), brick.mask.data());
  const Bounds box = lattice_.node_box(level, ijk);
  const UnstructuredMesh& mesh = points_.mesh();
  Vec3d corners[kMaxCellVertices];
  std::vector<float> values(F * kMaxCellVertices);
  std::vector<const float*> per_field(F);
  for (uint64_t cell : cells) {
    if (points_.cell_flat(cell)) continue;
    const std::span<const uint32_t> vs = mesh.cell(cell);
    for (size_t i = 0; i < vs.size(); ++i) corners[i] = to_double(mesh.points[vs[i]]);
    for (size_t f = 0; f < F; ++f) {
      if (points_.association(f) != Association::Vertex) {
        per_field[f] = nullptr;
        continue;
      }
      for (size_t i = 0; i < vs.size(); ++i) values[f * kMaxCellVertices + i] = points_.value(vs[i], f);
      per_field[f] = values.data() + f * kMaxCellVertices;
    }
    if (cell_interpolant_exceeds(brick, box, mesh.cell_types[cell], corners, per_field, thresholds_)) return true;
  }
  return false;
}

SplitTest::SplitTest(const OctreeDataPoints& points, std::span<const BrickStoreField> fields, double error,
                     uint32_t resolution)
    : points_(points), geometric_(error == 0), resolution_(resolution) {
  for (const BrickStoreField& f : fields) thresholds_.push_back(error * (f.max - f.min));
}

bool SplitTest::needs_split(const Bounds& box, std::span<const uint64_t> cells, VoxelSpread& table) const {
  table.begin(box, resolution_, thresholds_, geometric_);
  std::vector<float> values(thresholds_.size());
  const UnstructuredMesh& mesh = points_.mesh();
  Vec3d corners[kMaxCellVertices];
  bool split = false;
  for (uint64_t cell : cells) {
    if (geometric_ && !points_.cell_flat(cell)) {
      const std::span<const uint32_t> vs = mesh.cell(cell);
      for (size_t i = 0; i < vs.size(); ++i) corners[i] = to_double(mesh.points[vs[i]]);
      if (table.add_cell_edges(mesh.cell_types[cell], corners)) return true;
    }
    points_.for_each_point(cell, [&](uint64_t p) {
      if (split || !points_.splits(p)) return;
      for (size_t f = 0; f < values.size(); ++f) values[f] = points_.value(p, f);
      split = table.add(points_.position(p), values.data());
    });
    if (split) return true;
  }
  return false;
}

}  // namespace ugvr
