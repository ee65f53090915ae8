#include <gtest/gtest.h>

#include <cmath>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/dataset.h"

namespace ugvr {
namespace {

// Reference cells in VTK vertex order.
std::vector<Vec3d> reference_cell(CellType t) {
  switch (t) {
    case CellType::Tetra: return {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    case CellType::Pyramid: return {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}};
    // VTK: the base (0,1,2) has its right-hand normal pointing away from the top (3,4,5).
    case CellType::Wedge: return {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 1}, {1, 0, 1}};
    case CellType::Hexahedron:
      return {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  }
  return {};
}

TEST(CellType, FacesPointOutwardAndCoverTheCell) {
  for (CellType t : kAllCellTypes) {
    const auto p = reference_cell(t);
    const CellInfo info = cell_info(t);
    ASSERT_EQ(p.size(), info.vertex_count);
    Vec3d centroid{};
    for (auto q : p) centroid = centroid + q * (1.0 / double(p.size()));
    // Divergence theorem: sum over faces of (face centroid . area vector) / 3 = volume, and each face normal
    // points away from the centroid.
    double volume = 0;
    int uses[8] = {};
    for (int f = 0; f < info.face_count; ++f) {
      const CellFace face = info.faces[size_t(f)];
      Vec3d area{}, fc{};
      for (int i = 0; i < face.size; ++i) {
        const Vec3d a = p[face.v[size_t(i)]], b = p[face.v[size_t((i + 1) % face.size)]];
        area = area + cross(a, b) * 0.5;
        fc = fc + a * (1.0 / face.size);
        ++uses[face.v[size_t(i)]];
      }
      EXPECT_GT(dot(area, fc - centroid), 0) << cell_name(t) << " face " << f << " points inward";
      volume += dot(fc, area) / 3.0;
    }
    const double expected = t == CellType::Tetra     ? 1.0 / 6
                            : t == CellType::Pyramid ? 1.0 / 3
                            : t == CellType::Wedge   ? 0.5
                                                     : 1.0;
    EXPECT_NEAR(volume, expected, 1e-12) << cell_name(t);
    // Every vertex lies on at least 3 faces (a closed polyhedron).
    for (int v = 0; v < info.vertex_count; ++v) EXPECT_GE(uses[v], 3) << cell_name(t);
  }
}

TEST(CellType, VtkMappingPolicy) {
  EXPECT_EQ(map_vtk_cell_type(10).kind, VtkCellMapping::Kind::Keep);
  EXPECT_EQ(map_vtk_cell_type(24).type, CellType::Tetra);
  EXPECT_EQ(map_vtk_cell_type(24).corner_count, 4);
  EXPECT_EQ(map_vtk_cell_type(24).expected_points, 10);
  EXPECT_EQ(map_vtk_cell_type(29).type, CellType::Hexahedron);
  EXPECT_EQ(map_vtk_cell_type(11).voxel_order, true);
  EXPECT_EQ(map_vtk_cell_type(5).kind, VtkCellMapping::Kind::DropLowerDimension);
  EXPECT_EQ(map_vtk_cell_type(42).kind, VtkCellMapping::Kind::Unsupported);
  EXPECT_EQ(map_vtk_cell_type(999).kind, VtkCellMapping::Kind::Unsupported);
}

TEST(DataArray, KeepsStoredTypeAndGathers) {
  DataArray a = DataArray::from(std::vector<int16_t>{1, 2, 3, 4, 5, 6}, 2);
  EXPECT_EQ(a.type(), ScalarType::Int16);
  EXPECT_EQ(a.tuples(), 3u);
  EXPECT_EQ(a.byte_size(), 12u);
  EXPECT_EQ(a.get(2, 1), 6);
  const uint64_t ids[] = {2, 0};
  DataArray g = a.gather(ids);
  EXPECT_EQ(g.tuples(), 2u);
  EXPECT_EQ(g.get(0, 0), 5);
  EXPECT_EQ(g.get(1, 1), 2);
  EXPECT_EQ(g.type(), ScalarType::Int16);
  EXPECT_FALSE(a == g);
  EXPECT_EQ(parse_scalar_type("vtktypeint64"), ScalarType::Int64);
  EXPECT_EQ(parse_scalar_type("Float32"), ScalarType::Float32);
  EXPECT_FALSE(parse_scalar_type("quaternion").has_value());
}

TEST(Field, RangesPerComponentAndMagnitude) {
  Field v("velocity", Association::Vertex, DataArray::from(std::vector<float>{3, 4, 0, -1, 0, 0, 0, 0, 12}, 3));
  EXPECT_EQ(v.range(0), (Range{-1, 3, 0}));
  EXPECT_EQ(v.range(2), (Range{0, 12, 0}));
  EXPECT_EQ(v.range(kMagnitude), (Range{1, 12, 0}));
  EXPECT_DOUBLE_EQ(v.scalar(0, kMagnitude), 5);
  EXPECT_THROW(v.range(3), Error);
  // Cached ranges are dropped when the data is changed.
  v.mutable_data().set(0, 0, 100);
  EXPECT_EQ(v.range(0).max, 100);
}

TEST(Field, RangeSkipsNaN) {
  Field f("p", Association::Cell, DataArray::from(std::vector<double>{NAN, 2, -3, NAN}, 1));
  const Range r = f.range();
  EXPECT_EQ(r.min, -3);
  EXPECT_EQ(r.max, 2);
  EXPECT_EQ(r.nan_count, 2u);
}

TEST(FieldSet, ScalarSelectors) {
  FieldSet fs;
  fs.add(Field("Momentum", Association::Vertex, DataArray::from(std::vector<float>{1, 2, 2}, 3)));
  fs.add(Field("EQPS", Association::Cell, DataArray::from(std::vector<float>{0.5f}, 1)));
  EXPECT_EQ(fs.scalar("Momentum").component, kMagnitude);
  EXPECT_EQ(fs.scalar("Momentum:y").component, 1);
  EXPECT_EQ(fs.scalar("Momentum:2").component, 2);
  EXPECT_EQ(fs.scalar("Momentum:magnitude").field->name(), "Momentum");
  EXPECT_EQ(fs.scalar("EQPS").field->association(), Association::Cell);
  EXPECT_THROW(fs.scalar("Momentum:3"), Error);
  try {
    fs.scalar("Density");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("Momentum"), std::string::npos) << "lists the available fields";
  }
}

TEST(UnstructuredMesh, ValidateNamesTheBadCell) {
  UnstructuredMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const uint32_t good[] = {0, 1, 2, 3}, bad[] = {0, 1, 2, 9};
  m.add_cell(CellType::Tetra, good);
  EXPECT_NO_THROW(m.validate("m.vtu"));
  m.add_cell(CellType::Tetra, bad);
  try {
    m.validate("m.vtu");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.vtu: cell 1 refers to vertex 9"), std::string::npos) << e.what();
  }
  EXPECT_EQ(m.cell_type_counts().tetra, 2u);
  EXPECT_EQ(m.bounds().hi, (Vec3d{1, 1, 1}));
}

TEST(Block, ValidateFieldsChecksTupleCounts) {
  Block b{"b", ImageGrid{GridDims{{3, 3, 3}}, {}, {1, 1, 1}}, {}};
  b.fields.add(Field("ok", Association::Vertex, DataArray(ScalarType::Float32, 1, 27)));
  b.fields.add(Field("cells", Association::Cell, DataArray(ScalarType::UInt8, 1, 8)));
  EXPECT_NO_THROW(b.validate_fields("x"));
  b.fields.add(Field("bad", Association::Cell, DataArray(ScalarType::UInt8, 1, 9)));
  EXPECT_THROW(b.validate_fields("x"), Error);
  EXPECT_EQ(grid_kind_name(b.grid), "uniform");
  EXPECT_EQ(grid_cell_count(b.grid), 8u);
  EXPECT_EQ(grid_bounds(b.grid).hi, (Vec3d{2, 2, 2}));
}

}  // namespace
}  // namespace ugvr

namespace ugvr {
namespace {
TEST(CellVolume, ReferenceCellsAndInversion) {
  const std::pair<CellType, double> cases[] = {
      {CellType::Tetra, 1.0 / 6}, {CellType::Pyramid, 1.0 / 3}, {CellType::Wedge, 0.5}, {CellType::Hexahedron, 1}};
  for (auto [t, expected] : cases) {
    UnstructuredMesh m;
    for (Vec3d p : reference_cell(t)) m.points.push_back({float(p.x) + 10, float(p.y) - 5, float(p.z)});
    std::vector<uint32_t> ids(m.points.size());
    for (uint32_t i = 0; i < ids.size(); ++i) ids[i] = i;
    m.add_cell(t, ids);
    EXPECT_NEAR(cell_volume(m, 0), expected, 1e-6) << cell_name(t);
    for (auto& p : m.points) p.z = -p.z;  // mirror: inverted
    EXPECT_NEAR(cell_volume(m, 0), -expected, 1e-6) << cell_name(t);
  }
}
}  // namespace
}  // namespace ugvr
