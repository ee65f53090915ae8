// Shape functions, inverse maps and gradients of the four linear cell types, on skewed and warped cells.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "ugvr/grid/cell_interpolation.h"

namespace ugvr {
namespace {

// A random point of the type's parametric domain, kept `margin` away from its boundary (and, for the pyramid, away
// from the apex where the map is singular).
Vec3d random_rst(CellType type, std::mt19937& rng, double margin = 0.0) {
  std::uniform_real_distribution<double> u(margin, 1.0 - margin);
  for (;;) {
    const Vec3d p{u(rng), u(rng), u(rng)};
    if (type == CellType::Pyramid && p.z > 0.95) continue;
    if (parametric_inside(type, p, -margin)) return p;
  }
}

Vec3d forward(CellType type, const Vec3d* v, Vec3d rst) {
  double N[kMaxCellVertices];
  shape_functions(type, rst, N);
  Vec3d x{};
  for (int i = 0; i < cell_vertex_count(type); ++i) x = x + v[i] * N[i];
  return x;
}

double jacobian_det(CellType type, const Vec3d* v, Vec3d rst) {
  double dN[3 * kMaxCellVertices];
  shape_derivatives(type, rst, dN);
  const int n = cell_vertex_count(type);
  Vec3d c[3]{};
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < n; ++i) c[j] = c[j] + v[i] * dN[j * n + i];
  return dot(c[0], cross(c[1], c[2]));
}

// A skewed, warped cell: the reference cell (pyramid apex over the base centre) under a random affine map, then
// every vertex moved by up to `warp` (relative to a unit cell), rejected until the Jacobian keeps one sign inside.
std::vector<Vec3d> random_cell(CellType type, std::mt19937& rng, double warp) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = cell_vertex_count(type);
  for (;;) {
    double A[3][3];
    for (auto& row : A)
      for (double& a : row) a = 0.6 * u(rng);
    for (int i = 0; i < 3; ++i) A[i][i] += 1.5;
    const Vec3d shift{10 * u(rng), 10 * u(rng), 10 * u(rng)};
    std::vector<Vec3d> v(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      Vec3d p = parametric_vertex(type, i);
      if (type == CellType::Pyramid && i == 4) p = {0.5, 0.5, 1.0};
      const Vec3d q{A[0][0] * p.x + A[0][1] * p.y + A[0][2] * p.z, A[1][0] * p.x + A[1][1] * p.y + A[1][2] * p.z,
                    A[2][0] * p.x + A[2][1] * p.y + A[2][2] * p.z};
      v[size_t(i)] = shift + q + Vec3d{warp * u(rng), warp * u(rng), warp * u(rng)};
    }
    const double d0 = jacobian_det(type, v.data(), parametric_center(type));
    bool ok = std::abs(d0) > 0.05;
    for (int k = 0; ok && k < 200; ++k) {
      Vec3d p = random_rst(type, rng);
      if (type == CellType::Pyramid) p.z = std::min(p.z, 0.9);
      ok = jacobian_det(type, v.data(), p) * d0 > 0;
    }
    if (ok) return v;
  }
}

class CellInterpolation : public ::testing::TestWithParam<CellType> {};

TEST_P(CellInterpolation, ShapeFunctionsArePartitionOfUnityAndKronecker) {
  const CellType type = GetParam();
  const int n = cell_vertex_count(type);
  std::mt19937 rng(1);
  for (int k = 0; k < 1000; ++k) {
    const Vec3d p = random_rst(type, rng);
    double N[kMaxCellVertices], dN[3 * kMaxCellVertices];
    shape_functions(type, p, N);
    shape_derivatives(type, p, dN);
    double sum = 0, dsum[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i) {
      sum += N[i];
      for (int j = 0; j < 3; ++j) dsum[j] += dN[j * n + i];
    }
    EXPECT_NEAR(sum, 1.0, 1e-14);
    for (double d : dsum) EXPECT_NEAR(d, 0.0, 1e-14);
  }
  for (int j = 0; j < n; ++j) {
    double N[kMaxCellVertices];
    shape_functions(type, parametric_vertex(type, j), N);
    for (int i = 0; i < n; ++i) EXPECT_EQ(N[i], i == j ? 1.0 : 0.0) << "vertex " << j << " function " << i;
    EXPECT_TRUE(parametric_inside(type, parametric_vertex(type, j), 0.0));
  }
  EXPECT_TRUE(parametric_inside(type, parametric_center(type), 0.0));
}

TEST_P(CellInterpolation, DerivativesMatchFiniteDifferences) {
  const CellType type = GetParam();
  const int n = cell_vertex_count(type);
  std::mt19937 rng(2);
  const double h = 1e-6;
  for (int k = 0; k < 200; ++k) {
    const Vec3d p = random_rst(type, rng, 0.01);
    double dN[3 * kMaxCellVertices];
    shape_derivatives(type, p, dN);
    for (int j = 0; j < 3; ++j) {
      Vec3d a = p, b = p;
      a[j] -= h, b[j] += h;
      double Na[kMaxCellVertices], Nb[kMaxCellVertices];
      shape_functions(type, a, Na);
      shape_functions(type, b, Nb);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(dN[j * n + i], (Nb[i] - Na[i]) / (2 * h), 1e-8);
    }
  }
}

TEST_P(CellInterpolation, InverseMapInvertsForwardMapOnWarpedCells) {
  const CellType type = GetParam();
  std::mt19937 rng(3);
  for (int c = 0; c < 200; ++c) {
    const std::vector<Vec3d> v = random_cell(type, rng, 0.25);
    for (int k = 0; k < 50; ++k) {
      const Vec3d rst = random_rst(type, rng);
      const Vec3d x = forward(type, v.data(), rst);
      Vec3d back;
      ASSERT_TRUE(inverse_map(type, v.data(), x, parametric_center(type), back)) << "cell " << c;
      EXPECT_NEAR(back.x, rst.x, 1e-9);
      EXPECT_NEAR(back.y, rst.y, 1e-9);
      EXPECT_NEAR(back.z, rst.z, 1e-9);
      EXPECT_TRUE(parametric_inside(type, back, 1e-9));
    }
  }
}

TEST_P(CellInterpolation, PointsOutsideMapOutsideTheDomain) {
  const CellType type = GetParam();
  std::mt19937 rng(4);
  int tested = 0;
  for (int c = 0; c < 100; ++c) {
    const std::vector<Vec3d> v = random_cell(type, rng, 0.1);
    // Just beyond the middle of a face: outside the cell whatever the warp, and close enough for Newton.
    for (int f = 0; f < cell_face_count(type); ++f) {
      const CellFace face = cell_info(type).faces[size_t(f)];
      Vec3d mid{};
      for (int i = 0; i < face.size; ++i) mid = mid + v[face.v[size_t(i)]] * (1.0 / face.size);
      Vec3d centre{};
      for (const Vec3d& p : v) centre = centre + p * (1.0 / double(v.size()));
      const Vec3d x = mid + (mid - centre) * 0.2;
      Vec3d rst;
      if (!inverse_map(type, v.data(), x, parametric_center(type), rst)) continue;
      ++tested;
      EXPECT_FALSE(parametric_inside(type, rst, 1e-6)) << "cell " << c << " face " << f;
    }
  }
  EXPECT_GT(tested, 100 * cell_face_count(type) * 9 / 10);
}

TEST_P(CellInterpolation, GradientOfLinearFieldIsItsCoefficients) {
  const CellType type = GetParam();
  const int n = cell_vertex_count(type);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int c = 0; c < 200; ++c) {
    const std::vector<Vec3d> v = random_cell(type, rng, 0.25);
    const Vec3d a{u(rng), u(rng), u(rng)};
    const double b = u(rng);
    double values[kMaxCellVertices];
    for (int i = 0; i < n; ++i) values[i] = dot(a, v[size_t(i)]) + b;
    for (int k = 0; k < 20; ++k) {
      const Vec3d rst = random_rst(type, rng);
      const Vec3d g = gradient_in_cell(type, v.data(), rst, values);
      EXPECT_NEAR(g.x, a.x, 1e-9);
      EXPECT_NEAR(g.y, a.y, 1e-9);
      EXPECT_NEAR(g.z, a.z, 1e-9);
      // Shape functions reproduce linear fields exactly, whatever the warp.
      EXPECT_NEAR(interpolate(type, rst, values), dot(a, forward(type, v.data(), rst)) + b, 1e-9);
    }
  }
}

TEST_P(CellInterpolation, DegenerateCellsAreRefused) {
  const CellType type = GetParam();
  const int n = cell_vertex_count(type);
  // All vertices on the plane z = 0: the Jacobian is singular everywhere.
  std::vector<Vec3d> v(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const Vec3d p = parametric_vertex(type, i);
    v[size_t(i)] = {p.x + 0.3 * p.z, p.y + 0.2 * p.z, 0.0};
  }
  Vec3d rst;
  EXPECT_FALSE(inverse_map(type, v.data(), {0.2, 0.2, 0.0}, parametric_center(type), rst));
  const double values[kMaxCellVertices] = {1, 2, 3, 4, 5, 6, 7, 8};
  const Vec3d g = gradient_in_cell(type, v.data(), parametric_center(type), values);
  EXPECT_EQ(g, Vec3d{});
}

TEST_P(CellInterpolation, MonomialFormMatchesShapeFunctions) {
  const CellType type = GetParam();
  const int n = cell_vertex_count(type);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int c = 0; c < 100; ++c) {
    const std::vector<Vec3d> v = random_cell(type, rng, 0.25);
    double values[kMaxCellVertices];
    for (int i = 0; i < n; ++i) values[i] = u(rng);
    const auto [map, field] = with_cell_type(type, [&](auto tag) {
      constexpr CellType T = decltype(tag)::value;
      return std::pair{to_monomial<T>(v.data()), to_monomial<T>(values)};
    });
    for (int k = 0; k < 20; ++k) {
      const Vec3d rst = random_rst(type, rng);
      const Vec3d x = forward(type, v.data(), rst), y = map.evaluate(rst);
      EXPECT_NEAR(length(x - y), 0.0, 1e-12);
      EXPECT_NEAR(field.evaluate(rst), interpolate(type, rst, values), 1e-12);
      Vec3d a, b;
      ASSERT_TRUE(inverse_map(type, v.data(), x, parametric_center(type), a));
      ASSERT_TRUE(inverse_map_monomial(map, x, parametric_center(type), b));
      EXPECT_NEAR(a.x, b.x, 1e-10);
      EXPECT_NEAR(a.y, b.y, 1e-10);
      EXPECT_NEAR(a.z, b.z, 1e-10);
      EXPECT_EQ(parametric_inside(type, a, 1e-9), parametric_margin(type, a) >= -1e-9);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, CellInterpolation, ::testing::ValuesIn(kAllCellTypes),
                         [](const auto& param_info) { return std::string(cell_name(param_info.param)); });

TEST(CellInterpolationTetra, ClosedFormAgreesWithNewton) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  for (int c = 0; c < 500; ++c) {
    const std::vector<Vec3d> v = random_cell(CellType::Tetra, rng, 0.3);
    for (int k = 0; k < 10; ++k) {
      // Inside and outside alike: both solve the same linear system.
      const Vec3d x = forward(CellType::Tetra, v.data(), {u(rng), u(rng), u(rng)});
      Vec3d closed, newton;
      ASSERT_TRUE(inverse_map<CellType::Tetra>(v.data(), x, {}, closed));
      ASSERT_TRUE(inverse_map_newton<CellType::Tetra>(v.data(), x, parametric_center<CellType::Tetra>(), newton));
      EXPECT_NEAR(closed.x, newton.x, 1e-12);
      EXPECT_NEAR(closed.y, newton.y, 1e-12);
      EXPECT_NEAR(closed.z, newton.z, 1e-12);
    }
  }
}

TEST(CellInterpolationInside, ToleranceWidensTheDomain) {
  EXPECT_TRUE(parametric_inside(CellType::Tetra, {0.5, 0.5, 0.0}, 0.0));
  EXPECT_FALSE(parametric_inside(CellType::Tetra, {0.5, 0.5, 1e-9}, 0.0));
  EXPECT_TRUE(parametric_inside(CellType::Tetra, {0.5, 0.5, 1e-9}, 1e-8));
  EXPECT_FALSE(parametric_inside(CellType::Tetra, {-1e-7, 0.2, 0.2}, 1e-8));
  EXPECT_TRUE(parametric_inside(CellType::Wedge, {0.5, 0.5, 1.0}, 0.0));
  EXPECT_FALSE(parametric_inside(CellType::Wedge, {0.6, 0.5, 0.5}, 0.0));
  EXPECT_FALSE(parametric_inside(CellType::Wedge, {0.2, 0.2, 1.01}, 0.001));
  EXPECT_TRUE(parametric_inside(CellType::Pyramid, {1.0, 1.0, 1.0}, 0.0));
  EXPECT_FALSE(parametric_inside(CellType::Pyramid, {1.0, -0.01, 0.5}, 0.001));
  EXPECT_TRUE(parametric_inside(CellType::Hexahedron, {1.0005, 0.0, -0.0005}, 0.001));
  EXPECT_FALSE(parametric_inside(CellType::Hexahedron, {0.5, 1.002, 0.5}, 0.001));
}

}  // namespace
}  // namespace ugvr
