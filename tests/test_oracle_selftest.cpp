// Self-tests of the reference renderer (tests/oracle): the exact engine is only as well tested as the oracle is
// right, so the oracle itself is checked here against hand-made cells and closed forms, with no engine involved.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>

#include "oracle/reference_renderer.h"
#include "ugvr/grid/structured_cells.h"

namespace ugvr {
namespace {

using oracle::box_dataset;
using oracle::ReferenceRenderer;

// Parametric coordinates of each cell type's vertices, VTK order (the pyramid apex at any (r, s), t = 1).
std::vector<std::array<double, 3>> reference_vertices(CellType type) {
  switch (type) {
    case CellType::Tetra: return {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    case CellType::Hexahedron:
      return {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    case CellType::Wedge: return {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
    case CellType::Pyramid: return {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}};
  }
  return {};
}

// A random parametric point strictly inside the reference cell (margin keeps it away from the faces).
std::array<double, 3> random_inside(CellType type, std::mt19937_64& rng, double margin = 0.02) {
  std::uniform_real_distribution<double> u(margin, 1 - margin);
  for (;;) {
    const std::array<double, 3> p{u(rng), u(rng), u(rng)};
    if (type == CellType::Tetra && p[0] + p[1] + p[2] > 1 - margin) continue;
    if (type == CellType::Wedge && p[0] + p[1] > 1 - margin) continue;
    if (type == CellType::Pyramid && p[2] > 1 - margin) continue;
    return p;
  }
}

// Hand-made cells: the reference shape scaled, sheared and with its vertices moved off the affine image, so that
// hexahedra, wedges and pyramids have non-planar faces and Newton has real work to do. Returned as a one-cell
// dataset with a vertex field of arbitrary values (vertex i has value 10 * i^2 - 3 i + 1).
struct OneCell {
  CellType type;
  std::vector<Vec3d> corners;  // after float32 rounding, as the mesh stores them
  std::vector<double> values;
  Dataset dataset;
};

OneCell make_cell(CellType type, bool distort) {
  OneCell c{type, {}, {}, {}};
  UnstructuredMesh mesh;
  std::vector<uint32_t> ids;
  const auto ref = reference_vertices(type);
  for (size_t i = 0; i < ref.size(); ++i) {
    const auto& r = ref[i];
    Vec3d p{2.0 * r[0] + 0.3 * r[1], 1.5 * r[1] - 0.2 * r[2], 1.2 * r[2] + 0.1 * r[0]};
    if (distort) p = p + Vec3d{0.07 * std::sin(3.0 * i), 0.05 * std::cos(5.0 * i), 0.06 * std::sin(7.0 * i + 1)};
    mesh.points.push_back(Vec3f{float(p.x), float(p.y), float(p.z)});
    c.corners.push_back(to_double(mesh.points.back()));
    c.values.push_back(10.0 * double(i * i) - 3.0 * double(i) + 1);
    ids.push_back(uint32_t(i));
  }
  mesh.add_cell(type, ids);
  Block block{"cell", std::move(mesh), {}};
  block.fields.add(Field("v", Association::Vertex, DataArray::from(c.values, 1)));
  c.dataset.blocks.push_back(std::move(block));
  return c;
}

Vec3d map_to_world(const OneCell& c, const std::array<double, 3>& rst) {
  double w[8];
  oracle::shape_functions(c.type, rst, w);
  Vec3d p{};
  for (size_t i = 0; i < c.corners.size(); ++i) p = p + c.corners[i] * w[i];
  return p;
}

double interpolate(const OneCell& c, const std::array<double, 3>& rst) {
  double w[8];
  oracle::shape_functions(c.type, rst, w);
  double v = 0;
  for (size_t i = 0; i < c.values.size(); ++i) v += c.values[i] * w[i];
  return v;
}

TEST(OracleSelfTest, ShapeFunctionsAreNodalAndSumToOne) {
  std::mt19937_64 rng(7);
  for (CellType type : kAllCellTypes) {
    SCOPED_TRACE(std::string(cell_name(type)));
    const auto ref = reference_vertices(type);
    for (size_t i = 0; i < ref.size(); ++i) {
      double w[8];
      oracle::shape_functions(type, ref[i], w);
      for (size_t j = 0; j < ref.size(); ++j) EXPECT_NEAR(w[j], i == j ? 1.0 : 0.0, 1e-15);
    }
    for (int k = 0; k < 20; ++k) {
      double w[8];
      oracle::shape_functions(type, random_inside(type, rng), w);
      double sum = 0;
      for (size_t j = 0; j < ref.size(); ++j) sum += w[j];
      EXPECT_NEAR(sum, 1.0, 1e-14);
    }
  }
}

TEST(OracleSelfTest, LocatesPointsInHandMadeCells) {
  std::mt19937_64 rng(11);
  for (bool distort : {false, true}) {
    for (CellType type : kAllCellTypes) {
      SCOPED_TRACE(std::string(cell_name(type)) + (distort ? " distorted" : " straight"));
      const OneCell c = make_cell(type, distort);
      const ReferenceRenderer oracle(c.dataset, "v");
      for (int k = 0; k < 200; ++k) {
        const auto rst = random_inside(type, rng);
        const Vec3d p = map_to_world(c, rst);
        const auto loc = oracle.locate(p);
        ASSERT_TRUE(loc.has_value()) << "point " << k << " not located";
        if (type != CellType::Pyramid) {
          // (The pyramid's r, s are not unique near the apex; its value still is, checked below.)
          for (int a = 0; a < 3; ++a) EXPECT_NEAR(loc->rst[a], rst[a], 1e-9);
        }
        EXPECT_NEAR(loc->value, interpolate(c, rst), 1e-9 * 600);
      }
      // Points just outside each face (parametric coordinates a little beyond the reference cell, mapped through
      // the cell's own map, so they lie outside whatever the distortion) and far away are not located.
      const std::vector<std::array<double, 3>> outside = [&]() -> std::vector<std::array<double, 3>> {
        switch (type) {
          case CellType::Tetra: return {{-0.01, 0.3, 0.3}, {0.3, -0.01, 0.3}, {0.3, 0.3, -0.01}, {0.4, 0.3, 0.32}};
          case CellType::Wedge:
            return {{-0.01, 0.3, 0.5}, {0.3, -0.01, 0.5}, {0.5, 0.51, 0.5}, {0.3, 0.3, -0.01}, {0.3, 0.3, 1.01}};
          case CellType::Pyramid:
            return {{-0.01, 0.5, 0.3}, {1.01, 0.5, 0.3}, {0.5, -0.01, 0.3}, {0.5, 1.01, 0.3}, {0.5, 0.5, -0.01}};
          case CellType::Hexahedron:
            return {{-0.01, 0.5, 0.5}, {1.01, 0.5, 0.5},  {0.5, -0.01, 0.5},
                    {0.5, 1.01, 0.5},  {0.5, 0.5, -0.01}, {0.5, 0.5, 1.01}};
        }
        return {};
      }();
      for (const auto& rst : outside) {
        EXPECT_FALSE(oracle.locate(map_to_world(c, rst)).has_value())
            << "(" << rst[0] << ", " << rst[1] << ", " << rst[2] << ")";
      }
      EXPECT_FALSE(oracle.locate({10, 10, 10}).has_value());
      EXPECT_FALSE(oracle.locate({-1, 0.5, 0.5}).has_value());
    }
  }
}

// Isoparametric cells reproduce linear fields exactly, whatever their shape; so does a whole mesh of them.
TEST(OracleSelfTest, ReproducesLinearFieldsOnMeshes) {
  auto linear = [](Vec3d p) { return 1.0 + 2.0 * p.x - 3.0 * p.y + 0.5 * p.z; };
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto shape :
       {StructuredCellShape::Hexahedra, StructuredCellShape::SixTetrahedra, StructuredCellShape::FiveTetrahedra}) {
    const Dataset ds = box_dataset({0, 0, 0}, {1, 2, 1}, {3, 4, 5}, shape, linear);
    const ReferenceRenderer oracle(ds, "f");
    for (int k = 0; k < 500; ++k) {
      const Vec3d p{u(rng), 2 * u(rng), u(rng)};
      const auto v = oracle.sample(p);
      ASSERT_TRUE(v.has_value());
      EXPECT_NEAR(*v, linear(p), 1e-9);
    }
    EXPECT_FALSE(oracle.sample({0.5, 1, 1.001}).has_value());
    EXPECT_FALSE(oracle.sample({-0.001, 1, 0.5}).has_value());
    EXPECT_DOUBLE_EQ(oracle.field_min(), linear({0, 2, 0}));
    EXPECT_DOUBLE_EQ(oracle.field_max(), linear({1, 0, 1}));
  }
}

TEST(OracleSelfTest, TransferEvalMatchesTransferFunction) {
  TransferFunction ramp;  // no opacity points: opacity 0 everywhere
  ramp.color_points = {{-1, {0.2, 0.4, 0.6}}, {3, {1, 0, 0.5}}};
  ramp.opacity_unit_distance = 0.3;
  TransferFunction viridis = builtin_preset("viridis");
  viridis.rescale(-2, 5);
  viridis.opacity_points = {{-2, 0}, {0, 0.4}, {1, 1}, {5, 0.2}};
  for (const TransferFunction& tf : {ramp, viridis}) {
    const oracle::TransferEval eval(tf);
    for (double s = -3; s <= 6; s += 0.0625 / 3) {
      for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(eval.color(s)[c], tf.color(s)[c]) << s;
      EXPECT_DOUBLE_EQ(eval.opacity(s), tf.opacity(s)) << s;
      EXPECT_DOUBLE_EQ(eval.extinction(s), tf.extinction(s)) << s;
    }
    for (const ColorPoint& p : tf.color_points) EXPECT_DOUBLE_EQ(eval.color(p.x).y, tf.color(p.x).y);
    const double nan = std::nan("");
    EXPECT_EQ(eval.color(nan), tf.color(nan));
    EXPECT_EQ(eval.opacity(nan), 0.0);
    EXPECT_EQ(eval.extinction(nan), 0.0);
  }
}

// ---- Closed forms ----

// The oracle against the closed-form scenes, far tighter than the engine is held to (float32 output ~1e-7): its
// integration error must be negligible against the engine comparisons' 1e-3.
void check_family(std::string_view family) {
  for (const oracle::ClosedFormScene& scene : oracle::closed_form_scenes(family)) {
    const ReferenceRenderer oracle(*scene.dataset, scene.field);
    const oracle::SceneError e = oracle::scene_error(scene, oracle.render(scene.camera, scene.tf, scene.settings));
    EXPECT_LE(e.max_abs, 2e-6) << scene.name << ": worst pixel (" << e.x << ", " << e.y << ")";
  }
}

TEST(OracleSelfTest, ConstantExtinctionBoxMatchesClosedForm) { check_family("constant"); }
TEST(OracleSelfTest, LinearFieldSlabMatchesClosedForm) { check_family("linear-slab"); }
TEST(OracleSelfTest, CellDataLayersMatchClosedForm) { check_family("cell-layers"); }
TEST(OracleSelfTest, MipAndClipMatchClosedForm) { check_family("mip"); }
TEST(OracleSelfTest, IsosurfacesMatchClosedForm) { check_family("iso"); }

// Reports the oracle's speed on a real-size mesh (no assertion on time: it runs under sanitizers too).
TEST(OracleSelfTest, SpeedOnTenThousandCells) {
  const Dataset ds = box_dataset({0, 0, 0}, {1, 1, 1}, {12, 12, 12}, StructuredCellShape::SixTetrahedra,
                                 [](Vec3d p) { return std::sin(6 * p.x) * std::cos(4 * p.y) + p.z; });
  const ReferenceRenderer oracle(ds, "f");
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(oracle.field_min(), oracle.field_max());
  tf.opacity_unit_distance = std::sqrt(3.0) / 20;
  RenderSettings settings;
  settings.width = settings.height = 48;
  settings.early_termination_opacity = 1;
  Camera camera;
  camera.position = {1.9, -1.3, 2.4};
  camera.focal_point = {0.5, 0.5, 0.5};
  camera.view_up = {0, 0, 1};
  const auto start = std::chrono::steady_clock::now();
  const Image image = oracle.render(camera, tf, settings);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("oracle: %llu cells, 48x48 rays, step %.3g: %.2f s\n", (unsigned long long)oracle.cell_count(),
              oracle.step(), seconds);
  EXPECT_EQ(image.width, 48);
}

}  // namespace
}  // namespace ugvr
