#include "ugvr/render/field_histogram.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <array>
#include <cmath>
#include <string>
#include <type_traits>
#include <variant>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_volume.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

// Bins values into counts over [lo, hi] (see the header for the edge cases).
class Binner {
 public:
  Binner(double lo, double hi, int bins) : lo_(lo), counts_(check_bins(bins), 0) {
    scale_ = hi > lo ? bins / (hi - lo) : 0;
  }
  void add(double v) {
    const int i = index(v);
    if (i >= 0) ++counts_[size_t(i)];
  }
  // The bin of `v`; -1 for a value that is not counted (not finite).
  int index(double v) const {
    if (!std::isfinite(v)) return -1;
    const int n = int(counts_.size());
    if (!(scale_ > 0)) return n / 2;
    const double t = std::floor((v - lo_) * scale_);
    return t < 0 ? 0 : t >= n ? n - 1 : int(t);
  }
  int bins() const { return int(counts_.size()); }
  std::vector<uint64_t> take() { return std::move(counts_); }

 private:
  static size_t check_bins(int bins) {
    if (bins < 1 || bins > kMaxHistogramBins)
      fail_in("histogram",
              "bins must be in [1, " + std::to_string(kMaxHistogramBins) + "], found " + std::to_string(bins));
    return size_t(bins);
  }
  double lo_, scale_ = 0;
  std::vector<uint64_t> counts_;
};

template <class T>
std::vector<uint64_t> histogram_of(std::span<const T> values, double lo, double hi, int bins) {
  Binner b(lo, hi, bins);
  for (const T v : values) b.add(double(v));
  return b.take();
}

// A cell as the weighting sees it: its absolute volume and its corners' point indices (VTK order).
struct CellCorners {
  double volume = 0;
  std::array<uint64_t, 8> points{};
  int count = 0;
};

// The cells of an unstructured mesh, cell c in the mesh's order (a cell field's).
struct MeshCells {
  const UnstructuredMesh& mesh;
  uint64_t count() const { return mesh.cell_count(); }
  uint64_t point_count() const { return mesh.point_count(); }
  bool get(uint64_t c, CellCorners& out) const {
    const auto v = mesh.cell(c);
    out.count = int(v.size());
    for (int i = 0; i < out.count; ++i) out.points[size_t(i)] = v[size_t(i)];
    if (mesh.cell_types[c] == CellType::Tetra) {  // most cells of most meshes: a determinant, not 4 faces
      const Vec3d o = to_double(mesh.points[v[0]]);
      const Vec3d a = to_double(mesh.points[v[1]]) - o, b = to_double(mesh.points[v[2]]) - o,
                  d = to_double(mesh.points[v[3]]) - o;
      out.volume = std::abs(dot(a, cross(b, d))) / 6.0;
    } else {
      out.volume = std::abs(cell_volume(mesh, c));
    }
    return true;
  }
};

// The hexahedra of a structured grid, cell (i, j, k) at GridDims::cell_index; `position(p)` a point's position. A
// cell with an IBLANKed corner does not exist (get returns false).
template <class Position>
struct StructuredCells {
  GridDims dims;
  Position position;
  const std::vector<int32_t>* iblank = nullptr;
  uint64_t count() const { return dims.cell_count(); }
  uint64_t point_count() const { return dims.point_count(); }
  bool get(uint64_t c, CellCorners& out) const {
    const auto n = dims.cells();
    const uint64_t i = c % n[0], j = (c / n[0]) % n[1], k = c / (uint64_t(n[0]) * n[1]);
    // VTK's hexahedron: the k face counter-clockwise from (i, j), then the k + 1 face.
    static constexpr int kDi[8] = {0, 1, 1, 0, 0, 1, 1, 0}, kDj[8] = {0, 0, 1, 1, 0, 0, 1, 1},
                         kDk[8] = {0, 0, 0, 0, 1, 1, 1, 1};
    std::array<Vec3d, 8> corners;
    out.count = 8;
    for (int v = 0; v < 8; ++v) {
      const uint64_t p = dims.point_index(i + kDi[v], j + kDj[v], k + kDk[v]);
      if (iblank && (*iblank)[p] == 0) return false;
      out.points[size_t(v)] = p;
      corners[size_t(v)] = position(p);
    }
    out.volume = std::abs(cell_volume(CellType::Hexahedron, corners));
    return true;
  }
};

template <class Cells>
std::vector<double> weights_of(const Cells& cells, const Field& field, int component, double lo, double hi, int bins) {
  const Binner binner(lo, hi, bins);
  const bool per_cell = field.association() == Association::Cell;
  const uint64_t needed = per_cell ? cells.count() : cells.point_count();
  if (field.tuples() != needed)
    fail_in("histogram", "field '" + field.name() + "' has " + std::to_string(field.tuples()) + " values, the grid " +
                             std::to_string(needed) + (per_cell ? " cells" : " points"));
  // A vertex field's bins once per point (a point is a corner of several cells).
  std::vector<int32_t> point_bin;
  if (!per_cell) {
    point_bin.resize(size_t(needed));
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, needed, uint64_t(1) << 16),
                      [&](const tbb::blocked_range<uint64_t>& r) {
                        for (uint64_t p = r.begin(); p != r.end(); ++p)
                          point_bin[size_t(p)] = binner.index(field.scalar(p, component));
                      });
  }
  using Weights = std::vector<double>;
  // Chunks of a fixed size reduced in a fixed order: the sums (hence the rounded counts) do not depend on threads.
  constexpr uint64_t kChunk = uint64_t(1) << 15;
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<uint64_t>(0, cells.count(), kChunk), Weights(size_t(binner.bins()), 0.0),
      [&](const tbb::blocked_range<uint64_t>& r, Weights w) {
        CellCorners cell;
        for (uint64_t c = r.begin(); c != r.end(); ++c) {
          if (!cells.get(c, cell) || !(cell.volume > 0)) continue;
          if (per_cell) {
            const int b = binner.index(field.scalar(c, component));
            if (b >= 0) w[size_t(b)] += cell.volume;
            continue;
          }
          const double share = cell.volume / cell.count;
          for (int v = 0; v < cell.count; ++v) {
            const int b = point_bin[size_t(cell.points[size_t(v)])];
            if (b >= 0) w[size_t(b)] += share;
          }
        }
        return w;
      },
      [](Weights a, const Weights& b) {
        for (size_t i = 0; i < a.size(); ++i) a[i] += b[i];
        return a;
      });
}

template <class Position>
StructuredCells<Position> structured_cells(const GridDims& dims, Position position,
                                           const std::vector<int32_t>* iblank = nullptr) {
  return {dims, std::move(position), iblank};
}

}  // namespace

std::vector<uint64_t> value_histogram(std::span<const float> values, double lo, double hi, int bins) {
  return histogram_of(values, lo, hi, bins);
}

std::vector<uint64_t> value_histogram(std::span<const double> values, double lo, double hi, int bins) {
  return histogram_of(values, lo, hi, bins);
}

std::vector<uint64_t> field_histogram(const Field& field, int component, int bins) {
  const Range r = field.range(component);
  return field_histogram(field, component, r.min, r.max, bins);
}

std::vector<uint64_t> field_histogram(const Field& field, int component, double lo, double hi, int bins) {
  Binner b(lo, hi, bins);
  for (uint64_t t = 0; t < field.tuples(); ++t) b.add(field.scalar(t, component));
  return b.take();
}

std::vector<double> volume_weights(const UnstructuredMesh& mesh, const Field& field, int component, double lo,
                                   double hi, int bins) {
  return weights_of(MeshCells{mesh}, field, component, lo, hi, bins);
}

std::vector<double> volume_weights(const Grid& grid, const Field& field, int component, double lo, double hi,
                                   int bins) {
  return std::visit(
      [&](const auto& g) -> std::vector<double> {
        using G = std::decay_t<decltype(g)>;
        if constexpr (std::is_same_v<G, UnstructuredMesh>) {
          return volume_weights(g, field, component, lo, hi, bins);
        } else if constexpr (std::is_same_v<G, StructuredGrid>) {
          const auto at = [&g](uint64_t p) { return to_double(g.points[p]); };
          return weights_of(structured_cells(g.dims, at, g.has_iblank() ? &g.iblank : nullptr), field, component, lo,
                            hi, bins);
        } else {  // ImageGrid, RectilinearGrid: positions from (i, j, k)
          const GridDims d = g.dims;
          const auto at = [&g, d](uint64_t p) {
            const uint64_t i = p % d.points[0], j = (p / d.points[0]) % d.points[1],
                           k = p / (uint64_t(d.points[0]) * d.points[1]);
            return g.point(i, j, k);
          };
          return weights_of(structured_cells(d, at), field, component, lo, hi, bins);
        }
      },
      grid);
}

std::vector<uint64_t> weighted_counts(std::span<const double> weights, std::span<const uint64_t> unweighted) {
  double total_weight = 0;
  for (const double w : weights) total_weight += w;
  uint64_t total = 0;
  for (const uint64_t n : unweighted) total += n;
  if (!(total_weight > 0) || weights.size() != unweighted.size())
    return std::vector<uint64_t>(unweighted.begin(), unweighted.end());
  std::vector<uint64_t> counts(weights.size());
  const double scale = double(total) / total_weight;
  for (size_t i = 0; i < counts.size(); ++i) counts[i] = uint64_t(std::llround(weights[i] * scale));
  return counts;
}

std::vector<uint64_t> volume_histogram(const Grid& grid, const Field& field, int component, double lo, double hi,
                                       int bins) {
  return weighted_counts(volume_weights(grid, field, component, lo, hi, bins),
                         field_histogram(field, component, lo, hi, bins));
}

std::vector<uint64_t> volume_histogram(const UnstructuredMesh& mesh, const Field& field, int component, int bins) {
  const Range r = field.range(component);
  return weighted_counts(volume_weights(mesh, field, component, r.min, r.max, bins),
                         field_histogram(field, component, r.min, r.max, bins));
}

std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, int bins, int max_level) {
  if (field >= store.field_count()) return store_histogram(store, field, 0, 1, bins, max_level);  // its error
  const BrickStoreField& f = store.layout().fields[field];
  return store_histogram(store, field, f.min, f.max, bins, max_level);
}

std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, double lo, double hi, int bins,
                                      int max_level) {
  if (field >= store.field_count())
    fail_in("histogram", "field index " + std::to_string(field) + " out of range (the store has " +
                             std::to_string(store.field_count()) + " fields)");
  Binner b(lo, hi, bins);
  const size_t r = store.resolution();
  std::vector<float> samples(r * r * r);
  std::vector<uint8_t> mask(r * r * r);
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& n = store.node(id);
    if (int(n.level) > max_level || !n.has_brick()) continue;
    store.read_brick(id, field, samples.data(), mask.data());
    for (size_t i = 0; i < samples.size(); ++i)
      if (mask[i]) b.add(samples[i]);
  }
  return b.take();
}

}  // namespace ugvr
