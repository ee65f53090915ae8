// End to end: `ugvr info --json` on every dataset of ../shared/data in a format of the foundation, checked against
// the counts and ranges published with the data (SOURCE.txt) and in the literature.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_data.h"
#include "ugvr/store/brick_store.h"

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

// `ugvr info STORE.ugvr`: a brick store built by `ugvr build` from a real mesh, described and verified.
namespace ugvr {
namespace {

std::string build_store(const test::ScratchDir& dir) {
  const std::string path = dir.file("spx.ugvr");
  const test::CommandResult r =
      test::run_ugvr("build " + test::data_path("spx/spx.inp") + " -o " + path + " --brick 8 --max-depth 3");
  EXPECT_EQ(r.status, 0) << r.out;
  return path;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}

void expect_contains(const std::string& out, std::initializer_list<std::string> needles) {
  for (const std::string& n : needles) EXPECT_NE(out.find(n), std::string::npos) << "no '" << n << "' in:\n" << out;
}

uint64_t sum(const json& array) {
  uint64_t t = 0;
  for (const json& v : array) t += v.get<uint64_t>();
  return t;
}

TEST(CliInfo, BrickStoreText) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  const test::CommandResult r = run("info " + path);
  EXPECT_EQ(r.status, 0) << r.out;
  expect_contains(r.out, {"format:   ugvr brick store, version 5", "bounds:   [", "root:     [",
                          "bricks:   8 x 8 x 8 samples, quant16",
                          "octree:   ", "  level 0: 1 node, 0 leaves, 1 with a brick", "bytes:    file ", "node table ",
                          "smaller than the bricks as float32", "fields:", "  vertex density (quant16): [0.2, 1]",
                          "build:    --brick 8 --fields density --error", "--max-depth 3", "(ugvr "});
}

// The build line says --cells for a store that keeps its leaves' cells (the command that would build it again), in
// core and out of core alike, and not for one without.
TEST(CliInfo, BrickStoreBuildLineSaysCells) {
  test::ScratchDir dir;
  const std::string mesh = dir.file("t.vtu");
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + mesh).status, 0);
  for (const std::string extra : {"", " --cells", " --cells --out-of-core"}) {
    const std::string store = dir.file("s.ugvr");
    const test::CommandResult b =
        test::run_ugvr("build " + mesh + " -o " + store + " --fields pressure --brick 8 --max-depth 2" + extra);
    ASSERT_EQ(b.status, 0) << b.out;
    const test::CommandResult r = run("info " + store);
    ASSERT_EQ(r.status, 0) << r.out;
    const size_t line = r.out.find("build:    --brick 8");
    ASSERT_NE(line, std::string::npos) << r.out;
    const std::string build = r.out.substr(line, r.out.find('\n', line) - line);
    EXPECT_EQ(build.find(" --cells") != std::string::npos, extra.find("--cells") != std::string::npos)
        << extra << ": " << build;
    EXPECT_EQ(build.find(" --out-of-core") != std::string::npos, extra.find("--out-of-core") != std::string::npos)
        << build;
  }
}

TEST(CliInfo, BrickStoreJson) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  const json r = info(path);
  EXPECT_EQ(r["format"], "ugvr brick store");
  EXPECT_EQ(r["version"], 5);
  EXPECT_EQ(r["sources"], json({path}));
  EXPECT_EQ(r["brick"], 8);
  EXPECT_EQ(r["encoding"]["samples"], "quant16");
  EXPECT_EQ(r["encoding"]["codec"], "zstd");
  ASSERT_EQ(r["fields"].size(), 1u);
  const json& f = r["fields"][0];
  EXPECT_EQ(f["name"], "density");
  EXPECT_EQ(f["location"], "vertex");
  EXPECT_EQ(f["encoding"], "quant16");
  EXPECT_NEAR(f["range"][0].get<double>(), 0.2, 1e-6);
  EXPECT_NEAR(f["range"][1].get<double>(), 1.0, 1e-6);
  // The store's bounds are the mesh's.
  EXPECT_EQ(r["bounds"], info(relative_data_path)["bounds"]);
  // Per level, adding up.
  EXPECT_EQ(r["nodes_per_level"][0], 1);
  EXPECT_EQ(r["nodes"].get<uint64_t>(), sum(r["nodes_per_level"]));
  EXPECT_EQ(r["leaves"].get<uint64_t>(), sum(r["leaves_per_level"]));
  EXPECT_EQ(r["nodes_with_data"].get<uint64_t>(), sum(r["nodes_with_data_per_level"]));
  EXPECT_GT(r["nodes"].get<uint64_t>(), 1u);
  EXPECT_EQ(r["depth_max"].get<size_t>() + 1, r["nodes_per_level"].size());
  EXPECT_LE(r["depth_max"], 3);
  // Bytes: the parts make the file; compressed smaller than float32.
  const json& b = r["bytes"];
  EXPECT_EQ(b["file"].get<uint64_t>(), std::filesystem::file_size(path));
  EXPECT_EQ(b["header"].get<uint64_t>() + b["blocks"].get<uint64_t>() + b["node_table"].get<uint64_t>() +
                b["provenance"].get<uint64_t>() + b["tf_errors"].get<uint64_t>() + b["boundary_faces"].get<uint64_t>(),
            b["file"].get<uint64_t>());
  EXPECT_GT(b["boundary_faces"].get<uint64_t>(), 0u);  // format version 4: the mesh's boundary faces per node
  EXPECT_EQ(b["tf_errors"].get<uint64_t>(), r["nodes"].get<uint64_t>() * 44);  // one field, 44 bytes per node
  EXPECT_GT(b["provenance"].get<uint64_t>(), 0u);
  EXPECT_EQ(b["unreferenced"], 0);
  EXPECT_EQ(b["blocks"], f["block_bytes"]);
  EXPECT_EQ(b["float32"].get<uint64_t>(), r["nodes_with_data"].get<uint64_t>() * 8 * 8 * 8 * 4);
  EXPECT_GT(b["ratio"].get<double>(), 1.0);
  // What the store records of its build (its provenance record): the input as given and the options.
  EXPECT_EQ(r["build"]["brick"], 8);
  EXPECT_EQ(r["build"]["fields"], json({"density"}));
  ASSERT_EQ(r["build"]["input"].size(), 1u);
  EXPECT_NE(r["build"]["input"][0].get<std::string>().find("spx.inp"), std::string::npos) << r["build"].dump();
  EXPECT_EQ(r["build"]["max_depth"], 3);
  EXPECT_TRUE(r["build"]["error"].is_number());
  EXPECT_EQ(r["build"]["out_of_core"], false);
  EXPECT_FALSE(r.contains("verify"));
}

TEST(CliInfo, BrickStoreVerify) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  const uint64_t bricks = info(path)["nodes_with_data"];
  const test::CommandResult good = run("info --verify " + path);
  EXPECT_EQ(good.status, 0) << good.out;
  expect_contains(good.out, {"verify:   all " + std::to_string(bricks) + " bricks verified"});
  const json v = info("--verify " + path)["verify"];
  EXPECT_EQ(v["ok"], true);
  EXPECT_EQ(v["bricks"], bricks);
  EXPECT_EQ(v["bad_blocks"], 0);
  EXPECT_EQ(v["bytes"], info(path)["bytes"]["blocks"]);
}

// The provenance record (how the store was built) carries its own checksum: a damaged one is named at its offset.
TEST(CliInfo, BrickStoreDamagedProvenanceIsNamed) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  uint64_t at = 0;
  {
    const BrickStoreReader s(path);
    ASSERT_FALSE(s.layout().provenance.empty());
    at = s.header().node_table_offset - s.header().provenance_size;
  }
  std::string bytes = read_bytes(path);
  bytes[at + 3] ^= 0x20;
  write_bytes(path, bytes);
  const test::CommandResult r = run("info " + path);
  EXPECT_EQ(r.status, 1);
  expect_contains(r.out, {"byte " + std::to_string(at), "provenance record checksum mismatch"});
}

TEST(CliInfo, BrickStoreVerifyFindsAFlippedPayloadByte) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  // The last node's brick, one byte in the middle of its payload.
  uint64_t node = 0;
  BlockRef block;
  {
    const BrickStoreReader s(path);
    for (uint64_t id = 0; id < s.node_count(); ++id) {
      if (s.node(id).has_brick()) node = id;
    }
    block = s.block(node, 0);
  }
  ASSERT_GT(node, 0u);
  std::string bytes = read_bytes(path);
  bytes[block.offset + kBlockHeaderSize + (block.size - kBlockHeaderSize) / 2] ^= 0x20;
  const std::string bad = dir.file("bad.ugvr");
  write_bytes(bad, bytes);
  // Opening checks only the header and the node table: the store still describes itself.
  EXPECT_EQ(run("info " + bad).status, 0);
  const test::CommandResult r = run("info --verify " + bad);
  EXPECT_EQ(r.status, 1) << r.out;
  expect_contains(r.out, {"verification failed", "1 of ", bad + ": byte " + std::to_string(block.offset),
                          "node " + std::to_string(node) + " field 'density'", "checksum mismatch"});
  // With --json, stdout is still one JSON object, saying what failed (the error line, on stderr, has no braces).
  const test::CommandResult j = run("info --json --verify " + bad);
  EXPECT_EQ(j.status, 1);
  const size_t open = j.out.find('{'), close = j.out.rfind('}');
  ASSERT_TRUE(open != std::string::npos && close != std::string::npos) << j.out;
  const json v = json::parse(j.out.substr(open, close - open + 1))["verify"];
  EXPECT_EQ(v["ok"], false);
  EXPECT_EQ(v["bad_bricks"], 1);
  ASSERT_EQ(v["errors"].size(), 1u);
  EXPECT_NE(v["errors"][0].get<std::string>().find("node " + std::to_string(node)), std::string::npos);
}

TEST(CliInfo, BrickStoreVerifyFindsAFlippedHeaderByte) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  std::string bytes = read_bytes(path);
  bytes[60] ^= 0x01;  // inside the root cell's bounds
  const std::string bad = dir.file("bad.ugvr");
  write_bytes(bad, bytes);
  for (const char* verify : {"", "--verify "}) {
    const test::CommandResult r = run(std::string("info ") + verify + bad);
    EXPECT_EQ(r.status, 1) << r.out;
    expect_contains(r.out, {bad + ": byte 172", "header checksum mismatch"});
  }
}

TEST(CliInfo, BrickStoreOptionsThatDoNotApply) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  test::ScratchDir dir;
  const std::string path = build_store(dir);
  const test::CommandResult topology = run("info --topology " + path);
  EXPECT_EQ(topology.status, 1);
  expect_contains(topology.out, {"--topology"});
  const test::CommandResult verify = run("info --verify " + relative_data_path);
  EXPECT_EQ(verify.status, 1);
  expect_contains(verify.out, {"--verify", "brick store"});
  // A file named .ugvr that is not a store is reported as a bad store, not as an unknown format.
  const std::string fake = dir.file("fake.ugvr");
  write_bytes(fake, "not a store at all");
  const test::CommandResult r = run("info " + fake);
  EXPECT_EQ(r.status, 1);
  expect_contains(r.out, {"not a ugvr brick store"});
}

}  // namespace
}  // namespace ugvr
