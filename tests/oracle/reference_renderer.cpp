#include "oracle/reference_renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ugvr::oracle {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Mat3 {
  Vec3d c0, c1, c2;  // columns
};

double det(const Mat3& m) { return dot(m.c0, cross(m.c1, m.c2)); }

// Solves m * x = b by Cramer's rule; false when m is (numerically) singular.
bool solve(const Mat3& m, Vec3d b, Vec3d& x) {
  const double d = det(m);
  // Relative to the column lengths, squared to spare the square roots.
  const double scale2 = dot(m.c0, m.c0) * dot(m.c1, m.c1) * dot(m.c2, m.c2);
  if (!(d != 0) || !(d * d > 1e-28 * scale2)) return false;
  x = {dot(b, cross(m.c1, m.c2)) / d, dot(m.c0, cross(b, m.c2)) / d, dot(m.c0, cross(m.c1, b)) / d};
  return true;
}

// Parametric derivatives of the shape functions: d[i] = (dN_i/dr, dN_i/ds, dN_i/dt).
void shape_derivatives(CellType type, const std::array<double, 3>& rst, Vec3d* d) {
  const double r = rst[0], s = rst[1], t = rst[2];
  switch (type) {
    case CellType::Tetra:
      d[0] = {-1, -1, -1};
      d[1] = {1, 0, 0};
      d[2] = {0, 1, 0};
      d[3] = {0, 0, 1};
      return;
    case CellType::Hexahedron: {
      static constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                            {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
      for (int i = 0; i < 8; ++i) {
        const double fr = kCorner[i][0] ? r : 1 - r, gr = kCorner[i][0] ? 1 : -1;
        const double fs = kCorner[i][1] ? s : 1 - s, gs = kCorner[i][1] ? 1 : -1;
        const double ft = kCorner[i][2] ? t : 1 - t, gt = kCorner[i][2] ? 1 : -1;
        d[i] = {gr * fs * ft, fr * gs * ft, fr * fs * gt};
      }
      return;
    }
    case CellType::Wedge: {
      const double u = 1 - r - s;
      d[0] = {-(1 - t), -(1 - t), -u};
      d[1] = {1 - t, 0, -r};
      d[2] = {0, 1 - t, -s};
      d[3] = {-t, -t, u};
      d[4] = {t, 0, r};
      d[5] = {0, t, s};
      return;
    }
    case CellType::Pyramid:
      d[0] = {-(1 - s) * (1 - t), -(1 - r) * (1 - t), -(1 - r) * (1 - s)};
      d[1] = {(1 - s) * (1 - t), -r * (1 - t), -r * (1 - s)};
      d[2] = {s * (1 - t), r * (1 - t), -r * s};
      d[3] = {-s * (1 - t), (1 - r) * (1 - t), -(1 - r) * s};
      d[4] = {0, 0, 1};
      return;
  }
}

bool inside_reference(CellType type, const std::array<double, 3>& p) {
  const double lo = -kParametricTolerance, hi = 1 + kParametricTolerance;
  const double r = p[0], s = p[1], t = p[2];
  switch (type) {
    case CellType::Tetra: return r >= lo && s >= lo && t >= lo && r + s + t <= hi;
    case CellType::Wedge: return r >= lo && s >= lo && r + s <= hi && t >= lo && t <= hi;
    case CellType::Hexahedron:
    case CellType::Pyramid: return r >= lo && r <= hi && s >= lo && s <= hi && t >= lo && t <= hi;
  }
  return false;
}

Vec3d map_point(CellType type, const Vec3d* corners, const std::array<double, 3>& rst) {
  double w[8];
  shape_functions(type, rst, w);
  Vec3d x{};
  for (int i = 0; i < cell_vertex_count(type); ++i) x = x + corners[i] * w[i];
  return x;
}

}  // namespace

void shape_functions(CellType type, const std::array<double, 3>& rst, double* w) {
  const double r = rst[0], s = rst[1], t = rst[2];
  switch (type) {
    case CellType::Tetra:
      w[0] = 1 - r - s - t;
      w[1] = r;
      w[2] = s;
      w[3] = t;
      return;
    case CellType::Hexahedron:
      w[0] = (1 - r) * (1 - s) * (1 - t);
      w[1] = r * (1 - s) * (1 - t);
      w[2] = r * s * (1 - t);
      w[3] = (1 - r) * s * (1 - t);
      w[4] = (1 - r) * (1 - s) * t;
      w[5] = r * (1 - s) * t;
      w[6] = r * s * t;
      w[7] = (1 - r) * s * t;
      return;
    case CellType::Wedge:
      w[0] = (1 - r - s) * (1 - t);
      w[1] = r * (1 - t);
      w[2] = s * (1 - t);
      w[3] = (1 - r - s) * t;
      w[4] = r * t;
      w[5] = s * t;
      return;
    case CellType::Pyramid:
      w[0] = (1 - r) * (1 - s) * (1 - t);
      w[1] = r * (1 - s) * (1 - t);
      w[2] = r * s * (1 - t);
      w[3] = (1 - r) * s * (1 - t);
      w[4] = t;
      return;
  }
}

namespace {

// locate_in_cell for a cell whose size (its bounding box diagonal) is known.
std::optional<std::array<double, 3>> invert_cell(CellType type, const Vec3d* c, Vec3d p,
                                                 const std::array<double, 3>* start, double size) {
  if (type == CellType::Tetra) {
    // The map is affine: one linear solve gives the barycentric coordinates.
    Vec3d x;
    if (!solve({c[1] - c[0], c[2] - c[0], c[3] - c[0]}, p - c[0], x)) return std::nullopt;
    const std::array<double, 3> rst{x.x, x.y, x.z};
    if (!inside_reference(type, rst)) return std::nullopt;
    return rst;
  }
  const int n = cell_vertex_count(type);
  std::array<double, 3> rst = start                       ? *start
                              : type == CellType::Wedge   ? std::array<double, 3>{1.0 / 3, 1.0 / 3, 0.5}
                              : type == CellType::Pyramid ? std::array<double, 3>{0.5, 0.5, 0.2}
                                                          : std::array<double, 3>{0.5, 0.5, 0.5};
  // Newton on x(rst) = p. Quadratic convergence from inside well-shaped cells (a step below 1e-11 leaves an error
  // ~1e-22); points outside either converge to parameters outside the reference cell or diverge, and both are
  // rejected below.
  bool converged = false;
  for (int iter = 0; iter < 50; ++iter) {
    double w[8];
    Vec3d d[8];
    shape_functions(type, rst, w);
    shape_derivatives(type, rst, d);
    Vec3d x{}, jr{}, js{}, jt{};
    for (int i = 0; i < n; ++i) {
      x = x + c[i] * w[i];
      jr = jr + c[i] * d[i].x;
      js = js + c[i] * d[i].y;
      jt = jt + c[i] * d[i].z;
    }
    const Vec3d residual = p - x;
    if (dot(residual, residual) <= 1e-26 * size * size) {
      converged = true;
      break;
    }
    Vec3d delta;
    // A singular Jacobian happens only at degenerate points (a pyramid's apex): the residual decides then.
    if (!solve({jr, js, jt}, residual, delta)) break;
    rst = {rst[0] + delta.x, rst[1] + delta.y, rst[2] + delta.z};
    if (std::abs(rst[0]) > 10 || std::abs(rst[1]) > 10 || std::abs(rst[2]) > 10) return std::nullopt;
    if (std::max({std::abs(delta.x), std::abs(delta.y), std::abs(delta.z)}) < 1e-11) {
      converged = true;
      break;
    }
  }
  if (!converged && length(p - map_point(type, c, rst)) > 1e-10 * size) return std::nullopt;
  if (!inside_reference(type, rst)) return std::nullopt;
  return rst;
}

}  // namespace

std::optional<std::array<double, 3>> locate_in_cell(CellType type, const Vec3d* c, Vec3d p,
                                                    const std::array<double, 3>* start) {
  Bounds box;
  for (int i = 0; i < cell_vertex_count(type); ++i) box.add(c[i]);
  return invert_cell(type, c, p, start, length(box.size()));
}

namespace {

// Piecewise-linear interpolation clamped at the ends, in TransferFunction's arithmetic.
template <class T>
T interpolate_clamped(const std::vector<double>& xs, const std::vector<T>& values, double s) {
  if (s <= xs.front()) return values.front();
  if (s >= xs.back()) return values.back();
  const size_t upper = size_t(std::upper_bound(xs.begin(), xs.end(), s) - xs.begin());
  const size_t i = std::min(upper, xs.size() - 1) - 1;
  const double t = (s - xs[i]) / (xs[i + 1] - xs[i]);
  return values[i] * (1 - t) + values[i + 1] * t;
}

}  // namespace

TransferEval::TransferEval(const TransferFunction& tf)
    : nan_color_(tf.nan_color), unit_distance_(tf.opacity_unit_distance) {
  for (const ColorPoint& p : tf.color_points) {
    color_x_.push_back(p.x);
    color_.push_back(p.rgb);
  }
  for (const OpacityPoint& p : tf.opacity_points) {
    opacity_x_.push_back(p.x);
    opacity_.push_back(p.opacity);
  }
}

Vec3d TransferEval::color(double s) const {
  if (std::isnan(s)) return nan_color_;
  return interpolate_clamped(color_x_, color_, s);
}

double TransferEval::opacity(double s) const {
  if (std::isnan(s) || opacity_.empty()) return 0;
  return interpolate_clamped(opacity_x_, opacity_, s);
}

double TransferEval::extinction(double s) const {
  return -std::log1p(-std::min(opacity(s), kMaxTableOpacity)) / unit_distance_;
}

ReferenceRenderer::ReferenceRenderer(const Dataset& dataset, std::string_view selector) {
  offsets_.push_back(0);
  field_min_ = kInf;
  field_max_ = -kInf;
  auto note_value = [&](double v) {
    if (std::isnan(v)) return;
    field_min_ = std::min(field_min_, v);
    field_max_ = std::max(field_max_, v);
  };
  for (const Block& source : dataset.blocks) {
    const Block block = to_unstructured_block(source, StructuredCellShape::Hexahedra);
    const auto& mesh = std::get<UnstructuredMesh>(block.grid);
    const ScalarRef ref = block.fields.scalar(selector);
    const bool per_cell = ref.field->association() == Association::Cell;
    const auto base = uint32_t(points_.size());
    for (uint64_t i = 0; i < mesh.point_count(); ++i) {
      points_.push_back(to_double(mesh.points[i]));
      const double v = per_cell ? std::nan("") : ref.field->scalar(i, ref.component);
      point_values_.push_back(v);
    }
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      types_.push_back(mesh.cell_types[c]);
      for (uint32_t v : mesh.cell(c)) connectivity_.push_back(base + v);
      offsets_.push_back(connectivity_.size());
      cell_data_.push_back(per_cell ? 1 : 0);
      const double value = per_cell ? ref.field->scalar(c, ref.component) : std::nan("");
      cell_values_.push_back(value);
      if (per_cell) {
        note_value(value);
      } else {
        for (uint32_t v : mesh.cell(c)) note_value(point_values_[base + v]);
      }
    }
  }
  if (types_.empty()) throw std::runtime_error("oracle: the dataset has no cells");
  if (!(field_min_ <= field_max_)) field_min_ = field_max_ = 0;

  // Cell boxes, padded so that the parametric tolerance of the inside test is never cut off by the box test.
  cell_boxes_.resize(types_.size());
  for (uint64_t c = 0; c < types_.size(); ++c) {
    Bounds b;
    for (int i = 0; i < cell_vertex_count(types_[c]); ++i) b.add(corner(c, i));
    const double pad = 1e-7 * length(b.size()) + 1e-300;
    cell_boxes_[c] = {b.lo.x - pad, b.lo.y - pad, b.lo.z - pad, b.hi.x + pad, b.hi.y + pad, b.hi.z + pad};
    bounds_.add(b);
  }

  tet_inverse_.resize(types_.size());
  for (uint64_t c = 0; c < types_.size(); ++c) {
    if (types_[c] != CellType::Tetra) continue;
    const Vec3d p0 = corner(c, 0), a = corner(c, 1) - p0, b = corner(c, 2) - p0, e = corner(c, 3) - p0;
    // Rows of the inverse are the cross products of the other two columns over the determinant; a flat
    // tetrahedron gets NaNs, which fail every inside comparison.
    const double d = dot(a, cross(b, e));
    const double inv = d != 0 ? 1 / d : std::nan("");
    const Vec3d r0 = cross(b, e) * inv, r1 = cross(e, a) * inv, r2 = cross(a, b) * inv;
    tet_inverse_[c] = {r0.x, r0.y, r0.z, r1.x, r1.y, r1.z, r2.x, r2.y, r2.z, p0.x, p0.y, p0.z};
  }

  // Bounding-volume hierarchy over the cell boxes: median splits of the box centres along the widest axis, down to
  // leaves of a few cells. (A uniform grid degrades on graded CFD meshes, whose cells near walls are thousands of
  // times smaller than far away.)
  bvh_cells_.resize(types_.size());
  for (uint64_t c = 0; c < types_.size(); ++c) bvh_cells_[c] = uint32_t(c);
  auto centre = [&](uint32_t c, int axis) { return cell_boxes_[c][axis] + cell_boxes_[c][3 + axis]; };
  auto build = [&](auto&& self, uint32_t begin, uint32_t end) -> void {
    const auto index = uint32_t(bvh_.size());
    bvh_.push_back({});
    std::array<double, 6> box{kInf, kInf, kInf, -kInf, -kInf, -kInf};
    std::array<double, 6> centres{kInf, kInf, kInf, -kInf, -kInf, -kInf};
    for (uint32_t i = begin; i < end; ++i) {
      const uint32_t c = bvh_cells_[i];
      for (int a = 0; a < 3; ++a) {
        box[a] = std::min(box[a], cell_boxes_[c][a]);
        box[3 + a] = std::max(box[3 + a], cell_boxes_[c][3 + a]);
        centres[a] = std::min(centres[a], centre(c, a));
        centres[3 + a] = std::max(centres[3 + a], centre(c, a));
      }
    }
    bvh_[index].box = box;
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (centres[3 + a] - centres[a] > centres[3 + axis] - centres[axis]) axis = a;
    if (end - begin <= 4 || !(centres[3 + axis] > centres[axis])) {
      bvh_[index].first = begin;
      bvh_[index].count = end - begin;
      return;
    }
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(bvh_cells_.begin() + begin, bvh_cells_.begin() + mid, bvh_cells_.begin() + end,
                     [&](uint32_t x, uint32_t y) {
                       return centre(x, axis) < centre(y, axis) || (centre(x, axis) == centre(y, axis) && x < y);
                     });
    self(self, begin, mid);  // the left child is the next node
    bvh_[index].right = uint32_t(bvh_.size());
    self(self, mid, end);
  };
  bvh_.reserve(2 * types_.size() / 3 + 1);
  build(build, 0, uint32_t(types_.size()));
}

bool ReferenceRenderer::test_cell(uint64_t cell, Vec3d p, const std::array<double, 3>* start, Location& out) const {
  const auto& b = cell_boxes_[cell];
  if (p.x < b[0] || p.y < b[1] || p.z < b[2] || p.x > b[3] || p.y > b[4] || p.z > b[5]) return false;
  const CellType type = types_[cell];
  const int n = cell_vertex_count(type);
  std::optional<std::array<double, 3>> rst;
  if (type == CellType::Tetra) {
    const auto& m = tet_inverse_[cell];
    const Vec3d q{p.x - m[9], p.y - m[10], p.z - m[11]};
    const std::array<double, 3> bary{m[0] * q.x + m[1] * q.y + m[2] * q.z, m[3] * q.x + m[4] * q.y + m[5] * q.z,
                                     m[6] * q.x + m[7] * q.y + m[8] * q.z};
    if (inside_reference(type, bary)) rst = bary;
  } else {
    Vec3d corners[8];
    for (int i = 0; i < n; ++i) corners[i] = corner(cell, i);
    rst = invert_cell(type, corners, p, start, length(Vec3d{b[3] - b[0], b[4] - b[1], b[5] - b[2]}));
  }
  if (!rst) return false;
  out.cell = cell;
  out.rst = *rst;
  out.per_cell = cell_data_[cell] != 0;
  if (out.per_cell) {
    out.value = cell_values_[cell];
  } else {
    double w[8];
    shape_functions(type, *rst, w);
    double v = 0;
    for (int i = 0; i < n; ++i) v += w[i] * point_values_[connectivity_[offsets_[cell] + uint64_t(i)]];
    out.value = v;
  }
  return true;
}

std::optional<Location> ReferenceRenderer::locate(Vec3d p, const Location* hint) const {
  Location loc;
  if (hint && test_cell(hint->cell, p, &hint->rst, loc)) return loc;
  // Depth-first, left child first: the answer for a point shared by several cells does not depend on threads.
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& node = bvh_[stack[--top]];
    const auto& b = node.box;
    if (p.x < b[0] || p.y < b[1] || p.z < b[2] || p.x > b[3] || p.y > b[4] || p.z > b[5]) continue;
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t cell = bvh_cells_[i];
        if (hint && cell == hint->cell) continue;
        if (test_cell(cell, p, nullptr, loc)) return loc;
      }
      continue;
    }
    const auto self = uint32_t(&node - bvh_.data());
    stack[top++] = node.right;
    stack[top++] = self + 1;
  }
  return std::nullopt;
}

double ReferenceRenderer::step() const { return step_ > 0 ? step_ : length(bounds_.size()) / 4000; }

namespace {

// One located point of a ray. `key` names the smooth piece it belongs to: 0 outside the mesh, 1 inside a cell with
// per-vertex data (the field is continuous across those), 2 + cell inside a cell with per-cell data.
struct RaySample {
  double t = 0;
  uint64_t key = 0;
  Location loc;
  bool inside() const { return key != 0; }
};

class RayWalker {
 public:
  RayWalker(const ReferenceRenderer& oracle, const Ray& ray) : oracle_(oracle), ray_(ray) {}

  RaySample at(double t, const RaySample* near) const {
    RaySample s;
    s.t = t;
    const Location* hint = near && near->inside() ? &near->loc : nullptr;
    if (const auto loc = oracle_.locate(ray_.origin + ray_.direction * t, hint)) {
      s.loc = *loc;
      s.key = loc->per_cell ? 2 + loc->cell : 1;
    }
    return s;
  }

  // Calls piece(a, b) for consecutive pieces [a.t, b.t] covering [t0, t1] front to back. Pieces are at most one
  // step long and split in halves (adaptively) until each has the same key at both ends and, inside the mesh, a
  // field change of at most `value_tolerance` (steep gradients, e.g. boundary layers of graded CFD meshes, whose
  // cells are far thinner than a step, would otherwise alias). A piece whose ends differ in key is ~1e-5 steps
  // long: the key change (entering or leaving the mesh, or a jump of cell data) is located that precisely.
  template <class Piece>
  void walk(double t0, double t1, double step, double value_tolerance, Piece&& piece) const {
    min_length_ = step * 0x1p-16;
    min_smooth_length_ = step * 0x1p-12;
    value_tolerance_ = value_tolerance;
    const auto n = uint64_t(std::ceil((t1 - t0) / step));
    RaySample a = at(t0, nullptr);
    for (uint64_t k = 0; k < n; ++k) {
      const double tb = k + 1 == n ? t1 : t0 + double(k + 1) * step;
      const RaySample b = at(tb, &a);
      if (a.key == b.key && !a.inside()) {
        // Both ends outside: a ray grazing an edge or a corner can still cross the mesh for less than a step, so
        // the midpoint is tried as well (outside points are cheap: their boxes reject them).
        const RaySample m = at(0.5 * (a.t + b.t), nullptr);
        if (m.inside()) {
          refine(a, m, piece);
          refine(m, b, piece);
        } else {
          piece(a, b);
        }
      } else {
        refine(a, b, piece);
      }
      a = b;
    }
  }

 private:
  template <class Piece>
  void refine(const RaySample& a, const RaySample& b, Piece& piece) const {
    const double length = b.t - a.t;
    const bool split =
        length > min_length_ && (a.key != b.key || (a.inside() && length > min_smooth_length_ &&
                                                    std::abs(b.loc.value - a.loc.value) > value_tolerance_));
    if (!split) {
      piece(a, b);
      return;
    }
    const RaySample m = at(0.5 * (a.t + b.t), a.inside() ? &a : &b);
    refine(a, m, piece);
    refine(m, b, piece);
  }

  const ReferenceRenderer& oracle_;
  Ray ray_;
  mutable double min_length_ = 0, min_smooth_length_ = 0, value_tolerance_ = 0;
};

// Ray parameter interval inside the padded box, t >= 0; false when the ray misses it.
bool clip_to_box(const Ray& ray, const Bounds& box, double& t0, double& t1) {
  t0 = 0;
  t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    const double o = ray.origin[a], d = ray.direction[a];
    if (d == 0) {
      if (o < box.lo[a] || o > box.hi[a]) return false;
      continue;
    }
    double ta = (box.lo[a] - o) / d, tb = (box.hi[a] - o) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

}  // namespace

void ReferenceRenderer::shade_ray(const Ray& ray, const TransferEval& tf, const RenderSettings& settings,
                                  double out[4]) const {
  Vec3d color{0, 0, 0};
  double transmittance = 1;
  auto finish = [&] {
    const auto& bg = settings.background;
    const double alpha = 1 - transmittance * (1 - bg[3]);
    const Vec3d rgb = color + Vec3d{bg[0], bg[1], bg[2]} * (transmittance * bg[3]);
    for (int c = 0; c < 3; ++c) out[c] = alpha > 0 ? rgb[c] / alpha : 0;
    out[3] = alpha;
  };

  Bounds box = bounds_;
  const double pad = 1e-6 * length(bounds_.size());
  box.lo = box.lo - Vec3d{pad, pad, pad};
  box.hi = box.hi + Vec3d{pad, pad, pad};
  double t0, t1;
  if (!clip_to_box(ray, box, t0, t1)) return finish();
  if (settings.clip_plane) {
    // Kept: dot(o + t d - q, n) >= 0, i.e. a t + b >= 0.
    const double a = dot(ray.direction, settings.clip_plane->normal);
    const double b = dot(ray.origin - settings.clip_plane->point, settings.clip_plane->normal);
    if (a == 0) {
      if (b < 0) return finish();
    } else if (a > 0) {
      t0 = std::max(t0, -b / a);
    } else {
      t1 = std::min(t1, -b / a);
    }
    if (!(t0 < t1)) return finish();
  }

  const RayWalker walker(*this, ray);
  const double h = step();
  // A field change of 1/1000 of the transfer function's range per piece keeps colour and extinction, linear
  // between the map's points, close to linear over every piece.
  const double value_tolerance = 1e-3 * (tf.range_max() - tf.range_min());
  switch (settings.mode) {
    case RenderMode::EmissionAbsorption:
      walker.walk(t0, t1, h, value_tolerance, [&](const RaySample& a, const RaySample& b) {
        // The midpoint rule: with the same key at both ends the field is continuous over the piece (vertex data)
        // or constant (one cell of cell data), and the mean of the ends is its midpoint value to O(length^2)
        // (exactly where it is linear, as in tetrahedra). A piece with different ends is ~1e-5 steps long: either
        // end will do.
        double s;
        if (a.key == b.key) {
          if (!a.inside()) return;
          s = 0.5 * (a.loc.value + b.loc.value);
        } else if (a.inside()) {
          s = a.loc.value;
        } else {
          s = b.loc.value;
        }
        const double alpha = -std::expm1(-tf.extinction(s) * (b.t - a.t));
        color = color + tf.color(s) * (transmittance * alpha);
        transmittance *= 1 - alpha;
      });
      break;
    case RenderMode::Mip: {
      double best = -kInf, best_t = 0;
      auto consider = [&](const RaySample& s) {
        if (s.inside() && s.loc.value > best) {
          best = s.loc.value;
          best_t = s.t;
        }
      };
      walker.walk(t0, t1, h, value_tolerance, [&](const RaySample& a, const RaySample& b) {
        consider(a);
        consider(b);
      });
      if (best == -kInf) return finish();
      // Golden-section search around the best sample: the samples are at most a step apart, so the true maximum
      // of a peak lies within a step of its best sample.
      constexpr double kRatio = 0.6180339887498949;
      double lo = std::max(t0, best_t - h), hi = std::min(t1, best_t + h);
      auto value_at = [&](double t) {
        const RaySample s = walker.at(t, nullptr);
        if (s.inside()) consider(s);
        return s.inside() ? s.loc.value : -kInf;
      };
      double x1 = hi - kRatio * (hi - lo), x2 = lo + kRatio * (hi - lo);
      double f1 = value_at(x1), f2 = value_at(x2);
      for (int iter = 0; iter < 60 && hi - lo > 1e-9 * h; ++iter) {
        if (f1 < f2) {
          lo = x1;
          x1 = x2;
          f1 = f2;
          x2 = lo + kRatio * (hi - lo);
          f2 = value_at(x2);
        } else {
          hi = x2;
          x2 = x1;
          f2 = f1;
          x1 = hi - kRatio * (hi - lo);
          f1 = value_at(x1);
        }
      }
      const double alpha = tf.opacity(best);
      color = tf.color(best) * alpha;
      transmittance = 1 - alpha;
      break;
    }
    case RenderMode::Isosurface: {
      struct Crossing {
        double t;
        size_t iso;
      };
      std::vector<Crossing> crossings;
      auto between = [&](const RaySample& p, const RaySample& q) {
        if (!p.inside() || !q.inside() || p.key != q.key) return;
        for (size_t i = 0; i < settings.iso_values.size(); ++i) {
          const double v = settings.iso_values[i];
          if ((p.loc.value < v) == (q.loc.value < v)) continue;
          // Bisection on the sign of s - v, keeping p's side at `lo`.
          double lo = p.t, hi = q.t;
          const bool below = p.loc.value < v;
          for (int iter = 0; iter < 80 && hi - lo > 1e-10 * h; ++iter) {
            const double mid = 0.5 * (lo + hi);
            const RaySample s = walker.at(mid, &p);
            if (!s.inside()) break;
            ((s.loc.value < v) == below ? lo : hi) = mid;
          }
          crossings.push_back({0.5 * (lo + hi), i});
        }
      };
      walker.walk(t0, t1, h, value_tolerance, [&](const RaySample& a, const RaySample& b) { between(a, b); });
      std::stable_sort(crossings.begin(), crossings.end(),
                       [](const Crossing& x, const Crossing& y) { return x.t < y.t; });
      for (const Crossing& c : crossings) {
        const double alpha = settings.iso_opacity;
        color = color + tf.color(settings.iso_values[c.iso]) * (transmittance * alpha);
        transmittance *= 1 - alpha;
      }
      break;
    }
  }
  finish();
}

Image ReferenceRenderer::render(const Camera& camera, const TransferFunction& tf,
                                const RenderSettings& settings) const {
  Image image(settings.width, settings.height);
  const CameraRays rays(camera, settings.width, settings.height);
  const TransferEval eval(tf);
  tbb::parallel_for(tbb::blocked_range<int>(0, settings.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < settings.width; ++x) {
        double out[4];
        shade_ray(rays.pixel(x, y), eval, settings, out);
        float* px = image.pixel(x, y);
        for (int c = 0; c < 4; ++c) px[c] = float(out[c]);
      }
    }
  });
  return image;
}

RgbDifference rgb_difference(const Image& a, const Image& b, double pixel_threshold) {
  if (a.width != b.width || a.height != b.height) throw std::runtime_error("rgb_difference: image sizes differ");
  RgbDifference d;
  double sum = 0;
  for (size_t p = 0; p < size_t(a.width) * size_t(a.height); ++p) {
    double worst = 0;
    for (int c = 0; c < 3; ++c) {
      const double diff = std::abs(double(a.rgba[p * 4 + c]) - double(b.rgba[p * 4 + c]));
      sum += diff * diff;
      worst = std::max(worst, diff);
    }
    d.max_abs = std::max(d.max_abs, worst);
    if (worst > pixel_threshold) ++d.pixels_over;
  }
  const double n = 3.0 * double(a.width) * double(a.height);
  d.rms = n > 0 ? std::sqrt(sum / n) : 0;
  return d;
}

Dataset box_dataset(Vec3d lo, Vec3d hi, std::array<uint32_t, 3> cells, StructuredCellShape shape,
                    const std::function<double(Vec3d)>& field) {
  ImageGrid grid;
  grid.dims.points = {cells[0] + 1, cells[1] + 1, cells[2] + 1};
  grid.origin = lo;
  grid.spacing = {(hi.x - lo.x) / cells[0], (hi.y - lo.y) / cells[1], (hi.z - lo.z) / cells[2]};
  ExplicitCells explicit_cells = make_explicit_cells(Grid(grid), shape);
  std::vector<double> values;
  values.reserve(explicit_cells.mesh.points.size());
  for (const Vec3f& p : explicit_cells.mesh.points) values.push_back(field(to_double(p)));
  Block block{"box", std::move(explicit_cells.mesh), {}};
  block.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(values), 1)));
  Dataset dataset;
  dataset.format = "test box";
  dataset.blocks.push_back(std::move(block));
  return dataset;
}

}  // namespace ugvr::oracle

// ---- Closed-form scenes ----

namespace ugvr::oracle {

bool segment_in_box(const Ray& ray, Vec3d lo, Vec3d hi, const std::optional<ClipPlane>& clip, double& t0, double& t1) {
  Bounds box;
  box.add(lo);
  box.add(hi);
  if (!clip_to_box(ray, box, t0, t1)) return false;
  if (clip) {
    const double a = dot(ray.direction, clip->normal), b = dot(ray.origin - clip->point, clip->normal);
    if (a == 0) return b >= 0;
    if (a > 0) t0 = std::max(t0, -b / a);
    if (a < 0) t1 = std::min(t1, -b / a);
  }
  return t0 < t1;
}

Vec3d linear_slab_radiance(Vec3d c_in, Vec3d c_out, double tau, double length) {
  if (length <= 0) return {0, 0, 0};
  const double e = std::exp(-tau * length);
  return c_in * (1 - e) + (c_out - c_in) * (((1 - e) / tau - length * e) / length);
}

namespace {

Camera parallel_camera(Vec3d position, Vec3d up, double scale) {
  Camera c;
  c.position = position;
  c.focal_point = {0.5, 0.5, 0.5};
  c.view_up = up;
  c.parallel_projection = true;
  c.parallel_scale = scale;
  return c;
}

Camera perspective_camera(Vec3d position, Vec3d focal, Vec3d up, double angle) {
  Camera c;
  c.position = position;
  c.focal_point = focal;
  c.view_up = up;
  c.view_angle = angle;
  return c;
}

struct NamedCamera {
  const char* name;
  Camera camera;
};

const NamedCamera kDown{"down", parallel_camera({0.5, 0.5, 3}, {0, 1, 0}, 0.75)};
const NamedCamera kUp{"up", parallel_camera({0.5, 0.5, -2}, {0, 1, 0}, 0.75)};
const NamedCamera kAlongX{"along-x", parallel_camera({-3, 0.5, 0.5}, {0, 0, 1}, 0.7)};
// Off every symmetry axis and close enough that some rays enter through the sides.
const NamedCamera kOblique{"oblique", perspective_camera({1.9, -1.3, 2.4}, {0.5, 0.5, 0.5}, {0, 0, 1}, 35)};
// Above the box at x = 0.2 looking down with a wide angle: rays reach the plane x = 0.3 (or 0.7) inside the box
// only in a band of the image whose edges follow from the ray directions.
const NamedCamera kWide{"wide", perspective_camera({0.2, 0.45, 3}, {0.2, 0.45, 0.5}, {0, 1, 0}, 50)};

RenderSettings scene_settings() {
  RenderSettings s;
  s.width = s.height = 24;
  s.background = {0.1, 0.2, 0.3, 1};
  s.early_termination_opacity = 1;
  s.lighting = false;
  return s;
}

const char* shape_name(StructuredCellShape shape) {
  switch (shape) {
    case StructuredCellShape::Hexahedra: return "hex";
    case StructuredCellShape::SixTetrahedra: return "6tet";
    case StructuredCellShape::FiveTetrahedra: return "5tet";
  }
  return "?";
}

// Fills scene.expected (and skip) from per_ray(ray, rgb, skip) -> rgb over the opaque background.
template <class PerRay>
void fill_expected(ClosedFormScene& scene, PerRay per_ray) {
  const RenderSettings& s = scene.settings;
  scene.expected = Image(s.width, s.height);
  scene.skip.assign(size_t(s.width) * size_t(s.height), 0);
  const CameraRays rays(scene.camera, s.width, s.height);
  for (int y = 0; y < s.height; ++y) {
    for (int x = 0; x < s.width; ++x) {
      Vec3d rgb{s.background[0], s.background[1], s.background[2]};
      bool skip = false;
      per_ray(rays.pixel(x, y), rgb, skip);
      float* px = scene.expected.pixel(x, y);
      for (int c = 0; c < 3; ++c) px[c] = float(rgb[c]);
      px[3] = 1;
      scene.skip[size_t(y) * size_t(s.width) + size_t(x)] = skip ? 1 : 0;
    }
  }
}

Vec3d background_of(const RenderSettings& s) { return {s.background[0], s.background[1], s.background[2]}; }

}  // namespace

std::vector<ClosedFormScene> closed_form_scenes(std::string_view family) {
  std::vector<ClosedFormScene> scenes;
  const Vec3d lo{0, 0, 0}, hi{1, 1, 1};
  auto base = [&](std::string name, std::shared_ptr<const Dataset> ds, std::string field, const NamedCamera& cam) {
    ClosedFormScene sc;
    sc.name = std::string(family) + " " + std::move(name) + " " + cam.name;
    sc.dataset = std::move(ds);
    sc.field = std::move(field);
    sc.camera = cam.camera;
    sc.settings = scene_settings();
    return sc;
  };

  if (family == "constant") {
    const Vec3d color{0.9, 0.5, 0.2};
    TransferFunction tf;
    tf.color_points = {{0, color}, {1, color}};
    tf.opacity_points = {{0, 0.6}, {1, 0.6}};
    tf.opacity_unit_distance = 0.4;
    const double tau = -std::log(1 - 0.6) / 0.4;
    for (auto shape : {StructuredCellShape::SixTetrahedra, StructuredCellShape::Hexahedra}) {
      auto ds = std::make_shared<const Dataset>(box_dataset(lo, hi, {3, 3, 3}, shape, [](Vec3d) { return 0.5; }));
      for (const NamedCamera* cam : {&kDown, &kOblique}) {
        for (bool clip : {false, true}) {
          ClosedFormScene sc = base(std::string(shape_name(shape)) + (clip ? " clip" : ""), ds, "f", *cam);
          sc.tf = tf;
          // Keeps z >= 0.25.
          if (clip) sc.settings.clip_plane = ClipPlane{{0, 0, 0.25}, {0, 0, 1}};
          const auto& clip_plane = sc.settings.clip_plane;
          const Vec3d bg = background_of(sc.settings);
          fill_expected(sc, [&](const Ray& ray, Vec3d& rgb, bool&) {
            double t0, t1;
            if (!segment_in_box(ray, lo, hi, clip_plane, t0, t1)) return;
            const double e = std::exp(-tau * (t1 - t0));
            rgb = color * (1 - e) + bg * e;
          });
          scenes.push_back(std::move(sc));
        }
      }
    }
  } else if (family == "linear-slab") {
    TransferFunction tf;
    tf.color_points = {{0, {0.1, 0.9, 0.2}}, {1, {0.8, 0.1, 0.6}}};
    tf.opacity_points = {{0, 0.5}, {1, 0.5}};
    tf.opacity_unit_distance = 0.5;
    const double tau = -std::log(0.5) / 0.5;
    for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra}) {
      auto ds = std::make_shared<const Dataset>(box_dataset(lo, hi, {2, 3, 4}, shape, [](Vec3d p) { return p.z; }));
      for (const NamedCamera* cam : {&kDown, &kUp, &kOblique}) {
        ClosedFormScene sc = base(shape_name(shape), ds, "f", *cam);
        sc.tf = tf;
        const Vec3d bg = background_of(sc.settings);
        fill_expected(sc, [&](const Ray& ray, Vec3d& rgb, bool&) {
          double t0, t1;
          if (!segment_in_box(ray, lo, hi, std::nullopt, t0, t1)) return;
          const double z_in = ray.origin.z + t0 * ray.direction.z, z_out = ray.origin.z + t1 * ray.direction.z;
          rgb = linear_slab_radiance(tf.color(z_in), tf.color(z_out), tau, t1 - t0) + bg * std::exp(-tau * (t1 - t0));
        });
        scenes.push_back(std::move(sc));
      }
    }
  } else if (family == "cell-layers") {
    TransferFunction tf;
    tf.color_points = {{0, {1, 0, 0}}, {1, {0, 0, 1}}};
    tf.opacity_points = {{0, 0.3}, {1, 0.8}};
    tf.opacity_unit_distance = 0.5;
    for (auto shape : {StructuredCellShape::SixTetrahedra, StructuredCellShape::Hexahedra}) {
      Dataset box = box_dataset(lo, hi, {3, 3, 2}, shape, [](Vec3d) { return 0.0; });
      Block& block = box.blocks[0];
      const auto& mesh = std::get<UnstructuredMesh>(block.grid);
      std::vector<float> layer;
      for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
        double z = 0;
        for (uint32_t v : mesh.cell(c)) z += mesh.points[v].z;
        layer.push_back(z / double(mesh.cell(c).size()) < 0.5 ? 0.0f : 1.0f);
      }
      block.fields.add(Field("layer", Association::Cell, DataArray::from(std::move(layer), 1)));
      auto ds = std::make_shared<const Dataset>(std::move(box));
      for (const NamedCamera* cam : {&kDown, &kOblique}) {
        ClosedFormScene sc = base(shape_name(shape), ds, "layer", *cam);
        sc.tf = tf;
        const Vec3d bg = background_of(sc.settings);
        fill_expected(sc, [&](const Ray& ray, Vec3d& rgb, bool&) {
          double t0, t1;
          if (!segment_in_box(ray, lo, hi, std::nullopt, t0, t1)) return;
          // The path splits where it crosses z = 0.5; each part is a constant slab.
          std::vector<double> cuts{t0, t1};
          if (ray.direction.z != 0) {
            const double t = (0.5 - ray.origin.z) / ray.direction.z;
            if (t > t0 && t < t1) cuts.insert(cuts.begin() + 1, t);
          }
          Vec3d color{0, 0, 0};
          double transmittance = 1;
          for (size_t i = 0; i + 1 < cuts.size(); ++i) {
            const double z = ray.origin.z + 0.5 * (cuts[i] + cuts[i + 1]) * ray.direction.z;
            const double value = z < 0.5 ? 0 : 1;
            const double alpha = 1 - std::exp(-tf.extinction(value) * (cuts[i + 1] - cuts[i]));
            color = color + tf.color(value) * (transmittance * alpha);
            transmittance *= 1 - alpha;
          }
          rgb = color + bg * transmittance;
        });
        scenes.push_back(std::move(sc));
      }
    }
  } else if (family == "mip") {
    TransferFunction tf;
    tf.color_points = {{0, {0, 0, 0}}, {2, {1, 0.5, 0.25}}};
    tf.opacity_points = {{0, 0.2}, {2, 0.9}};
    for (auto shape : {StructuredCellShape::SixTetrahedra, StructuredCellShape::Hexahedra}) {
      auto ds = std::make_shared<const Dataset>(box_dataset(lo, hi, {3, 3, 3}, shape, [](Vec3d p) { return p.z; }));
      for (const NamedCamera* cam : {&kDown, &kUp, &kOblique}) {
        for (bool clip : {false, true}) {
          ClosedFormScene sc = base(std::string(shape_name(shape)) + (clip ? " clip" : ""), ds, "f", *cam);
          sc.tf = tf;
          sc.settings.mode = RenderMode::Mip;
          // Keeps z <= 0.6.
          if (clip) sc.settings.clip_plane = ClipPlane{{0, 0, 0.6}, {0, 0, -1}};
          const auto& clip_plane = sc.settings.clip_plane;
          const Vec3d bg = background_of(sc.settings);
          fill_expected(sc, [&](const Ray& ray, Vec3d& rgb, bool&) {
            double t0, t1;
            if (!segment_in_box(ray, lo, hi, clip_plane, t0, t1)) return;
            const double s = std::max(ray.origin.z + t0 * ray.direction.z, ray.origin.z + t1 * ray.direction.z);
            rgb = tf.color(s) * tf.opacity(s) + bg * (1 - tf.opacity(s));
          });
          scenes.push_back(std::move(sc));
        }
      }
    }
  } else if (family == "iso") {
    TransferFunction tf;
    tf.color_points = {{0, {1, 0, 0}}, {1, {0, 0.5, 1}}};
    for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::SixTetrahedra}) {
      auto ds = std::make_shared<const Dataset>(box_dataset(lo, hi, {4, 3, 3}, shape, [](Vec3d p) { return p.x; }));
      // Looking down, the rays run inside the isosurfaces' planes' direction: they cross none (background).
      for (const NamedCamera* cam : {&kAlongX, &kWide, &kOblique, &kDown}) {
        ClosedFormScene sc = base(shape_name(shape), ds, "f", *cam);
        sc.tf = tf;
        sc.settings.mode = RenderMode::Isosurface;
        sc.settings.iso_values = {0.3, 0.7};
        sc.settings.iso_opacity = 0.5;
        const Vec3d bg = background_of(sc.settings);
        const std::vector<double> iso = sc.settings.iso_values;
        fill_expected(sc, [&](const Ray& ray, Vec3d& rgb, bool& skip) {
          double t0, t1;
          if (!segment_in_box(ray, lo, hi, std::nullopt, t0, t1) || ray.direction.x == 0) return;
          std::vector<std::pair<double, double>> hits;
          for (double v : iso) {
            const double t = (v - ray.origin.x) / ray.direction.x;
            const Vec3d p = ray.origin + ray.direction * t;
            // A crossing on the box's surface is ambiguous (hit or miss by rounding).
            for (double c : {p.y, p.z}) skip |= std::abs(c) < 1e-4 || std::abs(c - 1) < 1e-4;
            if (t >= t0 && t <= t1) hits.push_back({t, v});
          }
          std::sort(hits.begin(), hits.end());
          Vec3d color{0, 0, 0};
          double transmittance = 1;
          for (const auto& hit : hits) {
            color = color + tf.color(hit.second) * (transmittance * 0.5);
            transmittance *= 0.5;
          }
          rgb = color + bg * transmittance;
        });
        scenes.push_back(std::move(sc));
      }
    }
  } else {
    throw std::runtime_error("closed_form_scenes: unknown family " + std::string(family));
  }
  return scenes;
}

SceneError scene_error(const ClosedFormScene& scene, const Image& image) {
  SceneError e;
  if (image.width != scene.expected.width || image.height != scene.expected.height) {
    e.max_abs = std::numeric_limits<double>::infinity();
    return e;
  }
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (scene.skip[size_t(y) * size_t(image.width) + size_t(x)]) continue;
      for (int c = 0; c < 4; ++c) {
        const double d = std::abs(double(image.pixel(x, y)[c]) - double(scene.expected.pixel(x, y)[c]));
        if (!(d <= e.max_abs)) {
          e.max_abs = d;
          e.x = x;
          e.y = y;
        }
      }
    }
  }
  return e;
}

}  // namespace ugvr::oracle
