#include <gtest/gtest.h>

#include <map>
#include <set>

#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/topology.h"

namespace ugvr {
namespace {

double tet_volume(const UnstructuredMesh& m, std::span<const uint32_t> v) {
  const Vec3d a = to_double(m.points[v[0]]), b = to_double(m.points[v[1]]), c = to_double(m.points[v[2]]),
              d = to_double(m.points[v[3]]);
  return dot(cross(b - a, c - a), d - a) / 6.0;
}

StructuredGrid skewed_grid(uint32_t ni, uint32_t nj, uint32_t nk) {
  StructuredGrid g;
  g.dims.points = {ni, nj, nk};
  for (uint32_t k = 0; k < nk; ++k)
    for (uint32_t j = 0; j < nj; ++j)
      for (uint32_t i = 0; i < ni; ++i)
        g.points.push_back({float(i) + 0.1f * float(j), float(j) * 1.5f, float(k) + 0.05f * float(i * j)});
  return g;
}

// Boundary faces of an ni x nj x nk-point box split into tets: two triangles per boundary quad.
uint64_t expected_tet_boundary(uint32_t ni, uint32_t nj, uint32_t nk) {
  const uint64_t a = ni - 1, b = nj - 1, c = nk - 1;
  return 2 * 2 * (a * b + b * c + a * c);
}

class TetSplit : public ::testing::TestWithParam<StructuredCellShape> {};

TEST_P(TetSplit, ConformsAndFillsTheCells) {
  const StructuredGrid g = skewed_grid(5, 4, 6);
  const ExplicitCells cells = make_explicit_cells(g, GetParam());
  const uint64_t per = GetParam() == StructuredCellShape::FiveTetrahedra ? 5 : 6;
  ASSERT_EQ(cells.mesh.cell_count(), g.dims.cell_count() * per);
  cells.mesh.validate("split");
  double total = 0;
  for (uint64_t c = 0; c < cells.mesh.cell_count(); ++c) {
    const double v = tet_volume(cells.mesh, cells.mesh.cell(c));
    EXPECT_GT(v, 0) << "tet " << c << " is inverted";
    total += v;
  }
  // Same volume as the hexahedra (computed by the 6-tet split, which is exact for any trilinear-free polyhedron
  // with planar faces; the grid's faces are planar enough that both splits agree to rounding).
  const ExplicitCells six = make_explicit_cells(g, StructuredCellShape::SixTetrahedra);
  double total6 = 0;
  for (uint64_t c = 0; c < six.mesh.cell_count(); ++c) total6 += tet_volume(six.mesh, six.mesh.cell(c));
  EXPECT_NEAR(total, total6, 1e-3 * total6);

  const MeshTopology topo = build_topology(cells.mesh);
  EXPECT_EQ(topo.nonmanifold_faces, 0u);
  EXPECT_EQ(topo.boundary.size(), expected_tet_boundary(5, 4, 6)) << "interior faces must all be shared";
  // Symmetry: my neighbour's neighbour across the face it names is me.
  for (uint64_t c = 0; c < cells.mesh.cell_count(); ++c) {
    for (uint32_t f = 0; f < 4; ++f) {
      const uint64_t n = topo.neighbor(c, f);
      if (n == kNoNeighbor) continue;
      EXPECT_EQ(topo.neighbor(face_cell(n), face_local(n)), pack_face(c, f));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Splits, TetSplit,
                         ::testing::Values(StructuredCellShape::FiveTetrahedra, StructuredCellShape::SixTetrahedra));

TEST(Topology, HexGridNeighbours) {
  const StructuredGrid g = skewed_grid(4, 3, 3);
  const ExplicitCells hexes = make_explicit_cells(g, StructuredCellShape::Hexahedra);
  const MeshTopology topo = build_topology(hexes.mesh);
  EXPECT_EQ(topo.boundary.size(), 2u * (3 * 2 + 2 * 2 + 3 * 2));
  // Cell (0,0,0): its +i face (VTK hex face 1) touches cell (1,0,0) through that cell's -i face (face 0).
  EXPECT_EQ(topo.neighbor(0, 1), pack_face(1, 0));
  EXPECT_EQ(topo.neighbor(0, 0), kNoNeighbor);
}

TEST(Topology, MixedCellsShareTriangleAndQuadFaces) {
  // A hexahedron, a pyramid on its top face, and a tet on one pyramid triangle; a wedge on the hex's +x face.
  UnstructuredMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0},       {0, 1, 0},     {0, 0, 1}, {1, 0, 1},
              {1, 1, 1}, {0, 1, 1}, {0.5f, 0.5f, 2}, {0.5f, -1, 2}, {2, 0, 0}, {2, 0, 1}};
  const uint32_t hex[] = {0, 1, 2, 3, 4, 5, 6, 7}, pyr[] = {4, 5, 6, 7, 8}, tet[] = {4, 5, 8, 9};
  const uint32_t wedge[] = {1, 10, 2, 5, 11, 6};
  m.add_cell(CellType::Hexahedron, hex);
  m.add_cell(CellType::Pyramid, pyr);
  m.add_cell(CellType::Tetra, tet);
  m.add_cell(CellType::Wedge, wedge);
  const MeshTopology topo = build_topology(m);
  EXPECT_EQ(topo.neighbor(0, 5), pack_face(1, 0));  // hex top quad <-> pyramid base
  EXPECT_EQ(topo.neighbor(1, 1), pack_face(2, 3));  // pyramid triangle (4,5,8) <-> tet face 3 = (4,8,5)
  EXPECT_EQ(face_cell(topo.neighbor(3, 4)), 0u);    // wedge quad (2,6,5,1) <-> hex +x face
  EXPECT_EQ(topo.face_offsets.back(), 6u + 5 + 4 + 5);
}

TEST(Topology, NonManifoldFacesAreBoundary) {
  UnstructuredMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {1, 1, 1}};
  const uint32_t a[] = {0, 1, 2, 3}, b[] = {0, 2, 1, 4}, c[] = {0, 1, 2, 5};
  m.add_cell(CellType::Tetra, a);
  m.add_cell(CellType::Tetra, b);
  m.add_cell(CellType::Tetra, c);  // third cell on face (0,1,2)
  const MeshTopology topo = build_topology(m);
  EXPECT_EQ(topo.nonmanifold_faces, 3u);
  EXPECT_EQ(topo.boundary.size(), 12u);
}

TEST(StructuredCells, IblankDropsCellsTouchingBlankedPoints) {
  StructuredGrid g = skewed_grid(4, 4, 4);
  g.iblank.assign(g.points.size(), 1);
  g.iblank[g.dims.point_index(0, 0, 0)] = 0;   // one corner: 1 cell gone
  g.iblank[g.dims.point_index(2, 2, 2)] = -1;  // overset "in use" value: keeps its cells
  g.iblank[g.dims.point_index(1, 1, 1)] = 0;   // interior point: its 8 cells gone (one already gone)
  const ExplicitCells hexes = make_explicit_cells(g, StructuredCellShape::Hexahedra);
  EXPECT_EQ(hexes.mesh.cell_count(), 27u - 8u);
  const ExplicitCells tets = make_explicit_cells(g, StructuredCellShape::FiveTetrahedra);
  EXPECT_EQ(tets.mesh.cell_count(), (27u - 8u) * 5);
  for (uint64_t c = 0; c < tets.mesh.cell_count(); ++c) EXPECT_GT(tet_volume(tets.mesh, tets.mesh.cell(c)), 0);

  Block b{"b", g, {}};
  std::vector<float> cell_values(27);
  for (size_t i = 0; i < 27; ++i) cell_values[i] = float(i);
  b.fields.add(Field("id", Association::Cell, DataArray::from(cell_values, 1)));
  const Block u = to_unstructured_block(b, StructuredCellShape::Hexahedra);
  const Field* id = u.fields.find("id");
  ASSERT_NE(id, nullptr);
  ASSERT_EQ(id->tuples(), 19u);
  for (uint64_t c = 0; c < 19; ++c) EXPECT_EQ(uint64_t(id->data().get(c, 0)), hexes.source_cell[c]);
  EXPECT_NE(u.fields.find("IBLANK", Association::Vertex), nullptr);
  u.validate_fields("u");
}

}  // namespace
}  // namespace ugvr
