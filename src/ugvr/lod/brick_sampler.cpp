#include "ugvr/lod/brick_sampler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/lod/cell_box_overlap.h"

namespace ugvr {
namespace {

constexpr double kNotInside = -std::numeric_limits<double>::infinity();

// One candidate cell, prepared once per brick for the many point tests it will take. Geometry: a tetrahedron keeps
// vertex 0 in map.c[0] and the rows of the inverse of its edge matrix in map.c[1..3] (barycentric coordinates are
// then one subtraction and three dot products); the other types keep their monomial form for Newton.
struct PreparedCell {
  Vec3d lo, hi;  // bounding box, widened like the buckets so the prefilter never rejects a point the test accepts
  uint64_t id;
  CellType type;
  MonomialForm<Vec3d> map;
  // Newton's first step from the parametric centre, precomputed (the centre's image and the inverse Jacobian
  // there): the start for tests that must not depend on where the sampler came from (see start()).
  Vec3d centre, centre_x;
  std::array<Vec3d, 3> centre_inverse;
  bool affine_start = false;

  // A start for Newton that depends only on the cell and p: the point under the affine map of the centre.
  Vec3d start(Vec3d p) const {
    if (!affine_start) return centre;
    const Vec3d d = p - centre_x;
    return centre + Vec3d{dot(centre_inverse[0], d), dot(centre_inverse[1], d), dot(centre_inverse[2], d)};
  }
};

// A cell of the current bucket whose box spans the current row's y and z: its x extent.
struct RowEntry {
  double lo, hi;
  uint32_t cell;
};

// The cell and parametric coordinates of the last sample seen at one (x, y) of the brick.
struct Seen {
  uint32_t cell = UINT32_MAX;
  Vec3d rst;
};

}  // namespace

struct BrickScratch::Impl {
  std::vector<PreparedCell> cells;
  std::vector<MonomialForm<double>> values;          // per prepared cell, per scalar (a cell scalar is a constant form)
  std::vector<double> cell_margin;                   // overlap margin per prepared cell
  std::vector<Seen> seen;                            // R² entries: (x, y) of the current or the previous z
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

// Parametric coordinates of p in the prepared cell and the margin by which p is inside (kNotInside when the inverse
// map fails).
template <CellType T>
double locate(const PreparedCell& c, Vec3d p, Vec3d guess, double newton_tolerance, Vec3d& rst) {
  if constexpr (T == CellType::Tetra) {
    const Vec3d d = p - c.map.c[0];
    rst = {dot(c.map.c[1], d), dot(c.map.c[2], d), dot(c.map.c[3], d)};
  } else {
    if (!inverse_map_monomial(c.map, p, guess, rst, newton_tolerance)) return kNotInside;
  }
  return parametric_margin<T>(rst);
}

inline bool in_box(const PreparedCell& c, Vec3d p) {
  return p.x >= c.lo.x && p.x <= c.hi.x && p.y >= c.lo.y && p.y <= c.hi.y && p.z >= c.lo.z && p.z <= c.hi.z;
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
    c.lo = bb.lo, c.hi = bb.hi;
    if (c.lo.x > box.hi.x || c.lo.y > box.hi.y || c.lo.z > box.hi.z || c.hi.x < box.lo.x || c.hi.y < box.lo.y ||
        c.hi.z < box.lo.z) {
      continue;
    }
    if (c.type == CellType::Tetra) {
      Vec3d rows[3];
      if (!detail::inverse_rows(v[1] - v[0], v[2] - v[0], v[3] - v[0], rows)) continue;  // flat: no volume
      c.map.c[0] = v[0], c.map.c[1] = rows[0], c.map.c[2] = rows[1], c.map.c[3] = rows[2];
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
    }
    s.cells.push_back(c);
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
      first[size_t(a)] = bucket_index(a, c.lo[a]);
      last[size_t(a)] = bucket_index(a, c.hi[a]);
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
  const double newton_tolerance = options_.newton_tolerance;
  auto test = [&](uint32_t k, Vec3d p, Vec3d guess, Vec3d& rst) {
    const PreparedCell& c = s.cells[k];
    if (!in_box(c, p)) return kNotInside;
    ++st.cell_tests;
    return with_cell_type(c.type,
                          [&](auto tag) { return locate<decltype(tag)::value>(c, p, guess, newton_tolerance, rst); });
  };
  const double tol = options_.tolerance, interior = options_.interior_margin;
  s.seen.assign(size_t(R) * R, Seen{});
  Seen previous, before_previous;  // the samples before this one in visiting order
  for (uint32_t z = 0; z < R; ++z) {
    for (uint32_t y = 0; y < R; ++y) {
      const uint32_t bzy = B * (s.bucket_of[1][y] + B * s.bucket_of[2][z]);
      uint32_t row_bucket = UINT32_MAX;  // the bucket whose cells s.row holds, for this row
      const bool border_zy = z == 0 || z == R - 1 || y == 0 || y == R - 1;
      for (uint32_t x = 0; x < R; ++x) {
        const Vec3d p{s.coords[0][x], s.coords[1][y], s.coords[2][z]};
        // Border samples are shared with other bricks: every test starts from PreparedCell::start there, so the
        // result depends on nothing but the point and the cell.
        const bool border = border_zy || x == 0 || x == R - 1;
        uint32_t hit = UINT32_MAX;
        Vec3d rst;
        // 1. The cells of the previous sample and of the neighbours at y - 1 and z - 1, accepted only well inside
        //    (then no other cell can hold the point).
        Seen& here = s.seen[x + size_t(R) * y];  // still the sample at z - 1
        const Seen& below = y > 0 ? s.seen[x + size_t(R) * (y - 1)] : Seen{};
        const uint32_t tries[3] = {previous.cell, below.cell, here.cell};
        // Samples are evenly spaced: along x, extrapolating the last two samples' coordinates leaves Newton an error
        // of second order in the spacing instead of first.
        const bool run = x >= 2 && before_previous.cell == previous.cell;
        const Vec3d warm[3] = {run ? previous.rst * 2.0 - before_previous.rst : previous.rst, below.rst, here.rst};
        for (int i = 0; i < 3 && hit == UINT32_MAX; ++i) {
          const uint32_t k = tries[i];
          if (k == UINT32_MAX || (i > 0 && k == tries[0]) || (i > 1 && k == tries[1])) continue;
          const Vec3d guess = border ? s.cells[k].start(p) : warm[i];
          if (test(k, p, guess, rst) >= interior) hit = k, ++st.cache_hits;
        }
        // 2. The bucket: a cell well inside wins at once, else the lowest id within tolerance. Its cells are first
        //    narrowed to those whose box spans this row's y and z; the samples of the row in the same bucket (most
        //    of them outside the mesh: inside ones rarely get here) then compare x alone.
        if (hit == UINT32_MAX) {
          ++st.searches;
          const uint32_t b = s.bucket_of[0][x] + bzy;
          if (b != row_bucket) {
            row_bucket = b;
            s.row.clear();
            for (uint32_t e = s.bucket_offsets[b]; e < s.bucket_offsets[b + 1]; ++e) {
              const PreparedCell& c = s.cells[s.bucket_cells[e]];
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
            Vec3d r;
            const double m = test(k, p, c.start(p), r);
            if (m >= interior) {
              hit = k, rst = r;
              break;
            }
            if (m >= -tol && c.id < best_id) best_id = c.id, hit = k, rst = r;
          }
        }
        before_previous = previous;
        here = previous = Seen{hit, rst};
        if (hit == UINT32_MAX) continue;
        const size_t si = x + size_t(R) * (y + size_t(R) * z);
        out.mask[si] = 1;
        ++out.valid;
        const MonomialForm<double>* vals = s.values.data() + size_t(hit) * F;
        for (size_t f = 0; f < F; ++f) out.values[f * per_field + si] = float(vals[f].evaluate(rst));
      }
    }
  }
  if (stats) *stats += st;
}

}  // namespace ugvr
