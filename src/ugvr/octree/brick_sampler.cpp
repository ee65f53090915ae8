#include "ugvr/octree/brick_sampler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/octree/cell_box_overlap.h"

namespace ugvr {
namespace {

constexpr double kNotInside = -std::numeric_limits<double>::infinity();

// Two doubles processed as one: the first inverse-map steps of two samples at once (cell_interpolation.h's
// inverse_map_step rounds each lane exactly as its scalar form), SSE2 / NEON registers. Four lanes (AVX, through a
// target clone) saved only a fifth of the step's time in place, where gathering each lane's cell costs about as much
// as the arithmetic, and a 32-byte vector type changes the calling convention between clones.
constexpr int kLanes = 2;  // first_steps builds its lanes for two
using Lanes = double __attribute__((vector_size(8 * kLanes)));

// parametric_margin with the hexahedron and the tetrahedron, by far the commonest types, inline.
[[gnu::always_inline]] inline double margin_of(CellType type, Vec3d rst) {
  if (type == CellType::Hexahedron) return parametric_margin<CellType::Hexahedron>(rst);
  if (type == CellType::Tetra) return parametric_margin<CellType::Tetra>(rst);
  return parametric_margin(type, rst);
}

// One candidate cell, prepared once per brick for the many point tests it will take. A cell whose map is affine (a
// tetrahedron, or a parallelepiped: no nonlinear monomial) has its inverse in closed form, start() below; the others
// keep their monomial form for Newton.
struct PreparedCell {
  uint64_t id;
  CellType type;
  MonomialForm<Vec3d> map;
  // inverse_map_step's constants: monomial_nonlinearity(map), and the singular-Jacobian threshold (squared), from
  // the columns at the parametric centre (kSingularJacobian).
  double nonlinearity = 0, det_floor2 = 0;
  // Newton's first step from the parametric centre, precomputed (the centre's image and the inverse Jacobian
  // there): the start for tests that must not depend on where the sampler came from (see start()).
  Vec3d centre, centre_x;
  std::array<Vec3d, 3> centre_inverse;
  bool affine_start = false;
  // A point within `tolerance` of the cell has its coordinates within a bound B of start(p) (the affine map's error
  // over the cell, outside_below() below), so the margin of start(p) is above -(tolerance + 3 B) (a margin combines up
  // to three coordinates). Below `outside_below`, p is out of the cell's reach and Newton is not run: most bucket
  // tests of points outside the mesh end there (lox post: a tenth of all tests).
  double outside_below = -std::numeric_limits<double>::infinity();

  // The map is affine and start() its exact inverse (up to rounding): no Newton.
  bool closed_form = false;

  // A start for Newton that depends only on the cell and p: the point under the affine map of the centre.
  [[gnu::always_inline]] Vec3d start(Vec3d p) const {
    if (!affine_start) return centre;
    const Vec3d d = p - centre_x;
    return centre + Vec3d{dot(centre_inverse[0], d), dot(centre_inverse[1], d), dot(centre_inverse[2], d)};
  }
  [[gnu::always_inline]] bool surely_outside(Vec3d start_rst) const {
    return margin_of(type, start_rst) < outside_below;
  }
};

// PreparedCell::outside_below for a cell of monomial form m whose affine map at the parametric centre u_c has the
// inverse A (rows). Writing u = u_c + d, the map is x(u) = x(u_c) + J(u_c) d + E(d) with
//   E(d) = (c4 + c7 u_c.t) dr ds + (c5 + c7 u_c.s) dr dt + (c6 + c7 u_c.r) ds dt + c7 dr ds dt,
// so start(p) = u + A E(d) for p = x(u). Over the cell widened by the tolerance (every type's parametric domain lies
// in the unit cube: |d_a| <= max(u_c.a, 1 - u_c.a), plus 1e-6 for the widening) each coordinate of start(p) is
// then within B = max_i sum_j |A_ij| max|E_j| of u.
double outside_below(const MonomialForm<Vec3d>& m, Vec3d centre, const std::array<Vec3d, 3>& A, double tolerance) {
  const Vec3d D{std::max(centre.x, 1 - centre.x) + 1e-6, std::max(centre.y, 1 - centre.y) + 1e-6,
                std::max(centre.z, 1 - centre.z) + 1e-6};
  Vec3d E;
  for (int j = 0; j < 3; ++j) {
    const double c7 = m.c[7][j];
    E[j] = std::abs(m.c[4][j] + c7 * centre.z) * D.x * D.y + std::abs(m.c[5][j] + c7 * centre.y) * D.x * D.z +
           std::abs(m.c[6][j] + c7 * centre.x) * D.y * D.z + std::abs(c7) * D.x * D.y * D.z;
  }
  double B = 0;
  for (int i = 0; i < 3; ++i) B = std::max(B, std::abs(A[i].x) * E.x + std::abs(A[i].y) * E.y + std::abs(A[i].z) * E.z);
  // 1e-9: room for the rounding of start() and of the margin (about 1e-15 of the cell's parametric size).
  return -(tolerance + 3 * B) - 1e-9;
}

// A cell of the current bucket whose box spans the current row's y and z: its x extent.
struct RowEntry {
  double lo, hi;
  uint32_t cell;
};

// The cell, parametric coordinates and inverse Jacobian of a sample already located: a nearby sample in the same
// cell starts Newton from rst + J^-1 (p - p_seen), which is off by O(spacing² x the cell's nonlinearity) only.
struct Seen {
  uint32_t cell = UINT32_MAX;
  Vec3d rst;
  std::array<Vec3d, 3> inverse;  // rows of J^-1 (d rst / d position); not kept for a closed-form cell

  // The first-order prediction for the point `delta` away along `axis`.
  Vec3d predict(int axis, double delta) const {
    return rst + Vec3d{inverse[0][axis], inverse[1][axis], inverse[2][axis]} * delta;
  }
};

// A sample tried first in the cell its neighbour at y - 1 (or z - 1) lies in, and the outcome.
struct Attempt {
  uint32_t cell = UINT32_MAX;  // none: no neighbour to go by
  bool done = false;           // found well inside that cell: nothing left to do
  Vec3d guess;
  // Where it is not done: the first step's outcome (inverse_map_corrected's state after one iteration).
  Vec3d rst;
  double error2, step2, det2;

  // Decided without a step: not in that cell (a converged outcome, so no Newton is carried on).
  void settle() { error2 = 0, step2 = 0, det2 = std::numeric_limits<double>::infinity(); }
};

}  // namespace

struct BrickScratch::Impl {
  std::vector<PreparedCell> cells;
  std::vector<Bounds> boxes;  // per prepared cell, apart: the box tests and the bucket rows scan them alone
  std::vector<MonomialForm<double>> values;          // per prepared cell, per scalar (a cell scalar is a constant form)
  std::vector<double> cell_margin;                   // overlap margin per prepared cell
  std::vector<Seen> seen;                            // R² entries: (x, y) of the current or the previous z
  std::vector<Attempt> attempts;                     // R entries: the current row
  std::vector<uint32_t> batch;                       // samples of the current row with an attempt
  std::vector<RowEntry> row;                         // the current row's cells of the current bucket
  std::vector<std::pair<uint32_t, uint32_t>> pairs;  // (bucket, prepared cell) before sorting
  std::vector<uint32_t> bucket_offsets, bucket_cells, fill;
  std::array<std::vector<double>, 3> coords;
  std::array<std::vector<uint32_t>, 3> bucket_of;
};

BrickScratch::BrickScratch() : impl_(std::make_unique<Impl>()) {}
BrickScratch::~BrickScratch() = default;
BrickScratch::BrickScratch(BrickScratch&&) noexcept = default;
BrickScratch& BrickScratch::operator=(BrickScratch&&) noexcept = default;

Bounds BrickLattice::node_box(int level, std::array<uint32_t, 3> node) const {
  Bounds b;
  for (int a = 0; a < 3; ++a) {
    const uint64_t m = uint64_t(node[size_t(a)]) * (resolution - 1);
    b.lo[a] = coordinate(a, level, m);
    b.hi[a] = coordinate(a, level, m + resolution - 1);
  }
  return b;
}

BrickSampler::BrickSampler(const UnstructuredMesh& mesh, std::vector<ScalarRef> scalars, BrickSamplerOptions options)
    : mesh_(mesh), scalars_(std::move(scalars)), options_(options) {
  for (const ScalarRef& s : scalars_) {
    if (!s.field) throw Error("brick sampler: no field given");
    const Field& f = *s.field;
    const uint64_t want = f.association() == Association::Vertex ? mesh.point_count() : mesh.cell_count();
    if (f.tuples() != want) {
      throw Error("brick sampler: field '" + f.name() + "' has " + std::to_string(f.tuples()) +
                  " tuples, the mesh has " + std::to_string(want) + " " +
                  std::string(association_name(f.association())) + "s");
    }
    if (s.component < kMagnitude || s.component >= f.components()) {
      throw Error("brick sampler: field '" + f.name() + "' has no component " + std::to_string(s.component));
    }
  }
}

namespace {

// The scalar of `field` at tuple t: a component, or the magnitude (a 1-component field is its own magnitude).
template <class T>
double scalar_at(std::span<const T> v, int components, int component, uint64_t t) {
  if (components == 1) return double(v[t]);
  if (component >= 0) return double(v[t * uint64_t(components) + uint64_t(component)]);
  double s = 0;
  for (int c = 0; c < components; ++c) {
    const double x = double(v[t * uint64_t(components) + uint64_t(c)]);
    s += x * x;
  }
  return std::sqrt(s);
}

// Parametric coordinates of p in the prepared cell (and the inverse Jacobian there) and the margin by which p is
// inside, Newton starting from `guess`; kNotInside when the inverse map fails.
double locate(const PreparedCell& c, Vec3d p, Vec3d guess, double accuracy, InverseMapResult& r) {
  if (c.closed_form) {  // r.inverse is left alone: a closed-form cell needs no prediction
    r.rst = c.start(p);
    return margin_of(c.type, r.rst);
  }
  if (!inverse_map_corrected(c.map, c.nonlinearity, c.det_floor2, p - c.map.c[0], guess, accuracy, r)) {
    return kNotInside;
  }
  return margin_of(c.type, r.rst);
}

// A prepared cell's bounding box, widened like the buckets so the prefilter never rejects a point the test accepts.
inline bool in_box(const Bounds& c, Vec3d p) {
  return p.x >= c.lo.x && p.x <= c.hi.x && p.y >= c.lo.y && p.y <= c.hi.y && p.z >= c.lo.z && p.z <= c.hi.z;
}

// The first inverse-map steps of the attempts at samples batch[0..count) of row (py, pz), kLanes at a time. An
// attempt whose step converged (locate()'s tests) well inside its cell is done: its history entry here_row[x] is
// written; the others keep what the caller needs to carry on (Attempt).
void first_steps(const PreparedCell* cells, const double* xs, double py, double pz, const uint32_t* batch, size_t count,
                 Attempt* attempts, Seen* here_row, double accuracy2, double interior) {
  for (size_t i = 0; i < count; i += kLanes) {
    const int used = int(std::min<size_t>(kLanes, count - i));
    uint32_t x[kLanes];
    const PreparedCell* c[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      x[l] = batch[i + size_t(std::min(l, used - 1))];  // a short group repeats its last sample
      c[l] = &cells[attempts[x[l]].cell];
    }
    // Lanes built from registers (element-wise stores into a vector would cost a failed store-to-load forward).
    auto lanes = [](Vec3d a, Vec3d b) { return Vec3<Lanes>{Lanes{a.x, b.x}, Lanes{a.y, b.y}, Lanes{a.z, b.z}}; };
    MonomialForm<Vec3<Lanes>> m;
    for (size_t k = 1; k < 8; ++k) m.c[k] = lanes(c[0]->map.c[k], c[1]->map.c[k]);
    // The same expression as locate()'s (p - c0), lane by lane: the same bits.
    const Vec3<Lanes> target =
        lanes(Vec3d{xs[x[0]], py, pz} - c[0]->map.c[0], Vec3d{xs[x[1]], py, pz} - c[1]->map.c[0]);
    const Vec3<Lanes> guess = lanes(attempts[x[0]].guess, attempts[x[1]].guess);
    const Lanes nonlinearity{c[0]->nonlinearity, c[1]->nonlinearity};
    const InverseMapStep<Lanes> step = inverse_map_step(m, nonlinearity, target, guess);
    for (int l = 0; l < used; ++l) {
      Attempt& a = attempts[x[l]];
      const Vec3d rst{step.rst.x[l], step.rst.y[l], step.rst.z[l]};
      a.rst = rst, a.error2 = step.error2[l], a.step2 = step.step2[l], a.det2 = step.det2[l];
      // locate()'s tests, in its order.
      if (!(a.det2 > c[l]->det_floor2) || !(a.step2 < 1e16) || !(a.error2 <= accuracy2)) continue;
      if (margin_of(c[l]->type, rst) < interior) continue;
      a.done = true;
      Seen& seen = here_row[x[l]];
      seen.cell = a.cell, seen.rst = rst;
      for (size_t k = 0; k < 3; ++k)
        seen.inverse[k] = {step.inverse[k].x[l], step.inverse[k].y[l], step.inverse[k].z[l]};
    }
  }
}

}  // namespace

void BrickSampler::sample(const BrickLattice& lattice, int level, std::array<uint32_t, 3> node,
                          std::span<const uint64_t> candidates, BrickScratch& scratch, BrickSamples& out,
                          BrickSamplerStats* stats) const {
  BrickScratch::Impl& s = *scratch.impl_;
  const uint32_t R = lattice.resolution;
  if (R < 2) throw Error("brick sampler: resolution must be at least 2");
  const size_t per_field = size_t(R) * R * R;
  const size_t F = scalars_.size();
  out.resolution = R;
  out.field_count = uint32_t(F);
  out.values.assign(F * per_field, 0.0f);
  out.mask.assign(per_field, 0);
  out.valid = 0;
  BrickSamplerStats st;
  st.samples = per_field;

  // Sample coordinates along each axis, from lattice lines (bit-identical across bricks; see the header).
  Bounds box;
  for (int a = 0; a < 3; ++a) {
    auto& c = s.coords[size_t(a)];
    c.resize(R);
    const uint64_t m0 = uint64_t(node[size_t(a)]) * (R - 1);
    for (uint32_t x = 0; x < R; ++x) c[x] = lattice.coordinate(a, level, m0 + x);
    box.lo[a] = c[0], box.hi[a] = c[R - 1];
  }

  // Prepare the candidates.
  s.cells.clear();
  s.boxes.clear();
  s.values.clear();
  s.cell_margin.clear();
  for (uint64_t id : candidates) {
    PreparedCell c;
    c.id = id;
    c.type = mesh_.cell_types[id];
    Vec3d v[kMaxCellVertices];
    const int n = gather_cell_vertices(mesh_, id, v);
    Bounds bb;
    for (int i = 0; i < n; ++i) bb.add(v[i]);
    const double margin = kOverlapMargin * length(bb.size());
    bb = expanded(bb, margin);
    if (bb.lo.x > box.hi.x || bb.lo.y > box.hi.y || bb.lo.z > box.hi.z || bb.hi.x < box.lo.x || bb.hi.y < box.lo.y ||
        bb.hi.z < box.lo.z) {
      continue;
    }
    if (c.type == CellType::Tetra) {
      // Barycentric coordinates: start() from the origin of parametric space, vertex 0, with the inverse of the
      // edge matrix.
      if (!detail::inverse_rows(v[1] - v[0], v[2] - v[0], v[3] - v[0], c.centre_inverse.data())) continue;  // flat
      c.centre = {}, c.centre_x = v[0];
      c.affine_start = c.closed_form = true;
    } else {
      c.map = with_cell_type(c.type, [&](auto tag) { return to_monomial<decltype(tag)::value>(v); });
      c.centre = parametric_center(c.type);
      c.centre_x = c.map.evaluate(c.centre);
      Vec3d cols[3];
      double dN[3 * kMaxCellVertices];
      shape_derivatives(c.type, c.centre, dN);
      for (int j = 0; j < 3; ++j) {
        cols[j] = {};
        for (int i = 0; i < n; ++i) cols[j] = cols[j] + v[i] * dN[j * n + i];
      }
      c.affine_start = detail::inverse_rows(cols[0], cols[1], cols[2], c.centre_inverse.data());
      if (c.affine_start) c.outside_below = outside_below(c.map, c.centre, c.centre_inverse, options_.tolerance);
      c.nonlinearity = monomial_nonlinearity(c.map);
      c.closed_form = c.affine_start && c.nonlinearity == 0;
      c.det_floor2 =
          kSingularJacobian * kSingularJacobian * dot(cols[0], cols[0]) * dot(cols[1], cols[1]) * dot(cols[2], cols[2]);
    }
    s.cells.push_back(c);
    s.boxes.push_back(bb);
    s.cell_margin.push_back(margin);
  }
  const size_t nc = s.cells.size();
  s.values.resize(nc * F);
  for (size_t f = 0; f < F; ++f) {
    const ScalarRef& sc = scalars_[f];
    const Field& field = *sc.field;
    field.data().visit([&](auto v) {
      double vals[kMaxCellVertices];
      for (size_t k = 0; k < nc; ++k) {
        MonomialForm<double>& dst = s.values[k * F + f];
        const uint64_t id = s.cells[k].id;
        if (field.association() == Association::Vertex) {
          const std::span<const uint32_t> ids = mesh_.cell(id);
          for (size_t i = 0; i < ids.size(); ++i) vals[i] = scalar_at(v, field.components(), sc.component, ids[i]);
          dst = with_cell_type(s.cells[k].type, [&](auto tag) { return to_monomial<decltype(tag)::value>(vals); });
        } else {
          dst = {};
          dst.c[0] = scalar_at(v, field.components(), sc.component, id);
        }
      }
    });
  }
  st.candidates = nc;
  if (nc == 0) {
    if (stats) *stats += st;
    return;
  }

  // Coarse buckets over the brick.
  const uint32_t B =
      uint32_t(std::clamp(std::lround(std::cbrt(double(nc) / options_.cells_per_bucket)), 1L, long(std::min(16u, R))));
  const Vec3d bsize = (box.hi - box.lo) * (1.0 / double(B));
  auto bucket_lo = [&](int a, uint32_t i) { return box.lo[a] + (box.hi[a] - box.lo[a]) * (double(i) / double(B)); };
  auto bucket_index = [&](int a, double x) {
    const double f = bsize[a] > 0 ? std::floor((x - box.lo[a]) / bsize[a]) : 0.0;
    return uint32_t(std::clamp(f, 0.0, double(B - 1)));
  };
  s.pairs.clear();
  for (uint32_t k = 0; k < nc; ++k) {
    const PreparedCell& c = s.cells[k];
    std::array<uint32_t, 3> first{}, last{};
    for (int a = 0; a < 3; ++a) {
      // The same floor as the samples' lookup (bucket_of), so a sample in the cell's box finds it; the overlap test
      // below uses the bucket's own box, widened by the margin that covers the difference.
      first[size_t(a)] = bucket_index(a, s.boxes[k].lo[a]);
      last[size_t(a)] = bucket_index(a, s.boxes[k].hi[a]);
    }
    const bool single = first == last;
    Vec3d v[kMaxCellVertices];
    if (!single) gather_cell_vertices(mesh_, c.id, v);
    for (uint32_t z = first[2]; z <= last[2]; ++z)
      for (uint32_t y = first[1]; y <= last[1]; ++y)
        for (uint32_t x = first[0]; x <= last[0]; ++x) {
          if (!single) {
            Bounds b;
            b.lo = {bucket_lo(0, x), bucket_lo(1, y), bucket_lo(2, z)};
            b.hi = {bucket_lo(0, x + 1), bucket_lo(1, y + 1), bucket_lo(2, z + 1)};
            if (!cell_box_overlap(c.type, v, expanded(b, s.cell_margin[k]), options_.bucket_axes)) continue;
          }
          s.pairs.push_back({x + B * (y + B * z), k});
        }
  }
  const uint32_t bucket_count = B * B * B;
  s.bucket_offsets.assign(bucket_count + 1, 0);
  for (const auto& [b, k] : s.pairs) ++s.bucket_offsets[b + 1];
  for (uint32_t b = 0; b < bucket_count; ++b) s.bucket_offsets[b + 1] += s.bucket_offsets[b];
  s.bucket_cells.resize(s.pairs.size());
  s.fill.assign(s.bucket_offsets.begin(), s.bucket_offsets.end() - 1);
  for (const auto& [b, k] : s.pairs) s.bucket_cells[s.fill[b]++] = k;  // pairs come in cell order: stays sorted
  st.bucket_entries = s.pairs.size();
  for (int a = 0; a < 3; ++a) {
    auto& bo = s.bucket_of[size_t(a)];
    bo.resize(R);
    for (uint32_t x = 0; x < R; ++x) bo[x] = bucket_index(a, s.coords[size_t(a)][x]);
  }

  // Point in a prepared cell: the margin by which p is inside it, or kNotInside.
  const double accuracy = options_.newton_accuracy, accuracy2 = accuracy * accuracy;
  auto test = [&](uint32_t k, Vec3d p, Vec3d guess, InverseMapResult& r) {
    const PreparedCell& c = s.cells[k];
    if (!in_box(s.boxes[k], p)) return kNotInside;
    ++st.cell_tests;
    return locate(c, p, guess, accuracy, r);
  };
  const double tol = options_.tolerance, interior = options_.interior_margin;
  s.seen.assign(size_t(R) * R, Seen{});
  s.attempts.resize(R);
  s.batch.resize(R);

  // The mask and values of sample si, found at rst in prepared cell k.
  uint8_t* const mask = out.mask.data();
  float* const values = out.values.data();
  const MonomialForm<double>* const cell_values = s.values.data();
  uint64_t valid = 0, hits = 0, predicted_hits = 0;  // out.valid, st.cache_hits, st.predicted_hits, kept in registers
  auto record = [&](size_t si, uint32_t k, Vec3d rst) {
    mask[si] = 1;
    ++valid;
    const MonomialForm<double>* vals = cell_values + size_t(k) * F;
    for (size_t f = 0; f < F; ++f) values[f * per_field + si] = float(vals[f].evaluate(rst));
  };

  InverseMapResult found, r;
  for (uint32_t z = 0; z < R; ++z) {
    for (uint32_t y = 0; y < R; ++y) {
      const double py = s.coords[1][y], pz = s.coords[2][z];
      const size_t row_offset = size_t(R) * (y + size_t(R) * z);
      const bool border_zy = z == 0 || z == R - 1 || y == 0 || y == R - 1;
      Seen* const here_row = s.seen.data() + size_t(R) * y;  // (x, y): still the samples at z - 1
      const Seen* const below_row = y > 0 ? here_row - R : nullptr;
      // 1. The whole row at once: each sample is tried first in the cell of its neighbour at y - 1 (else z - 1),
      //    from that neighbour's prediction; an affine cell decides at once (closed form), the others are batched.
      //    These tests depend on the previous row or plane only, not on each other, so they run two at a time
      //    (first_steps); the row's other work comes after, in order. Border samples are shared with other bricks:
      //    every test starts from PreparedCell::start there, so the result depends on nothing but the point and the
      //    cell.
      uint32_t* const batch = s.batch.data();
      size_t batched = 0;
      for (uint32_t x = 0; x < R; ++x) {
        Attempt& a = s.attempts[x];
        a.cell = UINT32_MAX, a.done = false;
        // The neighbour at y - 1, or the one at z - 1 where it alone has a cell or where both cells take Newton and
        // its prediction lies deeper inside its cell. (A closed-form cell is tested without a prediction.)
        const Seen* from = below_row && below_row[x].cell != UINT32_MAX ? &below_row[x] : nullptr;
        const Seen* other = z > 0 && here_row[x].cell != UINT32_MAX ? &here_row[x] : nullptr;
        Vec3d prediction;
        bool predicted = false;
        if (other && (!from || other->cell != from->cell)) {
          if (!from) {
            from = other;
          } else if (!s.cells[from->cell].closed_form && !s.cells[other->cell].closed_form) {
            prediction = from->predict(1, py - s.coords[1][y - 1]), predicted = true;
            const Vec3d alternative = other->predict(2, pz - s.coords[2][z - 1]);
            if (margin_of(s.cells[other->cell].type, alternative) > margin_of(s.cells[from->cell].type, prediction)) {
              from = other, prediction = alternative;
            }
          }
        }
        if (!from) continue;
        const Vec3d p{s.coords[0][x], py, pz};
        const PreparedCell& c = s.cells[from->cell];
        if (!in_box(s.boxes[from->cell], p)) continue;
        a.cell = from->cell;
        if (c.closed_form) {  // nothing to batch: decided here
          ++st.predicted;
          const Vec3d rst = c.start(p);
          if (margin_of(c.type, rst) >= interior) {
            a.done = true;
            Seen& seen = here_row[x];
            seen.cell = a.cell, seen.rst = rst;  // no inverse: a closed-form cell needs no prediction
          } else {
            a.settle();
          }
          continue;
        }
        const bool border = border_zy || x == 0 || x == R - 1;
        if (border) {
          a.guess = c.start(p);
          if (c.surely_outside(a.guess)) {
            a.settle();
            continue;
          }
        } else {
          a.guess = predicted ? prediction
                              : from->predict(from == other ? 2 : 1,
                                              from == other ? pz - s.coords[2][z - 1] : py - s.coords[1][y - 1]);
        }
        batch[batched++] = x;
      }
      st.predicted += batched;
      first_steps(s.cells.data(), s.coords[0].data(), py, pz, batch, batched, s.attempts.data(), here_row, accuracy2,
                  interior);

      // 2. In order along the row, the samples not done yet: the attempt's Newton carried on, then the cells of the
      //    previous sample and of the neighbours at y - 1 and z - 1, accepted only well inside (then no other cell
      //    can hold the point), then the bucket.
      const uint32_t bzy = B * (s.bucket_of[1][y] + B * s.bucket_of[2][z]);
      uint32_t row_bucket = UINT32_MAX;  // the bucket whose cells s.row holds, for this row
      for (uint32_t x = 0; x < R; ++x) {
        const Attempt& a = s.attempts[x];
        if (a.done) {
          ++predicted_hits, ++hits;
          record(row_offset + x, a.cell, here_row[x].rst);
          continue;
        }
        const Vec3d p{s.coords[0][x], py, pz};
        const bool border = border_zy || x == 0 || x == R - 1;
        uint32_t hit = UINT32_MAX;
        if (a.cell != UINT32_MAX && a.det2 > s.cells[a.cell].det_floor2 && a.step2 < 1e16 && !(a.error2 <= accuracy2)) {
          // Not converged in one step: go on from there, exactly as locate() would have.
          const PreparedCell& c = s.cells[a.cell];
          if (inverse_map_corrected(c.map, c.nonlinearity, c.det_floor2, p - c.map.c[0], a.rst, accuracy, found,
                                    kInverseMapMaxIterations - 1) &&
              margin_of(c.type, found.rst) >= interior) {
            hit = a.cell, ++hits, ++predicted_hits;
          }
        }
        if (hit == UINT32_MAX) {
          // The previous sample is here_row[x - 1] by now; here_row[x] still holds z - 1. Each cell once (not the
          // attempt's); closed-form cells in that order (a test costs less than a prediction), Newton cells after
          // them, the one whose prediction lies deepest inside first.
          const Seen* tries[3] = {x > 0 ? &here_row[x - 1] : nullptr, below_row ? &below_row[x] : nullptr,
                                  z > 0 ? &here_row[x] : nullptr};
          int newton[3], n = 0;
          for (int i = 0; i < 3 && hit == UINT32_MAX; ++i) {
            if (!tries[i]) continue;
            const uint32_t k = tries[i]->cell;
            if (k == UINT32_MAX || k == a.cell || (i > 0 && tries[0] && k == tries[0]->cell) ||
                (i > 1 && tries[1] && k == tries[1]->cell)) {
              continue;
            }
            if (!s.cells[k].closed_form) {
              newton[n++] = i;
            } else if (test(k, p, p, found) >= interior) {  // (the guess is not used)
              hit = k, ++hits;
            }
          }
          if (hit == UINT32_MAX && n > 0) {
            Vec3d predictions[3];
            double depth[3];
            for (int j = 0; j < n; ++j) {
              const int i = newton[j];
              const double delta =
                  i == 0 ? p.x - s.coords[0][x - 1] : (i == 1 ? py - s.coords[1][y - 1] : pz - s.coords[2][z - 1]);
              predictions[i] = tries[i]->predict(i, delta);
              depth[i] = margin_of(s.cells[tries[i]->cell].type, predictions[i]);
              for (int m = j; m > 0 && depth[newton[m - 1]] < depth[newton[m]]; --m)
                std::swap(newton[m], newton[m - 1]);
            }
            for (int j = 0; j < n && hit == UINT32_MAX; ++j) {
              const int i = newton[j];
              const uint32_t k = tries[i]->cell;
              const PreparedCell& c = s.cells[k];
              const Vec3d guess = border ? c.start(p) : predictions[i];
              if (border && c.surely_outside(guess)) continue;
              if (test(k, p, guess, found) >= interior) hit = k, ++hits;
            }
          }
        }
        // 3. The bucket: a cell well inside wins at once, else the lowest id within tolerance. Its cells are first
        //    narrowed to those whose box spans this row's y and z; the samples of the row in the same bucket (most
        //    of them outside the mesh: inside ones rarely get here) then compare x alone.
        if (hit == UINT32_MAX) {
          ++st.searches;
          const uint32_t b = s.bucket_of[0][x] + bzy;
          if (b != row_bucket) {
            row_bucket = b;
            s.row.clear();
            for (uint32_t e = s.bucket_offsets[b]; e < s.bucket_offsets[b + 1]; ++e) {
              const Bounds& c = s.boxes[s.bucket_cells[e]];
              if (p.y >= c.lo.y && p.y <= c.hi.y && p.z >= c.lo.z && p.z <= c.hi.z) {
                s.row.push_back({c.lo.x, c.hi.x, s.bucket_cells[e]});
              }
            }
          }
          uint64_t best_id = UINT64_MAX;
          for (const RowEntry& entry : s.row) {
            if (p.x < entry.lo || p.x > entry.hi) continue;
            const uint32_t k = entry.cell;
            const PreparedCell& c = s.cells[k];
            const Vec3d start = c.start(p);
            if (!c.closed_form && c.surely_outside(start)) continue;
            const double m = test(k, p, start, r);
            if (m >= interior) {
              hit = k, found = r;
              break;
            }
            if (m >= -tol && c.id < best_id) best_id = c.id, hit = k, found = r;
          }
        }
        if (hit == UINT32_MAX) {
          here_row[x].cell = UINT32_MAX;
        } else {
          Seen& seen = here_row[x];
          seen.cell = hit, seen.rst = found.rst, seen.inverse = found.inverse;
          record(row_offset + x, hit, found.rst);
        }
      }
    }
  }
  out.valid = valid;
  st.cache_hits = hits, st.predicted_hits = predicted_hits;
  st.cell_tests += st.predicted;  // the attempts are tests too
  if (stats) *stats += st;
}

}  // namespace ugvr
