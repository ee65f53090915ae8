// End to end: `ugvr info --json` on every dataset of ../shared/data in a format of the foundation, checked against
// the counts and ranges published with the data (SOURCE.txt) and in the literature.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "test_data.h"

namespace ugvr {
namespace {

using nlohmann::json;

using test::CommandResult;

CommandResult run(const std::string& args) { return test::run_ugvr(args); }

json info(const std::string& files) {
  const CommandResult r = run("info --json " + files);
  EXPECT_EQ(r.status, 0) << r.out;
  try {
    return json::parse(r.out);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not JSON: " << r.out;
    return json::object();
  }
}

const json* field(const json& block, const std::string& name) {
  for (const json& f : block["fields"]) {
    if (f["name"] == name) return &f;
  }
  return nullptr;
}

void expect_range(const json& block, const std::string& name, double lo, double hi, double tol) {
  const json* f = field(block, name);
  ASSERT_NE(f, nullptr) << "no field " << name;
  EXPECT_NEAR((*f)["range"][0].get<double>(), lo, tol) << name;
  EXPECT_NEAR((*f)["range"][1].get<double>(), hi, tol) << name;
}

void expect_cells(const json& block, uint64_t tet, uint64_t pyr, uint64_t wedge, uint64_t hex) {
  const json& c = block["cell_types"];
  EXPECT_EQ(c["tetra"], tet);
  EXPECT_EQ(c["pyramid"], pyr);
  EXPECT_EQ(c["wedge"], wedge);
  EXPECT_EQ(c["hexahedron"], hex);
}

TEST(CliInfo, BluntFin) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  const json r = info(relative_data_path + " " + ::ugvr::test::data_path("blunt-fin/bluntfinq.bin"));
  ASSERT_EQ(r["blocks"].size(), 1u);
  const json& b = r["blocks"][0];
  EXPECT_EQ(b["kind"], "curvilinear");
  EXPECT_EQ(b["dimensions"], json({40, 32, 32}));
  EXPECT_EQ(r["points"], 40960);
  EXPECT_EQ(r["cells"], 37479);
  expect_range(b, "Density", 0.193, 4.98, 0.01);
  expect_range(b, "Pressure", 0.26, 10.0, 0.05);
  expect_range(b, "VelocityMagnitude", 0.0, 3.12, 0.02);
}

TEST(CliInfo, OxygenPostWithIblank) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const json r = info(relative_data_path + " " + ::ugvr::test::data_path("lox-post/postq.bin"));
  const json& b = r["blocks"][0];
  EXPECT_EQ(b["dimensions"], json({38, 76, 38}));
  EXPECT_EQ(r["points"], 109744);
  EXPECT_EQ(r["cells"], 102675);
  // The file's IBLANK holds 1 (in use) and -1 (overset fringe, still in use: VTK blanks only 0), no 0.
  ASSERT_TRUE(b.contains("iblank"));
  EXPECT_EQ(b["iblank"]["blanked_points"], 0);
  EXPECT_EQ(b["iblank"]["overset_points"], 4332);
  expect_range(b, "Density", 1.0, 1.0, 1e-6);
}

TEST(CliInfo, KieferBracketQuadraticTets) {
  UGVR_REQUIRE_DATA("fea-kiefer-bracket/dataset.vtu");
  const json r = info(relative_data_path);
  const json& b = r["blocks"][0];
  EXPECT_EQ(b["kind"], "unstructured");
  expect_cells(b, 56786, 0, 0, 0);
  EXPECT_EQ(r["points"], 102578);
  expect_range(b, "Equivalent (von-Mises) Stress (psi)", 0.014, 23.3, 0.05);
  EXPECT_EQ(b["inverted_cells"], 0);
}

TEST(CliInfo, NotchHexAndWedgeBothFormats) {
  UGVR_REQUIRE_DATA("notch-stress/notch_stress.vtk");
  const json legacy = info(relative_data_path);
  expect_cells(legacy["blocks"][0], 0, 0, 4, 2188);
  EXPECT_EQ(legacy["points"], 12717);
  const json xml = info(::ugvr::test::data_path("notch-stress/notch_disp.vtu"));
  expect_cells(xml["blocks"][0], 0, 0, 4, 2188);
}

TEST(CliInfo, CanHexWithCellField) {
  UGVR_REQUIRE_DATA("can/can.vtu");
  const json r = info(relative_data_path);
  const json& b = r["blocks"][0];
  expect_cells(b, 0, 0, 0, 4800);
  EXPECT_EQ(r["points"], 6724);
  const json* eqps = field(b, "EQPS");
  ASSERT_NE(eqps, nullptr);
  EXPECT_EQ((*eqps)["location"], "cell");
  expect_range(b, "EQPS", 0.0216, 2.89, 0.005);
  const json* displ = field(b, "DISPL");
  ASSERT_NE(displ, nullptr);
  EXPECT_EQ((*displ)["components"], 3);
}

TEST(CliInfo, OfficeStructuredGrid) {
  UGVR_REQUIRE_DATA("vtk-office/office.binary.vtk");
  const json r = info(relative_data_path);
  const json& b = r["blocks"][0];
  EXPECT_EQ(b["kind"], "curvilinear");
  EXPECT_EQ(b["dimensions"], json({21, 20, 20}));
  EXPECT_EQ(r["cells"], 7220);
  expect_range(b, "scalars", -3.87, 0.719, 0.01);
}

TEST(CliInfo, SmallFixtures) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/Tetrahedron.vtu");
  const std::string d = ::ugvr::test::data_path("vtk-small-ugrids/");
  expect_cells(info(d + "Tetrahedron.vtu")["blocks"][0], 96, 0, 0, 0);
  expect_cells(info(d + "tetraMesh.vtk")["blocks"][0], 160, 0, 0, 0);
  expect_cells(info(d + "hexa.vtk")["blocks"][0], 0, 0, 0, 10648);
  expect_cells(info(d + "AngularSector.vtk")["blocks"][0], 0, 144, 0, 7632);
  expect_cells(info(d + "a_grid.vtk")["blocks"][0], 4802, 0, 0, 0);
  const json mixed = info(d + "uGridEx.vtk");
  expect_cells(mixed["blocks"][0], 2, 0, 0, 2);
  EXPECT_FALSE(mixed["warnings"].empty()) << "dropped 2-D cells are reported";
  const json structured = info(d + "SampleStructGrid.vtk");
  EXPECT_EQ(structured["blocks"][0]["dimensions"], json({20, 30, 40}));
  expect_cells(info(d + "tetra.vtu")["blocks"][0], 1, 0, 0, 0);
}

TEST(CliInfo, RejectedInputsNameTheFileAndProblem) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/polyhedron2pieces.vtu");
  const CommandResult poly = run("info " + relative_data_path);
  EXPECT_EQ(poly.status, 1);
  EXPECT_NE(poly.out.find("polyhedron2pieces.vtu"), std::string::npos) << poly.out;
  EXPECT_NE(poly.out.find("POLYHEDRON"), std::string::npos) << poly.out;
  const CommandResult surface = run("info " + ::ugvr::test::data_path("vtk-small-ugrids/blow.vtk"));
  EXPECT_EQ(surface.status, 1);
  EXPECT_NE(surface.out.find("blow.vtk"), std::string::npos) << surface.out;
}

TEST(CliInfo, TopologyOfARealMesh) {
  UGVR_REQUIRE_DATA("vtk-small-ugrids/a_grid.vtk");
  const json r = info("--topology " + relative_data_path);
  const json& t = r["blocks"][0]["topology"];
  EXPECT_EQ(t["nonmanifold_faces"], 0);
  // Every tet face is interior (shared by 2) or boundary: 4 * tets = 2 * interior + boundary.
  const uint64_t boundary = t["boundary_faces"];
  EXPECT_GT(boundary, 0u);
  EXPECT_EQ((4 * 4802 - boundary) % 2, 0u);
}

// The formats of issue 8, through the command line.
TEST(CliInfo, FieldFormats) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  const json spx = info(relative_data_path);
  expect_cells(spx["blocks"][0], 12936, 0, 0, 0);
  EXPECT_EQ(spx["points"], 2896);
  expect_range(spx["blocks"][0], "density", 0.2, 1.0, 1e-6);
  const json z88 = info(test::data_path("z88-piston-tets/b21_lin_g.nas"));
  expect_cells(z88["blocks"][0], 278577, 0, 0, 0);
  EXPECT_EQ(z88["points"], 57184);
  EXPECT_EQ(z88["blocks"][0]["inverted_cells"], 0);
  const json disk = info(test::data_path("disk-out-ref/disk_out_ref.ex2"));
  expect_cells(disk["blocks"][0], 0, 0, 0, 7472);
  size_t vertex_fields = 0;
  for (const json& f : disk["blocks"][0]["fields"]) vertex_fields += f["location"] == "vertex";
  EXPECT_EQ(vertex_fields, 7u);
  expect_range(disk["blocks"][0], "Temp", 293.15, 913.15, 0.01);
  expect_cells(info(test::data_path("exodus-misc/mug.e"))["blocks"][0], 0, 0, 0, 1716 + 760);
  expect_cells(info(test::data_path("exodus-misc/box-noglom.ex2"))["blocks"][0], 40, 0, 0, 0);
  const json fs8 = info(test::data_path("exodus-misc/mesh_fs8.exo"));
  expect_cells(fs8["blocks"][0], 0, 0, 336 + 336 + 672, 0);
  EXPECT_EQ(fs8["blocks"][0]["inverted_cells"], 0);
  const json first = info("--time-step 0 " + test::data_path("exodus-misc/mug.e"));
  EXPECT_NE(first["format"].get<std::string>(), info(test::data_path("exodus-misc/mug.e"))["format"].get<std::string>())
      << "the chosen time step is part of the format line";
  EXPECT_NE(run("info --time-step 21 " + test::data_path("exodus-misc/mug.e")).status, 0);
}

TEST(CliInfo, UsageErrors) {
  EXPECT_NE(run("info").status, 0);
  EXPECT_NE(run("info /nonexistent/file.vtu").status, 0);
  EXPECT_NE(run("frobnicate").status, 0);
}

}  // namespace
}  // namespace ugvr

namespace ugvr {
namespace {

TEST(CliInfo, RawVolumeLayoutFromTheCommandLine) {
  test::ScratchDir dir;
  const std::string path = dir.file("v.raw");
  std::vector<uint16_t> values(4 * 5 * 6);
  for (size_t i = 0; i < values.size(); ++i) values[i] = uint16_t(i);
  FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_EQ(std::fwrite(values.data(), 2, values.size(), f), values.size());
  std::fclose(f);
  const json r = info("--raw-dims 4 5 6 --raw-type uint16 --raw-spacing 1 2 3 " + path);
  const json& b = r["blocks"][0];
  EXPECT_EQ(b["kind"], "uniform");
  EXPECT_EQ(b["dimensions"], json({4, 5, 6}));
  EXPECT_EQ(r["bounds"]["max"], json({3.0, 8.0, 15.0}));
  expect_range(b, "values", 0, 119, 0);
  const test::CommandResult wrong = run("info --raw-dims 4 5 7 --raw-type uint16 " + path);
  EXPECT_EQ(wrong.status, 1);
  EXPECT_NE(wrong.out.find("v.raw"), std::string::npos) << wrong.out;
}

}  // namespace
}  // namespace ugvr
