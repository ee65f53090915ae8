// PolyhedronDecomposer (grid/polyhedra.h): native shapes recognised in VTK order whatever the face order and
// orientation; other polyhedra split conformingly around cell and face centres; fields carried over.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/grid/polyhedra.h"
#include "ugvr/grid/topology.h"

namespace ugvr {
namespace {

struct Faces {
  std::vector<uint32_t> sizes, vertices;
  void add(std::initializer_list<uint32_t> f, bool reverse = false, size_t rotate = 0) {
    std::vector<uint32_t> v(f);
    if (reverse) std::reverse(v.begin(), v.end());
    std::rotate(v.begin(), v.begin() + rotate % v.size(), v.end());
    sizes.push_back(uint32_t(v.size()));
    vertices.insert(vertices.end(), v.begin(), v.end());
  }
};

UnstructuredMesh unit_cube_points() {
  UnstructuredMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  return m;
}

double total_volume(const UnstructuredMesh& m) {
  double v = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) v += cell_volume(m, c);
  return v;
}

TEST(Polyhedra, HexahedronFromFacesInAnyOrderIsNative) {
  for (int variant = 0; variant < 4; ++variant) {
    UnstructuredMesh m = unit_cube_points();
    PolyhedronDecomposer d(m, "cube");
    Faces f;  // OpenFOAM-like: each face with its own start and orientation
    const bool r = variant & 1;
    const size_t rot = size_t(variant);
    f.add({4, 5, 6, 7}, r, rot);
    f.add({0, 3, 2, 1}, !r, rot + 1);
    f.add({0, 1, 5, 4}, r, rot + 2);
    f.add({3, 7, 6, 2}, r, rot);
    f.add({0, 4, 7, 3}, !r, rot + 3);
    f.add({1, 2, 6, 5}, r, rot + 1);
    d.add_polyhedron(f.sizes, f.vertices);
    ASSERT_EQ(m.cell_count(), 1u);
    EXPECT_EQ(m.cell_types[0], CellType::Hexahedron);
    EXPECT_NEAR(cell_volume(m, 0), 1.0, 1e-12) << "variant " << variant;
    EXPECT_EQ(d.recognised(), 1u);
    EXPECT_EQ(d.added_points(), 0u);
    EXPECT_TRUE(d.identity());
    // Each of the cell's six faces is one of the input faces (same vertex set).
    const auto c = m.cell(0);
    for (const auto& face : cell_info(CellType::Hexahedron).faces) {
      std::vector<uint32_t> fv{c[face.v[0]], c[face.v[1]], c[face.v[2]], c[face.v[3]]};
      std::sort(fv.begin(), fv.end());
      bool found = false;
      for (size_t k = 0; k < 6; ++k) {
        std::vector<uint32_t> in(f.vertices.begin() + 4 * k, f.vertices.begin() + 4 * k + 4);
        std::sort(in.begin(), in.end());
        found |= in == fv;
      }
      EXPECT_TRUE(found);
    }
  }
}

TEST(Polyhedra, TetraPyramidWedgeAreNativeAndPositive) {
  UnstructuredMesh m = unit_cube_points();
  PolyhedronDecomposer d(m, "shapes");
  Faces tet;
  tet.add({0, 1, 2});
  tet.add({0, 1, 6}, true);
  tet.add({1, 2, 6});
  tet.add({2, 0, 6}, true, 1);
  d.add_polyhedron(tet.sizes, tet.vertices);
  Faces pyr;
  pyr.add({0, 1, 2, 3}, false, 2);
  pyr.add({0, 1, 6});
  pyr.add({1, 2, 6}, true);
  pyr.add({2, 3, 6});
  pyr.add({3, 0, 6}, true);
  d.add_polyhedron(pyr.sizes, pyr.vertices);
  Faces wedge;  // the prism x + y <= 1 of the cube
  wedge.add({0, 1, 3});
  wedge.add({4, 5, 7}, true);
  wedge.add({0, 1, 5, 4}, false, 1);
  wedge.add({1, 3, 7, 5}, true);
  wedge.add({3, 0, 4, 7});
  d.add_polyhedron(wedge.sizes, wedge.vertices);
  ASSERT_EQ(m.cell_count(), 3u);
  EXPECT_EQ(m.cell_types[0], CellType::Tetra);
  EXPECT_EQ(m.cell_types[1], CellType::Pyramid);
  EXPECT_EQ(m.cell_types[2], CellType::Wedge);
  EXPECT_NEAR(cell_volume(m, 0), 1.0 / 6, 1e-12);
  EXPECT_NEAR(cell_volume(m, 1), 1.0 / 3, 1e-12);
  EXPECT_NEAR(cell_volume(m, 2), 0.5, 1e-12);
  EXPECT_EQ(d.recognised(), 3u);
  m.validate("shapes");
}

// Two hexagonal prisms stacked on a shared hexagon: neither is a native shape.
struct HexPrisms {
  UnstructuredMesh mesh;
  Faces lower, upper;
  HexPrisms() {
    for (int layer = 0; layer < 3; ++layer)
      for (int i = 0; i < 6; ++i) {
        const double a = std::numbers::pi / 3 * i;
        mesh.points.push_back({float(std::cos(a)), float(std::sin(a)), float(layer)});
      }
    auto ring = [](int layer, bool reverse) {
      std::vector<uint32_t> r;
      for (int i = 0; i < 6; ++i) r.push_back(uint32_t(6 * layer + i));
      if (reverse) std::reverse(r.begin(), r.end());
      return r;
    };
    auto add_prism = [&](Faces& f, int layer) {
      auto bottom = ring(layer, true), top = ring(layer + 1, false);
      f.sizes.push_back(6);
      f.vertices.insert(f.vertices.end(), bottom.begin(), bottom.end());
      f.sizes.push_back(6);
      f.vertices.insert(f.vertices.end(), top.begin(), top.end());
      for (uint32_t i = 0; i < 6; ++i) {
        const uint32_t a = 6 * layer + i, b = 6 * layer + (i + 1) % 6;
        f.add({a, b, b + 6, a + 6}, i % 2 == 1);
      }
    };
    add_prism(lower, 0);
    add_prism(upper, 1);
  }
};

TEST(Polyhedra, OtherPolyhedraSplitConformingly) {
  HexPrisms p;
  PolyhedronDecomposer d(p.mesh, "prisms");
  d.add_polyhedron(p.lower.sizes, p.lower.vertices);
  d.add_polyhedron(p.upper.sizes, p.upper.vertices);
  EXPECT_EQ(d.decomposed(), 2u);
  // Per prism: 6 pyramids on the sides + 6 tetrahedra on each hexagon around its centre.
  EXPECT_EQ(p.mesh.cell_count(), 36u);
  // Two cell centres, and three hexagon centres: the shared one once.
  EXPECT_EQ(d.added_points(), 5u);
  const double hexagon_area = 3 * std::sqrt(3.0) / 2;
  EXPECT_NEAR(total_volume(p.mesh), 2 * hexagon_area, 1e-5);
  for (uint64_t c = 0; c < p.mesh.cell_count(); ++c) EXPECT_GT(cell_volume(p.mesh, c), 0) << c;
  p.mesh.validate("prisms");
  // Conforming: the only boundary faces are the union's surface (2 hexagons of 6 triangles, 12 side quads).
  const MeshTopology topo = build_topology(p.mesh);
  EXPECT_EQ(topo.boundary.size(), 24u);
  EXPECT_EQ(topo.nonmanifold_faces, 0u);
  for (uint64_t o = 0; o < 18; ++o) EXPECT_EQ(d.source_cell(o), 0u);
  for (uint64_t o = 18; o < 36; ++o) EXPECT_EQ(d.source_cell(o), 1u);
  EXPECT_NE(d.summary().find("2 decomposed"), std::string::npos) << d.summary();
}

TEST(Polyhedra, FieldsFollowTheirCells) {
  HexPrisms p;
  const uint64_t points = p.mesh.point_count();
  PolyhedronDecomposer d(p.mesh, "prisms");
  std::vector<uint32_t> tet{0, 1, 2, 6};  // a native cell first: the identity map is kept up to the first split
  d.add_native(CellType::Tetra, tet);
  d.add_polyhedron(p.lower.sizes, p.lower.vertices);
  std::vector<double> z(points);
  for (uint64_t i = 0; i < points; ++i) z[i] = p.mesh.points[i].z;
  const Field pz("z", Association::Vertex, DataArray::from(z, 1));
  const Field expanded = d.expand_point_field(pz);
  ASSERT_EQ(expanded.tuples(), p.mesh.point_count());
  // Centre values are means of their vertices: here z, which is linear, equals each centre's own z.
  for (uint64_t i = points; i < p.mesh.point_count(); ++i)
    EXPECT_NEAR(expanded.scalar(i, 0), p.mesh.points[i].z, 1e-6) << i;
  const Field cells("id", Association::Cell, DataArray::from(std::vector<int32_t>{7, 9}, 1));
  const Field per_piece = d.expand_cell_field(cells);
  ASSERT_EQ(per_piece.tuples(), p.mesh.cell_count());
  EXPECT_EQ(per_piece.scalar(0, 0), 7);
  for (uint64_t o = 1; o < p.mesh.cell_count(); ++o) EXPECT_EQ(per_piece.scalar(o, 0), 9);
  EXPECT_THROW(d.expand_cell_field(Field("bad", Association::Cell, DataArray::from(std::vector<float>{1}, 1))), Error);
}

TEST(Polyhedra, BadPolyhedraAreNamed) {
  UnstructuredMesh m = unit_cube_points();
  PolyhedronDecomposer d(m, "bad.case");
  std::vector<uint32_t> sizes{3, 3, 3, 2}, verts{0, 1, 2, 0, 1, 6, 1, 2, 6, 2, 0};
  try {
    d.add_polyhedron(sizes, verts);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.case"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("face of 2 vertices"), std::string::npos) << e.what();
  }
  std::vector<uint32_t> sizes4{3, 3, 3, 3}, out_of_range{0, 1, 2, 0, 1, 60, 1, 2, 6, 2, 0, 6};
  EXPECT_THROW(d.add_polyhedron(sizes4, out_of_range), Error);
  std::vector<uint32_t> three{3, 3, 3};
  EXPECT_THROW(d.add_polyhedron(three, std::span(verts).first(9)), Error);
}

}  // namespace
}  // namespace ugvr
