#include "ugvr/octree/node_error.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/octree/cell_box_overlap.h"

namespace ugvr {

FieldError ErrorSum::result() const {
  FieldError e;
  e.max = float(max);
  e.rms = count ? float(std::sqrt(sum_sq / double(count))) : 0.0f;
  return e;
}

store_format::TfErrorEntry make_tf_error_entry(const ErrorHistogram& h, double field_min, double field_max) {
  store_format::TfErrorEntry e;
  if (h.total == 0) return e;
  constexpr int K = store_format::kTfErrorGroups;
  const double range = field_max - field_min;
  auto code = [&](double v, bool up) {
    if (!(range > 0)) return uint16_t(0);
    const double c = (v - field_min) / range * 65535.0;
    return uint16_t(std::clamp(up ? std::ceil(c) : std::floor(c), 0.0, 65535.0));
  };
  // Groups of about n / K pairs, cut at bin edges; a bin heavier than a group makes fewer, heavier groups.
  const double n = double(h.total);
  const double width = h.scale > 0 ? 1.0 / h.scale : 0.0;
  e.bound[0] = code(h.fine_min, false);
  int g = 0, b = 0;
  uint64_t taken = 0;
  while (g < K && b < kErrorBins && taken < h.total) {
    uint64_t c = 0;
    double sq = 0;
    const double target = double(g + 1) * n / K;
    while (b < kErrorBins && (c == 0 || double(taken + c + h.count[size_t(b)]) <= target + 0.5 || g == K - 1)) {
      c += h.count[size_t(b)];
      sq += h.sum_sq[size_t(b)];
      ++b;
    }
    taken += c;
    e.bound[g + 1] = taken == h.total ? code(h.fine_max, true) : code(std::min(h.fine_max, h.lo + width * b), true);
    if (c > 0) {
      const double rms = std::sqrt(sq / double(c));
      e.spread[g] = range > 0 ? uint16_t(std::min(65535.0, std::ceil(rms / range * 65535.0))) : 0;
      e.weight[g] = uint8_t(std::clamp(std::lround(double(c) / n * 255.0), 1L, 255L));
    }
    ++g;
  }
  for (int rest = g + 1; rest <= K; ++rest) e.bound[rest] = e.bound[g];
  return e;
}

namespace {

// The 8 samples around brick coordinate u (clamped into the brick) and their trilinear weights.
struct TrilinearStencil {
  size_t corner[8];
  double weight[8];
};

TrilinearStencil trilinear_stencil(uint32_t R, Vec3d u) {
  uint32_t i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(u[a], 0.0, double(R - 1));
    i0[a] = std::min(uint32_t(c), R - 2);
    t[a] = c - double(i0[a]);
  }
  TrilinearStencil st;
  for (int q = 0; q < 8; ++q) {
    const uint32_t dx = q & 1, dy = (q >> 1) & 1, dz = (q >> 2) & 1;
    st.corner[q] = (i0[0] + dx) + size_t(R) * ((i0[1] + dy) + size_t(R) * (i0[2] + dz));
    st.weight[q] = (dx ? t[0] : 1 - t[0]) * (dy ? t[1] : 1 - t[1]) * (dz ? t[2] : 1 - t[2]);
  }
  return st;
}

// interpolate_brick, but only where all 8 surrounding samples hold data; field f alone.
bool interpolate_inside(const BrickSamples& brick, Vec3d u, uint32_t f, double& out) {
  const uint32_t R = brick.resolution;
  const TrilinearStencil st = trilinear_stencil(R, u);
  const float* v = brick.values.data() + f * size_t(R) * R * R;
  double sum = 0;
  for (int q = 0; q < 8; ++q) {
    if (!brick.mask[st.corner[q]]) return false;
    sum += st.weight[q] * v[st.corner[q]];
  }
  out = sum;
  return true;
}

}  // namespace

bool interpolate_brick(const BrickSamples& brick, Vec3d u, double* out) {
  const uint32_t R = brick.resolution;
  const size_t n = size_t(R) * R * R;
  const TrilinearStencil st = trilinear_stencil(R, u);
  bool any = false;
  for (int q = 0; q < 8; ++q) any = any || brick.mask[st.corner[q]];
  if (!any) return false;
  for (uint32_t f = 0; f < brick.field_count; ++f) {
    const float* v = brick.values.data() + f * n;
    double sum = 0;
    for (int q = 0; q < 8; ++q) sum += st.weight[q] * v[st.corner[q]];
    out[f] = sum;
  }
  return true;
}

bool cell_interpolant_exceeds(const BrickSamples& brick, const Bounds& box, CellType type, const Vec3d* vertices,
                              std::span<const float* const> values, std::span<const double> thresholds) {
  const uint32_t R = brick.resolution;
  Vec3d scale;
  for (int a = 0; a < 3; ++a) {
    const double extent = box.hi[a] - box.lo[a];
    scale[a] = extent > 0 ? double(R - 1) / extent : 0.0;
  }
  const int n = cell_vertex_count(type);
  // Test point p with value per field sum_i w_i values[f][i] over the listed vertices.
  auto exceeds = [&](Vec3d p, std::span<const uint8_t> ids) {
    if (!box_contains(box, p)) return false;
    const Vec3d u{(p.x - box.lo.x) * scale.x, (p.y - box.lo.y) * scale.y, (p.z - box.lo.z) * scale.z};
    for (size_t f = 0; f < values.size(); ++f) {
      if (!values[f]) continue;
      double exact = 0;
      for (uint8_t i : ids) exact += values[f][i];
      exact /= double(ids.size());
      double voxel = 0;
      if (!interpolate_inside(brick, u, uint32_t(f), voxel)) return false;
      if (std::abs(voxel - exact) > thresholds[f]) return true;
    }
    return false;
  };
  std::array<uint8_t, kMaxCellVertices> all{};
  Vec3d centre{0, 0, 0};
  for (int i = 0; i < n; ++i) {
    all[size_t(i)] = uint8_t(i);
    centre = centre + vertices[i];
    const uint8_t one[1] = {uint8_t(i)};
    if (exceeds(vertices[i], one)) return true;
  }
  for (const auto& e : cell_edges(type)) {
    if (exceeds((vertices[e[0]] + vertices[e[1]]) * 0.5, e)) return true;
  }
  return exceeds(centre * (1.0 / n), std::span<const uint8_t>(all.data(), size_t(n)));
}

void measure_against_children(const BrickSamples& brick, const std::array<const BrickSamples*, 8>& children,
                              std::span<ErrorSum> sums) {
  const uint32_t R = brick.resolution, F = brick.field_count;
  const size_t n = size_t(R) * R * R;
  // Child line m of octant half h is parent line (h (R - 1) + m) / 2: a parent line when even, else halfway between
  // two. So along each axis the lookup has corners lo, hi with weights 1, 0 or 1/2, 1/2, and interpolate_brick's
  // trilinear sum separates: for each child row (y, z), the bilinear blend in y and z of the parent's samples is
  // taken once per parent x (`row`, with the "any corner has data" mask in `row_mask`), and each child sample then
  // reads one or two of them. This runs over 8 R³ samples per interior node. The products are exact (weights are
  // powers of two), so the sums equal interpolate_brick's whenever the values' magnitudes are within 2^29 of each
  // other, that is on any real field.
  struct Axis {
    std::vector<uint32_t> lo, hi;  // parent sample indices along the axis
    std::vector<double> w_hi;      // 0 or 0.5
  };
  Axis axes[2];  // per half; the same for the three axes
  for (uint32_t half = 0; half < 2; ++half) {
    Axis& ax = axes[half];
    for (uint32_t x = 0; x < R; ++x) {
      const uint32_t line = half * (R - 1) + x;
      ax.lo.push_back(line / 2);
      ax.hi.push_back(line / 2 + line % 2);
      ax.w_hi.push_back(line % 2 ? 0.5 : 0.0);
    }
  }
  std::vector<double> row(size_t(F) * R);
  std::vector<uint8_t> row_mask(R);
  const uint8_t* m = brick.mask.data();
  for (uint32_t o = 0; o < 8; ++o) {
    const BrickSamples* child = children[o];
    if (!child || child->valid == 0) continue;
    const Axis &X = axes[o & 1], &Y = axes[(o >> 1) & 1], &Z = axes[(o >> 2) & 1];
    const uint32_t px0 = X.lo[0], px1 = X.hi[R - 1];  // the parent's x range under this child
    for (uint32_t z = 0; z < R; ++z)
      for (uint32_t y = 0; y < R; ++y) {
        const size_t s0 = size_t(R) * (y + size_t(R) * z);
        const uint8_t* cm = child->mask.data() + s0;
        if (std::all_of(cm, cm + R, [](uint8_t b) { return b == 0; })) continue;  // no data in this child row
        const size_t c00 = size_t(R) * (Y.lo[y] + size_t(R) * Z.lo[z]),
                     c10 = size_t(R) * (Y.hi[y] + size_t(R) * Z.lo[z]),
                     c01 = size_t(R) * (Y.lo[y] + size_t(R) * Z.hi[z]),
                     c11 = size_t(R) * (Y.hi[y] + size_t(R) * Z.hi[z]);
        const double wy = Y.w_hi[y], wz = Z.w_hi[z];
        const double w00 = (1 - wy) * (1 - wz), w10 = wy * (1 - wz), w01 = (1 - wy) * wz, w11 = wy * wz;
        for (uint32_t px = px0; px <= px1; ++px) row_mask[px] = m[px + c00] | m[px + c10] | m[px + c01] | m[px + c11];
        for (uint32_t f = 0; f < F; ++f) {
          const float* v = brick.values.data() + f * n;
          double* rf = row.data() + size_t(f) * R;
          for (uint32_t px = px0; px <= px1; ++px) {
            rf[px] = w00 * v[px + c00] + w10 * v[px + c10] + w01 * v[px + c01] + w11 * v[px + c11];
          }
        }
        // Field by field (each field's sum sees its samples in the same order), in a local accumulator: through
        // memory, the sum's dependency chain would cost a store-to-load round trip per sample.
        for (uint32_t f = 0; f < F; ++f) {
          const double* rf = row.data() + size_t(f) * R;
          const float* cv = child->values.data() + f * n + s0;
          ErrorSum acc = sums[f];
          for (uint32_t x = 0; x < R; ++x) {
            if (!cm[x]) continue;
            const uint32_t lo = X.lo[x], hi = X.hi[x];
            if (!(row_mask[lo] | row_mask[hi])) continue;
            const double interpolated = lo == hi ? rf[lo] : 0.5 * (rf[lo] + rf[hi]);
            acc.add(interpolated, double(cv[x]));
          }
          sums[f] = acc;
        }
      }
  }
}

BrickPointMeasure::BrickPointMeasure(const BrickSamples& brick, const Bounds& box)
    : brick_(brick), box_(box), interpolated_(brick.field_count) {
  for (int a = 0; a < 3; ++a) {
    const double extent = box.hi[a] - box.lo[a];
    scale_[a] = extent > 0 ? double(brick.resolution - 1) / extent : 0.0;
  }
}

void BrickPointMeasure::add(Vec3d p, const float* exact, std::span<ErrorSum> sums) {
  const Vec3d u{(p.x - box_.lo.x) * scale_.x, (p.y - box_.lo.y) * scale_.y, (p.z - box_.lo.z) * scale_.z};
  if (!interpolate_brick(brick_, u, interpolated_.data())) return;
  for (uint32_t f = 0; f < brick_.field_count; ++f)
    if (!std::isnan(exact[f])) sums[f].add(interpolated_[f], double(exact[f]));
}

void measure_against_points(const BrickSamples& brick, const Bounds& box, const OctreeDataPoints& data,
                            std::span<const uint64_t> points, std::span<ErrorSum> sums) {
  BrickPointMeasure measure(brick, box);
  std::vector<float> exact(brick.field_count);
  for (uint64_t p : points) {
    for (uint32_t f = 0; f < brick.field_count; ++f) exact[f] = data.value(p, f);
    measure.add(data.position(p), exact.data(), sums);
  }
}

}  // namespace ugvr
