// ASCII mesh readers: AVS UCD (.inp), TetGen (.node/.ele), tetrahedral OFF and NASTRAN bulk data. Real files of
// ../shared/data when present (skipped otherwise), hand-written files of every variant, and malformed files that must
// fail with the file name and the line.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <functional>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

std::string write_file(const test::ScratchDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.file(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

using test::error_of;

const UnstructuredMesh& mesh_of(const Dataset& d) { return std::get<UnstructuredMesh>(d.blocks.at(0).grid); }

uint64_t inverted_cells(const UnstructuredMesh& m) {
  uint64_t n = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) n += cell_volume(m, c) <= 0;
  return n;
}

bool has_warning(const Dataset& d, std::string_view text) {
  for (const std::string& w : d.warnings) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

// Expects an error naming the file and `file:line`, and containing `text`.
void expect_error_at(const std::function<Dataset()>& read, const std::string& path, int line, std::string_view text) {
  const std::string e = error_of(read);
  EXPECT_NE(e.find(path + ":" + std::to_string(line) + ":"), std::string::npos) << e;
  EXPECT_NE(e.find(text), std::string::npos) << e;
}

// --- real data -------------------------------------------------------------------------------------------------

TEST(AvsUcdReal, Spx) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  const Dataset d = read_avs_ucd(relative_data_path);
  const UnstructuredMesh& m = mesh_of(d);
  EXPECT_EQ(m.point_count(), 2896u);
  EXPECT_EQ(m.cell_type_counts().tetra, 12936u);
  const Field* density = d.blocks[0].fields.find("density", Association::Vertex);
  ASSERT_NE(density, nullptr);
  EXPECT_EQ(density->data().type(), ScalarType::Float64);
  EXPECT_DOUBLE_EQ(density->range().min, 0.2);
  EXPECT_DOUBLE_EQ(density->range().max, 1.0);
  // AVS tets are turned the other way from VTK's: read in VTK order, all but a handful of bad cells of the file
  // (12 of them: 11 inverted, 1 degenerate) are positive.
  EXPECT_LE(inverted_cells(m), 12u);
  EXPECT_TRUE(has_warning(d, "negative volume"));
}

TEST(NastranReal, Z88Piston) {
  UGVR_REQUIRE_DATA("z88-piston-tets/b21_lin_g.nas");
  const Dataset d = read_nastran(relative_data_path);
  const UnstructuredMesh& m = mesh_of(d);
  EXPECT_EQ(m.point_count(), 57184u);
  EXPECT_EQ(m.cell_type_counts().tetra, 278577u);
  EXPECT_EQ(m.cell_count(), 278577u);
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_TRUE(has_warning(d, "4430 PLOAD4")) << (d.warnings.empty() ? "" : d.warnings[0]);
  const Field* pid = d.blocks[0].fields.find("PID", Association::Cell);
  ASSERT_NE(pid, nullptr);
  EXPECT_EQ(pid->data().type(), ScalarType::Int32);
  EXPECT_EQ(pid->range().max, 1.0);
}

TEST(CliInfoAscii, RealFiles) {
  for (const char* relative : {"spx/spx.inp", "z88-piston-tets/b21_lin_g.nas"}) {
    const std::string path = test::data_path(relative);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "dataset not found: " << path;
    FILE* p = popen((std::string(UGVR_BINARY) + " --quiet info --json " + path + " 2>&1").c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::string out;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    EXPECT_EQ(pclose(p), 0) << out;
    EXPECT_NE(out.find(relative[0] == 's' ? "12936" : "278577"), std::string::npos) << out;
  }
}

// --- AVS UCD ---------------------------------------------------------------------------------------------------

// A unit cube as one hexahedron in AVS order (first face turned away from the second), a pyramid on top (apex
// first) and a prism beside it, plus a triangle that is dropped; node data of a scalar and a 3-vector, cell data.
constexpr const char* kAvsMixed =
    "# comment\n"
    "11 4 4 1 0\n"
    "10 0 0 0\n11 1 0 0\n12 1 1 0\n13 0 1 0\n"
    "14 0 0 1\n15 1 0 1\n16 1 1 1\n17 0 1 1\n"
    "18 0.5 0.5 2\n19 2 0 0\n20 2 0 1\n"
    "1 3 hex 14 15 16 17 10 11 12 13\n"
    "2 4 pyr 18 14 15 16 17\n"
    "3 5 prism 11 12 19 15 16 20\n"
    "4 6 tri 10 11 12\n"
    "2 1 3\n"
    "temperature, K\n"
    "velocity, m/s\n"
    "10 1.5 1 2 3\n11 2.5 0 0 0\n12 0 0 0 0\n13 0 0 0 0\n14 0 0 0 0\n15 0 0 0 0\n"
    "16 0 0 0 0\n17 0 0 0 0\n18 9 0 0 0\n19 0 0 0 0\n20 0 0 0 0\n"
    "1 1\n"
    "pressure, Pa\n"
    "4 40\n3 30\n2 20\n1 10\n";

TEST(AvsUcd, MixedCellsAndData) {
  test::ScratchDir dir;
  const std::string path = write_file(dir, "mixed.inp", kAvsMixed);
  const Dataset d = read_avs_ucd(path);
  const UnstructuredMesh& m = mesh_of(d);
  EXPECT_EQ(m.point_count(), 11u);
  const CellTypeCounts counts = m.cell_type_counts();
  EXPECT_EQ(counts.hexahedron, 1u);
  EXPECT_EQ(counts.pyramid, 1u);
  EXPECT_EQ(counts.wedge, 1u);
  EXPECT_EQ(counts.total(), 3u);  // the triangle is dropped
  EXPECT_TRUE(has_warning(d, "lower-dimensional"));
  // Orderings converted to VTK's: every cell has positive volume.
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_FALSE(has_warning(d, "negative volume"));
  EXPECT_NEAR(cell_volume(m, 0), 1.0, 1e-6);
  EXPECT_NEAR(cell_volume(m, 1), 1.0 / 3.0, 1e-6);
  EXPECT_NEAR(cell_volume(m, 2), 0.5, 1e-6);
  // Apex of the pyramid moved last.
  EXPECT_EQ(m.cell(1)[4], 8u);
  const FieldSet& f = d.blocks[0].fields;
  const Field* t = f.find("temperature", Association::Vertex);
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->data().get(0, 0), 1.5);
  EXPECT_EQ(t->data().get(8, 0), 9.0);
  const Field* v = f.find("velocity", Association::Vertex);
  ASSERT_NE(v, nullptr);
  EXPECT_EQ(v->components(), 3);
  EXPECT_EQ(v->data().get(0, 2), 3.0);
  // Cell data follows the kept cells, whatever order the data lines come in.
  const Field* p = f.find("pressure", Association::Cell);
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(p->tuples(), 3u);
  EXPECT_EQ(p->data().get(0, 0), 10.0);
  EXPECT_EQ(p->data().get(2, 0), 30.0);
  const Field* mat = f.find("material", Association::Cell);
  ASSERT_NE(mat, nullptr);
  EXPECT_EQ(mat->data().get(1, 0), 4.0);
}

TEST(AvsUcd, Malformed) {
  test::ScratchDir dir;
  struct Case {
    std::string text;
    int line;
    std::string message;
  };
  const std::string nodes = "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  const std::vector<Case> cases = {
      {"4 1 0 0 0\n" + nodes + "1 1 tet 1 2 3 9\n", 6, "undefined node 9"},
      {"4 1 0 0 0\n" + nodes + "1 1 tet 1 2 3\n", 7, "unexpected end of file"},
      {"4 1 0 0 0\n" + nodes + "1 1 tet 1 2 3 4 4\n", 6, "more than 4 node ids"},
      {"4 1 0 0 0\n" + nodes + "1 1 hexa 1 2 3 4\n", 6, "unknown cell type 'hexa'"},
      {"2 0 0 0 0\n1 0 0 0\n2 1 x 0\n", 3, "found 'x'"},
      {"2 0 0 0 0\n1 0 0 0\n1 1 0 0\n", 3, "defined twice"},
      {"4 1 1 0 0\n" + nodes + "1 1 tet 1 2 3 4\n2 1 1\na,\nb,\n", 7, "components for 1 values"},
      {"4 1 1 0 0\n" + nodes + "1 1 tet 1 2 3 4\n1 1\na,\n1 0\n2 0\n3 0\n7 0\n", 12, "undefined node 7"},
      {"3\ndata\n", 1, "multi-step"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = write_file(dir, "bad" + std::to_string(i) + ".inp", cases[i].text);
    expect_error_at([&] { return read_avs_ucd(path); }, path, cases[i].line, cases[i].message);
  }
  // Absurd counts fail before anything is allocated.
  const std::string huge = write_file(dir, "huge.inp", "4000000000 1 0 0 0\n1 0 0 0\n");
  EXPECT_NE(error_of([&] { return read_avs_ucd(huge); }).find("bytes remain"), std::string::npos);
  const std::string binary = write_file(dir, "binary.inp", std::string("\x07\x00\x00\x00", 4));
  EXPECT_NE(error_of([&] { return read_avs_ucd(binary); }).find("binary AVS UCD"), std::string::npos);
}

// --- TetGen ----------------------------------------------------------------------------------------------------

TEST(TetGen, OneBasedWithAttributesAndComments) {
  test::ScratchDir dir;
  // Tets listed with the vertex order opposite to VTK's: the reader turns them.
  write_file(dir, "m.node",
             "# a cube corner\n5 3 1 1\n1 0 0 0 10 1\n2 1 0 0 20 1\n3 0 1 0 30 0  # inner\n4 0 0 1 40 1\n"
             "5 1 1 1 50 0\n");
  const std::string ele = write_file(dir, "m.ele", "2 4 1\n1 1 3 2 4 7\n2 2 4 3 5 8 # second\n");
  const Dataset d = read_tetgen(ele);
  const UnstructuredMesh& m = mesh_of(d);
  EXPECT_EQ(m.point_count(), 5u);
  EXPECT_EQ(m.cell_count(), 2u);
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_NE(d.format.find("1-based"), std::string::npos) << d.format;
  EXPECT_NE(d.format.find("reoriented"), std::string::npos) << d.format;
  EXPECT_EQ(d.sources.size(), 2u);
  const Field* a = d.blocks[0].fields.find("attribute_0", Association::Vertex);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->data().type(), ScalarType::Float64);
  EXPECT_EQ(a->data().get(4, 0), 50.0);
  const Field* marker = d.blocks[0].fields.find("boundary_marker", Association::Vertex);
  ASSERT_NE(marker, nullptr);
  EXPECT_EQ(marker->data().get(2, 0), 0.0);
  const Field* region = d.blocks[0].fields.find("attribute_0", Association::Cell);
  ASSERT_NE(region, nullptr);
  EXPECT_EQ(region->data().get(1, 0), 8.0);
  // The .node path works the same.
  EXPECT_EQ(mesh_of(read_tetgen(dir.file("m.node"))).cell_count(), 2u);
}

TEST(TetGen, ZeroBasedTet10InVtkOrder) {
  test::ScratchDir dir;
  write_file(dir, "q.node",
             "10 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 .5 0 0\n5 .5 .5 0\n6 0 .5 0\n"
             "7 0 0 .5\n8 .5 0 .5\n9 0 .5 .5\n");
  const std::string node = dir.file("q.node");
  write_file(dir, "q.ele", "1 10 0\n0 0 1 2 3 4 5 6 7 8 9\n");
  const Dataset d = read_tetgen(node);
  const UnstructuredMesh& m = mesh_of(d);
  ASSERT_EQ(m.cell_count(), 1u);
  EXPECT_EQ(m.cell(0).size(), 4u);
  EXPECT_NEAR(cell_volume(m, 0), 1.0 / 6.0, 1e-6);
  EXPECT_EQ(d.format.find("reoriented"), std::string::npos) << d.format;
}

TEST(TetGen, Malformed) {
  test::ScratchDir dir;
  const std::string nodes = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  struct Case {
    std::string node, ele;
    bool ele_error;
    int line;
    std::string message;
  };
  const std::vector<Case> cases = {
      {nodes, "1 4 0\n1 1 2 3 5\n", true, 2, "outside the .node file's ids [1, 4]"},
      {nodes, "1 5 0\n", true, 1, "must be 4 or 10"},
      {nodes, "1 4 0\n1 1 2 3          \n", true, 3, "unexpected end of file"},
      {"4 2 0 0\n", "1 4 0\n", false, 1, "only 3-D"},
      {"2 3 0 0\n1 0 0 0\n3 1 0 0\n", "", false, 3, "out of sequence"},
      {"2 3 0 0\n1 0 0 0\n2 1 0 zz\n", "", false, 3, "found 'zz'"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string base = "bad" + std::to_string(i);
    const std::string node = write_file(dir, base + ".node", cases[i].node);
    const std::string ele = write_file(dir, base + ".ele", cases[i].ele);
    expect_error_at([&] { return read_tetgen(node); }, cases[i].ele_error ? ele : node, cases[i].line,
                    cases[i].message);
  }
  const std::string lone = write_file(dir, "lone.node", nodes);
  EXPECT_NE(error_of([&] { return read_tetgen(lone); }).find("lone.ele"), std::string::npos);
  const std::string huge = write_file(dir, "huge.node", "999999999 3 0 0\n");
  write_file(dir, "huge.ele", "1 4 0\n");
  EXPECT_NE(error_of([&] { return read_tetgen(huge); }).find("bytes remain"), std::string::npos);
}

// --- tetrahedral OFF -------------------------------------------------------------------------------------------

const char* const kOffPoints = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";

TEST(OffTets, HavsVariant) {
  test::ScratchDir dir;
  const std::string path = write_file(dir, "havs.off",
                                      "5 2\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n1 1 1 5\n"
                                      "0 1 2 3\n1 2 3 4\n");
  const Dataset d = read_off_tets(path);
  const UnstructuredMesh& m = mesh_of(d);
  EXPECT_EQ(m.point_count(), 5u);
  EXPECT_EQ(m.cell_count(), 2u);
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_NE(d.format.find("x y z scalar per point"), std::string::npos) << d.format;
  const Field* s = d.blocks[0].fields.find("scalar", Association::Vertex);
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->range().min, 1.0);
  EXPECT_EQ(s->range().max, 5.0);
}

TEST(OffTets, KeywordPrefixedAndCellScalars) {
  test::ScratchDir dir;
  const std::string a =
      write_file(dir, "a.off", std::string("OFF\n4 1 0\n") + "0 0 0 7\n1 0 0 7\n0 1 0 7\n0 0 1 7\n" + "4 0 2 1 3\n");
  const Dataset da = read_off_tets(a);
  EXPECT_NE(da.format.find("OFF keyword"), std::string::npos) << da.format;
  EXPECT_NE(da.format.find("4 a b c d"), std::string::npos) << da.format;
  EXPECT_NE(da.format.find("reoriented"), std::string::npos) << da.format;
  EXPECT_EQ(inverted_cells(mesh_of(da)), 0u);

  const std::string b = write_file(dir, "b.off", std::string("4 1\n") + kOffPoints + "0 1 2 3 0.5\n");
  const Dataset db = read_off_tets(b);
  const Field* s = db.blocks[0].fields.find("scalar", Association::Cell);
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->data().get(0, 0), 0.5);

  const std::string c = write_file(dir, "c.off", std::string("4 1\n") + kOffPoints + "0 1 2 3\n1 2 3 4\n");
  const Dataset dc = read_off_tets(c);
  EXPECT_NE(dc.format.find("point scalars after"), std::string::npos) << dc.format;
  EXPECT_EQ(dc.blocks[0].fields.find("scalar", Association::Vertex)->data().get(3, 0), 4.0);
}

TEST(OffTets, AmbiguousAndMalformed) {
  test::ScratchDir dir;
  struct Case {
    std::string text;
    int line;
    std::string message;
  };
  const std::string p = kOffPoints;
  const std::vector<Case> cases = {
      {"4 1\n" + p + "4 0 1 2 3\n", 6, "ambiguous"},
      {"4 1\n" + p + "0 1 2 4\n", 6, "outside [0, 4)"},
      {"4 1\n0 0 0\n1 0 0 5\n", 3, "more than 3 values"},
      {"4 1\n0 0 0 1\n1 0\n", 3, "expected 4 values"},
      {"4 2\n" + p + "0 1 2 3\n", 7, "unexpected end of file"},
      {"4 1\n" + p + "0 1 2 3\n1 2\n", 8, "unexpected end of file"},
      {"4 1 3\n", 1, "third count must be 0"},
      {"x 1\n", 1, "expected the counts"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    // Padding at the end of the last line keeps the counts plausible for the bytes left, so the intended error is
    // reached.
    std::string text = cases[i].text;
    text.insert(text.rfind('\n'), std::string(40, ' '));
    const std::string path = write_file(dir, "bad" + std::to_string(i) + ".off", text);
    expect_error_at([&] { return read_off_tets(path); }, path, cases[i].line, cases[i].message);
  }
  const std::string huge = write_file(dir, "huge.off", "4000000000 1\n");
  EXPECT_NE(error_of([&] { return read_off_tets(huge); }).find("bytes remain"), std::string::npos);
}

// --- NASTRAN ---------------------------------------------------------------------------------------------------

// A fixed-format line: the name in 8 columns, then the fields right-aligned in `width` columns.
std::string fixed(const std::string& name, const std::vector<std::string>& fields, size_t width) {
  std::string line = name + std::string(8 - name.size(), ' ');
  for (const std::string& f : fields) line += std::string(width - f.size(), ' ') + f;
  return line + "\n";
}

TEST(Nastran, FreeSmallAndLargeFields) {
  test::ScratchDir dir;
  // Unit-cube hexahedron from small-field, large-field and free-field GRIDs (ids arbitrary), a 10-node CTETRA with a
  // continuation, a CPENTA and a CPYRAM, NASTRAN's exponent-less reals, and cards to ignore.
  const std::string text = std::string("SOL 101\nCEND\n  SPC = 1\nBEGIN BULK\n$ comment\n") +
                           fixed("GRID", {"101", "0", "0.", "0.", "0."}, 8) +
                           fixed("GRID", {"102", "", "1.", "0.", "0."}, 8) +
                           fixed("GRID*", {"103", "0", "1.0", "1.0"}, 16) + fixed("*", {"0."}, 16) +
                           "GRID,104,,0.,1.,0.\n"
                           "GRID,105,0,0.,0.,1.0+0\n"
                           "GRID,106,0,1.,0.,10.-1\n"
                           "GRID,107,0,1.0,1.0,1.\n"
                           "GRID,108,0,0.,1.0,1.E0\n"
                           "GRID,109,0,0.5,0.5,2.\n"
                           "GRID,110,0,2.,0.,0.\n"
                           "GRID,111,0,2.,0.,1.\n"
                           "CHEXA,1,7,101,102,103,104,105,106,\n"
                           "+,107,108\n" +
                           fixed("CPYRAM", {"2", "8", "105", "106", "107", "108", "109"}, 8) +
                           "CPENTA,3,9,102,110,103,106,111,107\n"
                           "CTETRA,4,9,101,102,104,105,,,\n"
                           ",,,,\n"
                           "MAT1,1,73000.,,0.33\nPLOAD4,1,2,5.\nPLOAD4,1,3,5.\n"
                           "ENDDATA\n"
                           "GRID,999,0,x,y,z\n";
  const std::string path = write_file(dir, "cube.bdf", text);
  const Dataset d = read_nastran(path);
  const UnstructuredMesh& m = mesh_of(d);
  EXPECT_EQ(m.point_count(), 11u);
  const CellTypeCounts counts = m.cell_type_counts();
  EXPECT_EQ(counts.hexahedron, 1u);
  EXPECT_EQ(counts.pyramid, 1u);
  EXPECT_EQ(counts.wedge, 1u);
  EXPECT_EQ(counts.tetra, 1u);
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_NEAR(cell_volume(m, 0), 1.0, 1e-6);
  EXPECT_NEAR(m.points[5][2], 1.0f, 1e-6f);  // "10.-1"
  EXPECT_NEAR(m.points[2][1], 1.0f, 1e-6f);  // large field
  const Field* pid = d.blocks[0].fields.find("PID", Association::Cell);
  ASSERT_NE(pid, nullptr);
  EXPECT_EQ(pid->data().get(0, 0), 7.0);
  EXPECT_EQ(pid->data().get(3, 0), 9.0);
  EXPECT_TRUE(has_warning(d, "ignored 3 other card(s): 2 PLOAD4, 1 MAT1")) << d.warnings.at(0);
}

TEST(Nastran, QuadraticTetAndCoordinateSystem) {
  test::ScratchDir dir;
  // System 5: origin (10,0,0), z along basic x, xz plane through basic y: local (x,y,z) -> basic (10+z, x, y).
  const std::string text =
      "CORD2R,5,0,10.,0.,0.,11.,0.,0.,\n,10.,1.,0.\n"
      "GRID,1,5,0.,0.,0.\nGRID,2,5,1.,0.,0.\nGRID,3,5,0.,1.,0.\nGRID,4,5,0.,0.,1.\n"
      "GRID,5,,.5,0.,0.\nGRID,6,,.5,.5,0.\nGRID,7,,0.,.5,0.\nGRID,8,,0.,0.,.5\nGRID,9,,.5,0.,.5\nGRID,10,,0.,.5,.5\n"
      "CTETRA,1,3,1,2,3,4,5,6,\n,7,8,9,10\n";
  const std::string path = write_file(dir, "tet10.nas", text);
  const Dataset d = read_nastran(path);
  const UnstructuredMesh& m = mesh_of(d);
  ASSERT_EQ(m.cell_count(), 1u);
  EXPECT_EQ(m.cell(0).size(), 4u);
  EXPECT_NEAR(m.points[1][0], 10.f, 1e-5f);
  EXPECT_NEAR(m.points[1][1], 1.f, 1e-5f);
  EXPECT_NEAR(m.points[3][0], 11.f, 1e-5f);
  EXPECT_NEAR(m.points[2][2], 1.f, 1e-5f);
  EXPECT_GT(cell_volume(m, 0), 0.0);
}

TEST(Nastran, Malformed) {
  test::ScratchDir dir;
  struct Case {
    std::string text;
    int line;
    std::string message;
  };
  const std::string grids = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\nGRID,4,,0.,0.,1.\n";
  const std::vector<Case> cases = {
      {grids + "CTETRA,1,1,1,2,3,9\n", 5, "GRID 9, which is not defined"},
      {grids + "CTETRA,1,1,1,2,3\n", 5, "lists 3 grid points, expected 4 to 10"},
      {grids + "CHEXA,1,1,1,2,3,4\n", 5, "expected 8 to 20"},
      {"GRID,1,,0.,abc,0.\n", 1, "found 'abc'"},
      {"GRID,1,,0.,0.,0.\nGRID,1,,0.,0.,0.\n", 2, "defined twice"},
      {"GRID,x,,0.,0.,0.\n", 1, "expected an integer for the grid id"},
      {"GRID,1,3,0.,0.,0.\nCTETRA,1,1,1,1,1,1\n", 1, "coordinate system 3"},
      {grids + "CTETRA,1,1,1,2,,4\n", 5, "missing a grid point id"},
      // An edge node (dropped by linearisation) must still be a defined GRID (issue 23).
      {grids + "CTETRA,1,1,1,2,3,4,99\n", 5, "GRID 99 (an edge node), which is not defined"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(cases[i].text);
    const std::string path = write_file(dir, "bad" + std::to_string(i) + ".nas", cases[i].text);
    expect_error_at([&] { return read_nastran(path); }, path, cases[i].line, cases[i].message);
  }
  const std::string shells = write_file(dir, "shell.nas", grids + "CTRIA3,1,1,1,2,3\n");
  EXPECT_NE(error_of([&] { return read_nastran(shells); }).find("no solid elements"), std::string::npos);
}

}  // namespace
}  // namespace ugvr
