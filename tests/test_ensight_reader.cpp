// EnSight Gold reader (io/ensight_reader.cpp).
//  - The shared samples (../shared/data/ensight-samples, from VTK's test data) give the counts VTK 9.1's
//    vtkGenericEnSightReader reports (SOURCE.txt); the polyhedral part of TEST.case keeps its 18 input polyhedra and
//    the decomposition's volume equals the sum of VTK's cell volumes; every 3-D element type of elements.case comes
//    out with VTK's vertex order (positive volume, VTK's volume for the linear ones).
//  - Small cases generated here in every encoding (ASCII, C binary in both byte orders, Fortran binary in both)
//    read to the same dataset: node and element ids, a dropped triangle, uniform iblanked and rectilinear blocks,
//    undef and partial values, wildcard time sets and single-file time steps chosen by time_step.
//  - Round trip to .vtu (ugvr convert), the exact engine on the polyhedral part against the oracle, and the LOD
//    engine's build + render on it.
//  - Fields-only steps (io/step_fields.h): a case with one geometry reads its later steps' variables without the
//    geometry file, bit for bit the whole read; a geometry per step is read whole.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "oracle/reference_renderer.h"
#include "step_fields_checks.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/exact/exact_renderer.h"

namespace ugvr {
namespace {

using test::error_of;
using test::ScratchDir;

const std::string kSamples = "ensight-samples/";

Dataset read_case(const std::string& path, int64_t step = -1) { return read_ensight(path, step); }

const UnstructuredMesh& mesh_of(const Block& b) { return std::get<UnstructuredMesh>(b.grid); }

double total_volume(const UnstructuredMesh& m) {
  double v = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) v += cell_volume(m, c);
  return v;
}

bool has_warning(const Dataset& ds, const std::string& needle) {
  for (const std::string& w : ds.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

// ---------------------------------------------------------------------------------------------------------------
// The shared samples.

TEST(EnSightSamples, PolyhedralPartKeepsVtkCountsAndVolume) {
  UGVR_REQUIRE_DATA(kSamples + "TEST.case");
  const Dataset ds = read_case(relative_data_path);
  // Part 2 is 2-D (quads and nsided faces): dropped with a warning.
  ASSERT_EQ(ds.blocks.size(), 1u);
  EXPECT_TRUE(has_warning(ds, "133 quad4")) << ds.warnings.at(0);
  const Block& b = ds.blocks[0];
  EXPECT_EQ(b.name, "Volume");
  const UnstructuredMesh& m = mesh_of(b);
  // VTK: 350 points, 140 cells = 122 hexahedra + 18 polyhedra. The polyhedra are decomposed; the decomposer
  // reports its 18 input polyhedra and the hexahedra stay as they are.
  EXPECT_EQ(m.cell_type_counts().hexahedron, 122u);
  EXPECT_TRUE(has_warning(ds, "part 1 (Volume): 18 polyhedra"));
  EXPECT_GT(m.point_count(), 350u);
  EXPECT_EQ(count_inverted_cells(m), 0u);
  // Sum of VTK 9.1's cell volumes (vtkCellSizeFilter) over the 140 cells: 0.002055185349.
  EXPECT_NEAR(total_volume(m), 0.002055185349, 1e-6 * 0.002055185349);
  // Cell fields are per original cell: VTK's Pressure range, and every piece of a polyhedron carries its value.
  const Range r = b.fields.find("Pressure", Association::Cell)->range();
  EXPECT_FLOAT_EQ(float(r.min), 0.121168f);
  EXPECT_FLOAT_EQ(float(r.max), 0.254608f);
  EXPECT_EQ(b.fields.find("Velocity", Association::Cell)->components(), 3);
  // The first hexahedron's pressure, as VTK reads it.
  EXPECT_FLOAT_EQ(float(b.fields.find("Pressure")->data().get(0, 0)), 0.25266f);
  EXPECT_NE(ds.format.find("t = 0.3"), std::string::npos) << ds.format;
}

TEST(EnSightSamples, EveryVolumeElementTypeInVtkOrder) {
  UGVR_REQUIRE_DATA(kSamples + "elements.case");
  const Dataset ds = read_case(relative_data_path);
  ASSERT_EQ(ds.blocks.size(), 1u);  // part 2 holds one nsided element only
  const UnstructuredMesh& m = mesh_of(ds.blocks[0]);
  // VTK: 108 points, 15 cells of which 8 are volume cells (tetra4/10, pyramid5/13, penta6/15, hexa8/20).
  EXPECT_EQ(m.point_count(), 108u);
  ASSERT_EQ(m.cell_count(), 8u);
  const CellTypeCounts c = m.cell_type_counts();
  EXPECT_EQ(c.tetra, 2u);
  EXPECT_EQ(c.pyramid, 2u);
  EXPECT_EQ(c.wedge, 2u);
  EXPECT_EQ(c.hexahedron, 2u);
  // VTK's volumes of the linear cells (its quadratic cells are curved; here they are their corners).
  const double linear[] = {1.0 / 6, 0, 1.0 / 3, 0, 1, 0, 0.5, 0};
  for (uint64_t i = 0; i < 8; ++i) {
    SCOPED_TRACE(i);
    EXPECT_GT(cell_volume(m, i), 0);
    if (linear[i] > 0) {
      EXPECT_NEAR(cell_volume(m, i), linear[i], 1e-6);
    }
  }
  EXPECT_TRUE(has_warning(ds, "1 tria6"));
  const FieldSet& f = ds.blocks[0].fields;
  EXPECT_EQ(f.find("pointTensors")->components(), 6);
  EXPECT_EQ(f.find("pointVectors")->components(), 3);
  // Per-element values of the dropped 0-D..2-D elements are skipped: the tetra4 (8th element) has 8, the penta15
  // (last) 15.
  const Field* cs = f.find("cellScalars", Association::Cell);
  ASSERT_NE(cs, nullptr);
  EXPECT_EQ(cs->data().get(0, 0), 8);
  EXPECT_EQ(cs->data().get(7, 0), 15);
  // Complex: the real part (VTK's component 0), with a warning.
  EXPECT_FLOAT_EQ(float(f.find("cellCScalars")->data().get(0, 0)), 8.1f);
  EXPECT_TRUE(has_warning(ds, "imaginary part"));
  // "3.300003+000" (Fortran E format without the 'e') in elements.Evec is 3.300003.
  const Field* ev = f.find("cellVectors", Association::Cell);
  ASSERT_NE(ev, nullptr);
  bool found = false;
  for (uint64_t t = 0; t < ev->tuples(); ++t)
    for (int k = 0; k < 3; ++k) found = found || std::abs(ev->data().get(t, k) - 3.300003) < 1e-6;
  EXPECT_FALSE(found) << "3.3 belongs to a dropped element; it must not appear";
}

TEST(EnSightSamples, StructuredBinaryBlocks) {
  UGVR_REQUIRE_DATA(kSamples + "office_bin.case");
  {
    const Dataset ds = read_case(relative_data_path);
    ASSERT_EQ(ds.blocks.size(), 1u);
    const auto& g = std::get<StructuredGrid>(ds.blocks[0].grid);
    EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{7, 7, 7}));  // VTK: 343 points, 216 hexahedra
    EXPECT_EQ(grid_cell_count(ds.blocks[0].grid), 216u);
    EXPECT_NE(ds.format.find("big-endian"), std::string::npos);
    EXPECT_EQ(ds.blocks[0].fields.find("vectors")->components(), 3);
  }
  {
    const Dataset ds = read_case(test::data_path(kSamples + "RectGrid_bin.case"));
    ASSERT_EQ(ds.blocks.size(), 1u);
    const auto& g = std::get<RectilinearGrid>(ds.blocks[0].grid);
    EXPECT_EQ(g.dims.point_count(), 704u);  // VTK: 704 points, 450 voxels
    EXPECT_EQ(g.dims.cell_count(), 450u);
    EXPECT_EQ(ds.blocks[0].fields.find("scalars")->tuples(), 704u);
  }
}

TEST(EnSightSamples, SingleFileTimeStepsAndPointParts) {
  UGVR_REQUIRE_DATA(kSamples + "LShape.case");
  // 11 steps of displacement in one file (BEGIN/END TIME STEP); the geometry's own time set has one step.
  const Dataset last = read_case(relative_data_path);
  ASSERT_EQ(last.blocks.size(), 1u);  // parts 2-5 are point sets
  EXPECT_EQ(last.point_count(), 16u);
  EXPECT_EQ(last.cell_count(), 3u);
  const Field* d = last.blocks[0].fields.find("displacement");
  ASSERT_NE(d, nullptr);
  // VTK at t = 1: magnitude range [0, 0.0123793]; at t = 0 all zero.
  EXPECT_NEAR(d->range().max, 0.0123793, 1e-6);
  const Dataset first = read_case(relative_data_path, 0);
  EXPECT_EQ(first.blocks[0].fields.find("displacement")->range().max, 0);
  const Dataset mid = read_case(relative_data_path, 5);
  const double m = mid.blocks[0].fields.find("displacement")->range().max;
  EXPECT_GT(m, 0);
  EXPECT_LT(m, d->range().max);
  EXPECT_NE(error_of([&] { read_case(relative_data_path, 11); }).find("time step 11 does not exist"),
            std::string::npos);
}

TEST(EnSightSamples, SurfaceOnlyCaseIsRefused) {
  UGVR_REQUIRE_DATA(kSamples + "blow1_bin.case");
  const std::string e = error_of([&] { read_case(relative_data_path); });
  EXPECT_NE(e.find("blow1_bin.geo"), std::string::npos) << e;
  EXPECT_NE(e.find("has a volume cell"), std::string::npos) << e;
  EXPECT_NE(e.find("1057 elements"), std::string::npos) << e;  // VTK: 1057 triangles and quads
}

TEST(EnSightSamples, ServerOfServersAndDispatch) {
  UGVR_REQUIRE_DATA(kSamples + "elements.sos");
  const Dataset sos = read_dataset(std::vector<std::string>{relative_data_path});
  const Dataset one = read_case(test::data_path(kSamples + "elements.case"));
  ASSERT_EQ(sos.blocks.size(), one.blocks.size());
  EXPECT_EQ(mesh_of(sos.blocks[0]), mesh_of(one.blocks[0]));
  EXPECT_EQ(sos.blocks[0].fields, one.blocks[0].fields);
  EXPECT_EQ(detect_format(std::vector<std::string>{relative_data_path}), InputFormat::EnSight);
}

// ---------------------------------------------------------------------------------------------------------------
// Generated cases.

// Writes EnSight values in one encoding: ASCII (one value per line), C binary or Fortran binary (one record per
// call), either byte order.
class Writer {
 public:
  enum Kind { Ascii, C, Fortran };
  Writer(Kind k, bool big) : kind_(k), big_(big) {}

  void str(const std::string& s) {
    if (kind_ == Ascii) {
      out_ += s + "\n";
      return;
    }
    std::string b = s;
    b.resize(80, '\0');
    record(b);
  }
  void ints(const std::vector<int32_t>& v) {
    if (kind_ == Ascii) {
      for (int32_t x : v) out_ += std::to_string(x) + "\n";
      return;
    }
    std::string b;
    for (int32_t x : v) b += word(std::bit_cast<uint32_t>(x));
    record(b);
  }
  void floats(const std::vector<float>& v) {
    if (kind_ == Ascii) {
      char buf[32];
      for (float x : v) {
        std::snprintf(buf, sizeof buf, "%.9g\n", double(x));
        out_ += buf;
      }
      return;
    }
    std::string b;
    for (float x : v) b += word(std::bit_cast<uint32_t>(x));
    record(b);
  }
  const std::string& bytes() const { return out_; }

 private:
  std::string word(uint32_t u) const {
    if (big_) u = __builtin_bswap32(u);
    return std::string(reinterpret_cast<const char*>(&u), 4);
  }
  void record(const std::string& payload) {
    if (kind_ == Fortran) out_ += word(uint32_t(payload.size()));
    out_ += payload;
    if (kind_ == Fortran) out_ += word(uint32_t(payload.size()));
  }
  Kind kind_;
  bool big_;
  std::string out_;
};

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// Part 1: a unit hexahedron (nodes 1-8) with a wedge on its +x face (nodes 2,3,6,7 + 9,10 ... as a penta6) and a
// tetra on top, node and element ids given (arbitrary labels), a triangle (dropped). Part 2: a uniform 3x3x2
// block, iblanked (one corner blanked). Part 3: a rectilinear 2x3x2 block.
void write_geometry(Writer& w) {
  w.str("generated");
  w.str("by test_ensight_reader");
  w.str("node id given");
  w.str("element id given");
  w.str("part");
  w.ints({1});
  w.str("mixed cells");
  w.str("coordinates");
  const std::vector<std::array<float, 3>> p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1},      {1, 0, 1},
                                               {1, 1, 1}, {0, 1, 1}, {2, 0, 0}, {2, 0, 1}, {0.5f, 0.5f, 2}};
  w.ints({11});
  std::vector<int32_t> ids;
  for (int i = 0; i < 11; ++i) ids.push_back(100 + 7 * i);
  w.ints(ids);
  for (int c = 0; c < 3; ++c) {
    std::vector<float> v;
    for (const auto& q : p) v.push_back(q[size_t(c)]);
    w.floats(v);
  }
  w.str("hexa8");
  w.ints({1});
  w.ints({555});
  w.ints({1, 2, 3, 4, 5, 6, 7, 8});
  w.str("tria3");
  w.ints({1});
  w.ints({556});
  w.ints({1, 2, 3});
  // EnSight penta6: triangles (2, 9, 3) and (6, 10, 7), counter-clockwise seen from the top one (EnSight's
  // orientation, which VTK's wedgeMap turns into a positive wedge).
  w.str("penta6");
  w.ints({1});
  w.ints({557});
  w.ints({2, 9, 3, 6, 10, 7});
  w.str("tetra4");
  w.ints({1});
  w.ints({558});
  w.ints({5, 6, 7, 11});
  w.str("part");
  w.ints({2});
  w.str("uniform block");
  w.str("block uniform iblanked");
  w.ints({3, 3, 2});
  w.floats({5, 0, 0, 0.5f, 0.5f, 1});
  std::vector<int32_t> ib(18, 1);
  ib[0] = 0;
  w.ints(ib);
  w.str("part");
  w.ints({3});
  w.str("rectilinear block");
  w.str("block rectilinear");
  w.ints({2, 3, 2});
  w.floats({10, 11});
  w.floats({0, 0.5f, 2});
  w.floats({0, 1});
}

// Per-node scalar "t" = base + node index (undef for node 3 in part 1), per-element scalar "c" (partial in part 1:
// only the hexahedron and the triangle).
void write_node_var(Writer& w, float base) {
  w.str("t per node");
  w.str("part");
  w.ints({1});
  w.str("coordinates undef");
  w.floats({-99});
  std::vector<float> v;
  for (int i = 0; i < 11; ++i) v.push_back(i == 2 ? -99 : base + float(i));
  w.floats(v);
  w.str("part");
  w.ints({2});
  w.str("block");
  std::vector<float> b;
  for (int i = 0; i < 18; ++i) b.push_back(base + 100 + float(i));
  w.floats(b);
  w.str("part");
  w.ints({3});
  w.str("block");
  w.floats({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12});
}

void write_element_var(Writer& w) {
  w.str("c per element");
  w.str("part");
  w.ints({1});
  w.str("hexa8");
  w.floats({1.5f});
  w.str("tria3 partial");
  w.ints({1});
  w.ints({1});
  w.floats({2.5f});
  w.str("penta6");
  w.floats({3.5f});
  w.str("tetra4");
  w.floats({4.5f});
  w.str("part");
  w.ints({3});
  w.str("block");
  w.floats({7, 8});
}

struct Encoding {
  Writer::Kind kind;
  bool big;
  const char* name;
};
const Encoding kEncodings[] = {{Writer::Ascii, false, "ascii"},
                               {Writer::C, false, "c-le"},
                               {Writer::C, true, "c-be"},
                               {Writer::Fortran, false, "fortran-le"},
                               {Writer::Fortran, true, "fortran-be"}};

std::string write_case(const ScratchDir& dir, const Encoding& e, const std::string& extra_case = "") {
  Writer g(e.kind, e.big);
  if (e.kind == Writer::C) g.str("C Binary");
  if (e.kind == Writer::Fortran) g.str("Fortran Binary");
  write_geometry(g);
  write_file(dir.file(std::string(e.name) + ".geo"), g.bytes());
  for (int step = 0; step < 3; ++step) {
    Writer v(e.kind, e.big);
    write_node_var(v, float(10 * step));
    char name[64];
    std::snprintf(name, sizeof name, "%s.t%03d", e.name, step + 1);
    write_file(dir.file(name), v.bytes());
  }
  Writer c(e.kind, e.big);
  write_element_var(c);
  write_file(dir.file(std::string(e.name) + ".c"), c.bytes());
  const std::string text = "# generated\nFORMAT\ntype: ensight gold\nGEOMETRY\nmodel: " + std::string(e.name) +
                           ".geo\nVARIABLE\nscalar per node: 1 t " + e.name + ".t***\nscalar per element: c " + e.name +
                           ".c\n" + extra_case +
                           "TIME\ntime set: 1\nnumber of steps: 3\nfilename start number: 1\nfilename increment: 1\n"
                           "time values: 0.0 0.5\n 1.0\n";
  const std::string path = dir.file(std::string(e.name) + ".case");
  write_file(path, text);
  return path;
}

TEST(EnSightGenerated, EveryEncodingReadsTheSameDataset) {
  ScratchDir dir;
  std::optional<Dataset> reference;
  for (const Encoding& e : kEncodings) {
    SCOPED_TRACE(e.name);
    const Dataset ds = read_case(write_case(dir, e));
    ASSERT_EQ(ds.blocks.size(), 3u);
    EXPECT_TRUE(has_warning(ds, "1 tria3")) << (ds.warnings.empty() ? "" : ds.warnings[0]);
    const UnstructuredMesh& m = mesh_of(ds.blocks[0]);
    EXPECT_EQ(ds.blocks[0].name, "mixed cells");
    EXPECT_EQ(m.point_count(), 11u);
    ASSERT_EQ(m.cell_count(), 3u);
    EXPECT_EQ(m.cell_types[1], CellType::Wedge);
    EXPECT_EQ(count_inverted_cells(m), 0u);
    EXPECT_NEAR(total_volume(m), 1 + 0.5 + 1.0 / 6, 1e-6);
    // Last step (t = 1): t = 20 + node index, node 3 undefined.
    const Field* t = ds.blocks[0].fields.find("t");
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->data().get(0, 0), 20);
    EXPECT_EQ(t->data().get(10, 0), 30);
    EXPECT_TRUE(std::isnan(t->data().get(2, 0)));
    // Element values: the triangle's (partial) dropped with it; penta and tetra after it.
    const Field* c = ds.blocks[0].fields.find("c", Association::Cell);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->data().get(0, 0), 1.5);
    EXPECT_EQ(c->data().get(1, 0), 3.5);
    EXPECT_EQ(c->data().get(2, 0), 4.5);
    // The iblanked uniform block becomes a curvilinear grid with its IBLANK.
    const auto& sg = std::get<StructuredGrid>(ds.blocks[1].grid);
    EXPECT_EQ(sg.dims.points, (std::array<uint32_t, 3>{3, 3, 2}));
    ASSERT_EQ(sg.iblank.size(), 18u);
    EXPECT_EQ(sg.iblank[0], 0);
    EXPECT_FLOAT_EQ(sg.points[17].x, 6);
    EXPECT_FLOAT_EQ(sg.points[17].z, 1);
    EXPECT_EQ(ds.blocks[1].fields.find("c"), nullptr);  // no values for part 2
    const auto& rg = std::get<RectilinearGrid>(ds.blocks[2].grid);
    EXPECT_EQ(rg.coords[1], (std::vector<double>{0, 0.5, 2}));
    EXPECT_EQ(ds.blocks[2].fields.find("c", Association::Cell)->data().get(1, 0), 8);
    if (!reference) {
      reference = ds;
      continue;
    }
    for (size_t b = 0; b < ds.blocks.size(); ++b) {
      EXPECT_EQ(ds.blocks[b].grid, reference->blocks[b].grid);
      EXPECT_EQ(ds.blocks[b].fields, reference->blocks[b].fields);
    }
  }
}

TEST(EnSightGenerated, WildcardTimeSetChoosesTheStep) {
  ScratchDir dir;
  const std::string path = write_case(dir, kEncodings[1]);
  for (int64_t step : {0, 1, 2}) {
    const Dataset ds = read_case(path, step);
    EXPECT_EQ(ds.blocks[0].fields.find("t")->data().get(0, 0), 10.0 * double(step)) << step;
    EXPECT_EQ(ds.blocks[1].fields.find("t")->data().get(0, 0), 100 + 10.0 * double(step)) << step;
  }
  // The same through read_dataset and the options.
  ReadOptions o;
  o.time_step = 1;
  EXPECT_EQ(read_dataset(std::vector<std::string>{path}, o).blocks[0].fields.find("t")->data().get(1, 0), 11);
  const std::string e = error_of([&] { read_case(path, 3); });
  EXPECT_NE(e.find("time step 3 does not exist: the case has 3 time steps"), std::string::npos) << e;
  // A step whose file is missing is named.
  std::filesystem::remove(dir.file("c-le.t002"));
  EXPECT_NE(error_of([&] { read_case(path, 1); }).find("c-le.t002"), std::string::npos);
}

// Changing geometry: the model itself has a wildcard and a time set; each step's geometry and variable are read
// together (here the second step's geometry is the first one's, written again in another encoding's byte order).
TEST(EnSightGenerated, ChangingGeometryPerStep) {
  ScratchDir dir;
  write_case(dir, kEncodings[1]);
  for (int step = 0; step < 2; ++step) {
    Writer g(Writer::C, step == 1);
    g.str("C Binary");
    write_geometry(g);
    write_file(dir.file("moving" + std::to_string(step) + ".geo"), g.bytes());
  }
  const std::string path = dir.file("moving.case");
  write_file(path,
             "FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: 1 moving*.geo\nVARIABLE\nscalar per node: t c-le.t001\n"
             "TIME\ntime set: 1\nnumber of steps: 2\nfilename numbers: 0 1\ntime values: 0 1\n");
  // Step 1 reads moving1.geo (big-endian), step 0 moving0.geo; the variable is static.
  const Dataset ds = read_case(path, 1);
  EXPECT_NE(ds.format.find("big-endian"), std::string::npos) << ds.format;
  EXPECT_EQ(ds.blocks[0].fields.find("t")->data().get(0, 0), 0);
  const Dataset first = read_case(path, 0);
  EXPECT_NE(first.format.find("little-endian"), std::string::npos) << first.format;
  EXPECT_EQ(first.blocks[0].grid, ds.blocks[0].grid);
  // A missing step file is named.
  std::filesystem::remove(dir.file("moving1.geo"));
  EXPECT_NE(error_of([&] { read_case(path, 1); }).find("moving1.geo"), std::string::npos);
}

TEST(EnSightGenerated, SingleFileStepsInEveryEncoding) {
  ScratchDir dir;
  for (const Encoding& e : kEncodings) {
    SCOPED_TRACE(e.name);
    write_case(dir, e);
    // All three steps of "t" in one file between BEGIN / END TIME STEP, read through a file set.
    Writer v(e.kind, e.big);
    if (e.kind == Writer::C) v.str("C Binary");
    for (int step = 0; step < 3; ++step) {
      v.str("BEGIN TIME STEP");
      write_node_var(v, float(10 * step));
      v.str("END TIME STEP");
    }
    write_file(dir.file(std::string(e.name) + ".tall"), v.bytes());
    const std::string text = "FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: " + std::string(e.name) +
                             ".geo\nVARIABLE\nscalar per node: 1 1 t " + e.name +
                             ".tall\nTIME\ntime set: 1\nnumber of steps: 3\ntime values: 0 1 2\nFILE\nfile set: 1\n"
                             "number of steps: 3\n";
    const std::string path = dir.file(std::string(e.name) + "-single.case");
    write_file(path, text);
    for (int64_t step : {0, 1, 2}) {
      const Dataset ds = read_case(path, step);
      EXPECT_EQ(ds.blocks[0].fields.find("t")->data().get(10, 0), 10 + 10.0 * double(step)) << step;
    }
  }
}

TEST(EnSightGenerated, CaseErrorsAreNamed) {
  ScratchDir dir;
  write_case(dir, kEncodings[0]);
  const std::pair<std::string, std::string> bad[] = {
      {"FORMAT\ntype: ensight\nGEOMETRY\nmodel: ascii.geo\n", "only EnSight Gold"},
      {"FORMAT\ntype: ensight gold\n", "no 'model:'"},
      {"FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: 4 ascii.geo\n", "time set 4 is not defined"},
      {"FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: ascii.geo change_coords_only\n", "change_coords_only"},
      {"FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: ascii.geo\nTIME\ntime set: 1\nnumber of steps: 3\n"
       "time values: 1 2\n",
       "time values"},
      {"FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: missing.geo\n", "missing.geo"},
      {"FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: ascii.geo\nVARIABLE\nscalar per node: t ascii.c\n", "ascii.c"},
  };
  for (const auto& [text, needle] : bad) {
    SCOPED_TRACE(text);
    const std::string path = dir.file("bad.case");
    write_file(path, text);
    const std::string e = error_of([&] { read_case(path); });
    EXPECT_NE(e.find(needle), std::string::npos) << e;
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Round trip, exact engine against the oracle, LOD engine.

TEST(EnSightRoundTrip, ConvertToVtuKeepsCellsAndFields) {
  UGVR_REQUIRE_DATA(kSamples + "TEST.case");
  ScratchDir dir;
  for (const char* name : {"TEST.case", "elements.case"}) {
    SCOPED_TRACE(name);
    const std::string in = test::data_path(kSamples + name), out = dir.file("out.vtu");
    const test::CommandResult r = test::run_ugvr("convert " + in + " " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    const Dataset a = read_case(in);
    const Dataset b = read_dataset(std::vector<std::string>{out});
    ASSERT_EQ(b.blocks.size(), 1u);
    EXPECT_EQ(mesh_of(b.blocks[0]), mesh_of(a.blocks[0]));
    for (const Field& f : a.blocks[0].fields) {
      const Field* g = b.blocks[0].fields.find(f.name(), f.association());
      ASSERT_NE(g, nullptr) << f.name();
      EXPECT_EQ(g->data(), f.data()) << f.name();
    }
  }
}

TEST(EnSightRender, PolyhedralPartMatchesTheOracle) {
  UGVR_REQUIRE_DATA(kSamples + "TEST.case");
  const Dataset ds = read_case(relative_data_path);
  const oracle::ReferenceRenderer reference(ds, "Pressure");
  ExactEngine engine(ds);
  engine.set_field(ds, "Pressure");
  RenderSettings s;
  s.width = s.height = 48;
  s.early_termination_opacity = 1;
  s.lighting = false;
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(reference.field_min(), reference.field_max());
  tf.opacity_unit_distance = length(ds.bounds().size()) / 10;
  for (const char* preset : {"iso", "+z"}) {
    SCOPED_TRACE(preset);
    const Camera cam = camera_preset(preset, ds.bounds());
    const Image exact = engine.render(cam, tf, s);
    const Image expected = reference.render(cam, tf, s);
    const oracle::RgbDifference d = oracle::rgb_difference(exact, expected, 1e-2);
    std::printf("ensight TEST.case %s: rms %.2e, max %.2e\n", preset, d.rms, d.max_abs);
    EXPECT_LE(d.rms, 1e-3);
    // Not an empty comparison: the part covers a good share of the view.
    uint64_t covered = 0;
    for (int y = 0; y < expected.height; ++y)
      for (int x = 0; x < expected.width; ++x)
        if (std::abs(expected.pixel(x, y)[0] - float(s.background[0])) > 0.02f) ++covered;
    EXPECT_GT(covered, uint64_t(s.width * s.height / 20));
  }
}

TEST(EnSightRender, LodEngineBuildsAndRendersThePolyhedralPart) {
  UGVR_REQUIRE_DATA(kSamples + "TEST.case");
  ScratchDir dir;
  const std::string store = dir.file("test.ugvr");
  const test::CommandResult b =
      test::run_ugvr("build " + relative_data_path + " --fields Pressure --brick 8 --max-depth 2 -o " + store);
  ASSERT_EQ(b.status, 0) << b.out;
  const test::CommandResult r = test::run_ugvr("render " + store + " -o " + dir.file("lod.png") + " --size 32");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_GT(std::filesystem::file_size(dir.file("lod.png")), 100u);
}

// ---- Fields-only steps

std::shared_ptr<const TimeSeries> series_of(const std::string& path) {
  return std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
}

using test::expect_same_bits;
using test::expect_whole_read;

// The generated case in every encoding (one geometry: a mixed part with a dropped triangle, undef and partial values,
// an iblanked uniform block, a rectilinear block; "t" per node a file per step, "c" per element one file): each step's
// variables read fields-only equal the whole read bit for bit. The geometry file is then overwritten with garbage of
// its size and its time stamp put back: the fields-only reads still succeed (they never open it) while a whole read
// fails on it. Through the scene, switches swap fields on the walk mesh built once.
TEST(EnSightSteps, OneGeometryStepsReadFieldsOnlyInEveryEncoding) {
  ScratchDir dir;
  for (const Encoding& e : kEncodings) {
    SCOPED_TRACE(e.name);
    const auto series = series_of(write_case(dir, e));
    ASSERT_EQ(series->kind, SeriesKind::EnSight);
    ASSERT_EQ(series->size(), 3u);
    StepFieldReader reader(series);
    reader.read_whole(0);
    const auto k0 = reader.geometry_keys(0);
    ASSERT_TRUE(k0.has_value());
    EXPECT_EQ(reader.geometry_keys(2), k0);
    EXPECT_TRUE(reader.has_mesh_of(2, 0));
    for (size_t k : {2u, 1u, 0u}) expect_whole_read(*series, reader.read(k), k);

    std::vector<StepFields> before;
    for (size_t k = 0; k < 3; ++k) before.push_back(reader.read(k));
    const std::string geo = dir.file(std::string(e.name) + ".geo");
    const auto stamp = std::filesystem::last_write_time(geo);
    write_file(geo, std::string(std::filesystem::file_size(geo), 'x'));
    std::filesystem::last_write_time(geo, stamp);
    EXPECT_EQ(reader.geometry_keys(1), k0);
    for (size_t k = 0; k < 3; ++k) {
      const StepFields after = reader.read(k);
      for (size_t b = 0; b < after.blocks.size(); ++b) expect_same_bits(after.blocks[b], before[k].blocks[b]);
    }
    EXPECT_NE(error_of([&] { read_time_step(*series, 1); }), "(no error)") << "the whole read opens the geometry";
  }
  const auto series = series_of(write_case(dir, kEncodings[0]));
  ExactScene scene(series, 0);
  scene.bind("t");
  for (uint32_t k : {2u, 1u}) {
    scene.set_step(k);
    ExactScene fresh(std::make_shared<const Dataset>(read_time_step(*series, k)));
    fresh.bind("t");
    const std::vector<float>&a = scene.engine.bound_values(), &b = fresh.engine.bound_values();
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << k << ": bitwise (undef is NaN)";
  }
  EXPECT_EQ(scene.fields_only, 2u);
  EXPECT_EQ(scene.rebuilds, 0u);
}

// VTK's LShape sample: 11 steps of a vector per node in one file (BEGIN / END TIME STEP), the geometry in a file set
// of one step (static), point-set parts dropped. Steps read fields-only (no layout kept: the first read whole) equal
// the whole read bit for bit.
TEST(EnSightSteps, SingleFileVariableStepsOfTheLShapeSample) {
  UGVR_REQUIRE_DATA(kSamples + "LShape.case");
  const auto series = series_of(relative_data_path);
  ASSERT_EQ(series->size(), 11u);
  StepFieldReader reader(series);
  ASSERT_TRUE(reader.geometry_keys(0).has_value());
  for (size_t k : {10u, 0u, 5u}) expect_whole_read(*series, reader.read(k), k);
}

// VTK's TEST sample (a polyhedral part: its nfaced cells split around their centres, element values repeated on the
// pieces) as a series of two steps: the sample's files copied beside a .case of two time values, the second step's
// variable files a copy of the first's. The second step read fields-only equals its whole read bit for bit.
TEST(EnSightSteps, PolyhedralSampleStepsReadFieldsOnly) {
  UGVR_REQUIRE_DATA(kSamples + "TEST.case");
  ScratchDir dir;
  const std::filesystem::path from = std::filesystem::path(relative_data_path).parent_path();
  std::filesystem::copy_file(from / "test.geo", dir.file("test.geo"));
  for (const char* v : {"pressure", "velocity", "extr_velocity", "extr_pressure"})
    for (const char* n : {".0001", ".0002"})
      std::filesystem::copy_file(from / (std::string("test.") + v + ".0001"), dir.file(std::string("test.") + v + n));
  std::ifstream in(relative_data_path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = text.find("number of steps:       1");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 24, "number of steps:       2");
  text += "            0.4\n";
  write_file(dir.file("test2.case"), text);
  const auto series = series_of(dir.file("test2.case"));
  ASSERT_EQ(series->size(), 2u);
  StepFieldReader reader(series);
  reader.read_whole(0);
  expect_whole_read(*series, reader.read(1), 1);
  EXPECT_GT(reader.read(1).blocks.at(0).find("Pressure")->tuples(), 18u) << "the polyhedra's pieces";
}

// A geometry file per step ('*' wildcards with a time set): no key, read whole; the scene switches by fingerprint
// (the two files hold one mesh in two byte orders: swapped, not rebuilt, but not fields-only). A variable file missing
// at a step of a one-geometry case: the whole read's error naming it, the scene left on its step.
TEST(EnSightSteps, AGeometryPerStepIsReadWholeAndAMissingVariableFileIsNamed) {
  ScratchDir dir;
  const std::string one = write_case(dir, kEncodings[1]);
  for (int step = 0; step < 2; ++step) {
    Writer g(Writer::C, step == 1);
    g.str("C Binary");
    write_geometry(g);
    write_file(dir.file("moving" + std::to_string(step + 1) + ".geo"), g.bytes());
  }
  const std::string path = dir.file("moving.case");
  write_file(path,
             "FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: 1 moving*.geo\nVARIABLE\nscalar per node: 1 t c-le.t***\n"
             "TIME\ntime set: 1\nnumber of steps: 2\nfilename numbers: 1 2\ntime values: 0 1\n");
  const auto moving = series_of(path);
  StepFieldReader reader(moving);
  EXPECT_FALSE(reader.geometry_keys(1).has_value());
  EXPECT_FALSE(reader.has_mesh_of(1, 0));
  EXPECT_NE(error_of([&] { reader.read(1); }).find("the geometry changes per step"), std::string::npos);
  ExactScene scene(moving, 0);
  scene.bind("t");
  scene.set_step(1);
  EXPECT_EQ(scene.fields_only, 0u);
  EXPECT_NE(scene.dataset->format.find("big-endian"), std::string::npos) << "step 1's own geometry file";

  const auto series = series_of(one);
  ExactScene shown(series, 0);
  shown.bind("t");
  std::filesystem::remove(dir.file("c-le.t002"));
  const std::string e = error_of([&] { shown.set_step(1); });
  EXPECT_NE(e.find("c-le.t002"), std::string::npos) << e;
  EXPECT_EQ(e, error_of([&] { read_time_step(*series, 1); }));
  EXPECT_EQ(shown.step, 0u);
  shown.set_step(2);
  EXPECT_EQ(shown.fields_only, 1u);
}

}  // namespace
}  // namespace ugvr
