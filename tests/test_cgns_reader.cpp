// The CGNS reader (io/cgns_reader.cpp): the shared structured sample against VTK 9.1's counts and values, and
// unstructured files written here by libcgns itself (ADF and HDF5; per-type, MIXED and NGON/NFACE sections; rind;
// iterative data) read back to the mesh and fields they were written from. Fields-only steps (io/step_fields.h): a
// file whose steps are FlowSolutionPointers on a grid that does not move reads a step's solution alone, bit for bit the
// whole read.
#include <cgnslib.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>

#include "step_fields_checks.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/cgns_fields.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/render/exact/exact_renderer.h"

namespace ugvr {
namespace {

using test::ScratchDir;

#define CG(call) ASSERT_EQ((call), CG_OK) << cg_get_error()

TEST(CgnsReader, SharedStructuredSampleMatchesVtk) {
  UGVR_REQUIRE_DATA("cgns-sqnz/sqnz_s.adf.cgns");
  const std::vector<std::string> paths{relative_data_path};
  EXPECT_EQ(detect_format(paths), InputFormat::Cgns);
  const Dataset ds = read_dataset(paths);
  EXPECT_EQ(ds.format, "CGNS (ADF)");
  // ../shared/data/cgns-sqnz/SOURCE.txt: VTK 9.1's vtkCGNSReader reports 12 zones, 15,228 points, 11,264 hexahedra.
  ASSERT_EQ(ds.blocks.size(), 12u);
  EXPECT_EQ(ds.point_count(), 15228u);
  EXPECT_EQ(ds.cell_count(), 11264u);
  const Block& b0 = ds.blocks[0];
  EXPECT_EQ(b0.name, "SQNZ/dom1_1_1_1");
  ASSERT_TRUE(std::holds_alternative<StructuredGrid>(b0.grid));
  EXPECT_EQ(std::get<StructuredGrid>(b0.grid).dims.points, (std::array<uint32_t, 3>{15, 9, 9}));
  // Momentum X/Y/Z grouped into a vector, as VTK does; ranges as vtkCGNSReader gives them for the first zone.
  const Field* density = b0.fields.find("Density");
  const Field* momentum = b0.fields.find("Momentum");
  ASSERT_NE(density, nullptr);
  ASSERT_NE(momentum, nullptr);
  EXPECT_EQ(density->association(), Association::Cell);
  EXPECT_EQ(momentum->components(), 3);
  EXPECT_NEAR(density->range().min, 0.7895130710766533, 1e-12);
  EXPECT_NEAR(density->range().max, 0.914286030153726, 1e-12);
  EXPECT_NEAR(momentum->range().min, 0.3836539315557368, 1e-12);
  EXPECT_NEAR(momentum->range().max, 0.5286443499106337, 1e-12);
}

enum class Layout { PerType, Mixed, Polyhedra };

const char* const kSectionNames[] = {"Tetra", "Pyramid", "Penta", "Hexa"};

ElementType_t cgns_type(CellType t) {
  switch (t) {
    case CellType::Tetra: return TETRA_4;
    case CellType::Pyramid: return PYRA_5;
    case CellType::Wedge: return PENTA_6;
    case CellType::Hexahedron: return HEXA_8;
  }
  return ElementTypeNull;
}

// The cell's nodes in CGNS order, 1-based: CGNS's PENTA_6 runs its first triangle the other way round from VTK's
// wedge; the other types agree.
std::vector<cgsize_t> cgns_nodes(const UnstructuredMesh& m, uint64_t c) {
  std::vector<cgsize_t> n;
  for (uint32_t v : m.cell(c)) n.push_back(cgsize_t(v) + 1);
  if (m.cell_types[c] == CellType::Wedge) {
    std::swap(n[1], n[2]);
    std::swap(n[4], n[5]);
  }
  return n;
}

// Writes the first block of `ds` (an unstructured mesh with point field "pressure" and a cell field) as a CGNS file;
// `more(fn)` may add nodes to its zone (base 1, zone 1) before the file is closed.
void write_unstructured(const std::string& path, const Dataset& ds, Layout layout, int file_type,
                        const std::function<void(int)>& more = {}) {
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  CG(cg_set_file_type(file_type));
  int fn = 0, B = 0, Z = 0;
  CG(cg_open(path.c_str(), CG_MODE_WRITE, &fn));
  CG(cg_base_write(fn, "Base", 3, 3, &B));
  cgsize_t size[3] = {cgsize_t(mesh.point_count()), cgsize_t(mesh.cell_count()), 0};
  CG(cg_zone_write(fn, B, "Wing", size, Unstructured, &Z));
  for (int a = 0; a < 3; ++a) {
    std::vector<double> x(mesh.point_count());
    for (size_t i = 0; i < x.size(); ++i)
      x[i] = a == 0 ? mesh.points[i].x : a == 1 ? mesh.points[i].y : mesh.points[i].z;
    int C = 0;
    const char* name[] = {"CoordinateX", "CoordinateY", "CoordinateZ"};
    CG(cg_coord_write(fn, B, Z, RealDouble, name[a], x.data(), &C));
  }
  int S = 0;
  cgsize_t next = 1;
  if (layout == Layout::PerType) {
    // Sections by type in cell order runs: element numbers follow cell order only if cells are sorted by type, so
    // write one section per run of equal types.
    uint64_t c = 0;
    while (c < mesh.cell_count()) {
      uint64_t e = c;
      std::vector<cgsize_t> conn;
      while (e < mesh.cell_count() && mesh.cell_types[e] == mesh.cell_types[c]) {
        auto n = cgns_nodes(mesh, e);
        conn.insert(conn.end(), n.begin(), n.end());
        ++e;
      }
      const std::string name = std::string(kSectionNames[c % 4]) + std::to_string(next);
      CG(cg_section_write(fn, B, Z, name.c_str(), cgns_type(mesh.cell_types[c]), next, next + cgsize_t(e - c) - 1, 0,
                          conn.data(), &S));
      next += cgsize_t(e - c);
      c = e;
    }
  } else if (layout == Layout::Mixed) {
    std::vector<cgsize_t> conn, offsets{0};
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      conn.push_back(cgns_type(mesh.cell_types[c]));
      auto n = cgns_nodes(mesh, c);
      conn.insert(conn.end(), n.begin(), n.end());
      offsets.push_back(cgsize_t(conn.size()));
    }
    CG(cg_poly_section_write(fn, B, Z, "Cells", MIXED, 1, cgsize_t(mesh.cell_count()), 0, conn.data(), offsets.data(),
                             &S));
    next = cgsize_t(mesh.cell_count()) + 1;
  } else {
    // Every cell as an NFACE_n of its faces; faces listed once per cell in an NGON_n section after the cells.
    std::vector<cgsize_t> faces, face_offsets{0}, cells, cell_offsets{0};
    const cgsize_t first_face = cgsize_t(mesh.cell_count()) + 1;
    cgsize_t face_number = first_face;
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      const auto v = mesh.cell(c);
      const CellInfo info = cell_info(mesh.cell_types[c]);
      for (int f = 0; f < info.face_count; ++f) {
        for (int k = 0; k < info.faces[size_t(f)].size; ++k)
          faces.push_back(cgsize_t(v[info.faces[size_t(f)].v[size_t(k)]]) + 1);
        face_offsets.push_back(cgsize_t(faces.size()));
        cells.push_back(f % 2 ? face_number : -face_number);  // signs (orientation) must not matter
        ++face_number;
      }
      cell_offsets.push_back(cgsize_t(cells.size()));
    }
    CG(cg_poly_section_write(fn, B, Z, "Cells", NFACE_n, 1, cgsize_t(mesh.cell_count()), 0, cells.data(),
                             cell_offsets.data(), &S));
    CG(cg_poly_section_write(fn, B, Z, "Faces", NGON_n, first_face, face_number - 1, 0, faces.data(),
                             face_offsets.data(), &S));
    next = face_number;
  }
  // A boundary section of lower dimension: skipped by the reader.
  std::vector<cgsize_t> tri{1, 2, 3};
  CG(cg_section_write(fn, B, Z, "Wall", TRI_3, next, next, 0, tri.data(), &S));

  int sols[2] = {0, 0};  // per association: one FlowSolution_t each
  for (const Field& f : ds.blocks[0].fields) {
    const bool vertex = f.association() == Association::Vertex;
    int& sol = sols[vertex ? 0 : 1];
    if (sol == 0) {
      CG(cg_sol_write(fn, B, Z, vertex ? "NodalSolution" : "CellSolution", vertex ? Vertex : CellCenter, &sol));
    }
    for (int comp = 0; comp < f.components(); ++comp) {
      std::vector<double> v(f.tuples());
      for (uint64_t t = 0; t < f.tuples(); ++t) v[t] = f.data().get(t, comp);
      std::string name = f.name();
      if (f.components() == 3) name += "XYZ"[comp];
      int F = 0;
      CG(cg_field_write(fn, B, Z, sol, RealDouble, name.c_str(), v.data(), &F));
    }
  }
  if (more) more(fn);
  CG(cg_close(fn));
}

// Cells as sorted vertex sets (the order within a cell may differ by the wedge flip; the set may not).
std::multiset<std::vector<uint32_t>> cell_sets(const UnstructuredMesh& m) {
  std::multiset<std::vector<uint32_t>> s;
  for (uint64_t c = 0; c < m.cell_count(); ++c) {
    std::vector<uint32_t> v(m.cell(c).begin(), m.cell(c).end());
    std::sort(v.begin(), v.end());
    s.insert(v);
  }
  return s;
}

void expect_same_mesh_and_fields(const Dataset& written, const Dataset& read) {
  ASSERT_EQ(read.blocks.size(), 1u);
  const auto& a = std::get<UnstructuredMesh>(written.blocks[0].grid);
  const auto& b = std::get<UnstructuredMesh>(read.blocks[0].grid);
  ASSERT_EQ(b.point_count(), a.point_count());
  ASSERT_EQ(b.cell_count(), a.cell_count());
  EXPECT_EQ(b.points, a.points);
  EXPECT_EQ(b.cell_types, a.cell_types);
  EXPECT_EQ(cell_sets(b), cell_sets(a));
  for (uint64_t c = 0; c < b.cell_count(); ++c) ASSERT_GT(cell_volume(b, c), 0) << "cell " << c;
  for (const Field& f : written.blocks[0].fields) {
    const Field* g = read.blocks[0].fields.find(f.name());
    ASSERT_NE(g, nullptr) << f.name();
    EXPECT_EQ(g->association(), f.association());
    ASSERT_EQ(g->components(), f.components());
    for (uint64_t t = 0; t < f.tuples(); t += 7)
      for (int c = 0; c < f.components(); ++c) ASSERT_EQ(g->data().get(t, c), f.data().get(t, c)) << f.name() << t;
  }
}

Dataset small_mixed_mesh() {
  GenerateOptions o;
  o.cells = 3000;
  o.kind = GenCellKind::Mixed;
  return generate_in_memory(o);
}

TEST(CgnsReader, UnstructuredSectionsRoundTripAdfAndHdf5) {
  ScratchDir dir;
  const Dataset ds = small_mixed_mesh();
  for (int file_type : {CG_FILE_ADF, CG_FILE_HDF5}) {
    for (Layout layout : {Layout::PerType, Layout::Mixed}) {
      const std::string path = dir.file("mixed.cgns");
      std::filesystem::remove(path);
      write_unstructured(path, ds, layout, file_type);
      const std::vector<std::string> paths{path};
      ASSERT_EQ(detect_format(paths), InputFormat::Cgns);
      const Dataset read = read_dataset(paths);
      EXPECT_EQ(read.format, file_type == CG_FILE_HDF5 ? "CGNS (HDF5)" : "CGNS (ADF)");
      SCOPED_TRACE(std::to_string(file_type) + (layout == Layout::Mixed ? " mixed" : " per type"));
      expect_same_mesh_and_fields(ds, read);
      bool noted = false;
      for (const auto& w : read.warnings) noted |= w.find("1 elements of lower dimension") != std::string::npos;
      EXPECT_TRUE(noted);
    }
  }
}

TEST(CgnsReader, PolyhedraWithNativeShapesComeBackNative) {
  ScratchDir dir;
  const Dataset ds = small_mixed_mesh();
  const std::string path = dir.file("poly.cgns");
  write_unstructured(path, ds, Layout::Polyhedra, CG_FILE_HDF5);
  const Dataset read = read_dataset(std::vector<std::string>{path});
  ASSERT_EQ(read.blocks.size(), 1u);
  const auto& a = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  const auto& b = std::get<UnstructuredMesh>(read.blocks[0].grid);
  EXPECT_EQ(b.point_count(), a.point_count());  // no centre point added: every polyhedron had a native shape
  EXPECT_EQ(b.cell_types, a.cell_types);
  EXPECT_EQ(cell_sets(b), cell_sets(a));
  for (uint64_t c = 0; c < b.cell_count(); ++c) ASSERT_GT(cell_volume(b, c), 0) << c;
  const Field* cell_field = nullptr;
  for (const Field& f : ds.blocks[0].fields)
    if (f.association() == Association::Cell) cell_field = &f;
  if (cell_field) {
    const Field* g = read.blocks[0].fields.find(cell_field->name());
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(g->data().get(17, 0), cell_field->data().get(17, 0));
  }
}

// Round trip CGNS -> .vtu -> read (what `ugvr convert` does): the same cells and fields, polyhedra decomposed.
TEST(CgnsReader, RoundTripThroughVtuKeepsCellsAndFields) {
  ScratchDir dir;
  const Dataset ds = small_mixed_mesh();
  const std::string cgns = dir.file("mixed.cgns"), vtu = dir.file("mixed.vtu");
  write_unstructured(cgns, ds, Layout::Polyhedra, CG_FILE_HDF5);
  const Dataset read = read_dataset(std::vector<std::string>{cgns});
  write_vtu(read, vtu);
  const Dataset back = read_dataset(std::vector<std::string>{vtu});
  ASSERT_EQ(back.blocks.size(), 1u);
  EXPECT_EQ(std::get<UnstructuredMesh>(back.blocks[0].grid), std::get<UnstructuredMesh>(read.blocks[0].grid));
  for (const Field& f : read.blocks[0].fields) {
    const Field* g = back.blocks[0].fields.find(f.name());
    ASSERT_NE(g, nullptr) << f.name();
    EXPECT_EQ(g->data(), f.data()) << f.name();
  }
}

// One hexagonal prism (not a native shape) as NGON/NFACE: decomposed, with a cell-centred value on every piece.
TEST(CgnsReader, GeneralPolyhedronIsDecomposed) {
  ScratchDir dir;
  const std::string path = dir.file("prism.cgns");
  int fn = 0, B = 0, Z = 0, S = 0;
  CG(cg_open(path.c_str(), CG_MODE_WRITE, &fn));
  CG(cg_base_write(fn, "Base", 3, 3, &B));
  cgsize_t size[3] = {12, 1, 0};
  CG(cg_zone_write(fn, B, "Prism", size, Unstructured, &Z));
  std::vector<double> xyz[3];
  for (int layer = 0; layer < 2; ++layer)
    for (int i = 0; i < 6; ++i) {
      xyz[0].push_back(std::cos(i * M_PI / 3));
      xyz[1].push_back(std::sin(i * M_PI / 3));
      xyz[2].push_back(layer);
    }
  int C = 0;
  CG(cg_coord_write(fn, B, Z, RealDouble, "CoordinateX", xyz[0].data(), &C));
  CG(cg_coord_write(fn, B, Z, RealDouble, "CoordinateY", xyz[1].data(), &C));
  CG(cg_coord_write(fn, B, Z, RealDouble, "CoordinateZ", xyz[2].data(), &C));
  std::vector<cgsize_t> faces{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}, offsets{0, 6, 12};
  for (cgsize_t i = 0; i < 6; ++i) {
    const cgsize_t a = i + 1, b = (i + 1) % 6 + 1;
    faces.insert(faces.end(), {a, b, b + 6, a + 6});
    offsets.push_back(offsets.back() + 4);
  }
  std::vector<cgsize_t> cell{2, 3, 4, 5, 6, 7, 8, 9}, cell_offsets{0, 8};
  CG(cg_poly_section_write(fn, B, Z, "Cell", NFACE_n, 1, 1, 0, cell.data(), cell_offsets.data(), &S));
  CG(cg_poly_section_write(fn, B, Z, "Faces", NGON_n, 2, 9, 0, faces.data(), offsets.data(), &S));
  int sol = 0, F = 0;
  CG(cg_sol_write(fn, B, Z, "Sol", CellCenter, &sol));
  double value = 4.5;
  CG(cg_field_write(fn, B, Z, sol, RealDouble, "T", &value, &F));
  CG(cg_close(fn));

  const Dataset read = read_dataset(std::vector<std::string>{path});
  const auto& m = std::get<UnstructuredMesh>(read.blocks[0].grid);
  EXPECT_EQ(m.cell_count(), 18u);   // 6 pyramids on the sides, 6 tetrahedra on each hexagon
  EXPECT_EQ(m.point_count(), 15u);  // + cell centre + two face centres
  double volume = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) volume += cell_volume(m, c);
  EXPECT_NEAR(volume, 3 * std::sqrt(3.0) / 2, 1e-6);
  const Field* t = read.blocks[0].fields.find("T");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->tuples(), 18u);
  EXPECT_EQ(t->range().min, 4.5);
  EXPECT_EQ(t->range().max, 4.5);
}

// A structured zone with a rind layer on its solution and two solutions named by iterative data (time steps).
TEST(CgnsReader, RindIsCutAndIterativeDataPicksTheStep) {
  ScratchDir dir;
  const std::string path = dir.file("steps.cgns");
  int fn = 0, B = 0, Z = 0, C = 0;
  CG(cg_open(path.c_str(), CG_MODE_WRITE, &fn));
  CG(cg_base_write(fn, "Base", 3, 3, &B));
  cgsize_t size[9] = {3, 3, 3, 2, 2, 2, 0, 0, 0};
  CG(cg_zone_write(fn, B, "Box", size, Structured, &Z));
  std::vector<double> x, y, z;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        x.push_back(i);
        y.push_back(j);
        z.push_back(k);
      }
  CG(cg_coord_write(fn, B, Z, RealDouble, "CoordinateX", x.data(), &C));
  CG(cg_coord_write(fn, B, Z, RealDouble, "CoordinateY", y.data(), &C));
  CG(cg_coord_write(fn, B, Z, RealDouble, "CoordinateZ", z.data(), &C));
  for (int step = 0; step < 2; ++step) {
    int sol = 0;
    const std::string name = "Step" + std::to_string(step);
    CG(cg_sol_write(fn, B, Z, name.c_str(), CellCenter, &sol));
    // One rind cell on each side of every direction: 4 x 4 x 4 values, the core 2 x 2 x 2 in the middle.
    CG(cg_goto(fn, B, "Zone_t", Z, "FlowSolution_t", sol, "end"));
    int rind[6] = {1, 1, 1, 1, 1, 1};
    CG(cg_rind_write(rind));
    std::vector<double> v;
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
          const bool core = i >= 1 && i <= 2 && j >= 1 && j <= 2 && k >= 1 && k <= 2;
          v.push_back(core ? 100 * step + (i - 1) + 2 * (j - 1) + 4 * (k - 1) : -1);
        }
    int F = 0;
    CG(cg_field_write(fn, B, Z, sol, RealDouble, "Q", v.data(), &F));
  }
  CG(cg_ziter_write(fn, B, Z, "ZoneIterativeData"));
  CG(cg_goto(fn, B, "Zone_t", Z, "ZoneIterativeData_t", 1, "end"));
  char pointers[64];
  std::fill(pointers, pointers + 64, ' ');
  std::copy_n("Step0", 5, pointers);
  std::copy_n("Step1", 5, pointers + 32);
  cgsize_t dims[2] = {32, 2};
  CG(cg_array_write("FlowSolutionPointers", Character, 2, dims, pointers));
  int BI = 0;
  (void)BI;
  CG(cg_biter_write(fn, B, "BaseIterativeData", 2));
  CG(cg_close(fn));

  for (int64_t step : {int64_t(0), int64_t(1), int64_t(-1)}) {
    ReadOptions options;
    options.time_step = step;
    const Dataset ds = read_dataset(std::vector<std::string>{path}, options);
    const Field* q = ds.blocks[0].fields.find("Q");
    ASSERT_NE(q, nullptr);
    ASSERT_EQ(q->tuples(), 8u);
    const double base = step == 0 ? 0 : 100;
    for (uint64_t t = 0; t < 8; ++t) EXPECT_EQ(q->scalar(t, 0), base + double(t)) << step << " " << t;
  }
  ReadOptions too_far;
  too_far.time_step = 2;
  EXPECT_THROW(read_dataset(std::vector<std::string>{path}, too_far), Error);
}

TEST(CgnsReader, BrokenFilesAreNamed) {
  ScratchDir dir;
  const Dataset ds = small_mixed_mesh();
  const std::string good = dir.file("good.cgns");
  write_unstructured(good, ds, Layout::PerType, CG_FILE_ADF);
  // Truncated to half: libcgns cannot read it; the message names the file.
  const std::string cut = dir.file("cut.cgns");
  std::filesystem::copy_file(good, cut);
  std::filesystem::resize_file(cut, std::filesystem::file_size(good) / 2);
  try {
    read_dataset(std::vector<std::string>{cut});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.cgns"), std::string::npos) << e.what();
  }
}

// Files that are neither ADF nor HDF5 are refused before libcgns sees them: its ADF layer aborted the process on a
// 2-byte file (found by fuzz_cgns; fuzz/regression/fuzz_cgns). The header checks let the real formats through.
TEST(CgnsReader, FilesWithoutACgnsHeaderAreRefusedNotAborted) {
  ScratchDir dir;
  const auto refused = [&](const std::string& name, const std::string& bytes) {
    const std::string path = dir.file(name);
    std::ofstream(path, std::ios::binary) << bytes;
    try {
      read_dataset(std::vector<std::string>{path});
      ADD_FAILURE() << name << ": no error";
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(name), std::string::npos) << m;
      EXPECT_NE(m.find("not a CGNS file"), std::string::npos) << m;
    }
  };
  refused("two.cgns", "oo");
  refused("text.cgns", std::string(4096, 'x'));
  // The ADF magic in a file shorter than ADF's file header.
  refused("short.cgns", std::string("\xc0\xa8\xa3\xa9"
                                    "ADF Database Version A02011>",
                                    32));
  // Both formats still open.
  const Dataset ds = small_mixed_mesh();
  for (const int format : {CG_FILE_ADF, CG_FILE_HDF5}) {
    const std::string path = dir.file(format == CG_FILE_ADF ? "adf.cgns" : "hdf5.cgns");
    write_unstructured(path, ds, Layout::PerType, format);
    EXPECT_EQ(read_dataset(std::vector<std::string>{path}).cell_count(), ds.cell_count());
  }
}

// ---- Fields-only steps

using test::expect_same_bits;
using test::expect_whole_read;

// Adds `steps` FlowSolutions to zone 1 of the file open as `fn` (written by write_unstructured without fields) and the
// iterative data naming one per step (`pointer(k)`, default "Step<k>"): step k has a vertex field Q = k + i / 8 and a
// vector P (PX, PY, PZ), except step 1, at the cell centres (Q = 100 k + c / 4).
void add_steps(int fn, const UnstructuredMesh& mesh, int steps, const std::function<std::string(int)>& pointer = {}) {
  for (int k = 0; k < steps; ++k) {
    const bool cells = k == 1;
    const std::string name = "Step" + std::to_string(k);
    int sol = 0, F = 0;
    CG(cg_sol_write(fn, 1, 1, name.c_str(), cells ? CellCenter : Vertex, &sol));
    const size_t n = cells ? mesh.cell_count() : mesh.point_count();
    std::vector<double> q(n);
    for (size_t i = 0; i < n; ++i) q[i] = cells ? 100.0 * k + double(i) / 4 : k + double(i) / 8;
    CG(cg_field_write(fn, 1, 1, sol, RealDouble, "Q", q.data(), &F));
    if (cells) continue;
    for (const char* axis : {"PX", "PY", "PZ"}) {
      for (size_t i = 0; i < n; ++i) q[i] = double(axis[1]) * k - double(i);
      CG(cg_field_write(fn, 1, 1, sol, RealDouble, axis, q.data(), &F));
    }
  }
  CG(cg_ziter_write(fn, 1, 1, "ZoneIterativeData"));
  CG(cg_goto(fn, 1, "Zone_t", 1, "ZoneIterativeData_t", 1, "end"));
  std::vector<char> pointers(size_t(32 * steps), ' ');
  for (int k = 0; k < steps; ++k) {
    const std::string name = pointer ? pointer(k) : "Step" + std::to_string(k);
    std::copy(name.begin(), name.end(), pointers.begin() + 32 * k);
  }
  cgsize_t dims[2] = {32, steps};
  CG(cg_array_write("FlowSolutionPointers", Character, 2, dims, pointers.data()));
  CG(cg_biter_write(fn, 1, "BaseIterativeData", steps));
}

std::shared_ptr<const TimeSeries> series_of(const std::string& path) {
  return std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
}

Dataset mesh_without_fields() {
  Dataset ds = small_mixed_mesh();
  ds.blocks[0].fields = FieldSet{};
  return ds;
}

// ADF and HDF5, a MIXED section (a boundary section beside it skipped with a note) and polyhedra (NFACE_n: through the
// decomposition's expansion; not per-type sections: a section per run of one type is hundreds of nodes here, and
// libcgns took 200 ms to open such a file): each step's solution read alone equals the whole read bit for bit (vertex
// and cell fields, the vector grouped, the notes: the mesh's and the step's "time step k of 3"), and reads fewer bytes
// than it. Through the scene, switches swap the fields on the walk mesh built once.
TEST(CgnsSteps, StaticMeshStepsReadTheirSolutionAloneBitForBit) {
  ScratchDir dir;
  const Dataset ds = mesh_without_fields();
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  for (const int file_type : {CG_FILE_ADF, CG_FILE_HDF5}) {
    for (const Layout layout : {Layout::Mixed, Layout::Polyhedra}) {
      SCOPED_TRACE(std::to_string(file_type) + (layout == Layout::Mixed ? " mixed" : " polyhedra"));
      const std::string path = dir.file("steps.cgns");
      std::filesystem::remove(path);
      write_unstructured(path, ds, layout, file_type, [&](int fn) { add_steps(fn, mesh, 3); });
      const auto series = series_of(path);
      ASSERT_EQ(series->kind, SeriesKind::Cgns);
      ASSERT_EQ(series->size(), 3u);
      StepFieldReader reader(series);
      reader.read_whole(0);
      const auto k0 = reader.geometry_keys(0);
      ASSERT_TRUE(k0.has_value());
      EXPECT_EQ(reader.geometry_keys(2), k0);
      EXPECT_TRUE(reader.has_mesh_of(2, 0));
      for (size_t k : {2u, 1u, 0u}) expect_whole_read(*series, reader.read(k), k);
      EXPECT_NE(reader.read(0).blocks[0].find("P"), nullptr) << "PX, PY, PZ grouped";
      EXPECT_EQ(reader.read(1).blocks[0].find("Q")->association(), Association::Cell);
      if (test::bytes_read_so_far() != 0) {
        uint64_t before = test::bytes_read_so_far();
        reader.read(2);
        const uint64_t fields_only = test::bytes_read_so_far() - before;
        before = test::bytes_read_so_far();
        read_time_step(*series, 2);
        const uint64_t whole = test::bytes_read_so_far() - before;
        EXPECT_LT(fields_only, whole) << "no coordinates nor element sections";
      }
    }
  }
  const auto series = series_of(dir.file("steps.cgns"));
  ExactScene scene(series, 0);
  scene.bind("Q");
  for (uint32_t k : {2u, 0u}) {
    scene.set_step(k);
    ExactScene fresh(std::make_shared<const Dataset>(read_time_step(*series, k)));
    fresh.bind("Q");
    EXPECT_EQ(scene.engine.bound_values(), fresh.engine.bound_values()) << k;
  }
  EXPECT_EQ(scene.fields_only, 2u);
  EXPECT_EQ(scene.rebuilds, 0u);
}

// The shared 12-zone structured sample (cell-centred solutions, no iterative data: every solution read): the fields
// read on the kept layout equal the whole read's, zone by zone, and its notes in order.
TEST(CgnsSteps, TheTwelveZoneSampleReadOnItsLayoutEqualsTheWholeRead) {
  UGVR_REQUIRE_DATA("cgns-sqnz/sqnz_s.adf.cgns");
  std::shared_ptr<const CgnsLayout> layout;
  const Dataset whole = read_cgns(relative_data_path, -1, &layout);
  ASSERT_TRUE(cgns_layout_mesh_key(*layout).has_value());
  std::string format;
  std::vector<std::string> sources, notes;
  const std::vector<FieldSet> fields = read_cgns_fields(*layout, relative_data_path, -1, format, sources, notes);
  ASSERT_EQ(fields.size(), 12u);
  for (size_t b = 0; b < 12; ++b) expect_same_bits(fields[b], whole.blocks[b].fields);
  EXPECT_EQ(format, whole.format);
  EXPECT_EQ(sources, whole.sources);
  EXPECT_EQ(notes, whole.warnings);
}

// A zone with an ArbitraryGridMotion has no key: its steps are read whole (a pass over the values too). A pointer to a
// solution the zone lacks: the fields-only read fails with the whole read's error, and a switch to that step leaves
// the scene on its step.
TEST(CgnsSteps, AMovingGridIsReadWholeAndABadPointerIsTheWholeReadsError) {
  ScratchDir dir;
  const Dataset ds = mesh_without_fields();
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  const std::string moving = dir.file("moving.cgns");
  write_unstructured(moving, ds, Layout::Mixed, CG_FILE_HDF5, [&](int fn) {
    add_steps(fn, mesh, 2);
    int A = 0;
    CG(cg_arbitrary_motion_write(fn, 1, 1, "Motion", DeformingGrid, &A));
  });
  const auto series = series_of(moving);
  StepFieldReader reader(series);
  reader.read_whole(0);
  EXPECT_FALSE(reader.geometry_keys(1).has_value());
  EXPECT_FALSE(reader.has_mesh_of(1, 0));
  expect_whole_read(*series, reader.read_values(1, 0), 1);

  const std::string bad = dir.file("bad.cgns");
  write_unstructured(bad, ds, Layout::Mixed, CG_FILE_HDF5, [&](int fn) {
    add_steps(fn, mesh, 3, [](int k) { return k == 2 ? std::string("Missing") : "Step" + std::to_string(k); });
  });
  const auto bad_series = series_of(bad);
  StepFieldReader bad_reader(bad_series);
  bad_reader.read_whole(0);
  ASSERT_TRUE(bad_reader.has_mesh_of(2, 0));
  std::string whole;
  try {
    read_time_step(*bad_series, 2);
  } catch (const Error& e) {
    whole = e.what();
  }
  EXPECT_NE(whole.find("names 'Missing'"), std::string::npos) << whole;
  try {
    bad_reader.read(2);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), whole);
  }
  ExactScene scene(bad_series, 0);
  EXPECT_THROW(scene.set_step(2), Error);
  EXPECT_EQ(scene.step, 0u);
  scene.set_step(1);
  EXPECT_EQ(scene.fields_only, 1u);
}

}  // namespace
}  // namespace ugvr
