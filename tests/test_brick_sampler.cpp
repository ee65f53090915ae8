// Cell/box overlap against brute force, the sample lattice's shared samples, and leaf bricks against a brute-force
// point location on synthetic grids and on the real spx, blunt fin and oxygen post meshes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/cell_box_overlap.h"

namespace ugvr {
namespace {

// ---- cell / box overlap --------------------------------------------------------------------------------------------

Vec3d forward(CellType type, const Vec3d* v, Vec3d rst) {
  double N[kMaxCellVertices];
  shape_functions(type, rst, N);
  Vec3d x{};
  for (int i = 0; i < cell_vertex_count(type); ++i) x = x + v[i] * N[i];
  return x;
}

Vec3d random_rst(CellType type, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (;;) {
    const Vec3d p{u(rng), u(rng), u(rng)};
    if (parametric_inside(type, p, 0.0)) return p;
  }
}

// A skewed cell, its vertices moved by up to `warp` (so quadrilateral faces are not planar); not necessarily convex.
std::vector<Vec3d> random_cell(CellType type, std::mt19937& rng, double warp) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = cell_vertex_count(type);
  double A[3][3];
  for (auto& row : A)
    for (double& a : row) a = 0.5 * u(rng);
  for (int i = 0; i < 3; ++i) A[i][i] += 1.2;
  std::vector<Vec3d> v(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    Vec3d p = parametric_vertex(type, i);
    if (type == CellType::Pyramid && i == 4) p = {0.5, 0.5, 1.0};
    v[size_t(i)] = Vec3d{A[0][0] * p.x + A[0][1] * p.y + A[0][2] * p.z, A[1][0] * p.x + A[1][1] * p.y + A[1][2] * p.z,
                         A[2][0] * p.x + A[2][1] * p.y + A[2][2] * p.z} +
                   Vec3d{warp * u(rng), warp * u(rng), warp * u(rng)};
  }
  return v;
}

bool in_bounds(const Bounds& b, Vec3d p) {
  return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

// Overlap by dense sampling: points of the cell inside the box, or points of the box inside the cell. Finds every
// overlap that is not thin.
bool brute_force_overlap(CellType type, const std::vector<Vec3d>& v, const Bounds& box, std::mt19937& rng,
                         int density = 1) {
  for (const Vec3d& p : v)
    if (in_bounds(box, p)) return true;
  for (int k = 0; k < 2000 * density * density * density; ++k)
    if (in_bounds(box, forward(type, v.data(), random_rst(type, rng)))) return true;
  const int n = 12 * density;
  for (int z = 0; z <= n; ++z)
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x) {
        const Vec3d p =
            box.lo + Vec3d{(box.hi.x - box.lo.x) * x / n, (box.hi.y - box.lo.y) * y / n, (box.hi.z - box.lo.z) * z / n};
        Vec3d rst;
        if (inverse_map(type, v.data(), p, parametric_center(type), rst) && parametric_inside(type, rst, 0.0)) {
          return true;
        }
      }
  return false;
}

class CellBoxOverlap : public ::testing::TestWithParam<CellType> {};

TEST_P(CellBoxOverlap, NeverMissesAnOverlapFoundByBruteForce) {
  const CellType type = GetParam();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.4, 1.4), size(0.02, 0.8);
  int overlaps = 0, brute_overlaps = 0, false_positives = 0;
  const int trials = 1500;
  for (int trial = 0; trial < trials; ++trial) {
    const std::vector<Vec3d> v = random_cell(type, rng, type == CellType::Tetra ? 0.0 : 0.2);
    Bounds box;
    const Vec3d c{u(rng), u(rng), u(rng)};
    const Vec3d h{size(rng), size(rng), size(rng)};
    box.lo = c - h * 0.5, box.hi = c + h * 0.5;
    const bool sat = cell_box_overlap(type, v.data(), box);
    // Fewer axes may only add overlaps.
    const bool faces = cell_box_overlap(type, v.data(), box, OverlapAxes::FaceNormals);
    const bool boxes = cell_box_overlap(type, v.data(), box, OverlapAxes::BoxNormals);
    ASSERT_TRUE(!sat || faces) << "trial " << trial;
    ASSERT_TRUE(!faces || boxes) << "trial " << trial;
    // Where the two disagree, look again 4x denser per axis: most of those overlaps are merely thin.
    bool brute = brute_force_overlap(type, v, box, rng);
    if (sat && !brute) brute = brute_force_overlap(type, v, box, rng, 4);
    overlaps += sat, brute_overlaps += brute;
    ASSERT_TRUE(sat || !brute) << "trial " << trial << ": separating axis claims no overlap, brute force found one";
    false_positives += sat && !brute;
  }
  // Both outcomes must be well represented.
  EXPECT_GT(brute_overlaps, trials / 5);
  EXPECT_LT(brute_overlaps, trials * 4 / 5);
  std::printf("%s: %d overlaps by SAT, %d by brute force, %d false positives (%.2f%% of trials)\n",
              std::string(cell_name(type)).c_str(), overlaps, brute_overlaps, false_positives,
              100.0 * false_positives / trials);
  // The test is exact for tetrahedra (convex, planar faces): what remains there are contacts too thin even for the
  // denser look. Warped cells add the volume of their convex hull beyond the cell (about 2% of these trials).
  EXPECT_LE(false_positives, type == CellType::Tetra ? trials / 500 : trials / 25);
}

INSTANTIATE_TEST_SUITE_P(AllTypes, CellBoxOverlap, ::testing::ValuesIn(kAllCellTypes),
                         [](const auto& param_info) { return std::string(cell_name(param_info.param)); });

TEST(CellBoxOverlapTetra, TouchingCountsAndEdgeAxesSeparate) {
  const Vec3d tet[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  auto box = [](Vec3d lo, Vec3d hi) {
    Bounds b;
    b.lo = lo, b.hi = hi;
    return b;
  };
  // Touches the edge (1,0,0)-(0,1,0) at (0.5, 0.5, 0) only.
  EXPECT_TRUE(cell_box_overlap(CellType::Tetra, tet, box({0.5, 0.5, -1}, {1, 1, 0})));
  // Separated only by the tet's slanted face normal (1,1,1): every box axis overlaps.
  EXPECT_FALSE(cell_box_overlap(CellType::Tetra, tet, box({0.34, 0.34, 0.34}, {1, 1, 1})));
  // Separated only by an edge x box-axis cross product: the first box pulled off the edge (1,0,0)-(0,1,0); the
  // axis (1,1,0) = (1,-1,0) x z separates it, no box or face normal does.
  EXPECT_FALSE(cell_box_overlap(CellType::Tetra, tet, box({0.5 + 1e-3, 0.5 + 1e-3, -1}, {1, 1, 0})));
  // Inside and containing.
  EXPECT_TRUE(cell_box_overlap(CellType::Tetra, tet, box({0.1, 0.1, 0.1}, {0.2, 0.2, 0.2})));
  EXPECT_TRUE(cell_box_overlap(CellType::Tetra, tet, box({-1, -1, -1}, {2, 2, 2})));
}

UnstructuredMesh jittered_grid(uint32_t n, StructuredCellShape shape, uint32_t seed, double jitter = 0.25) {
  StructuredGrid g;
  g.dims = GridDims{{n + 1, n + 2, n}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  for (uint32_t k = 0; k < g.dims.points[2]; ++k)
    for (uint32_t j = 0; j < g.dims.points[1]; ++j)
      for (uint32_t i = 0; i < g.dims.points[0]; ++i) {
        // A sheared, bent box, every vertex jittered (boundary vertices too: the mesh is not a box).
        const double x = i + u(rng), y = j + u(rng), z = k + u(rng);
        g.points.push_back({float(x + 0.3 * y), float(y + 0.05 * x * x), float(z - 0.2 * x)});
      }
  return make_explicit_cells(g, shape).mesh;
}

TEST(CellBoxOverlapLists, AgreeWithTheTestOnEveryPair) {
  const UnstructuredMesh mesh = jittered_grid(6, StructuredCellShape::FiveTetrahedra, 3);
  Bounds region = mesh.bounds();
  region.lo = region.lo + Vec3d{0.7, 0.3, 0.1};  // a region not aligned with the mesh's bounds
  const std::array<uint32_t, 3> dims{3, 4, 2};
  const BoxCellLists lists = cells_overlapping_boxes(mesh, region, dims);
  for (uint32_t z = 0; z < dims[2]; ++z)
    for (uint32_t y = 0; y < dims[1]; ++y)
      for (uint32_t x = 0; x < dims[0]; ++x) {
        const uint64_t b = x + dims[0] * (y + dims[1] * z);
        Bounds box;
        for (int a = 0; a < 3; ++a) {
          const uint32_t i = a == 0 ? x : (a == 1 ? y : z);
          box.lo[a] = region.lo[a] + region.size()[a] * (double(i) / dims[size_t(a)]);
          box.hi[a] = region.lo[a] + region.size()[a] * (double(i + 1) / dims[size_t(a)]);
        }
        std::vector<uint64_t> expected;
        for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
          Vec3d v[kMaxCellVertices];
          gather_cell_vertices(mesh, c, v);
          if (cell_box_overlap(mesh.cell_types[c], v, box)) expected.push_back(c);
        }
        const auto got = lists.box(b);
        // Every overlapping cell is listed (the margin may add cells that merely come within it).
        EXPECT_TRUE(std::includes(got.begin(), got.end(), expected.begin(), expected.end())) << "box " << b;
        EXPECT_LE(got.size(), expected.size() + 2) << "box " << b;
      }
}

// ---- the sampler's inverse map: corrected Newton steps ------------------------------------------------------------

using Lanes = double __attribute__((vector_size(16)));  // as the sampler's first steps

// inverse_map_corrected ends within its accuracy of a solution (plain Newton to 1e-12 stays there; warped cells can
// map two points of parameter space to one point, so which solution depends on the guess), from the centre and from
// guesses off by up to 0.05, on warped cells of every Newton type, points outside them too; and on a cell as smooth
// as a real grid's, a guess as close as a neighbouring sample's prediction mostly takes one step.
TEST(SamplerInverseMap, CorrectedNewtonIsAccurate) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> off(-0.05, 0.05), out(-0.3, 1.3);
  for (CellType type : {CellType::Hexahedron, CellType::Wedge, CellType::Pyramid}) {
    int converged = 0, tries = 0, one_step = 0;
    for (int trial = 0; trial < 400; ++trial) {
      const std::vector<Vec3d> v = random_cell(type, rng, 0.2);
      const MonomialForm<Vec3d> m =
          with_cell_type(type, [&](auto tag) { return to_monomial<decltype(tag)::value>(v.data()); });
      const double nonlinearity = monomial_nonlinearity(m);
      const Vec3d rst = trial % 2 ? random_rst(type, rng) : Vec3d{out(rng), out(rng), out(rng) * 0.7};
      const Vec3d p = forward(type, v.data(), rst);
      for (const Vec3d guess : {parametric_center(type), rst + Vec3d{off(rng), off(rng), off(rng)}}) {
        ++tries;
        InverseMapResult r;
        if (!inverse_map_corrected(m, nonlinearity, 0.0, p - m.c[0], guess, 1e-12, r)) continue;
        ++converged;
        Vec3d exact;
        ASSERT_TRUE(inverse_map_newton(type, v.data(), p, r.rst, exact));
        const double err =
            std::max({std::abs(r.rst.x - exact.x), std::abs(r.rst.y - exact.y), std::abs(r.rst.z - exact.z)});
        ASSERT_LE(err, 1e-11) << cell_name(type) << " trial " << trial;
      }
      // A cell as smooth as a real grid's (nonlinearity a few percent of its size).
      const std::vector<Vec3d> w = random_cell(type, rng, 0.02);
      const MonomialForm<Vec3d> mw =
          with_cell_type(type, [&](auto tag) { return to_monomial<decltype(tag)::value>(w.data()); });
      const Vec3d target = forward(type, w.data(), rst) - mw.c[0];
      const InverseMapStep<double> st =
          inverse_map_step(mw, monomial_nonlinearity(mw), target, rst + Vec3d{1e-5, -1e-5, 1e-5});
      one_step += st.error2 <= 1e-24;
    }
    EXPECT_GT(converged, tries * 9 / 10) << cell_name(type);
    EXPECT_GT(one_step, 400 * 3 / 4) << cell_name(type);
  }
}

// Two points as the two lanes of one step round exactly as each alone: a shared border sample gets the same bits
// whether the sampler takes it in a pair or alone.
TEST(SamplerInverseMap, LanesRoundAsTheScalarStep) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.2, 1.2);
  auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (int trial = 0; trial < 2000; ++trial) {
    const CellType type =
        trial % 3 == 0 ? CellType::Hexahedron : (trial % 3 == 1 ? CellType::Wedge : CellType::Pyramid);
    MonomialForm<Vec3d> m[2];
    Vec3d target[2], guess[2];
    for (int l = 0; l < 2; ++l) {
      const std::vector<Vec3d> v = random_cell(type, rng, 0.3);
      m[l] = with_cell_type(type, [&](auto tag) { return to_monomial<decltype(tag)::value>(v.data()); });
      target[l] = forward(type, v.data(), {u(rng), u(rng), u(rng)}) - m[l].c[0];
      guess[l] = {u(rng), u(rng), u(rng)};
    }
    auto lanes = [](Vec3d a, Vec3d b) { return Vec3<Lanes>{Lanes{a.x, b.x}, Lanes{a.y, b.y}, Lanes{a.z, b.z}}; };
    MonomialForm<Vec3<Lanes>> ml;
    for (size_t k = 0; k < 8; ++k) ml.c[k] = lanes(m[0].c[k], m[1].c[k]);
    const InverseMapStep<Lanes> both =
        inverse_map_step(ml, Lanes{monomial_nonlinearity(m[0]), monomial_nonlinearity(m[1])},
                         lanes(target[0], target[1]), lanes(guess[0], guess[1]));
    for (int l = 0; l < 2; ++l) {
      const InverseMapStep<double> one = inverse_map_step(m[l], monomial_nonlinearity(m[l]), target[l], guess[l]);
      ASSERT_TRUE(same(one.rst.x, both.rst.x[l]) && same(one.rst.y, both.rst.y[l]) && same(one.rst.z, both.rst.z[l]))
          << "trial " << trial << " lane " << l;
      ASSERT_TRUE(same(one.error2, both.error2[l]) && same(one.step2, both.step2[l]) && same(one.det2, both.det2[l]));
      for (size_t k = 0; k < 3; ++k) {
        ASSERT_TRUE(same(one.inverse[k].x, both.inverse[k].x[l]) && same(one.inverse[k].y, both.inverse[k].y[l]) &&
                    same(one.inverse[k].z, both.inverse[k].z[l]));
      }
    }
  }
}

// ---- lattice ------------------------------------------------------------------------------------------------------

TEST(BrickLattice, SharedSamplesAreBitIdentical) {
  BrickLattice lattice;
  lattice.root.lo = {-0.123456789, 3.3, 1e3 / 7};
  lattice.root.hi = {0.987654321, 17.1, 1e3 / 3};
  lattice.resolution = 33;
  std::mt19937 rng(7);
  for (int level = 0; level < 10; ++level) {
    std::uniform_int_distribution<uint64_t> m(0, uint64_t(32) << level);
    for (int k = 0; k < 1000; ++k) {
      const uint64_t line = m(rng);
      for (int a = 0; a < 3; ++a) {
        const double here = lattice.coordinate(a, level, line), finer = lattice.coordinate(a, level + 1, 2 * line);
        EXPECT_EQ(std::memcmp(&here, &finer, sizeof here), 0);
      }
    }
    // Neighbouring nodes share their common face exactly.
    const uint32_t nodes = 1u << level;
    for (uint32_t i = 0; i + 1 < nodes && i < 50; ++i) {
      EXPECT_EQ(lattice.node_box(level, {i, 0, 0}).hi.x, lattice.node_box(level, {i + 1, 0, 0}).lo.x);
    }
    EXPECT_EQ(lattice.node_box(level, {0, 0, 0}).lo.y, lattice.root.lo.y);
  }
}

// ---- brute-force point location over a lattice ---------------------------------------------------------------------

// For every point of the lattice of `level` (all nodes), the cell the sampler must pick and the exact field values,
// found cell by cell: each cell tests the lattice points in its bounding box. Shares nothing with the sampler but the
// point-in-cell predicate and its rule for points on faces.
struct Located {
  uint64_t n = 0;              // lattice points per axis
  std::vector<uint64_t> cell;  // UINT64_MAX: in no cell
  std::vector<double> margin;  // of the chosen cell
  std::vector<double> values;  // scalar-major, n³ each
};

Located brute_force_locate(const UnstructuredMesh& mesh, const std::vector<ScalarRef>& scalars,
                           const BrickLattice& lattice, int level, const BrickSamplerOptions& o) {
  Located L;
  L.n = (uint64_t(lattice.resolution - 1) << level) + 1;
  const uint64_t total = L.n * L.n * L.n;
  L.cell.assign(total, UINT64_MAX);
  L.margin.assign(total, -INFINITY);
  L.values.assign(scalars.size() * total, 0.0);
  const Vec3d size = lattice.root.size();
  for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
    const CellType type = mesh.cell_types[c];
    Vec3d v[kMaxCellVertices];
    const int nv = gather_cell_vertices(mesh, c, v);
    Bounds bb;
    for (int i = 0; i < nv; ++i) bb.add(v[i]);
    std::array<uint64_t, 3> first{}, last{};
    bool empty = false;
    for (int a = 0; a < 3; ++a) {
      const double f0 = std::ceil((bb.lo[a] - lattice.root.lo[a]) / size[a] * double(L.n - 1)) - 1;
      const double f1 = std::floor((bb.hi[a] - lattice.root.lo[a]) / size[a] * double(L.n - 1)) + 1;
      if (f1 < 0 || f0 > double(L.n - 1)) empty = true;
      first[size_t(a)] = uint64_t(std::clamp(f0, 0.0, double(L.n - 1)));
      last[size_t(a)] = uint64_t(std::clamp(f1, 0.0, double(L.n - 1)));
    }
    if (empty) continue;
    for (uint64_t z = first[2]; z <= last[2]; ++z)
      for (uint64_t y = first[1]; y <= last[1]; ++y)
        for (uint64_t x = first[0]; x <= last[0]; ++x) {
          const Vec3d p{lattice.coordinate(0, level, x), lattice.coordinate(1, level, y),
                        lattice.coordinate(2, level, z)};
          Vec3d rst;
          if (!inverse_map(type, v, p, parametric_center(type), rst)) continue;
          const double m = parametric_margin(type, rst);
          if (m < -o.tolerance) continue;
          const uint64_t s = x + L.n * (y + L.n * z);
          // The sampler's rule: a cell holding the point well inside, else the lowest id within tolerance.
          const bool better = L.cell[s] == UINT64_MAX || (m >= o.interior_margin && L.margin[s] < o.interior_margin) ||
                              (L.margin[s] < o.interior_margin && m < o.interior_margin && c < L.cell[s]);
          if (!better) continue;
          L.cell[s] = c, L.margin[s] = m;
          const std::span<const uint32_t> ids = mesh.cell(c);
          for (size_t f = 0; f < scalars.size(); ++f) {
            const Field& field = *scalars[f].field;
            if (field.association() == Association::Cell) {
              L.values[f * total + s] = field.scalar(c, scalars[f].component);
            } else {
              double vals[kMaxCellVertices];
              for (size_t i = 0; i < ids.size(); ++i) vals[i] = field.scalar(ids[i], scalars[f].component);
              L.values[f * total + s] = interpolate(type, rst, vals);
            }
          }
        }
  }
  return L;
}

struct Comparison {
  uint64_t samples = 0, valid = 0, mask_mismatches = 0;
  std::vector<double> max_error;   // per scalar, relative to its range
  uint64_t shared_mismatches = 0;  // border samples that differ between the bricks holding them
};

// Samples every node of `level` and compares with brute force; also checks that samples two bricks share agree bit
// for bit (every lattice point is computed by each brick that holds it).
Comparison sample_and_compare(const UnstructuredMesh& mesh, const std::vector<ScalarRef>& scalars, int level,
                              uint32_t R) {
  BrickLattice lattice;
  lattice.root = mesh.bounds();
  lattice.resolution = R;
  const BrickSampler sampler(mesh, scalars);
  const Located L = brute_force_locate(mesh, scalars, lattice, level, sampler.options());
  const uint32_t nodes = 1u << level;
  const BoxCellLists lists = cells_overlapping_boxes(mesh, lattice.root, {nodes, nodes, nodes});
  const uint64_t total = L.n * L.n * L.n;
  // First brick's bits per lattice point, to compare with the other bricks holding it.
  std::vector<float> seen(scalars.size() * total, NAN);
  std::vector<int8_t> seen_mask(total, -1);
  Comparison cmp;
  cmp.max_error.assign(scalars.size(), 0.0);
  std::vector<double> range(scalars.size());
  for (size_t f = 0; f < scalars.size(); ++f) {
    const Range r = scalars[f].field->range(scalars[f].component);
    range[f] = std::max(r.max - r.min, 1e-300);
  }
  BrickScratch scratch;
  BrickSamples out;
  for (uint32_t k = 0; k < nodes; ++k)
    for (uint32_t j = 0; j < nodes; ++j)
      for (uint32_t i = 0; i < nodes; ++i) {
        sampler.sample(lattice, level, {i, j, k}, lists.box(i + nodes * (j + nodes * k)), scratch, out);
        for (uint32_t z = 0; z < R; ++z)
          for (uint32_t y = 0; y < R; ++y)
            for (uint32_t x = 0; x < R; ++x) {
              const size_t si = x + size_t(R) * (y + size_t(R) * z);
              const uint64_t gx = uint64_t(i) * (R - 1) + x, gy = uint64_t(j) * (R - 1) + y,
                             gz = uint64_t(k) * (R - 1) + z;
              const uint64_t s = gx + L.n * (gy + L.n * gz);
              ++cmp.samples;
              const bool inside = L.cell[s] != UINT64_MAX;
              cmp.valid += inside;
              if (bool(out.mask[si]) != inside) ++cmp.mask_mismatches;
              if (seen_mask[s] >= 0 && seen_mask[s] != out.mask[si]) ++cmp.shared_mismatches;
              seen_mask[s] = int8_t(out.mask[si]);
              for (size_t f = 0; f < scalars.size(); ++f) {
                const float got = out.field(uint32_t(f))[si];
                float& first = seen[f * total + s];
                if (!std::isnan(first) && std::memcmp(&first, &got, 4) != 0) ++cmp.shared_mismatches;
                first = got;
                if (inside && out.mask[si]) {
                  const double err = std::abs(double(got) - L.values[f * total + s]) / range[f];
                  cmp.max_error[f] = std::max(cmp.max_error[f], err);
                }
              }
            }
      }
  return cmp;
}

void expect_exact(const Comparison& c, const std::string& what, double min_valid_fraction = 0.05) {
  SCOPED_TRACE(what);
  std::printf("%s: %llu samples, %llu valid, %llu mask mismatches, %llu shared mismatches, max error/range:",
              what.c_str(), (unsigned long long)c.samples, (unsigned long long)c.valid,
              (unsigned long long)c.mask_mismatches, (unsigned long long)c.shared_mismatches);
  for (double e : c.max_error) std::printf(" %.3g", e);
  std::printf("\n");
  EXPECT_EQ(c.mask_mismatches, 0u);
  EXPECT_EQ(c.shared_mismatches, 0u);
  EXPECT_GT(double(c.valid), min_valid_fraction * double(c.samples));
  for (double e : c.max_error) EXPECT_LE(e, 1e-5);
}

// A linear vertex field a·x + b and a per-cell field (the cell id).
struct SyntheticFields {
  FieldSet fields;
  std::vector<ScalarRef> refs;
};
SyntheticFields synthetic_fields(const UnstructuredMesh& mesh) {
  SyntheticFields s;
  std::vector<double> lin(mesh.point_count());
  for (size_t i = 0; i < lin.size(); ++i) {
    const Vec3d p = to_double(mesh.points[i]);
    lin[i] = 0.3 * p.x - 1.7 * p.y + 0.9 * p.z + 2.0;
  }
  std::vector<float> per_cell(mesh.cell_count());
  for (size_t c = 0; c < per_cell.size(); ++c) per_cell[c] = float(c % 97);
  std::vector<float> vec(mesh.point_count() * 3);
  for (size_t i = 0; i < mesh.point_count(); ++i) {
    vec[3 * i] = mesh.points[i].x, vec[3 * i + 1] = 2.0f, vec[3 * i + 2] = -mesh.points[i].z;
  }
  s.fields.add(Field("linear", Association::Vertex, DataArray::from(std::move(lin), 1)));
  s.fields.add(Field("cellid", Association::Cell, DataArray::from(std::move(per_cell), 1)));
  s.fields.add(Field("vec", Association::Vertex, DataArray::from(std::move(vec), 3)));
  s.refs = {s.fields.scalar("linear"), s.fields.scalar("cellid"), s.fields.scalar("vec"), s.fields.scalar("vec:z")};
  return s;
}

class BrickSamplerSynthetic : public ::testing::TestWithParam<StructuredCellShape> {};

TEST_P(BrickSamplerSynthetic, MatchesBruteForceAndSharesBorders) {
  const UnstructuredMesh mesh = jittered_grid(7, GetParam(), 5);
  const SyntheticFields s = synthetic_fields(mesh);
  for (int level : {0, 1, 2}) {
    const Comparison c = sample_and_compare(mesh, s.refs, level, 9);
    expect_exact(c, "level " + std::to_string(level), 0.2);
  }
}

INSTANTIATE_TEST_SUITE_P(Shapes, BrickSamplerSynthetic,
                         ::testing::Values(StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra,
                                           StructuredCellShape::SixTetrahedra),
                         [](const auto& param_info) {
                           switch (param_info.param) {
                             case StructuredCellShape::Hexahedra: return std::string("hexahedra");
                             case StructuredCellShape::FiveTetrahedra: return std::string("five_tets");
                             case StructuredCellShape::SixTetrahedra: break;
                           }
                           return std::string("six_tets");
                         });

// A hexahedral mesh's cells split into two wedges each (by the same diagonal everywhere, so neighbours still share
// their faces) or into six pyramids over its faces with the apex at its centroid.
UnstructuredMesh split_hexahedra(const UnstructuredMesh& hexes, CellType to) {
  UnstructuredMesh out;
  out.points = hexes.points;
  for (uint64_t c = 0; c < hexes.cell_count(); ++c) {
    const std::span<const uint32_t> h = hexes.cell(c);
    if (to == CellType::Wedge) {
      const uint32_t a[6] = {h[0], h[1], h[2], h[4], h[5], h[6]}, b[6] = {h[0], h[2], h[3], h[4], h[6], h[7]};
      out.add_cell(CellType::Wedge, a);
      out.add_cell(CellType::Wedge, b);
    } else {
      Vec3d centroid{};
      for (uint32_t i : h) centroid = centroid + to_double(hexes.points[i]) * 0.125;
      const uint32_t apex = uint32_t(out.points.size());
      out.points.push_back({float(centroid.x), float(centroid.y), float(centroid.z)});
      const int faces[6][4] = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4}, {3, 2, 6, 7}, {0, 3, 7, 4}, {1, 2, 6, 5}};
      for (const auto& f : faces) {
        const uint32_t pyramid[5] = {h[size_t(f[0])], h[size_t(f[1])], h[size_t(f[2])], h[size_t(f[3])], apex};
        out.add_cell(CellType::Pyramid, pyramid);
      }
    }
  }
  return out;
}

TEST(BrickSampler, WedgesAndPyramidsMatchBruteForce) {
  const UnstructuredMesh hexes = jittered_grid(5, StructuredCellShape::Hexahedra, 13, 0.3);
  for (CellType type : {CellType::Wedge, CellType::Pyramid}) {
    const UnstructuredMesh mesh = split_hexahedra(hexes, type);
    const SyntheticFields s = synthetic_fields(mesh);
    for (int level : {0, 1, 2}) {
      expect_exact(sample_and_compare(mesh, s.refs, level, 9),
                   std::string(cell_name(type)) + " level " + std::to_string(level), 0.2);
    }
  }
}

TEST(BrickSampler, AxisAlignedGridPutsSamplesOnFacesEdgesAndVertices) {
  // Lattice points coincide with grid vertices, edges and faces everywhere: the tolerance rule is exercised at
  // nearly every sample, and a linear field must still come out exact with no hole.
  ImageGrid g{GridDims{{5, 5, 5}}, {0, 0, 0}, {0.25, 0.25, 0.25}};
  for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra}) {
    const UnstructuredMesh mesh = make_explicit_cells(g, shape).mesh;
    const SyntheticFields s = synthetic_fields(mesh);
    const Comparison c = sample_and_compare(mesh, s.refs, 1, 9);
    EXPECT_EQ(c.valid, c.samples);
    expect_exact(c, "axis-aligned");
  }
}

TEST(BrickSampler, CandidatesOutsideTheBrickAndEmptyBricks) {
  const UnstructuredMesh mesh = jittered_grid(4, StructuredCellShape::Hexahedra, 9);
  const SyntheticFields s = synthetic_fields(mesh);
  const BrickSampler sampler(mesh, s.refs);
  BrickLattice lattice;
  lattice.root = mesh.bounds();
  lattice.root.hi = lattice.root.hi + lattice.root.size();  // the mesh fills one octant of the root
  lattice.resolution = 5;
  std::vector<uint64_t> all(mesh.cell_count());
  for (uint64_t c = 0; c < all.size(); ++c) all[c] = c;
  BrickScratch scratch;
  BrickSamples out;
  BrickSamplerStats stats;
  sampler.sample(lattice, 1, {1, 1, 1}, all, scratch, out, &stats);
  EXPECT_EQ(out.valid, 0u);
  sampler.sample(lattice, 1, {1, 1, 1}, {}, scratch, out, &stats);
  EXPECT_EQ(out.valid, 0u);
  EXPECT_EQ(out.values.size(), 4u * 125u);
  EXPECT_TRUE(std::all_of(out.values.begin(), out.values.end(), [](float v) { return v == 0.0f; }));
}

TEST(BrickSampler, RefusesFieldsOfAnotherMesh) {
  const UnstructuredMesh mesh = jittered_grid(2, StructuredCellShape::Hexahedra, 1);
  FieldSet fs;
  fs.add(Field("short", Association::Vertex, DataArray::from(std::vector<float>(3, 1.0f), 1)));
  EXPECT_THROW(BrickSampler(mesh, {fs.scalar("short")}), Error);
}

// ---- real data ----------------------------------------------------------------------------------------------------

std::vector<ScalarRef> refs(const FieldSet& fs, std::initializer_list<const char*> names) {
  std::vector<ScalarRef> r;
  for (const char* n : names) r.push_back(fs.scalar(n));
  return r;
}

TEST(BrickSamplerRealData, SpxTetrahedra) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  const Dataset ds = read_dataset(std::vector<std::string>{relative_data_path});
  const Block& b = ds.blocks.at(0);
  const auto& mesh = std::get<UnstructuredMesh>(b.grid);
  expect_exact(sample_and_compare(mesh, refs(b.fields, {"density"}), 2, 17), "spx");
}

Block plot3d_block(const std::string& xyz, const std::string& q, StructuredCellShape shape) {
  const Dataset ds = read_dataset(std::vector<std::string>{xyz, q});
  return to_unstructured_block(ds.blocks.at(0), shape);
}

TEST(BrickSamplerRealData, BluntFinHexahedraAndTetrahedra) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  const std::string q = test::data_path("blunt-fin/bluntfinq.bin");
  for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra}) {
    const Block b = plot3d_block(relative_data_path, q, shape);
    const auto& mesh = std::get<UnstructuredMesh>(b.grid);
    expect_exact(sample_and_compare(mesh, refs(b.fields, {"Density", "StagnationEnergy", "Momentum"}), 2, 17),
                 shape == StructuredCellShape::Hexahedra ? "blunt fin hexahedra" : "blunt fin 5 tets");
  }
}

TEST(BrickSamplerRealData, LoxPost) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const std::string q = test::data_path("lox-post/postq.bin");
  const Dataset ds = read_dataset(std::vector<std::string>{relative_data_path, q});
  for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra}) {
    const Block b = to_unstructured_block(ds.blocks.at(0), shape);
    const auto& mesh = std::get<UnstructuredMesh>(b.grid);
    const std::vector<ScalarRef> scalars = refs(b.fields, {"StagnationEnergy", "Momentum"});
    expect_exact(sample_and_compare(mesh, scalars, 2, 17),
                 shape == StructuredCellShape::Hexahedra ? "lox post hexahedra" : "lox post 5 tets");
  }
}

TEST(BrickSamplerRealData, LoxPostIblankHoles) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const std::string q = test::data_path("lox-post/postq.bin");
  Dataset ds = read_dataset(std::vector<std::string>{relative_data_path, q});
  auto& grid = std::get<StructuredGrid>(ds.blocks.at(0).grid);
  ASSERT_TRUE(grid.has_iblank());
  // The file's IBLANK holds only 1 and -1 (overset fringe points, in use: structured_grid.h), so it blanks no cell.
  // Blank points as a flow solver's hole cutting would: a block of the grid and a scatter of single points.
  const GridDims d = grid.dims;
  uint64_t blanked_points = 0;
  for (uint32_t k = 0; k < d.points[2]; ++k)
    for (uint32_t j = 0; j < d.points[1]; ++j)
      for (uint32_t i = 0; i < d.points[0]; ++i) {
        const bool block = i >= 12 && i < 24 && j >= 30 && j < 50 && k >= 8 && k < 20;
        const bool scatter = (i * 7 + j * 13 + k * 5) % 97 == 0;
        if (block || scatter) grid.iblank[d.point_index(i, j, k)] = 0, ++blanked_points;
      }
  StructuredGrid full = grid;
  full.iblank.clear();
  const UnstructuredMesh unblanked = make_explicit_cells(full, StructuredCellShape::Hexahedra).mesh;
  for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra}) {
    const Block b = to_unstructured_block(ds.blocks.at(0), shape);
    const auto& mesh = std::get<UnstructuredMesh>(b.grid);
    const uint64_t per_hex = shape == StructuredCellShape::Hexahedra ? 1 : 5;
    ASSERT_LT(mesh.cell_count(), unblanked.cell_count() * per_hex);
    const std::vector<ScalarRef> scalars = refs(b.fields, {"StagnationEnergy"});
    expect_exact(sample_and_compare(mesh, scalars, 2, 17), "lox post with holes");
  }
  // The holes hold lattice points (inside the unblanked grid, outside the blanked one), which the comparison above
  // required to be masked out.
  const UnstructuredMesh blanked =
      std::get<UnstructuredMesh>(to_unstructured_block(ds.blocks.at(0), StructuredCellShape::Hexahedra).grid);
  BrickLattice lattice;
  lattice.root = blanked.bounds();
  lattice.resolution = 17;
  const Located with = brute_force_locate(blanked, {}, lattice, 2, {});
  const Located without = brute_force_locate(unblanked, {}, lattice, 2, {});
  uint64_t holes = 0;
  for (size_t s = 0; s < with.cell.size(); ++s) holes += with.cell[s] == UINT64_MAX && without.cell[s] != UINT64_MAX;
  std::printf("lox post: %llu points blanked, %llu of %zu lattice points in the holes\n",
              (unsigned long long)blanked_points, (unsigned long long)holes, with.cell.size());
  EXPECT_GT(holes, 1000u);
}

}  // namespace
}  // namespace ugvr
