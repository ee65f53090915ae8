#include "ugvr/octree/split.h"

#include <algorithm>
#include <cmath>

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
  for (int a = 0; a < 3; ++a) {
    const double extent = box.hi[a] - box.lo[a];
    scale_[a] = extent > 0 ? double(R - 1) / extent : 0.0;
  }
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

SplitTest::SplitTest(const OctreeDataPoints& points, std::span<const BrickStoreField> fields, double error,
                     uint32_t resolution)
    : points_(points), geometric_(error == 0), resolution_(resolution) {
  for (const BrickStoreField& f : fields) thresholds_.push_back(error * (f.max - f.min));
}

bool SplitTest::needs_split(const Bounds& box, std::span<const uint64_t> cells, VoxelSpread& table) const {
  table.begin(box, resolution_, thresholds_, geometric_);
  std::vector<float> values(thresholds_.size());
  bool split = false;
  for (uint64_t cell : cells) {
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
