#include "ugvr/render/visible_bounds.h"

#include <algorithm>
#include <cmath>

#include "ugvr/grid/cell_volume.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/renderer.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

// `box` meets the data's bounds: the store's octree root is a cube around them, a node may stick out.
Bounds clipped(const Bounds& box, const Bounds& bounds) {
  Bounds c;
  c.lo = {std::max(box.lo.x, bounds.lo.x), std::max(box.lo.y, bounds.lo.y), std::max(box.lo.z, bounds.lo.z)};
  c.hi = {std::min(box.hi.x, bounds.hi.x), std::min(box.hi.y, bounds.hi.y), std::min(box.hi.z, bounds.hi.z)};
  return c;
}

// Nearly the whole domain: framing it would move the camera by a few percent for nothing (a transfer function that
// draws almost every cell, as auto's ramp on a field without a dominant mode, keeps today's view bit for bit).
bool nearly_covers(const Bounds& box, const Bounds& bounds) {
  const Vec3d b = box.size(), d = bounds.size();
  for (int a = 0; a < 3; ++a)
    if (b[a] < kNearlyAllVisible * d[a]) return false;
  return true;
}

// Widened about its centre so that its diagonal is at least `min_diagonal` (each axis grows by the same factor; a
// flat or point box grows on every axis by the same length).
Bounds widened(const Bounds& box, double min_diagonal) {
  const double diagonal = length(box.size());
  if (diagonal >= min_diagonal) return box;
  const Vec3d c = box.center();
  Vec3d half = box.size() * 0.5;
  if (diagonal > 0) {
    half = half * (min_diagonal / diagonal);
  } else {
    const double h = 0.5 * min_diagonal / std::sqrt(3.0);
    half = {h, h, h};
  }
  Bounds w;
  w.lo = c - half;
  w.hi = c + half;
  return w;
}

}  // namespace

double max_opacity(const TransferFunction& tf, double lo, double hi) {
  if (std::isnan(lo) || std::isnan(hi) || tf.opacity_points.empty()) return 0;
  if (hi < lo) std::swap(lo, hi);
  double most = std::max(tf.opacity(lo), tf.opacity(hi));
  // Between the ends the function is linear except at its points: the maximum is at an end or at a point inside.
  for (const OpacityPoint& p : tf.opacity_points)
    if (p.x > lo && p.x < hi) most = std::max(most, p.opacity);
  return most;
}

VisibleWeights::VisibleWeights(const Bounds& over_) : over(over_) {
  for (int a = 0; a < 3; ++a) lo[size_t(a)].fill(INFINITY), hi[size_t(a)].fill(-INFINITY);
}

void VisibleWeights::add(const Bounds& piece, double w) {
  if (piece.empty()) return;
  all.add(piece);
  const Vec3d c = piece.center(), extent = over.size();
  for (int a = 0; a < 3; ++a) {
    const double t = extent[a] > 0 ? std::floor((c[a] - over.lo[a]) / extent[a] * kFramingBins) : 0;
    const size_t i = t < 0 ? 0 : t >= kFramingBins ? kFramingBins - 1 : size_t(t);
    weight[size_t(a)][i] += w;
    lo[size_t(a)][i] = std::min(lo[size_t(a)][i], piece.lo[a]);
    hi[size_t(a)][i] = std::max(hi[size_t(a)][i], piece.hi[a]);
  }
}

void VisibleWeights::merge(const VisibleWeights& other) {
  all.add(other.all);
  for (size_t a = 0; a < 3; ++a)
    for (size_t i = 0; i < size_t(kFramingBins); ++i) {
      weight[a][i] += other.weight[a][i];
      lo[a][i] = std::min(lo[a][i], other.lo[a][i]);
      hi[a][i] = std::max(hi[a][i], other.hi[a][i]);
    }
}

std::vector<double> VisibleWeights::flat() const {
  std::vector<double> out;
  out.reserve(kFlatSize);
  for (const auto& w : weight) out.insert(out.end(), w.begin(), w.end());
  for (const auto& l : lo) out.insert(out.end(), l.begin(), l.end());
  for (int a = 0; a < 3; ++a) out.push_back(all.lo[a]);
  for (const auto& h : hi) out.insert(out.end(), h.begin(), h.end());
  for (int a = 0; a < 3; ++a) out.push_back(all.hi[a]);
  return out;
}

std::optional<VisibleWeights> VisibleWeights::from_flat(const Bounds& over, std::span<const double> values) {
  if (values.size() != kFlatSize) return std::nullopt;
  VisibleWeights w(over);
  const double* p = values.data();
  const auto take = [&p](std::array<double, kFramingBins>& to) {
    std::copy_n(p, kFramingBins, to.begin());
    p += kFramingBins;
  };
  for (auto& x : w.weight) take(x);
  for (auto& x : w.lo) take(x);
  for (int a = 0; a < 3; ++a) w.all.lo[a] = *p++;
  for (auto& x : w.hi) take(x);
  for (int a = 0; a < 3; ++a) w.all.hi[a] = *p++;
  return w;
}

Bounds all_space() {
  Bounds b;
  std::swap(b.lo, b.hi);  // (-inf, +inf) on every axis
  return b;
}

bool owns(const Bounds& own, Vec3d c) {
  for (int a = 0; a < 3; ++a)
    if (!(own.lo[a] <= c[a] && c[a] < own.hi[a])) return false;
  return true;
}

Bounds VisibleWeights::box() const {
  if (all.empty()) return all;
  Bounds b;
  for (int a = 0; a < 3; ++a) {
    const auto& w = weight[size_t(a)];
    double total = 0;
    for (const double x : w) total += x;
    if (!(total > 0)) return all;
    // The first and last bins past the tails' weight: the pieces in between are kept.
    const double tail = 0.5 * (1 - kFramedShare) * total;
    size_t first = 0, last = kFramingBins - 1;
    for (double below = 0; first < last && below + w[first] <= tail; ++first) below += w[first];
    for (double above = 0; last > first && above + w[last] <= tail; --last) above += w[last];
    double from = INFINITY, to = -INFINITY;
    for (size_t i = first; i <= last; ++i)
      if (w[i] > 0) from = std::min(from, lo[size_t(a)][i]), to = std::max(to, hi[size_t(a)][i]);
    b.lo[a] = from, b.hi[a] = to;
  }
  return b;
}

VisibleWeights visible_cell_weights(const WalkMesh& mesh, std::span<const float> values, bool per_cell,
                                    const TransferFunction& tf, double threshold, const Bounds& over,
                                    const Bounds& own) {
  VisibleWeights weights(over);
  std::array<Vec3d, 8> corners;
  for (int k = 0; k < 4; ++k) {
    const CellType type = kAllCellTypes[size_t(k)];
    const int n = cell_vertex_count(type);
    for (uint32_t c = mesh.type_begin[size_t(k)]; c < mesh.type_begin[size_t(k) + 1]; ++c) {
      const uint32_t* v = mesh.cell_vertices(c, k);
      double lo = INFINITY, hi = -INFINITY;
      if (per_cell) {
        lo = hi = c < values.size() ? double(values[c]) : NAN;
      } else {
        for (int i = 0; i < n; ++i) {
          const double s = v[i] < values.size() ? double(values[v[i]]) : NAN;
          if (std::isnan(s)) continue;  // no data there; the cell's other vertices still draw
          lo = std::min(lo, s), hi = std::max(hi, s);
        }
      }
      if (!(lo <= hi)) continue;
      const double opacity = max_opacity(tf, lo, hi);
      if (!(opacity > threshold)) continue;
      Bounds box;
      Vec3d sum{0, 0, 0};  // the centroid as kd_partition.h's cell_centroids sums it, to own what the kd-tree does
      for (int i = 0; i < n; ++i) {
        corners[size_t(i)] = to_double(mesh.points[v[i]]);
        box.add(corners[size_t(i)]);
        sum = sum + corners[size_t(i)];
      }
      if (!owns(own, sum * (1.0 / double(n)))) continue;
      const double volume = std::abs(cell_volume(type, std::span<const Vec3d>(corners.data(), size_t(n))));
      weights.add(box, opacity * volume);
    }
  }
  return weights;
}

Bounds visible_cell_bounds(const WalkMesh& mesh, std::span<const float> values, bool per_cell,
                           const TransferFunction& tf, double threshold) {
  return visible_cell_weights(mesh, values, per_cell, tf, threshold, mesh.bounds, all_space()).box();
}

VisibleWeights visible_cell_weights(const ExactEngine& engine, const TransferFunction& tf, double threshold,
                                    const Bounds& over, const Bounds& own) {
  return visible_cell_weights(engine.walk_mesh(), engine.bound_values(), engine.per_cell(), tf, threshold, over, own);
}

Bounds visible_cell_bounds(const ExactEngine& engine, const TransferFunction& tf, double threshold) {
  return visible_cell_bounds(engine.walk_mesh(), engine.bound_values(), engine.per_cell(), tf, threshold);
}

std::optional<Bounds> visible_node_bounds(const BrickStoreReader& store, const std::string& field,
                                          const TransferFunction& tf, double threshold) {
  const int index = store.field_index(field);
  if (index < 0) return std::nullopt;
  return visible_node_bounds(store, uint32_t(index), tf, threshold);
}

VisibleWeights visible_node_weights(const BrickStoreReader& store, uint32_t field, const TransferFunction& tf,
                                    double threshold, int max_level, const Bounds& over, const Bounds& own) {
  const Bounds& data = store.layout().data;
  VisibleWeights weights(over);
  const std::span<const BrickNode> nodes = store.nodes();
  for (uint64_t id = 0; id < nodes.size(); ++id) {
    const BrickNode& node = nodes[id];
    // The cut at max_level: its nodes, and the leaves above it. A node's min/max covers its subtree.
    if (node.level > max_level || (node.level < max_level && !node.is_leaf())) continue;
    const FieldStats& s = store.stats(id, field);
    if (!(s.min <= s.max)) continue;
    const double opacity = max_opacity(tf, s.min, s.max);
    if (!(opacity > threshold)) continue;
    const Bounds box = store.bounds(id);
    if (!owns(own, box.center())) continue;
    // A node's cell may stick out of the data (the root is a cube around it): its weight is the part inside.
    const Vec3d size = clipped(box, data).size();
    weights.add(box, opacity * size.x * size.y * size.z);
  }
  return weights;
}

Bounds visible_node_bounds(const BrickStoreReader& store, uint32_t field, const TransferFunction& tf, double threshold,
                           int max_level) {
  const Bounds& data = store.layout().data;
  return visible_node_weights(store, field, tf, threshold, max_level, data, all_space()).box();
}

Camera framed_default_camera(const Bounds& bounds, const std::optional<Bounds>& visible, double view_angle) {
  if (!visible || visible->empty()) return default_camera(bounds, view_angle);
  const Bounds box = clipped(*visible, bounds);
  if (box.empty() || nearly_covers(box, bounds)) return default_camera(bounds, view_angle);
  return default_camera(widened(box, kMinVisibleFraction * length(bounds.size())), view_angle);
}

Camera framed_default_camera(const Renderer& renderer, const TransferFunction& tf, double view_angle) {
  return framed_default_camera(renderer.bounds(), renderer.visible_bounds(tf, kVisibleOpacity), view_angle);
}

}  // namespace ugvr
