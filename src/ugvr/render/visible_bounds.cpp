#include "ugvr/render/visible_bounds.h"

#include <algorithm>
#include <cmath>

#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/renderer.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

bool reaches(const TransferFunction& tf, double lo, double hi, double threshold) {
  return max_opacity(tf, lo, hi) > threshold;
}

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

Bounds visible_cell_bounds(const WalkMesh& mesh, std::span<const float> values, bool per_cell,
                           const TransferFunction& tf, double threshold) {
  Bounds box;
  for (int k = 0; k < 4; ++k) {
    const int n = cell_vertex_count(kAllCellTypes[size_t(k)]);
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
      if (!(lo <= hi) || !reaches(tf, lo, hi, threshold)) continue;
      for (int i = 0; i < n; ++i) {
        const Vec3f p = mesh.points[v[i]];
        box.add(Vec3d{p.x, p.y, p.z});
      }
    }
  }
  return box;
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

Bounds visible_node_bounds(const BrickStoreReader& store, uint32_t field, const TransferFunction& tf, double threshold,
                           int max_level) {
  Bounds box;
  const std::span<const BrickNode> nodes = store.nodes();
  for (uint64_t id = 0; id < nodes.size(); ++id) {
    const BrickNode& node = nodes[id];
    // The cut at max_level: its nodes, and the leaves above it. A node's min/max covers its subtree.
    if (node.level > max_level || (node.level < max_level && !node.is_leaf())) continue;
    const FieldStats& s = store.stats(id, field);
    if (!(s.min <= s.max) || !reaches(tf, s.min, s.max, threshold)) continue;
    box.add(store.bounds(id));
  }
  return box;
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
