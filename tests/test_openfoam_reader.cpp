// The OpenFOAM reader on the cases of tests/data/openfoam (made by make_fixtures.sh with Debian's OpenFOAM v1912):
// counts against VTK 9.1's vtkPOpenFOAMReader (bench/compare_vtk_counts_openfoam.py), ascii = binary = gzip,
// decomposed = reconstructed, time directories, cell zones, the polyhedral (polyDualMesh) case rendered by the exact
// engine against the oracle and by the LOD engine, and the round trip through .vtu. The streaming FoamFile: every
// fixture and a set of damaged files parse alike through a tiny window (every token, comment and binary value crosses
// a refill) and the default one, and the window stays within its bound on ~20 MB files.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "oracle/reference_renderer.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/openfoam_reader.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/exact/exact_engine.h"

namespace ugvr {
namespace {

std::string case_path(const std::string& name) { return std::string(UGVR_SOURCE_DIR) + "/tests/data/openfoam/" + name; }

Dataset read_case(const std::string& name, int64_t time_step = -1) {
  ReadOptions options;
  options.time_step = time_step;
  return read_dataset(std::vector<std::string>{case_path(name)}, options);
}

const UnstructuredMesh& mesh_of(const Dataset& ds) {
  EXPECT_EQ(ds.blocks.size(), 1u);
  return std::get<UnstructuredMesh>(ds.blocks.at(0).grid);
}

bool has_note(const Dataset& ds, std::string_view text) {
  return std::any_of(ds.warnings.begin(), ds.warnings.end(),
                     [&](const std::string& w) { return w.find(text) != std::string::npos; });
}

// What VTK 9.1's vtkPOpenFOAMReader reports for the internal mesh (bench/compare_vtk_counts_openfoam.py: CaseType
// reconstructed, or decomposed for cavity_decomposed, ReadZones on, CreateCellToPoint off). Decompose polyhedra
// makes no difference on the cavity cases (all hexahedra). For "dual" it does: off, VTK reports 692 points and 343
// cells (187 hexahedra, 156 polyhedra); on, 848 points (a centre per polyhedron) and 1579 cells (187 hexahedra,
// 1080 pyramids, 312 tetrahedra).
struct VtkCounts {
  const char* name;
  uint64_t points, cells;
};
constexpr std::array<VtkCounts, 5> kVtkCavity{{{"cavity", 882, 400},
                                               {"cavity_binary", 882, 400},
                                               {"cavity_gzip", 882, 400},
                                               {"cavity_ascii_gz", 882, 400},
                                               {"cavity_decomposed", 924, 400}}};

TEST(OpenFoamReader, CavityCountsMatchVtk) {
  for (const VtkCounts& v : kVtkCavity) {
    SCOPED_TRACE(v.name);
    const Dataset ds = read_case(v.name);
    const UnstructuredMesh& m = mesh_of(ds);
    EXPECT_EQ(m.point_count(), v.points);
    EXPECT_EQ(m.cell_count(), v.cells);
    EXPECT_EQ(m.cell_type_counts().hexahedron, v.cells);
    EXPECT_EQ(count_inverted_cells(m), 0u);
    // VTK's cell arrays at the latest time: U and p; ours add the cell zone.
    const Block& b = ds.blocks[0];
    ASSERT_NE(b.fields.find("p", Association::Cell), nullptr);
    ASSERT_NE(b.fields.find("U", Association::Cell), nullptr);
    EXPECT_EQ(b.fields.find("U", Association::Cell)->components(), 3);
    EXPECT_TRUE(has_note(ds, "time directories (4): 0 0.1 0.2 0.3; read 0.3 (--time-step 3)"));
  }
}

TEST(OpenFoamReader, DualMeshCountsRelateToVtk) {
  const Dataset ds = read_case("dual");
  const UnstructuredMesh& m = mesh_of(ds);
  // VTK (decompose polyhedra off): 343 cells, 187 of them hexahedra, 692 points. Every input cell is a polyhedron
  // here; the decomposer keeps the 187 hexahedral ones (VTK's count) and splits the other 156.
  EXPECT_TRUE(has_note(ds, "343 polyhedra: 187 with a native shape")) << testing::PrintToString(ds.warnings);
  const CellTypeCounts t = m.cell_type_counts();
  EXPECT_EQ(t.hexahedron, 187u);
  EXPECT_EQ(t.wedge, 0u);
  // VTK (decompose polyhedra on) adds one point per polyhedron (848 = 692 + 156) and splits each face into
  // triangles/quads around it; ours adds the same cell centres plus one centre per face of 5+ vertices, shared by
  // the two cells on it, so its point count is at least VTK's.
  EXPECT_GE(m.point_count(), 848u);
  EXPECT_GT(t.pyramid + t.tetra, 0u);
  EXPECT_EQ(count_inverted_cells(m), 0u);
  // The cells' volumes add up to the box's (0.1^3): nothing lost or doubled by the decomposition.
  double volume = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) volume += cell_volume(m, c);
  EXPECT_NEAR(volume, 1e-3, 1e-9);
  const Field* p = ds.blocks[0].fields.find("p", Association::Cell);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->tuples(), m.cell_count());
  EXPECT_GT(p->range().max - p->range().min, 0);
}

// Largest difference between two fields of the same shape, relative to the value.
double max_relative_difference(const Field& a, const Field& b) {
  EXPECT_EQ(a.tuples(), b.tuples());
  EXPECT_EQ(a.components(), b.components());
  double worst = 0;
  for (uint64_t i = 0; i < std::min(a.tuples(), b.tuples()); ++i)
    for (int c = 0; c < a.components(); ++c) {
      const double x = a.data().get(i, c), y = b.data().get(i, c);
      worst = std::max(worst, std::abs(x - y) / std::max(std::abs(x), 1e-300));
    }
  return worst;
}

// ascii, binary, gzip-compressed binary and gzip-compressed ascii hold the same mesh and fields. gzip changes
// nothing (bit for bit); binary holds the doubles OpenFOAM parsed from the ascii text, which differ from ours in the
// last bit for one value of 0.3/p (0.0605441: OpenFOAM's parser rounds it one ulp off; ours is correctly rounded).
TEST(OpenFoamReader, AsciiBinaryAndGzipAgree) {
  const Dataset ascii = read_case("cavity");
  EXPECT_EQ(ascii.format, "OpenFOAM case (ascii)");
  EXPECT_EQ(read_case("cavity_binary").format, "OpenFOAM case (binary)");
  for (int64_t step = 0; step < 4; ++step) {
    SCOPED_TRACE(step);
    const Dataset a = read_case("cavity", step), agz = read_case("cavity_ascii_gz", step);
    const Dataset b = read_case("cavity_binary", step), bgz = read_case("cavity_gzip", step);
    EXPECT_EQ(mesh_of(agz), mesh_of(a));
    EXPECT_EQ(mesh_of(b), mesh_of(a));
    EXPECT_EQ(mesh_of(bgz), mesh_of(a));
    EXPECT_TRUE(agz.blocks[0].fields == a.blocks[0].fields);
    EXPECT_TRUE(bgz.blocks[0].fields == b.blocks[0].fields);
    ASSERT_EQ(b.blocks[0].fields.size(), a.blocks[0].fields.size());
    for (size_t i = 0; i < a.blocks[0].fields.size(); ++i)
      EXPECT_LE(max_relative_difference(b.blocks[0].fields[i], a.blocks[0].fields[i]), 1e-15)
          << a.blocks[0].fields[i].name();
  }
}

// The values of a field as a sorted list of tuples (order-free comparison between decompositions).
std::vector<std::vector<double>> tuples_sorted(const Field& f) {
  std::vector<std::vector<double>> out(f.tuples());
  for (uint64_t i = 0; i < f.tuples(); ++i)
    for (int c = 0; c < f.components(); ++c) out[i].push_back(f.data().get(i, c));
  std::sort(out.begin(), out.end());
  return out;
}

TEST(OpenFoamReader, DecomposedEqualsReconstructed) {
  const Dataset whole = read_case("cavity");
  const Dataset parts = read_case("cavity_decomposed");
  EXPECT_EQ(parts.format, "OpenFOAM case (ascii, decomposed)");
  EXPECT_TRUE(has_note(parts, "2 processor directories read as pieces"));
  EXPECT_EQ(mesh_of(parts).cell_count(), mesh_of(whole).cell_count());
  // The mesh covers the same box, and the processor boundary's points appear twice (924 = 882 + 42).
  EXPECT_EQ(parts.bounds().lo, whole.bounds().lo);
  EXPECT_EQ(parts.bounds().hi, whole.bounds().hi);
  for (int64_t step : {0, 3}) {
    const Dataset whole_step = read_case("cavity", step), parts_step = read_case("cavity_decomposed", step);
    for (const char* name : {"p", "U", "cellZone"}) {
      SCOPED_TRACE(std::string(name) + " step " + std::to_string(step));
      const Field* a = whole_step.blocks[0].fields.find(name, Association::Cell);
      const Field* b = parts_step.blocks[0].fields.find(name, Association::Cell);
      ASSERT_TRUE(a && b);
      EXPECT_EQ(tuples_sorted(*a), tuples_sorted(*b));
    }
  }
}

TEST(OpenFoamReader, TimeDirectoriesAreSteps) {
  // 0 holds uniform fields (p = 0 everywhere); 0.1, 0.2, 0.3 the solution, different at each step.
  const Field p0 = *read_case("cavity", 0).blocks[0].fields.find("p", Association::Cell);
  EXPECT_EQ(p0.range().min, 0);
  EXPECT_EQ(p0.range().max, 0);
  std::vector<Field> p;
  for (int64_t step = 1; step <= 3; ++step) {
    const Dataset ds = read_case("cavity", step);
    p.push_back(*ds.blocks[0].fields.find("p", Association::Cell));
    EXPECT_GT(p.back().range().max - p.back().range().min, 0.1);
  }
  EXPECT_FALSE(p[0].data() == p[1].data());
  EXPECT_FALSE(p[1].data() == p[2].data());
  EXPECT_TRUE(read_case("cavity", -1).blocks[0].fields.find("p")->data() == p[2].data());
  const std::string e = test::error_of([] { read_case("cavity", 4); });
  EXPECT_NE(e.find("time step 4 does not exist: the case has 4 time directories (0..3): 0 0.1 0.2 0.3"),
            std::string::npos)
      << e;
  // phi (a surfaceScalarField: face data) is named as not read.
  EXPECT_TRUE(has_note(read_case("cavity", 1), "not read from 0.1: phi (surfaceScalarField)"));
}

TEST(OpenFoamReader, CellZoneIsACellField) {
  const Dataset ds = read_case("cavity");
  const Field* z = ds.blocks[0].fields.find("cellZone", Association::Cell);
  ASSERT_NE(z, nullptr);
  EXPECT_EQ(z->data().type(), ScalarType::Int32);
  // topoSet's box y >= 0.08 of the 0.1 m cavity: the top 4 of 20 rows, 80 cells in zone 0 ("lid").
  uint64_t in_zone = 0;
  for (uint64_t c = 0; c < z->tuples(); ++c) in_zone += z->data().get(c, 0) == 0;
  EXPECT_EQ(in_zone, 80u);
  EXPECT_EQ(z->range().min, -1);
  EXPECT_TRUE(has_note(ds, "0 = lid"));
}

// Fields the fixtures lack, written into a copy of the cavity case's 0.1 directory: a volTensorField (9 components,
// nonuniform), a volSymmTensorField (6, uniform) and a pointScalarField (vertex data, one value per point), ascii as
// OpenFOAM writes them. Each arrives with its association, its components and its values in order.
TEST(OpenFoamReader, TensorSymmTensorAndPointFieldsAreRead) {
  test::ScratchDir dir;
  const std::filesystem::path root = dir.file("cavity");
  std::filesystem::copy(case_path("cavity"), root, std::filesystem::copy_options::recursive);
  const auto header = [](const std::string& cls, const std::string& object) {
    return "FoamFile\n{\n    version     2.0;\n    format      ascii;\n    class       " + cls +
           ";\n    location    \"0.1\";\n    object      " + object + ";\n}\n\ndimensions      [0 0 0 0 0 0 0];\n\n";
  };
  std::string tensor = header("volTensorField", "T") + "internalField   nonuniform List<tensor> \n400\n(\n";
  for (int c = 0; c < 400; ++c) {
    tensor += "(";
    for (int k = 0; k < 9; ++k) tensor += std::to_string(10 * c + k) + (k < 8 ? " " : ")\n");
  }
  tensor += ")\n;\n\nboundaryField\n{\n    movingWall { type zeroGradient; }\n}\n";
  std::ofstream(root / "0.1" / "T") << tensor;
  std::ofstream(root / "0.1" / "S") << header("volSymmTensorField", "S")
                                    << "internalField   uniform (1 2 3 4 5 6);\n\nboundaryField\n{\n}\n";
  std::string point = header("pointScalarField", "pw") + "internalField   nonuniform List<scalar> \n882\n(\n";
  for (int i = 0; i < 882; ++i) point += std::to_string(0.5 * i) + "\n";
  point += ")\n;\n\nboundaryField\n{\n}\n";
  std::ofstream(root / "0.1" / "pw") << point;

  ReadOptions options;
  options.time_step = 1;  // 0.1
  const Dataset ds = read_dataset(std::vector<std::string>{root.string()}, options);
  const FieldSet& fields = ds.blocks.at(0).fields;
  const Field* t = fields.find("T", Association::Cell);
  ASSERT_NE(t, nullptr);
  ASSERT_EQ(t->components(), 9);
  ASSERT_EQ(t->tuples(), 400u);
  for (uint64_t c : {0u, 1u, 217u, 399u})
    for (int k = 0; k < 9; ++k) EXPECT_EQ(t->data().get(c, k), double(10 * c + uint64_t(k))) << c << " " << k;
  const Field* sym = fields.find("S", Association::Cell);
  ASSERT_NE(sym, nullptr);
  ASSERT_EQ(sym->components(), 6);
  for (uint64_t c : {0u, 399u})
    for (int k = 0; k < 6; ++k) EXPECT_EQ(sym->data().get(c, k), double(k + 1));
  const Field* pw = fields.find("pw", Association::Vertex);
  ASSERT_NE(pw, nullptr);
  ASSERT_EQ(pw->components(), 1);
  ASSERT_EQ(pw->tuples(), mesh_of(ds).points.size());
  for (uint64_t i : {0u, 1u, 440u, 881u}) EXPECT_EQ(pw->data().get(i, 0), 0.5 * double(i)) << i;
  // The case's own fields are still there.
  EXPECT_NE(fields.find("p", Association::Cell), nullptr);
  EXPECT_NE(fields.find("U", Association::Cell), nullptr);
}

TEST(OpenFoamReader, CaseFoundFromFoamFileAndControlDict) {
  const std::string dir = case_path("cavity");
  for (const std::string& p : {dir, dir + "/cavity.foam", dir + "/system/controlDict"}) {
    SCOPED_TRACE(p);
    EXPECT_EQ(detect_format(std::vector<std::string>{p}), InputFormat::OpenFoam);
    EXPECT_EQ(read_dataset(std::vector<std::string>{p}).cell_count(), 400u);
  }
  EXPECT_FALSE(openfoam::is_openfoam_path(case_path("")));  // the folder of cases is not a case
}

// The polyhedral case, by the exact engine against the reference renderer (its own point location over the same
// cells), semi-transparent so that every cell along a ray counts.
TEST(OpenFoamReader, DualMeshExactEngineMatchesOracle) {
  const Dataset ds = read_case("dual");
  const oracle::ReferenceRenderer reference(ds, "p");
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(reference.field_min(), reference.field_max());
  tf.opacity_unit_distance = length(ds.bounds().size()) / 20;
  RenderSettings s;
  s.width = s.height = 48;
  s.early_termination_opacity = 1;
  s.lighting = false;
  const Camera camera = camera_preset("iso", ds.bounds());
  ExactEngine engine(ds);
  engine.set_field(ds, "p");
  const Image exact = engine.render(camera, tf, s);
  const Image expected = reference.render(camera, tf, s);
  const oracle::RgbDifference d = oracle::rgb_difference(exact, expected, 1e-2);
  std::printf("dual: rms %.2e, max %.2e, %llu pixels off by > 1e-2\n", d.rms, d.max_abs,
              (unsigned long long)d.pixels_over);
  // Measured: rms 5.9e-4, 3 pixels off by up to 3e-2. The field is cell data, constant per cell, so it jumps at
  // every face; the dual mesh's hexahedra and the pyramids on its quadrilateral faces have non-planar faces, where the
  // engine (linearised faces) and the oracle (its own point location) put the jump a little apart: a few pixels
  // along such faces differ, the image as a whole does not.
  EXPECT_LE(d.rms, 1e-3);
  EXPECT_LE(d.pixels_over, 48u * 48u / 200);
  uint64_t covered = 0;
  for (int y = 0; y < expected.height; ++y)
    for (int x = 0; x < expected.width; ++x)
      covered += std::abs(expected.pixel(x, y)[0] - float(s.background[0])) > 0.02f;
  EXPECT_GT(covered, uint64_t(48 * 48 / 10));
}

TEST(OpenFoamReader, DualMeshLodEngineBuildsAndRenders) {
  test::ScratchDir dir;
  const std::string store = dir.file("dual.ugvr");
  const test::CommandResult b =
      test::run_ugvr("build " + case_path("dual") + " --fields p --brick 8 --max-depth 2 -o " + store);
  ASSERT_EQ(b.status, 0) << b.out;
  const test::CommandResult r = test::run_ugvr("render " + store + " -o " + dir.file("lod.png"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(std::filesystem::file_size(dir.file("lod.png")) > 100);
}

// OpenFOAM -> .vtu (ugvr convert) -> read: the same cells and fields (polyhedra arrive decomposed, as native cells).
TEST(OpenFoamReader, ConvertToVtuRoundTrip) {
  test::ScratchDir dir;
  for (const char* name : {"cavity", "dual", "cavity_decomposed"}) {
    SCOPED_TRACE(name);
    const std::string vtu = dir.file(std::string(name) + ".vtu");
    const test::CommandResult c = test::run_ugvr("convert " + case_path(name) + " " + vtu);
    ASSERT_EQ(c.status, 0) << c.out;
    const Dataset original = read_case(name);
    const Dataset back = read_dataset(std::vector<std::string>{vtu});
    EXPECT_EQ(mesh_of(back), mesh_of(original));
    EXPECT_TRUE(back.blocks[0].fields == original.blocks[0].fields);
  }
}

TEST(OpenFoamReader, InfoListsTimeDirectories) {
  const test::CommandResult r = test::run_ugvr("info " + case_path("cavity") + " --time-step 1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("0 0.1 0.2 0.3; read 0.1 (--time-step 1)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("400"), std::string::npos) << r.out;
}

// The FoamFile layouts the generated cases do not cover (Debian's OpenFOAM writes LSB, label=32, scalar=64 only):
// 64-bit big-endian labels, 32-bit scalars, a uniform list "N{v}", an ascii faceCompactList.
std::string foam_header(const std::string& format, const std::string& cls, const std::string& arch) {
  return "FoamFile\n{\n    format " + format + ";\n    class " + cls + ";\n    arch \"" + arch +
         "\";\n    object x;\n}\n// comment\n/* block\n comment */\n";
}

template <class T>
std::string big_endian_bytes(std::initializer_list<T> values) {
  std::string out;
  for (T v : values) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    std::reverse(b, b + sizeof(T));
    out.append(b, sizeof(T));
  }
  return out;
}

TEST(OpenFoamReader, BinaryLayoutsOfOtherArchitectures) {
  {
    openfoam::FoamFile f("owner", foam_header("binary", "labelList", "MSB;label=64;scalar=64") + "3\n(" +
                                      big_endian_bytes<int64_t>({0, 7, 2}) + ")\n");
    EXPECT_EQ(f.header().label_bytes, 8);
    EXPECT_EQ(f.labels(7, false), (std::vector<int64_t>{0, 7, 2}));
    openfoam::FoamFile g("owner", foam_header("binary", "labelList", "MSB;label=64;scalar=64") + "3\n(" +
                                      big_endian_bytes<int64_t>({0, 8, 2}) + ")\n");
    EXPECT_NE(test::error_of([&] { g.labels(7, false); }).find("label 8 is outside 0..7"), std::string::npos);
  }
  {
    openfoam::FoamFile f("points", foam_header("binary", "vectorField", "MSB;label=32;scalar=32") + "2(" +
                                       big_endian_bytes<float>({1, 2, 3, 4.5f, 5, 6}) + ")");
    const std::vector<Vec3f> p = f.points();
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p[1].x, 4.5f);
    EXPECT_EQ(p[1].z, 6.0f);
  }
  {
    openfoam::FoamFile f("U", foam_header("ascii", "volVectorField", "LSB;label=32;scalar=64") +
                                  "dimensions [0 1 -1 0 0 0 0];\ninternalField nonuniform List<vector> 3{(1 2 3)};\n"
                                  "boundaryField { wall { type fixedValue; value uniform (0 0 0); } }\n");
    const auto v = f.internal_field(3);
    ASSERT_TRUE(v.has_value());
    EXPECT_EQ(v->values, (std::vector<double>{1, 2, 3, 1, 2, 3, 1, 2, 3}));
    openfoam::FoamFile g("U", foam_header("ascii", "volVectorField", "") +
                                  "internalField nonuniform List<vector> 99999999999{(1 2 3)};\n");
    EXPECT_NE(test::error_of([&] { g.internal_field(3); }).find("99999999999 values, expected 3"), std::string::npos);
  }
  {
    openfoam::FoamFile f("faces", foam_header("ascii", "faceCompactList", "") + "3 (0 3 7) 7 (0 1 2 0 2 3 4)");
    const openfoam::FaceList faces = f.faces(5);
    EXPECT_EQ(faces.offsets, (std::vector<uint64_t>{0, 3, 7}));
    EXPECT_EQ(faces.vertices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4}));
  }
}

// --- Streaming: the window ---------------------------------------------------------------------------------------

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void spit(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

std::string gzipped(const std::string& data) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);  // 16: a gzip wrapper
  std::string out(deflateBound(&z, uLong(data.size())) + 64, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = uInt(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

template <class T>
void append_bytes(std::string& out, const std::vector<T>& v) {
  out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

// Everything a FoamFile yields, as what its class says it is (as the fuzz target reads it), in one byte string; an
// error yields its message.
std::string parse_all(const std::string& name, const std::string& bytes, size_t window, uint64_t cells = 400) {
  std::string out;
  try {
    openfoam::FoamFile f(name, bytes, window);
    const std::string& cls = f.header().class_name;
    out = cls + "|" + f.header().object + "|" + std::to_string(f.header().binary) + "|";
    if (cls == "vectorField") {
      const std::vector<Vec3f> p = f.points();
      append_bytes(out, p);
    } else if (cls == "faceList" || cls == "faceCompactList") {
      const openfoam::FaceList faces = f.faces(1000);
      append_bytes(out, faces.offsets);
      append_bytes(out, faces.vertices);
    } else if (cls == "labelList") {
      append_bytes(out, f.labels(1 << 20, true));
    } else if (cls == "polyBoundaryMesh") {
      for (const auto& p : f.patches())
        out += p.name + "," + p.type + "," + std::to_string(p.n_faces) + "," + std::to_string(p.start_face) + ";";
    } else if (cls == "regIOobject" || f.header().object == "cellZones") {
      for (const auto& z : f.cell_zones(1000)) {
        out += z.name + ":";
        append_bytes(out, z.cells);
      }
    } else if (cls.starts_with("vol") || cls.starts_with("point")) {
      const uint64_t tuples = cls.starts_with("vol") ? cells : 882;
      if (const auto v = f.internal_field(tuples)) {
        out += std::to_string(v->components) + (v->uniform ? "u" : "n");
        append_bytes(out, v->values);
      }
    }
  } catch (const Error& e) {
    out = std::string("error: ") + e.what();
  }
  return out;
}

// The FoamFiles of every fixture case (plain, binary, gzip), relative to tests/data/openfoam.
std::vector<std::string> fixture_foam_files() {
  std::vector<std::string> out;
  const std::filesystem::path root = case_path("");
  for (const auto& e : std::filesystem::recursive_directory_iterator(root)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = std::filesystem::relative(e.path(), root).string();
    if (rel.find("/constant/polyMesh/") == std::string::npos && rel.find("/0") == std::string::npos) continue;
    out.push_back(rel);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(OpenFoamStreaming, TinyWindowsParseEveryFixtureAsTheDefaultWindow) {
  const std::vector<std::string> files = fixture_foam_files();
  ASSERT_GT(files.size(), 50u);
  size_t parsed = 0;
  for (const std::string& rel : files) {
    SCOPED_TRACE(rel);
    const std::string bytes = slurp(case_path(rel));
    const uint64_t cells = rel.find("processor") != std::string::npos ? 200 : rel.starts_with("dual") ? 343 : 400;
    const std::string reference = parse_all(rel, bytes, openfoam::FoamFile::kDefaultWindow, cells);
    // decomposePar's *ProcAddressing lists hold signed labels (face flips) that labels() refuses: they must fail
    // alike too.
    if (rel.find("ProcAddressing") == std::string::npos) {
      EXPECT_FALSE(reference.starts_with("error: ")) << reference;
      ++parsed;
    }
    // 16: the smallest window (a 4- or 8-byte value and every token cross refills); 17 and 61: odd sizes that cut
    // values and "*/" at every possible place.
    for (size_t window : {size_t(16), size_t(17), size_t(61), size_t(4096)})
      EXPECT_EQ(parse_all(rel, bytes, window, cells), reference) << "window " << window;
  }
  EXPECT_GT(parsed, 100u);
}

TEST(OpenFoamStreaming, DamagedFilesFailAlikeWhateverTheWindow) {
  const std::string points = slurp(case_path("cavity/constant/polyMesh/points"));
  const std::string bfaces = slurp(case_path("cavity_binary/constant/polyMesh/faces"));
  const std::string bpoints = slurp(case_path("cavity_binary/constant/polyMesh/points"));
  const std::string owner = slurp(case_path("cavity/constant/polyMesh/owner"));
  const std::string p = slurp(case_path("cavity/0.3/p"));
  auto edit = [](std::string s, const std::string& from, const std::string& to) {
    const size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return s;
  };
  struct Damaged {
    std::string name, bytes, expected;
  };
  const std::vector<Damaged> cases = {
      {"points", points.substr(0, points.size() / 2), "count 882 needs at least"},
      {"points", edit(points, "\n882\n", "\n99999999999\n"), "count 99999999999 needs at least"},
      {"points", edit(points, "(0 0 0)", "(0 0 0"), "expected ')' after a tuple"},
      {"points", edit(points, "(0 0 0)", "(0 x 0)"), "expected points (a number), found 'x'"},
      {"points", edit(points, "\n882\n", "\n882\n/* open"), "unterminated /* comment"},
      {"points", edit(points, "object      points;", "object      \"points;"), "unterminated string"},
      {"faces", bfaces.substr(0, bfaces.size() - 3000), "face vertices count 6560 needs at least 4 bytes each"},
      {"points", bpoints.substr(0, bpoints.size() - 100), "needs at least 24 bytes each"},
      {"owner", edit(owner, "(\n0\n", "(\n-5\n"), "label -5 is outside"},
      {"p", edit(p, "\n400\n", "\n401\n"), "internalField has 401 values, expected 400"},
      // gzip: cut, and counts that the (unknown) inflated size cannot hold: they fail at the data's end.
      {"points.gz", gzipped(points).substr(0, gzipped(points).size() / 2), "gzip data is truncated"},
      {"points.gz", gzipped(edit(points, "\n882\n", "\n99999999999\n")), "expected '(' before a tuple, found ')'"},
      {"points.gz", gzipped(edit(bpoints, "\n882\n", "\n99999999999\n")),
       "points needs 2399999999976 bytes of binary data, only "},
      {"faces.gz", gzipped(bfaces.substr(0, bfaces.size() - 3000)), "face vertices needs 26240 bytes of binary data"},
      {"p.gz", gzipped(edit(p, "\n400\n", "\n401\n")), "internalField has 401 values, expected 400"},
  };
  for (const Damaged& c : cases) {
    SCOPED_TRACE(c.expected);
    const std::string reference = parse_all(c.name, c.bytes, openfoam::FoamFile::kDefaultWindow);
    EXPECT_TRUE(reference.starts_with("error: " + c.name + ": byte ")) << reference;
    EXPECT_NE(reference.find(c.expected), std::string::npos) << reference;
    for (size_t window : {size_t(16), size_t(17), size_t(61)})
      EXPECT_EQ(parse_all(c.name, c.bytes, window), reference) << "window " << window;
  }
}

// ~20 MB of points, ascii and binary: read through a 64 KiB window, which never grows, and the values all arrive.
TEST(OpenFoamStreaming, WindowStaysWithinItsBoundOnLargeFiles) {
  test::ScratchDir dir;
  constexpr uint64_t kAsciiPoints = 700000, kBinaryPoints = 850000;
  constexpr size_t kWindow = size_t(64) << 10;
  const std::string head = "FoamFile\n{\n    format ascii;\n    class vectorField;\n    object points;\n}\n";
  std::string ascii = head + std::to_string(kAsciiPoints) + "\n(\n";
  for (uint64_t i = 0; i < kAsciiPoints; ++i)
    ascii += "(" + std::to_string(double(i) * 0.25) + " " + std::to_string(i % 1000) + " -1.5e-07)\n";
  ascii += ")\n";
  std::string binary =
      "FoamFile\n{\n    format binary;\n    class vectorField;\n    arch \"LSB;label=32;scalar=64\";\n"
      "    object points;\n}\n" +
      std::to_string(kBinaryPoints) + "\n(";
  for (uint64_t i = 0; i < kBinaryPoints; ++i) {
    const double v[3] = {double(i) * 0.25, double(i % 1000), -1.5e-7};
    binary.append(reinterpret_cast<const char*>(v), sizeof v);
  }
  binary += ")\n";
  EXPECT_GT(ascii.size(), uint64_t(18) << 20);
  EXPECT_GT(binary.size(), uint64_t(18) << 20);
  struct File {
    std::string name, bytes;
    uint64_t n;
  };
  for (const File& file : {File{"ascii_points", ascii, kAsciiPoints}, File{"binary_points", binary, kBinaryPoints},
                           File{"ascii_points.gz", gzipped(ascii), kAsciiPoints}}) {
    SCOPED_TRACE(file.name);
    spit(dir.file(file.name), file.bytes);
    openfoam::FoamFile f(dir.file(file.name), kWindow);
    const std::vector<Vec3f> p = f.points();
    ASSERT_EQ(p.size(), file.n);
    EXPECT_EQ(p[12345], (Vec3f{12345 * 0.25f, 345.0f, -1.5e-7f}));
    EXPECT_EQ(p.back().x, float(double(file.n - 1) * 0.25));
    EXPECT_GE(f.peak_window_bytes(), kWindow);
    EXPECT_LE(f.peak_window_bytes(), kWindow + 64);  // the window, and no token long enough to spill much
  }
}

// Line numbers in errors count the newlines of everything the window has moved past.
TEST(OpenFoamStreaming, LineNumbersStayRightFarIntoAFile) {
  std::string s = "FoamFile\n{\n    format ascii;\n    class labelList;\n    object owner;\n}\n5000\n(\n";
  for (int i = 0; i < 4999; ++i) s += "/* c\n */ 1 // x\n";
  s += "oops\n)\n";
  for (size_t window : {size_t(16), size_t(100), openfoam::FoamFile::kDefaultWindow}) {
    openfoam::FoamFile f("owner", s, window);
    const std::string e = test::error_of([&] { f.labels(10, false); });
    EXPECT_NE(e.find("line 10007: expected owner (an integer), found 'oops'"), std::string::npos) << e;
    EXPECT_NE(e.find("byte " + std::to_string(s.find("oops"))), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace ugvr
