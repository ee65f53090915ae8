// Read -> write .vtu -> read gives the same dataset (geometry, cells, fields and their types), for every real
// dataset of the foundation formats and every codec; structured inputs come back as their explicit hexahedra.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "test_data.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"

namespace ugvr {
namespace {

void expect_same_block(const Block& expected, const Block& actual, const std::string& what) {
  ASSERT_TRUE(std::holds_alternative<UnstructuredMesh>(actual.grid)) << what;
  const auto& a = std::get<UnstructuredMesh>(expected.grid);
  const auto& b = std::get<UnstructuredMesh>(actual.grid);
  EXPECT_EQ(a.points, b.points) << what;
  EXPECT_EQ(a.cell_types, b.cell_types) << what;
  EXPECT_EQ(a.cell_offsets, b.cell_offsets) << what;
  EXPECT_EQ(a.connectivity, b.connectivity) << what;
  ASSERT_EQ(expected.fields.size(), actual.fields.size()) << what;
  for (size_t i = 0; i < expected.fields.size(); ++i) {
    const Field& f = expected.fields[i];
    const Field* g = actual.fields.find(f.name(), f.association());
    ASSERT_NE(g, nullptr) << what << ": field " << f.name();
    EXPECT_EQ(g->data().type(), f.data().type()) << what << ": " << f.name();
    EXPECT_TRUE(g->data() == f.data()) << what << ": values of " << f.name();
  }
}

class RoundTrip : public ::testing::TestWithParam<std::vector<std::string>> {};

TEST_P(RoundTrip, ReadWriteReadIsIdentical) {
  std::vector<std::string> inputs;
  for (const std::string& rel : GetParam()) {
    const std::string p = test::data_path(rel);
    if (!std::filesystem::exists(p)) GTEST_SKIP() << "dataset not found: " << p;
    inputs.push_back(p);
  }
  const Dataset original = read_dataset(inputs);
  ASSERT_EQ(original.blocks.size(), 1u);
  const Block expected = to_unstructured_block(original.blocks[0], StructuredCellShape::Hexahedra);
  test::ScratchDir dir;
  for (Codec codec : {Codec::None, Codec::Zlib, Codec::Lz4}) {
    const std::string out = dir.file("out.vtu");
    write_vtu(original, out, {.codec = codec});
    const Dataset back = read_vtk_xml(out);
    ASSERT_EQ(back.blocks.size(), 1u);
    expect_same_block(expected, back.blocks[0], GetParam()[0] + " codec " + std::to_string(int(codec)));
  }
}

INSTANTIATE_TEST_SUITE_P(
    RealData, RoundTrip,
    ::testing::Values(
        std::vector<std::string>{"can/can.vtu"}, std::vector<std::string>{"fea-kiefer-bracket/dataset.vtu"},
        std::vector<std::string>{"notch-stress/notch_stress.vtk"},
        std::vector<std::string>{"notch-stress/notch_disp.vtu"},
        std::vector<std::string>{"vtk-small-ugrids/AngularSector.vtk"},
        std::vector<std::string>{"vtk-small-ugrids/uGridEx.vtk"},
        std::vector<std::string>{"vtk-small-ugrids/tetraMesh.vtk"},
        std::vector<std::string>{"vtk-office/office.binary.vtk"},
        std::vector<std::string>{"vtk-small-ugrids/SampleStructGrid.vtk"},
        std::vector<std::string>{"blunt-fin/bluntfinxyz.bin", "blunt-fin/bluntfinq.bin"},
        std::vector<std::string>{"lox-post/postxyz.bin", "lox-post/postq.bin"}, std::vector<std::string>{"spx/spx.inp"},
        std::vector<std::string>{"z88-piston-tets/b21_lin_g.nas"},
        std::vector<std::string>{"disk-out-ref/disk_out_ref.ex2"}, std::vector<std::string>{"exodus-misc/mug.e"},
        std::vector<std::string>{"exodus-misc/box-noglom.ex2"}, std::vector<std::string>{"exodus-misc/mesh_fs8.exo"}));

// The CLI path: generate -> info, convert -> info.
TEST(CliGenerate, MixedDatasetDescribesItself) {
  test::ScratchDir dir;
  const std::string out = dir.file("demo.vtu");
  auto [status, text] = test::run_ugvr("generate --cells 20000 --kind mixed -o " + out);
  ASSERT_EQ(status, 0) << text;
  auto [s2, json_text] = test::run_ugvr("info --json --topology " + out);
  ASSERT_EQ(s2, 0) << json_text;
  const auto r = nlohmann::json::parse(json_text);
  const auto& b = r["blocks"][0];
  for (const char* t : {"tetra", "pyramid", "wedge", "hexahedron"})
    EXPECT_GT(b["cell_types"][t].get<uint64_t>(), 0u) << t;
  EXPECT_NEAR(r["cells"].get<double>(), 20000, 0.05 * 20000);
  EXPECT_EQ(b["inverted_cells"], 0);
  EXPECT_EQ(b["topology"]["nonmanifold_faces"], 0);
  EXPECT_EQ(b["fields"].size(), 3u);
}

TEST(CliConvert, PlotThreeDToVtu) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  test::ScratchDir dir;
  const std::string out = dir.file("fin.vtu");
  auto [status, text] = test::run_ugvr("convert --compress lz4 " + relative_data_path + " " +
                                       test::data_path("blunt-fin/bluntfinq.bin") + " " + out);
  ASSERT_EQ(status, 0) << text;
  auto [s2, json_text] = test::run_ugvr("info --json " + out);
  ASSERT_EQ(s2, 0) << json_text;
  const auto r = nlohmann::json::parse(json_text);
  EXPECT_EQ(r["blocks"][0]["cell_types"]["hexahedron"], 37479);
  EXPECT_EQ(r["points"], 40960);
  // Refuses a non-.vtu output and leaves nothing behind on a failed read.
  auto [s3, t3] = test::run_ugvr("convert " + relative_data_path + " " + dir.file("x.vts"));
  EXPECT_NE(s3, 0);
  EXPECT_NE(t3.find(".vtu"), std::string::npos) << t3;
  auto [s4, t4] =
      test::run_ugvr("convert " + test::data_path("vtk-small-ugrids/blow.vtk") + " " + dir.file("blow.vtu"));
  EXPECT_NE(s4, 0);
  EXPECT_FALSE(std::filesystem::exists(dir.file("blow.vtu")));
}

}  // namespace
}  // namespace ugvr

namespace ugvr {
namespace {

TEST(CliRefine, OneLevelMultipliesCellsByEight) {
  test::ScratchDir dir;
  const std::string in = dir.file("small.vtu"), out = dir.file("fine.vtu");
  ASSERT_EQ(test::run_ugvr("generate --cells 2000 --kind tet -o " + in).status, 0);
  const auto before = nlohmann::json::parse(test::run_ugvr("info --json " + in).out);
  const test::CommandResult r = test::run_ugvr("refine " + in + " -o " + out + " --levels 1");
  ASSERT_EQ(r.status, 0) << r.out;
  const test::CommandResult info = test::run_ugvr("info --json --topology " + out);
  ASSERT_EQ(info.status, 0) << info.out;
  const auto after = nlohmann::json::parse(info.out);
  EXPECT_EQ(after["cells"].get<uint64_t>(), 8 * before["cells"].get<uint64_t>());
  EXPECT_EQ(after["blocks"][0]["inverted_cells"], 0);
  EXPECT_EQ(after["blocks"][0]["topology"]["nonmanifold_faces"], 0);
  EXPECT_NE(test::run_ugvr("refine " + in + " -o " + out + " --levels 9").status, 0);
}

}  // namespace
}  // namespace ugvr
