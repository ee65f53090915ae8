// Legacy VTK reader: the real files of ../shared/data (skipped when absent), hand-written files in every layout
// (ASCII / BINARY, 4.2 / 5.1, each dataset type, every attribute kind, METADATA blocks), and malformed files that must
// fail with the file name and the line (ASCII) or byte offset (BINARY).
#include <gtest/gtest.h>

#include <charconv>
#include <cstring>
#include <fstream>
#include <functional>
#include <variant>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

// --- helpers ---------------------------------------------------------------------------------------------------

// Builds a legacy file: text lines, and value blocks written as ASCII numbers or big-endian bytes (followed by the
// newline VTK writes after each block).
class VtkText {
 public:
  explicit VtkText(bool binary) : binary_(binary) {}
  bool binary() const { return binary_; }

  VtkText& line(std::string_view s) {
    out_ += s;
    out_ += '\n';
    return *this;
  }

  template <class T>
  VtkText& values(const std::vector<T>& v) {
    for (size_t i = 0; i < v.size(); ++i) {
      if (binary_) {
        char bytes[sizeof(T)];
        std::memcpy(bytes, &v[i], sizeof(T));
        for (size_t b = sizeof(T); b-- > 0;) out_ += bytes[b];  // big-endian (the tests run little-endian)
      } else {
        out_ += text(v[i]);
        out_ += (i % 9 == 8) ? '\n' : ' ';
      }
    }
    out_ += '\n';
    return *this;
  }

  // VTK "bit" arrays: packed, most significant bit first.
  VtkText& bits(const std::vector<int>& v) {
    if (!binary_) {
      std::vector<int32_t> ints(v.begin(), v.end());
      return values(ints);
    }
    std::string packed((v.size() + 7) / 8, '\0');
    for (size_t i = 0; i < v.size(); ++i) {
      if (v[i]) packed[i / 8] = char(packed[i / 8] | (0x80 >> (i % 8)));
    }
    out_ += packed + "\n";
    return *this;
  }

  // String arrays: a line each in ASCII, a one-byte length (0b11 + 6 bits) then the bytes in BINARY.
  VtkText& strings(const std::vector<std::string>& v) {
    for (const std::string& s : v) {
      if (binary_) {
        out_ += char(0xC0 | s.size());
        out_ += s;
      } else {
        out_ += s + "\n";
      }
    }
    if (binary_) out_ += '\n';
    return *this;
  }

  const std::string& str() const { return out_; }
  size_t size() const { return out_.size(); }

 private:
  template <class T>
  static std::string text(T x) {
    if constexpr (sizeof(T) == 1) {
      return std::to_string(int(x));
    } else {
      char buf[64];
      const auto r = std::to_chars(buf, buf + sizeof buf, x);  // shortest text that reads back to the same value
      return std::string(buf, r.ptr);
    }
  }

  bool binary_;
  std::string out_;
};

std::string write_file(const test::ScratchDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir.file(name);
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

std::string error_of(const std::string& path) {
  try {
    read_vtk_legacy(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

bool has_warning(const Dataset& d, std::string_view text) {
  for (const std::string& w : d.warnings) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

const Field& field(const Dataset& d, std::string_view name, Association a) {
  const Field* f = d.blocks.at(0).fields.find(name, a);
  if (!f) throw std::runtime_error("no field " + std::string(name));
  return *f;
}

template <class T>
std::vector<T> values_of(const Field& f) {
  const auto v = f.data().values<T>();
  return {v.begin(), v.end()};
}

// --- real data -------------------------------------------------------------------------------------------------

TEST(VtkLegacyReal, NotchStress51Binary) {
  UGVR_REQUIRE_DATA("notch-stress/notch_stress.vtk");
  const Dataset d = read_vtk_legacy(relative_data_path);
  EXPECT_EQ(d.format, "legacy VTK 5.1 BINARY UNSTRUCTURED_GRID");
  ASSERT_EQ(d.blocks.size(), 1u);
  const auto& mesh = std::get<UnstructuredMesh>(d.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 12717u);
  const CellTypeCounts counts = mesh.cell_type_counts();
  EXPECT_EQ(counts.hexahedron, 2188u);
  EXPECT_EQ(counts.wedge, 4u);
  EXPECT_EQ(counts.total(), 2192u);
  // The file labels its 20-node hexahedra VTK_HEXAHEDRON: corners are used and the user is told.
  EXPECT_TRUE(has_warning(d, "more points than their type has")) << d.warnings.size();
  const Field& stress = field(d, "Nodal Stress", Association::Vertex);
  EXPECT_EQ(stress.components(), 6);
  EXPECT_EQ(stress.data().type(), ScalarType::Float64);
  const Range normed = field(d, "Nodal Stress-normed", Association::Vertex).range();
  EXPECT_NEAR(normed.min, 3.2e3, 0.01e3);
  EXPECT_NEAR(normed.max, 8.1e6, 0.02e6);
  EXPECT_GT(normed.nan_count, 0u);
  EXPECT_NE(d.blocks[0].fields.find("Nodal Stress-0"), nullptr) << "%20 in names is decoded";
}

TEST(VtkLegacyReal, OfficeStructuredGridBinary) {
  UGVR_REQUIRE_DATA("vtk-office/office.binary.vtk");
  const Dataset d = read_vtk_legacy(relative_data_path);
  EXPECT_EQ(d.format, "legacy VTK 1.0 BINARY STRUCTURED_GRID");
  const auto& g = std::get<StructuredGrid>(d.blocks[0].grid);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{21, 20, 20}));
  EXPECT_EQ(g.points.size(), 8400u);
  EXPECT_EQ(grid_cell_count(d.blocks[0].grid), 7220u);
  const Range scalars = field(d, "scalars", Association::Vertex).range();
  EXPECT_NEAR(scalars.min, -3.87, 0.01);
  EXPECT_NEAR(scalars.max, 0.719, 0.01);
  const Field& vectors = field(d, "vectors", Association::Vertex);
  EXPECT_EQ(vectors.components(), 3);
  EXPECT_EQ(vectors.data().type(), ScalarType::Float32);
}

TEST(VtkLegacyReal, UGridExDropsLowerDimensionalCells) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/uGridEx.vtk");
  const Dataset d = read_vtk_legacy(relative_data_path);
  const auto& mesh = std::get<UnstructuredMesh>(d.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 27u);
  EXPECT_EQ(mesh.cell_type_counts().tetra, 2u);
  EXPECT_EQ(mesh.cell_type_counts().hexahedron, 2u);
  EXPECT_EQ(mesh.cell_count(), 4u);
  EXPECT_TRUE(has_warning(d, "ignored 8 lower-dimensional cell(s)"));
  EXPECT_EQ(field(d, "scalars", Association::Vertex).range(), (Range{0, 26, 0}));
  EXPECT_EQ(field(d, "vectors", Association::Vertex).components(), 3);
}

TEST(VtkLegacyReal, SmallUnstructuredFixtures) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/tetraMesh.vtk");
  const std::string dir = test::data_path("vtk-small-ugrids/");
  const Dataset tetra = read_vtk_legacy(dir + "tetraMesh.vtk");
  const auto& tm = std::get<UnstructuredMesh>(tetra.blocks[0].grid);
  EXPECT_EQ(tm.point_count(), 55u);
  EXPECT_EQ(tm.cell_type_counts().tetra, 160u);
  const Field& s = field(tetra, "scalars", Association::Vertex);
  EXPECT_EQ(s.data().type(), ScalarType::Int32);
  EXPECT_EQ(s.range(), (Range{0, 4, 0}));

  const Dataset hexa = read_vtk_legacy(dir + "hexa.vtk");
  EXPECT_EQ(std::get<UnstructuredMesh>(hexa.blocks[0].grid).cell_type_counts().hexahedron, 10648u);
  EXPECT_NEAR(field(hexa, "scalars", Association::Vertex).range().max, 17.32, 0.01);

  const Dataset sector = read_vtk_legacy(dir + "AngularSector.vtk");
  const CellTypeCounts sc = std::get<UnstructuredMesh>(sector.blocks[0].grid).cell_type_counts();
  EXPECT_EQ(sc.hexahedron, 7632u);
  EXPECT_EQ(sc.pyramid, 144u);
  const Field& cell_id = field(sector, "CellId", Association::Cell);
  EXPECT_EQ(cell_id.data().type(), ScalarType::Int64) << "vtkIdType is read as 64-bit ids";
  EXPECT_EQ(cell_id.tuples(), 7776u);

  const Dataset grid = read_vtk_legacy(dir + "a_grid.vtk");
  EXPECT_EQ(grid.format, "legacy VTK 4.2 BINARY UNSTRUCTURED_GRID");
  const auto& gm = std::get<UnstructuredMesh>(grid.blocks[0].grid);
  EXPECT_EQ(gm.point_count(), 1317u);
  EXPECT_EQ(gm.cell_type_counts().tetra, 4802u);
  EXPECT_TRUE(grid.blocks[0].fields.empty());
}

TEST(VtkLegacyReal, SampleStructGridPointAndCellScalars) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/SampleStructGrid.vtk");
  const Dataset d = read_vtk_legacy(relative_data_path);
  const auto& g = std::get<StructuredGrid>(d.blocks[0].grid);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{20, 30, 40}));
  EXPECT_EQ(field(d, "scalars", Association::Vertex).tuples(), 24000u);
  EXPECT_EQ(field(d, "scalars", Association::Cell).tuples(), 19u * 29u * 39u);
}

TEST(VtkLegacyReal, SurfaceAndPrismFilesAreRefused) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/blow.vtk");
  const std::string blow = error_of(relative_data_path);
  EXPECT_NE(blow.find("blow.vtk"), std::string::npos) << blow;
  EXPECT_NE(blow.find("volume"), std::string::npos) << blow;
  const std::string prisms = error_of(test::data_path("vtk-small-ugrids/PentaHexa.vtk"));
  EXPECT_NE(prisms.find("PentaHexa.vtk:"), std::string::npos) << prisms;
  EXPECT_NE(prisms.find("VTK_PENTAGONAL_PRISM"), std::string::npos) << prisms;
}

// --- hand-written files ----------------------------------------------------------------------------------------

// One unstructured grid (a hexahedron, a triangle that is dropped, a tetrahedron) with point, cell and field data,
// written in any of the four layouts. 5.1 files carry METADATA blocks and a NULL_ARRAY, as VTK 9 writes them.
std::string mixed_grid(bool binary, bool v51) {
  VtkText f(binary);
  f.line(v51 ? "# vtk DataFile Version 5.1" : "# vtk DataFile Version 4.2");
  f.line("mixed cells").line(binary ? "BINARY" : "ASCII").line("DATASET UNSTRUCTURED_GRID");
  f.line("POINTS 9 float").values<float>({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1,    0,    0, 0,
                                          1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 0.5f, 0.5f, 2});
  if (v51) {
    f.line("METADATA").line("INFORMATION 2").line("NAME L2_NORM_RANGE LOCATION vtkDataArray").line("DATA 2 0 2.5");
    f.line("NAME L2_NORM_FINITE_RANGE LOCATION vtkDataArray").line("DATA 2 0 2.5").line("");
    f.line("CELLS 4 15").line("OFFSETS vtktypeint64").values<int64_t>({0, 8, 11, 15});
    f.line("CONNECTIVITY vtktypeint64").values<int64_t>({0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 4, 5, 6, 8});
    f.line("METADATA").line("INFORMATION 0").line("");
  } else {
    f.line("CELLS 3 18").values<int32_t>({8, 0, 1, 2, 3, 4, 5, 6, 7, 3, 0, 1, 2, 4, 4, 5, 6, 8});
  }
  f.line("CELL_TYPES 3").values<int32_t>({12, 5, 10});
  f.line("CELL_DATA 3").line("SCALARS material int 1").line("LOOKUP_TABLE default").values<int32_t>({10, 20, 30});
  f.line("POINT_DATA 9").line("SCALARS temperature%20K float").line("LOOKUP_TABLE default");
  f.values<float>({0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f, 8.5f});
  f.line("VECTORS velocity double");
  std::vector<double> velocity;
  for (int i = 0; i < 27; ++i) velocity.push_back(i * 0.25 - 3);
  f.values(velocity);
  if (v51) {
    // Component names are skipped line by line (even one that looks like a keyword), up to the blank line.
    f.line("METADATA").line("COMPONENT_NAMES").line("vx").line("POINT_DATA%209").line("vz");
    f.line("INFORMATION 1").line("NAME L2_NORM_RANGE LOCATION vtkDataArray").line("DATA 2 0 3.5").line("");
  }
  f.line(v51 ? "FIELD FieldData 4" : "FIELD FieldData 3");
  f.line("ids 1 9 vtkIdType").values<int32_t>({100, 101, 102, 103, 104, 105, 106, 107, 108});
  if (v51) f.line("NULL_ARRAY");
  f.line("flags 1 9 bit").bits({1, 0, 1, 1, 0, 0, 0, 1, 1});
  f.line("labels 1 9 string").strings({"a", "b", "c", "d", "e", "f", "g", "h", "i"});
  return f.str();
}

TEST(VtkLegacyHandWritten, AllFourLayoutsGiveTheSameGrid) {
  test::ScratchDir dir;
  const Dataset reference = read_vtk_legacy(write_file(dir, "a42.vtk", mixed_grid(false, false)));
  EXPECT_EQ(reference.format, "legacy VTK 4.2 ASCII UNSTRUCTURED_GRID");
  const auto& mesh = std::get<UnstructuredMesh>(reference.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 9u);
  ASSERT_EQ(mesh.cell_count(), 2u);
  EXPECT_EQ(mesh.cell_types[0], CellType::Hexahedron);
  EXPECT_EQ(mesh.cell_types[1], CellType::Tetra);
  EXPECT_EQ(std::vector<uint32_t>(mesh.cell(1).begin(), mesh.cell(1).end()), (std::vector<uint32_t>{4, 5, 6, 8}));
  EXPECT_EQ(mesh.points[8], (Vec3f{0.5f, 0.5f, 2}));
  // The triangle's cell data goes with it.
  EXPECT_EQ(values_of<int32_t>(field(reference, "material", Association::Cell)), (std::vector<int32_t>{10, 30}));
  EXPECT_EQ(field(reference, "temperature K", Association::Vertex).data().type(), ScalarType::Float32);
  const Field& velocity = field(reference, "velocity", Association::Vertex);
  EXPECT_EQ(velocity.data().type(), ScalarType::Float64);
  EXPECT_EQ(velocity.data().get(8, 2), 26 * 0.25 - 3);
  EXPECT_EQ(values_of<int64_t>(field(reference, "ids", Association::Vertex)).back(), 108);
  EXPECT_EQ(values_of<uint8_t>(field(reference, "flags", Association::Vertex)),
            (std::vector<uint8_t>{1, 0, 1, 1, 0, 0, 0, 1, 1}));
  EXPECT_EQ(reference.blocks[0].fields.find("labels"), nullptr) << "string arrays are skipped";
  EXPECT_TRUE(has_warning(reference, "ignored string array 'labels'"));
  EXPECT_TRUE(has_warning(reference, "ignored 1 lower-dimensional cell(s) (1 VTK_TRIANGLE)"));
  EXPECT_EQ(reference.blocks[0].name, "mixed cells");

  for (const auto& [binary, v51] : {std::pair{true, false}, std::pair{false, true}, std::pair{true, true}}) {
    const std::string name = std::string(binary ? "binary" : "ascii") + (v51 ? "51" : "42") + ".vtk";
    SCOPED_TRACE(name);
    const Dataset d = read_vtk_legacy(write_file(dir, name, mixed_grid(binary, v51)));
    EXPECT_EQ(d.format, std::string("legacy VTK ") + (v51 ? "5.1" : "4.2") + (binary ? " BINARY" : " ASCII") +
                            " UNSTRUCTURED_GRID");
    EXPECT_TRUE(d.blocks[0].grid == reference.blocks[0].grid);
    EXPECT_TRUE(d.blocks[0].fields == reference.blocks[0].fields);
    EXPECT_EQ(d.warnings.size(), reference.warnings.size());
  }
}

std::string image_file(bool binary) {
  VtkText f(binary);
  f.line("# vtk DataFile Version 3.0").line("an image").line(binary ? "BINARY" : "ASCII");
  f.line("DATASET STRUCTURED_POINTS").line("DIMENSIONS 3 4 5").line("ORIGIN 1 2 3").line("SPACING 0.5 0.25 2");
  f.line("POINT_DATA 60").line("SCALARS density unsigned_char").line("LOOKUP_TABLE ramp");
  std::vector<uint8_t> density;
  for (int i = 0; i < 60; ++i) density.push_back(uint8_t(i * 4));
  f.values(density);
  // A colour table, not data: skipped (RGBA floats in ASCII, bytes in BINARY).
  f.line("LOOKUP_TABLE ramp 2");
  if (binary) {
    f.values<uint8_t>({0, 0, 0, 255, 255, 255, 255, 255});
  } else {
    f.values<float>({0, 0, 0, 1, 1, 1, 1, 1});
  }
  f.line("COLOR_SCALARS rgb 3");
  std::vector<uint8_t> rgb_bytes;
  std::vector<float> rgb_floats;
  for (int i = 0; i < 180; ++i) {
    const int level = i % 3;  // 0, 0.5, 1 -> 0, 128, 255
    rgb_bytes.push_back(uint8_t(level == 0 ? 0 : level == 1 ? 128 : 255));
    rgb_floats.push_back(float(level) * 0.5f);
  }
  if (binary) {
    f.values(rgb_bytes);
  } else {
    f.values(rgb_floats);
  }
  f.line("CELL_DATA 24").line("TENSORS6 strain float");
  std::vector<float> strain(144);
  for (size_t i = 0; i < strain.size(); ++i) strain[i] = float(i) / 8;
  f.values(strain);
  f.line("TEXTURE_COORDINATES uv 2 double");
  f.values(std::vector<double>(48, 0.75));
  f.line("GLOBAL_IDS gid long");
  std::vector<int64_t> gid(24);
  for (int i = 0; i < 24; ++i) gid[size_t(i)] = int64_t(1) << (i + 20);
  f.values(gid);
  return f.str();
}

TEST(VtkLegacyHandWritten, StructuredPointsWithEveryAttributeKind) {
  test::ScratchDir dir;
  const Dataset ascii = read_vtk_legacy(write_file(dir, "image_a.vtk", image_file(false)));
  const Dataset binary = read_vtk_legacy(write_file(dir, "image_b.vtk", image_file(true)));
  EXPECT_EQ(ascii.format, "legacy VTK 3.0 ASCII STRUCTURED_POINTS");
  const auto& image = std::get<ImageGrid>(ascii.blocks[0].grid);
  EXPECT_EQ(image.dims.points, (std::array<uint32_t, 3>{3, 4, 5}));
  EXPECT_EQ(image.origin, (Vec3d{1, 2, 3}));
  EXPECT_EQ(image.spacing, (Vec3d{0.5, 0.25, 2}));
  EXPECT_EQ(ascii.blocks[0].fields.size(), 5u);
  const Field& density = field(ascii, "density", Association::Vertex);
  EXPECT_EQ(density.data().type(), ScalarType::UInt8);
  EXPECT_EQ(density.range(), (Range{0, 236, 0}));
  const Field& rgb = field(ascii, "rgb", Association::Vertex);
  EXPECT_EQ(rgb.data().type(), ScalarType::UInt8);
  EXPECT_EQ(rgb.components(), 3);
  EXPECT_EQ(values_of<uint8_t>(rgb).at(4), 128u) << "ASCII colours in [0, 1] become bytes as in VTK";
  EXPECT_EQ(field(ascii, "strain", Association::Cell).components(), 6);
  EXPECT_EQ(field(ascii, "uv", Association::Cell).components(), 2);
  EXPECT_EQ(values_of<int64_t>(field(ascii, "gid", Association::Cell)).back(), int64_t(1) << 43);
  EXPECT_TRUE(binary.blocks[0].grid == ascii.blocks[0].grid);
  EXPECT_TRUE(binary.blocks[0].fields == ascii.blocks[0].fields);
}

std::string rectilinear_file(bool binary) {
  VtkText f(binary);
  f.line("# vtk DataFile Version 2.0").line("axes").line(binary ? "BINARY" : "ASCII");
  f.line("DATASET RECTILINEAR_GRID");
  // Dataset-level field data (ParaView writes the time here): not per point or cell, so not kept.
  f.line("FIELD FieldData 1").line("TIME 1 1 double").values<double>({0.5});
  f.line("DIMENSIONS 2 3 2");
  f.line("X_COORDINATES 2 float").values<float>({0, 1});
  f.line("Y_COORDINATES 3 double").values<double>({0, 0.5, 2});
  f.line("Z_COORDINATES 2 int").values<int32_t>({-1, 1});
  f.line("CELL_DATA 2").line("FIELD FieldData 2").line("pressure 1 2 double").values<double>({1.5, -2.5});
  f.line("Pa%2Fs 2 2 unsigned_short").values<uint16_t>({1, 2, 3, 65535});
  f.line("POINT_DATA 12").line("SCALARS s short 2").line("LOOKUP_TABLE default");
  std::vector<int16_t> s;
  for (int i = 0; i < 24; ++i) s.push_back(int16_t(i - 12));
  f.values(s);
  return f.str();
}

TEST(VtkLegacyHandWritten, RectilinearGridWithFieldData) {
  test::ScratchDir dir;
  for (const bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "BINARY" : "ASCII");
    const Dataset d = read_vtk_legacy(write_file(dir, "rect.vtk", rectilinear_file(binary)));
    const auto& r = std::get<RectilinearGrid>(d.blocks[0].grid);
    EXPECT_EQ(r.coords[0], (std::vector<double>{0, 1}));
    EXPECT_EQ(r.coords[1], (std::vector<double>{0, 0.5, 2}));
    EXPECT_EQ(r.coords[2], (std::vector<double>{-1, 1}));
    EXPECT_EQ(values_of<double>(field(d, "pressure", Association::Cell)), (std::vector<double>{1.5, -2.5}));
    const Field& rate = field(d, "Pa/s", Association::Cell);
    EXPECT_EQ(rate.components(), 2);
    EXPECT_EQ(values_of<uint16_t>(rate).back(), 65535);
    const Field& s = field(d, "s", Association::Vertex);
    EXPECT_EQ(s.components(), 2);
    EXPECT_EQ(s.data().type(), ScalarType::Int16);
    EXPECT_EQ(values_of<int16_t>(s).front(), -12);
    EXPECT_TRUE(has_warning(d, "ignored dataset-level FIELD 'FieldData'"));
    EXPECT_EQ(d.blocks[0].fields.find("TIME"), nullptr);
  }
}

// A structured hexahedral grid big enough that arrays, cell lists and tokens cross every buffer and chunk boundary.
std::string big_hex_grid(bool binary, int n) {
  VtkText f(binary);
  f.line("# vtk DataFile Version 5.1").line("big").line(binary ? "BINARY" : "ASCII");
  f.line("DATASET UNSTRUCTURED_GRID");
  std::vector<double> points;
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        points.insert(points.end(), {i * 0.125, j * 0.25 + 1000, k * 0.5 - 3});
      }
    }
  }
  f.line("POINTS " + std::to_string(n * n * n) + " double").values(points);
  std::vector<int64_t> offsets{0}, connectivity;
  std::vector<uint8_t> types;
  auto id = [n](int i, int j, int k) { return int64_t(i + n * (j + n * k)); };
  for (int k = 0; k + 1 < n; ++k) {
    for (int j = 0; j + 1 < n; ++j) {
      for (int i = 0; i + 1 < n; ++i) {
        connectivity.insert(connectivity.end(),
                            {id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                             id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
        offsets.push_back(int64_t(connectivity.size()));
      }
    }
  }
  const size_t cells = offsets.size() - 1;
  f.line("CELLS " + std::to_string(offsets.size()) + " " + std::to_string(connectivity.size()));
  f.line("OFFSETS vtktypeint64").values(offsets).line("CONNECTIVITY vtktypeint64").values(connectivity);
  f.line("CELL_TYPES " + std::to_string(cells)).values(std::vector<int32_t>(cells, 12));
  std::vector<float> scalars;
  for (size_t i = 0; i < points.size() / 3; ++i) scalars.push_back(float(i) * 0.5f);
  f.line("POINT_DATA " + std::to_string(n * n * n)).line("SCALARS s float").line("LOOKUP_TABLE default");
  f.values(scalars);
  return f.str();
}

TEST(VtkLegacyHandWritten, LargeFileStreamsAcrossChunks) {
  test::ScratchDir dir;
  const int n = 30;  // 81,000 coordinates (> one 65,536-value chunk), 219,501 ids; the ASCII file is > 1 MiB
  const std::string ascii_text = big_hex_grid(false, n);
  ASSERT_GT(ascii_text.size(), size_t(1) << 20);
  const Dataset ascii = read_vtk_legacy(write_file(dir, "big_a.vtk", ascii_text));
  const Dataset binary = read_vtk_legacy(write_file(dir, "big_b.vtk", big_hex_grid(true, n)));
  const auto& mesh = std::get<UnstructuredMesh>(ascii.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), uint64_t(n) * n * n);
  EXPECT_EQ(mesh.cell_type_counts().hexahedron, uint64_t(n - 1) * (n - 1) * (n - 1));
  EXPECT_EQ(mesh.points.back(), (Vec3f{(n - 1) * 0.125f, (n - 1) * 0.25f + 1000, (n - 1) * 0.5f - 3}));
  const auto last = mesh.cell(mesh.cell_count() - 1);
  EXPECT_EQ(last[6], uint32_t(n * n * n - 1));
  for (uint64_t c = 0; c < mesh.cell_count(); c += 997) EXPECT_GT(cell_volume(mesh, c), 0) << c;
  EXPECT_EQ(field(ascii, "s", Association::Vertex).range().max, (n * n * n - 1) * 0.5);
  EXPECT_TRUE(binary.blocks[0].grid == ascii.blocks[0].grid);
  EXPECT_TRUE(binary.blocks[0].fields == ascii.blocks[0].fields);
}

TEST(VtkLegacyHandWritten, KeywordsAreCaseInsensitiveAndDuplicatesReplace) {
  test::ScratchDir dir;
  const std::string text =
      "# vtk DataFile Version 3.0\n\nascii\ndataset structured_points\ndimensions 2 2 2\nspacing 1 1 1\n"
      "direction 1 0 0 0 1 0 0 0 1\npoint_data 8\nscalars a float\nlookup_table default\n1 2 3 4 5 6 7 8\n"
      "Scalars a double\nLookup_Table default\n8 7 6 5 4 3 2 1\n";
  const Dataset d = read_vtk_legacy(write_file(dir, "case.vtk", text));
  ASSERT_EQ(d.blocks[0].fields.size(), 1u);
  const Field& a = field(d, "a", Association::Vertex);
  EXPECT_EQ(a.data().type(), ScalarType::Float64) << "the later array of a name wins, as in VTK";
  EXPECT_EQ(a.data().get(0, 0), 8);
  EXPECT_TRUE(has_warning(d, "appears twice"));
}

// --- malformed files -------------------------------------------------------------------------------------------

// A small valid ASCII grid, one line per entry, to be broken line by line.
std::vector<std::string> small_grid_lines() {
  return {"# vtk DataFile Version 4.2",  // 1
          "small",                       // 2
          "ASCII",                       // 3
          "DATASET UNSTRUCTURED_GRID",   // 4
          "POINTS 4 float",              // 5
          "0 0 0 1 0 0",                 // 6
          "0 1 0 0 0 1",                 // 7
          "CELLS 1 5",                   // 8
          "4 0 1 2 3",                   // 9
          "CELL_TYPES 1",                // 10
          "10",                          // 11
          "POINT_DATA 4",                // 12
          "SCALARS s float 1",           // 13
          "LOOKUP_TABLE default",        // 14
          "1 2 3 4"};                    // 15
}

std::string join(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

struct Malformed {
  std::string name;
  std::function<void(std::vector<std::string>&)> edit;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(VtkLegacyMalformed, AsciiErrorsNameFileLineAndProblem) {
  test::ScratchDir dir;
  ASSERT_NO_THROW(read_vtk_legacy(write_file(dir, "valid.vtk", join(small_grid_lines()))));
  const std::vector<Malformed> cases = {
      {"not_a_number", [](auto& l) { l[6] = "0 1 0 0 0 abc"; }, {":7:", "POINTS", "'abc'"}},
      {"id_out_of_range", [](auto& l) { l[8] = "4 0 1 2 99"; }, {":9:", "cell 0", "99", "outside [0, 4)"}},
      {"absurd_points", [](auto& l) { l[4] = "POINTS 999999999999 float"; }, {":5:", "999999999999"}},
      {"missing_cell_types", [](auto& l) { l.erase(l.begin() + 9, l.begin() + 11); }, {":8:", "CELL_TYPES"}},
      {"missing_cells", [](auto& l) { l.erase(l.begin() + 7, l.begin() + 9); }, {":8:", "CELLS"}},
      {"truncated_values",
       [](auto& l) {
         l.resize(7);
         l[6] = "0 1 0 0 0" + std::string(20, ' ');
       },
       {":8:", "end of file", "POINTS", "value 11"}},
      {"too_few_bytes", [](auto& l) { l.resize(6); }, {":5:", "POINTS count 12", "bytes remain"}},
      {"short_point_list", [](auto& l) { l[6] = "0 1 0"; }, {":8:", "POINTS", "'CELLS'"}},
      {"cell_count_mismatch",
       [](auto& l) {
         l[9] = "CELL_TYPES 2";
         l[10] = "10 10";
       },
       {":10:", "CELLS has 1"}},
      {"cell_list_too_long", [](auto& l) { l[8] = "7 0 1 2 3"; }, {":9:", "7 points"}},
      {"wrong_point_count", [](auto& l) { l[8] = "3 0 1 2 3"; }, {":9:", "needs 4 points"}},
      {"unknown_cell_type", [](auto& l) { l[10] = "99"; }, {":9:", "unknown cell type"}},
      {"point_data_mismatch", [](auto& l) { l[11] = "POINT_DATA 5"; }, {":12:", "POINT_DATA 5", "4 points"}},
      {"unknown_type", [](auto& l) { l[12] = "SCALARS s quaternion"; }, {":13:", "unknown data type 'quaternion'"}},
      {"no_lookup_table",
       [](auto& l) {
         l[13] = "1 2 3 4";
         l.pop_back();
       },
       {":14:", "LOOKUP_TABLE"}},
      {"bad_attribute", [](auto& l) { l[12] = "COLORS s float"; }, {":13:", "unexpected keyword 'COLORS'"}},
      {"bad_geometry_keyword", [](auto& l) { l[7] = "CELLZ 1 5"; }, {":8:", "unexpected keyword 'CELLZ'"}},
      {"polydata", [](auto& l) { l[3] = "DATASET POLYDATA"; }, {":4:", "not a volume"}},
      {"unknown_dataset", [](auto& l) { l[3] = "DATASET GRAPH"; }, {":4:", "unsupported dataset type"}},
      {"not_vtk", [](auto& l) { l[0] = "# VTK file"; }, {":1:", "not a legacy VTK file"}},
      {"bad_encoding", [](auto& l) { l[2] = "TEXT"; }, {":3:", "ASCII or BINARY"}},
      {"negative_count", [](auto& l) { l[4] = "POINTS -4 float"; }, {":5:", "'-4'"}},
      {"only_header", [](auto& l) { l.resize(4); }, {"no POINTS"}},
      {"huge_components", [](auto& l) { l[12] = "SCALARS s float 99999999"; }, {":13:", "component count"}},
      {"bad_dims_keyword", [](auto& l) { l[3] = "DATASET STRUCTURED_POINTS"; }, {":5:", "unexpected keyword"}},
  };
  for (const Malformed& m : cases) {
    std::vector<std::string> lines = small_grid_lines();
    m.edit(lines);
    const std::string message = error_of(write_file(dir, m.name + ".vtk", join(lines)));
    EXPECT_NE(message.find(m.name + ".vtk"), std::string::npos) << m.name << ": " << message;
    for (const std::string& want : m.expected) {
      EXPECT_NE(message.find(want), std::string::npos) << m.name << ": '" << want << "' not in: " << message;
    }
  }
}

TEST(VtkLegacyMalformed, StructuredGridsMustBeVolumesAndConsistent) {
  test::ScratchDir dir;
  const std::string head = "# vtk DataFile Version 3.0\nx\nASCII\n";
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"DATASET STRUCTURED_POINTS\nDIMENSIONS 4 4 1\nPOINT_DATA 16\n", {":5:", "no volume cells"}},
      {"DATASET STRUCTURED_POINTS\nDIMENSIONS 0 4 4\n", {":5:", "DIMENSIONS"}},
      {"DATASET STRUCTURED_POINTS\nDIMENSIONS 4000000 4000000 4000000\n", {":5:", "2^42"}},
      {"DATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nDIRECTION 0 1 0 1 0 0 0 0 1\n", {":6:", "DIRECTION"}},
      {"DATASET STRUCTURED_POINTS\nSPACING 1 1 1\n", {"no DIMENSIONS"}},
      {"DATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nORIGIN 0 nan 0\n", {":6:", "ORIGIN must be finite"}},
      {"DATASET STRUCTURED_GRID\nDIMENSIONS 2 2 3\nPOINTS 8 float\n0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1\n",
       {":6:", "need 12"}},
      {"DATASET RECTILINEAR_GRID\nDIMENSIONS 2 2 2\nX_COORDINATES 2 float\n0 1\nY_COORDINATES 2 float\n0 1\n",
       {"no Z_COORDINATES"}},
      {"DATASET RECTILINEAR_GRID\nDIMENSIONS 2 2 2\nX_COORDINATES 3 float\n0 1 2\nY_COORDINATES 2 float\n0 1\n"
       "Z_COORDINATES 2 float\n0 1\n",
       {":6:", "X_COORDINATES has 3 values"}},
      {"DATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nCELL_DATA 1\nFIELD f 1\na 1 2 float\n1 2\n",
       {":8:", "FIELD array a has 2 tuples but CELL_DATA has 1"}},
  };
  for (const auto& [body, expected] : cases) {
    const std::string message = error_of(write_file(dir, "x.vtk", head + body));
    for (const std::string& want : expected) {
      EXPECT_NE(message.find(want), std::string::npos) << "'" << want << "' not in: " << message;
    }
    EXPECT_NE(message.find("x.vtk"), std::string::npos) << message;
  }
}

TEST(VtkLegacyMalformed, BinaryErrorsNameTheByteOffset) {
  test::ScratchDir dir;
  const std::string good = mixed_grid(true, true);
  ASSERT_NO_THROW(read_vtk_legacy(write_file(dir, "good.vtk", good)));

  // Truncated in the middle of the points block.
  const size_t points_data = good.find("POINTS 9 float\n") + std::string("POINTS 9 float\n").size();
  const std::string truncated = error_of(write_file(dir, "truncated.vtk", good.substr(0, points_data + 20)));
  EXPECT_NE(truncated.find("truncated.vtk: byte " + std::to_string(points_data)), std::string::npos) << truncated;

  // Truncated inside the connectivity: found by the first pass, before any cell is built.
  const size_t conn = good.find("CONNECTIVITY vtktypeint64\n") + std::string("CONNECTIVITY vtktypeint64\n").size();
  const std::string cut = error_of(write_file(dir, "cut.vtk", good.substr(0, conn + 40)));
  EXPECT_NE(cut.find("cut.vtk: byte " + std::to_string(conn)), std::string::npos) << cut;

  // A point id out of range: the message names the byte of that id.
  std::string bad_id = good;
  const size_t id_at = conn + 14 * 8;  // the tet's last id (8)
  ASSERT_EQ(bad_id[id_at + 7], char(8));
  bad_id[id_at + 7] = char(99);
  const std::string out_of_range = error_of(write_file(dir, "bad_id.vtk", bad_id));
  EXPECT_NE(out_of_range.find("bad_id.vtk: byte " + std::to_string(id_at)), std::string::npos) << out_of_range;
  EXPECT_NE(out_of_range.find("99"), std::string::npos) << out_of_range;

  // Offsets that go backwards.
  std::string bad_offsets = good;
  const size_t offsets = good.find("OFFSETS vtktypeint64\n") + std::string("OFFSETS vtktypeint64\n").size();
  bad_offsets[offsets + 2 * 8 + 7] = char(3);  // 0, 8, 3, 15
  const std::string backwards = error_of(write_file(dir, "offsets.vtk", bad_offsets));
  EXPECT_NE(backwards.find("offsets.vtk: byte " + std::to_string(offsets + 16)), std::string::npos) << backwards;
  EXPECT_NE(backwards.find("outside [8, 15]"), std::string::npos) << backwards;

  // An absurd count in a binary file is refused before allocating, at the offset of the block.
  std::string absurd = good;
  absurd.replace(absurd.find("POINTS 9 float"), 14, "POINTS 999999999 float");
  const std::string absurd_message = error_of(write_file(dir, "absurd.vtk", absurd));
  EXPECT_NE(absurd_message.find("absurd.vtk: byte "), std::string::npos) << absurd_message;
  EXPECT_NE(absurd_message.find("2999999997"), std::string::npos) << absurd_message;

  // A string array whose length runs past the end of the file.
  VtkText s(true);
  s.line("# vtk DataFile Version 3.0").line("s").line("BINARY").line("DATASET STRUCTURED_POINTS");
  s.line("DIMENSIONS 2 2 2").line("POINT_DATA 8").line("FIELD f 1").line("names 1 1 string");
  const std::string strings = s.str() + "\x3f" + "abc";
  const std::string string_message = error_of(write_file(dir, "strings.vtk", strings));
  EXPECT_NE(string_message.find("strings.vtk: byte " + std::to_string(s.size() + 1)), std::string::npos)
      << string_message;
}

TEST(VtkLegacyMalformed, EmptyAndMissingFiles) {
  test::ScratchDir dir;
  const std::string empty = error_of(write_file(dir, "empty.vtk", ""));
  EXPECT_NE(empty.find("empty.vtk:1:"), std::string::npos) << empty;
  const std::string missing = error_of(dir.file("nope.vtk"));
  EXPECT_NE(missing.find("nope.vtk"), std::string::npos) << missing;
  const std::string no_title = error_of(write_file(dir, "title.vtk", "# vtk DataFile Version 2.0\n"));
  EXPECT_NE(no_title.find("title.vtk:2:"), std::string::npos) << no_title;
}

}  // namespace
}  // namespace ugvr
