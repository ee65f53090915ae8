#include "ugvr/lod/octree_error.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace ugvr {

FieldError ErrorSum::result() const {
  FieldError e;
  e.max = float(max);
  e.rms = count ? float(std::sqrt(sum_sq / double(count))) : 0.0f;
  return e;
}

bool interpolate_brick(const BrickSamples& brick, Vec3d u, double* out) {
  const uint32_t R = brick.resolution;
  const size_t n = size_t(R) * R * R;
  uint32_t i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(u[a], 0.0, double(R - 1));
    i0[a] = std::min(uint32_t(c), R - 2);
    t[a] = c - double(i0[a]);
  }
  size_t corner[8];
  double weight[8];
  bool any = false;
  for (int q = 0; q < 8; ++q) {
    const uint32_t dx = q & 1, dy = (q >> 1) & 1, dz = (q >> 2) & 1;
    corner[q] = (i0[0] + dx) + size_t(R) * ((i0[1] + dy) + size_t(R) * (i0[2] + dz));
    weight[q] = (dx ? t[0] : 1 - t[0]) * (dy ? t[1] : 1 - t[1]) * (dz ? t[2] : 1 - t[2]);
    any = any || brick.mask[corner[q]];
  }
  if (!any) return false;
  for (uint32_t f = 0; f < brick.field_count; ++f) {
    const float* v = brick.values.data() + f * n;
    double sum = 0;
    for (int q = 0; q < 8; ++q) sum += weight[q] * v[corner[q]];
    out[f] = sum;
  }
  return true;
}

void measure_against_children(const BrickSamples& brick, const std::array<const BrickSamples*, 8>& children,
                              std::span<ErrorSum> sums) {
  const uint32_t R = brick.resolution, F = brick.field_count;
  const size_t n = size_t(R) * R * R;
  // Child line m of octant half h is parent line (h (R - 1) + m) / 2: a parent line when even, else halfway between
  // two. So along each axis the lookup has corners lo, hi with weights 1, 0 or 1/2, 1/2: interpolate_brick's
  // arithmetic tabulated once, as this runs over 8 R³ samples per interior node.
  struct Axis {
    std::vector<size_t> lo, hi;  // sample offsets (already times the axis stride)
    std::vector<double> w_hi;    // 0 or 0.5
  };
  Axis axes[3][2];
  const size_t stride[3] = {1, R, size_t(R) * R};
  for (int a = 0; a < 3; ++a)
    for (uint32_t half = 0; half < 2; ++half) {
      Axis& ax = axes[a][half];
      for (uint32_t x = 0; x < R; ++x) {
        const uint32_t line = half * (R - 1) + x;
        ax.lo.push_back(size_t(line / 2) * stride[a]);
        ax.hi.push_back(size_t(line / 2 + line % 2) * stride[a]);
        ax.w_hi.push_back(line % 2 ? 0.5 : 0.0);
      }
    }
  for (uint32_t o = 0; o < 8; ++o) {
    const BrickSamples* child = children[o];
    if (!child || child->valid == 0) continue;
    const Axis &X = axes[0][o & 1], &Y = axes[1][(o >> 1) & 1], &Z = axes[2][(o >> 2) & 1];
    for (uint32_t z = 0; z < R; ++z)
      for (uint32_t y = 0; y < R; ++y) {
        const size_t c00 = Y.lo[y] + Z.lo[z], c10 = Y.hi[y] + Z.lo[z], c01 = Y.lo[y] + Z.hi[z], c11 = Y.hi[y] + Z.hi[z];
        const double wy = Y.w_hi[y], wz = Z.w_hi[z];
        const double w00 = (1 - wy) * (1 - wz), w10 = wy * (1 - wz), w01 = (1 - wy) * wz, w11 = wy * wz;
        for (uint32_t x = 0; x < R; ++x) {
          const size_t s = x + size_t(R) * (y + size_t(R) * z);
          if (!child->mask[s]) continue;
          const size_t corner[8] = {X.lo[x] + c00, X.hi[x] + c00, X.lo[x] + c10, X.hi[x] + c10,
                                    X.lo[x] + c01, X.hi[x] + c01, X.lo[x] + c11, X.hi[x] + c11};
          const uint8_t* m = brick.mask.data();
          if (!(m[corner[0]] | m[corner[1]] | m[corner[2]] | m[corner[3]] | m[corner[4]] | m[corner[5]] | m[corner[6]] |
                m[corner[7]])) {
            continue;
          }
          const double wx = X.w_hi[x];
          const double w[8] = {(1 - wx) * w00, wx * w00, (1 - wx) * w10, wx * w10,
                               (1 - wx) * w01, wx * w01, (1 - wx) * w11, wx * w11};
          for (uint32_t f = 0; f < F; ++f) {
            const float* v = brick.values.data() + f * n;
            double sum = 0;
            for (int q = 0; q < 8; ++q) sum += w[q] * v[corner[q]];
            sums[f].add(std::abs(sum - child->values[f * n + s]));
          }
        }
      }
  }
}

void measure_against_points(const BrickSamples& brick, const Bounds& box, const OctreeDataPoints& data,
                            std::span<const uint64_t> points, std::span<ErrorSum> sums) {
  const uint32_t R = brick.resolution, F = brick.field_count;
  Vec3d scale;
  for (int a = 0; a < 3; ++a) {
    const double extent = box.hi[a] - box.lo[a];
    scale[a] = extent > 0 ? double(R - 1) / extent : 0.0;
  }
  std::vector<double> interpolated(F);
  for (uint64_t p : points) {
    const Vec3d pos = data.position(p);
    const Vec3d u{(pos.x - box.lo.x) * scale.x, (pos.y - box.lo.y) * scale.y, (pos.z - box.lo.z) * scale.z};
    if (!interpolate_brick(brick, u, interpolated.data())) continue;
    for (uint32_t f = 0; f < F; ++f) {
      const float exact = data.value(p, f);
      if (!std::isnan(exact)) sums[f].add(std::abs(interpolated[f] - double(exact)));
    }
  }
}

}  // namespace ugvr
