// Time series (io/time_series.h): listing and reading .pvd, .series, numbered files, PLOT3D with several solutions
// and Exodus steps; malformed collections; the exact engine's step switch (field swap on a static mesh, rebuild on a
// changing one); `ugvr info` / `ugvr render --time` on a generated series; the generator's moving vortex street.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "test_data.h"
#include "ugvr/core/json_file.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/render/exact/exact_renderer.h"

namespace ugvr {
namespace {

using test::error_of;
using test::ScratchDir;

// An nx x 2 x 2 block of unit hexahedra starting at x = x0, with vertex field f = x + y + z + offset and cell field
// c = cell index + offset.
Dataset hex_block(int nx, double x0, double offset) {
  UnstructuredMesh m;
  const int px = nx + 1;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < px; ++i) m.points.push_back({float(x0 + i), float(j), float(k)});
  auto id = [&](int i, int j, int k) { return uint32_t(i + px * (j + 3 * k)); };
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < nx; ++i) {
        const uint32_t v[8] = {id(i, j, k),     id(i + 1, j, k),     id(i + 1, j + 1, k),     id(i, j + 1, k),
                               id(i, j, k + 1), id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        m.add_cell(CellType::Hexahedron, v);
      }
  std::vector<float> f;
  for (const Vec3f& p : m.points) f.push_back(float(p.x + p.y + p.z + offset));
  std::vector<float> c;
  for (uint64_t i = 0; i < m.cell_count(); ++i) c.push_back(float(double(i) + offset));
  Block b;
  b.grid = std::move(m);
  b.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(f), 1)));
  b.fields.add(Field("c", Association::Cell, DataArray::from(std::move(c), 1)));
  Dataset ds;
  ds.blocks.push_back(std::move(b));
  return ds;
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// Three steps of one mesh (field offset 0, 10, 20) as step_000N.vtu in `dir`.
void write_static_steps(const ScratchDir& dir) {
  for (int s = 0; s < 3; ++s) write_vtu(hex_block(2, 0, 10.0 * s), dir.file("step_000" + std::to_string(s) + ".vtu"));
}

double field_max(const Dataset& ds, const char* name) { return ds.blocks[0].fields.find(name)->range().max; }

TEST(TimeSeries, PvdListsStepsAndReadsEach) {
  ScratchDir dir;
  write_static_steps(dir);
  write_pvd(dir.file("flow.pvd"), {{0.0, "step_0000.vtu"}, {0.5, "step_0001.vtu"}, {1.5, "step_0002.vtu"}});
  const std::string path = dir.file("flow.pvd");
  ASSERT_TRUE(is_series_input(std::span<const std::string>(&path, 1)));
  const TimeSeries s = list_time_steps(std::span<const std::string>(&path, 1));
  EXPECT_EQ(s.kind, SeriesKind::Pvd);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.steps[1].time, 0.5);
  EXPECT_EQ(s.steps[2].time, 1.5);
  EXPECT_EQ(s.geometry, SeriesGeometry::Detect);
  const Dataset d1 = read_time_step(s, 1);
  EXPECT_DOUBLE_EQ(field_max(d1, "f"), 6 + 10);
  EXPECT_NE(d1.format.find("time step 1 of 3 (t = 0.5)"), std::string::npos) << d1.format;
  // read_dataset reads a series' last step by default, and ReadOptions::time_step picks one.
  EXPECT_DOUBLE_EQ(field_max(read_dataset(std::span<const std::string>(&path, 1)), "f"), 6 + 20);
  ReadOptions first;
  first.time_step = 0;
  EXPECT_DOUBLE_EQ(field_max(read_dataset(std::span<const std::string>(&path, 1), first), "f"), 6);
  EXPECT_NE(error_of([&] { read_time_step(s, 3); }).find("time step 3 does not exist: the series has 3 steps"),
            std::string::npos);
  // All three share one mesh: one fingerprint; another mesh has another.
  EXPECT_EQ(geometry_fingerprint(d1), geometry_fingerprint(read_time_step(s, 2)));
  EXPECT_NE(geometry_fingerprint(d1), geometry_fingerprint(hex_block(3, 0, 0)));
  EXPECT_NE(geometry_fingerprint(d1), geometry_fingerprint(hex_block(2, 0.5, 0)));
}

TEST(TimeSeries, PvdPartsOfOneTimestepAreBlocks) {
  ScratchDir dir;
  write_vtu(hex_block(1, 0, 0), dir.file("a.vtu"));
  write_vtu(hex_block(1, 5, 0), dir.file("b.vtu"));
  write_text(
      dir.file("parts.pvd"),
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\"><Collection>\n"
      "<DataSet timestep=\"2\" part=\"0\" file=\"a.vtu\"/>\n<DataSet timestep=\"2\" part=\"1\" file=\"b.vtu\"/>\n"
      "</Collection></VTKFile>\n");
  const std::string path = dir.file("parts.pvd");
  const TimeSeries s = list_time_steps(std::span<const std::string>(&path, 1));
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s.steps[0].files.size(), 2u);
  const Dataset ds = read_time_step(s, 0);
  ASSERT_EQ(ds.blocks.size(), 2u);
  EXPECT_EQ(ds.cell_count(), 8u);
}

TEST(TimeSeries, SeriesJsonListsSteps) {
  ScratchDir dir;
  write_static_steps(dir);
  write_text(dir.file("flow.vtu.series"),
             R"({"file-series-version": "1.0", "files": [{"name": "step_0000.vtu", "time": 1},
                 {"name": "step_0002.vtu", "time": 3.25}]})");
  const std::string path = dir.file("flow.vtu.series");
  const TimeSeries s = list_time_steps(std::span<const std::string>(&path, 1));
  EXPECT_EQ(s.kind, SeriesKind::SeriesJson);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.steps[0].time, 1);
  EXPECT_EQ(s.steps[1].time, 3.25);
  EXPECT_DOUBLE_EQ(field_max(read_time_step(s, 1), "f"), 6 + 20);
}

TEST(TimeSeries, NumberedSeriesByPatternOrGlob) {
  ScratchDir dir;
  // Numbers sort numerically (2 before 10), not by name; other files in the directory are ignored.
  write_vtu(hex_block(1, 0, 1), dir.file("flow_0002.vtu"));
  write_vtu(hex_block(1, 0, 2), dir.file("flow_0010.vtu"));
  write_vtu(hex_block(1, 0, 3), dir.file("flow_0001.vtu"));
  write_vtu(hex_block(1, 0, 4), dir.file("other_0005.vtu"));
  for (const std::string& pattern : {dir.file("flow_%04d.vtu"), dir.file("flow_*.vtu")}) {
    ASSERT_TRUE(is_series_pattern(pattern));
    const TimeSeries s = list_time_steps(std::span<const std::string>(&pattern, 1));
    EXPECT_EQ(s.kind, SeriesKind::Numbered);
    ASSERT_EQ(s.size(), 3u) << pattern;
    EXPECT_EQ(s.steps[0].time, 1);
    EXPECT_EQ(s.steps[1].time, 2);
    EXPECT_EQ(s.steps[2].time, 10);
    EXPECT_DOUBLE_EQ(field_max(read_time_step(s, 2), "f"), 5 + 2);  // flow_0010.vtu: offset 2
  }
  const std::string none = dir.file("nothing_%03d.vtu");
  EXPECT_NE(error_of([&] {
              list_time_steps(std::span<const std::string>(&none, 1));
            }).find("no file matches the numbered series pattern"),
            std::string::npos);
  EXPECT_FALSE(is_series_pattern("/data/run%1/flow.vtu"));  // a '%' in a directory is no pattern
}

TEST(TimeSeries, Plot3dSeveralSolutions) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  const std::string q = test::data_path("blunt-fin/bluntfinq.bin");
  const std::vector<std::string> inputs = {relative_data_path, q, q};
  ASSERT_TRUE(is_series_input(inputs));
  const TimeSeries s = list_time_steps(inputs);
  EXPECT_EQ(s.kind, SeriesKind::Plot3d);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.geometry, SeriesGeometry::Static);
  const Dataset d = read_time_step(s, 1);
  EXPECT_EQ(d.cell_count(), 37'479u) << d.format;
  EXPECT_NE(d.format.find("time step 1 of 2"), std::string::npos) << d.format;
  const std::vector<std::string> missing = {relative_data_path, q, q + ".missing"};
  EXPECT_NE(error_of([&] { list_time_steps(missing); }).find("does not exist"), std::string::npos);
}

TEST(TimeSeries, OpenFoamTimeDirectoriesAndEnSightTimeSetsAreListed) {
  const std::string cavity = std::string(UGVR_SOURCE_DIR) + "/tests/data/openfoam/cavity";
  const TimeSeries foam = list_time_steps(std::span<const std::string>(&cavity, 1));
  EXPECT_EQ(foam.kind, SeriesKind::OpenFoam);
  ASSERT_EQ(foam.size(), 4u);
  EXPECT_EQ(foam.steps[3].time, 0.3);
  EXPECT_EQ(foam.steps[1].reader_step, 1);
  bool read_01 = false;
  for (const std::string& w : read_time_step(foam, 1).warnings) read_01 |= w.find("read 0.1 (--time-step 1)") != w.npos;
  EXPECT_TRUE(read_01) << "step 1 is the time directory 0.1";
  UGVR_REQUIRE_DATA("ensight-samples/LShape.case");
  const TimeSeries ens = list_time_steps(std::span<const std::string>(&relative_data_path, 1));
  EXPECT_EQ(ens.kind, SeriesKind::EnSight);
  ASSERT_EQ(ens.size(), 11u);
  for (size_t i = 1; i < ens.size(); ++i) EXPECT_GT(ens.steps[i].time, ens.steps[i - 1].time);
  EXPECT_EQ(read_time_step(ens, 0).blocks[0].fields.find("displacement")->range().max, 0);
  EXPECT_GT(read_time_step(ens, 10).blocks[0].fields.find("displacement")->range().max, 0);
}

TEST(TimeSeries, MalformedCollectionsNameTheFile) {
  ScratchDir dir;
  write_static_steps(dir);
  auto listing_error = [&](const std::string& name, const std::string& text) {
    write_text(dir.file(name), text);
    const std::string path = dir.file(name);
    return error_of([&] { list_time_steps(std::span<const std::string>(&path, 1)); });
  };
  const std::string head = "<?xml version=\"1.0\"?><VTKFile type=\"Collection\"><Collection>";
  const std::string tail = "</Collection></VTKFile>";
  std::string e = listing_error("missing.pvd", head + "<DataSet timestep=\"0\" file=\"nope.vtu\"/>" + tail);
  EXPECT_NE(e.find("missing.pvd: DataSet 0: file"), std::string::npos) << e;
  EXPECT_NE(e.find("nope.vtu does not exist"), std::string::npos) << e;
  e = listing_error("bad.pvd", head + "<DataSet timestep=\"0\" file=\"step_0000.vtu\">" + tail);
  EXPECT_NE(e.find("bad.pvd"), std::string::npos) << e;
  EXPECT_NE(e.find("invalid XML"), std::string::npos) << e;
  e = listing_error("back.pvd", head + "<DataSet timestep=\"1\" file=\"step_0000.vtu\"/>" +
                                    "<DataSet timestep=\"0.5\" file=\"step_0001.vtu\"/>" + tail);
  EXPECT_NE(e.find("back.pvd"), std::string::npos) << e;
  EXPECT_NE(e.find("timestep 0.5 after 1: the times of a collection must not decrease"), std::string::npos) << e;
  e = listing_error("nan.pvd", head + "<DataSet timestep=\"soon\" file=\"step_0000.vtu\"/>" + tail);
  EXPECT_NE(e.find("nan.pvd"), std::string::npos) << e;
  EXPECT_NE(e.find("is not a finite number"), std::string::npos) << e;
  e = listing_error("empty.pvd", head + tail);
  EXPECT_NE(e.find("empty.pvd: the collection lists no <DataSet>"), std::string::npos) << e;

  e = listing_error("bad.series", R"({"files": [{"name": "step_0000.vtu", "time": 0},)");
  EXPECT_NE(e.find("bad.series: invalid JSON"), std::string::npos) << e;
  e = listing_error("missing.series", R"({"files": [{"name": "gone.vtu", "time": 0}]})");
  EXPECT_NE(e.find("missing.series: files[0]: file"), std::string::npos) << e;
  EXPECT_NE(e.find("gone.vtu does not exist"), std::string::npos) << e;
  e = listing_error("same.series",
                    R"({"files": [{"name": "step_0000.vtu", "time": 2}, {"name": "step_0001.vtu", "time": 2}]})");
  EXPECT_NE(e.find("same.series: files[1]: time 2 after 2: the times of a series must increase"), std::string::npos)
      << e;
  e = listing_error("untimed.series", R"({"files": [{"name": "step_0000.vtu"}]})");
  EXPECT_NE(e.find("untimed.series: files[0]: \"time\" must be a number"), std::string::npos) << e;
  e = listing_error("nested.series", R"({"files": [{"name": "empty.pvd", "time": 0}]})");
  EXPECT_NE(e.find("is itself a series"), std::string::npos) << e;
}

TEST(TimeSeries, StepSelection) {
  EXPECT_EQ(parse_step_selection("all", 3, "--time"), (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_EQ(parse_step_selection("4", 5, "--time"), (std::vector<uint32_t>{4}));
  EXPECT_EQ(parse_step_selection("1:7:3", 8, "--time"), (std::vector<uint32_t>{1, 4, 7}));
  EXPECT_EQ(parse_step_selection("2:3", 8, "--time"), (std::vector<uint32_t>{2, 3}));
  EXPECT_NE(error_of([] { parse_step_selection("5", 5, "--time"); }).find("--time: step 5 does not exist"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_step_selection("3:1", 5, "--time"); }).find("A <= B"), std::string::npos);
  EXPECT_NE(error_of([] { parse_step_selection("0:4:0", 5, "--time"); }).find("stride"), std::string::npos);
  EXPECT_NE(error_of([] { parse_step_selection("x", 5, "--time"); }).find("expected all, N or A:B[:S]"),
            std::string::npos);
}

// One frame through the renderer interface; the camera frames `frame` (default: the bounds the scene shows now, which
// for a step switch are the previous step's).
Image render_scene(const std::shared_ptr<ExactScene>& scene, const std::string& field, std::optional<uint32_t> step,
                   double lo, double hi, std::optional<Bounds> frame = std::nullopt) {
  ExactRenderer r(scene);
  FrameRequest req;
  req.settings.width = req.settings.height = 48;
  req.settings.field = field;
  const Bounds b = frame.value_or(scene->engine.bounds());
  req.camera = default_camera(b);
  req.tf = default_transfer_function(lo, hi, b);
  req.time_step = step;
  return r.render(req).image;
}

TEST(TimeSeries, ExactEngineSwapsFieldsOnAStaticMesh) {
  ScratchDir dir;
  write_static_steps(dir);
  write_pvd(dir.file("flow.pvd"), {{0.0, "step_0000.vtu"}, {1.0, "step_0001.vtu"}, {2.0, "step_0002.vtu"}});
  const std::string path = dir.file("flow.pvd");
  auto series = std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
  auto scene = std::make_shared<ExactScene>(series, 0);
  const Image a0 = render_scene(scene, "f", std::nullopt, 0, 26);
  const Image a2 = render_scene(scene, "f", 2u, 0, 26);
  EXPECT_EQ(scene->step, 2u);
  EXPECT_DOUBLE_EQ(scene->engine.field_max(), 26);
  const Image b0 = render_scene(scene, "f", 0u, 0, 26);
  EXPECT_EQ(scene->swaps, 2u);
  EXPECT_EQ(scene->rebuilds, 0u);  // detected static: the fingerprints agree
  EXPECT_TRUE(std::isinf(compare_images(a0, b0).psnr_db)) << "the same step gives the same image";
  EXPECT_LT(compare_images(a0, a2).psnr_db, 30);
  // A scene without a series refuses a step.
  auto one = std::make_shared<ExactScene>(std::make_shared<const Dataset>(hex_block(2, 0, 0)));
  EXPECT_NE(error_of([&] { render_scene(one, "f", 1u, 0, 6); }).find("a time step needs a time series"),
            std::string::npos);
}

TEST(TimeSeries, ChangingGeometryRendersEachStepWithItsOwnMesh) {
  ScratchDir dir;
  write_vtu(hex_block(2, 0, 0), dir.file("m0.vtu"));
  write_vtu(hex_block(4, -1, 0), dir.file("m1.vtu"));  // more cells, other points
  write_pvd(dir.file("moving.pvd"), {{0.0, "m0.vtu"}, {1.0, "m1.vtu"}});
  const std::string path = dir.file("moving.pvd");
  auto series = std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
  auto scene = std::make_shared<ExactScene>(series, 0);
  EXPECT_EQ(scene->engine.cell_count(), 8u);
  auto fresh = std::make_shared<ExactScene>(std::make_shared<const Dataset>(read_time_step(*series, 1)));
  const Bounds step1 = fresh->engine.bounds();
  for (const char* field : {"f", "c"}) {  // per vertex and per cell (cell order follows the new mesh)
    const Image moved = render_scene(scene, field, 1u, 0, 8, step1);
    EXPECT_EQ(scene->engine.cell_count(), 16u);
    EXPECT_EQ(scene->engine.bounds().lo.x, -1);
    // The same image as a scene built on step 1 alone.
    EXPECT_TRUE(std::isinf(compare_images(moved, render_scene(fresh, field, std::nullopt, 0, 8)).psnr_db)) << field;
    render_scene(scene, field, 0u, 0, 8);
    EXPECT_EQ(scene->engine.cell_count(), 8u);
  }
  EXPECT_EQ(scene->rebuilds, 4u);
  EXPECT_EQ(scene->swaps, 0u);
}

TEST(TimeSeries, ExodusMugHas21StepsThatRenderAsTheDataDiffers) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  const TimeSeries listed = list_time_steps(std::span<const std::string>(&relative_data_path, 1));
  EXPECT_EQ(listed.kind, SeriesKind::Exodus);
  EXPECT_EQ(listed.geometry, SeriesGeometry::Static);
  ASSERT_EQ(listed.size(), 21u);
  for (size_t i = 0; i < 21; ++i) EXPECT_NEAR(listed.steps[i].time, 0.1 * double(i), 1e-9) << i;
  auto series = std::make_shared<const TimeSeries>(listed);
  auto scene = std::make_shared<ExactScene>(series, 0);
  const std::string field = "convected";
  scene->bind(field);
  const double lo0 = scene->engine.field_min(), hi0 = scene->engine.field_max();
  const Image first = render_scene(scene, field, std::nullopt, 0, 1);
  const Image last = render_scene(scene, field, 20u, 0, 1);
  const double lo20 = scene->engine.field_min(), hi20 = scene->engine.field_max();
  EXPECT_TRUE(lo0 != lo20 || hi0 != hi20) << "the data differ between step 0 and step 20";
  const Image first_again = render_scene(scene, field, 0u, 0, 1);
  EXPECT_EQ(scene->swaps, 2u);
  EXPECT_EQ(scene->rebuilds, 0u);
  EXPECT_LT(compare_images(first, last).psnr_db, 35);
  EXPECT_TRUE(std::isinf(compare_images(first, first_again).psnr_db));
}

TEST(TimeSeries, CliInfoListsTheStepsOfMug) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  test::CommandResult r = test::run_ugvr("info --json " + relative_data_path);
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json time = nlohmann::json::parse(r.out)["time"];
  EXPECT_EQ(time["kind"], "exodus");
  EXPECT_EQ(time["count"], 21);
  EXPECT_EQ(time["geometry"], "static");
  ASSERT_EQ(time["steps"].size(), 21u);
  EXPECT_NEAR(time["steps"][20]["time"].get<double>(), 2.0, 1e-9);
  EXPECT_EQ(time["steps"][20]["reader_step"], 20);
  r = test::run_ugvr("info " + relative_data_path);
  EXPECT_NE(r.out.find("time:     21 steps (exodus), t = 0 .. 2; geometry static"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  step 20: t = 2\n"), std::string::npos) << r.out;
}

TEST(TimeSeries, GeneratorMovesTheVortexStreet) {
  GenerateOptions g;
  g.cells = 20'000;
  const Dataset a = generate_in_memory(g);
  g.time = 0.25;
  const Dataset b = generate_in_memory(g);
  EXPECT_EQ(geometry_fingerprint(a), geometry_fingerprint(b)) << "the grid does not move";
  const Field* pa = a.blocks[0].fields.find("pressure");
  const Field* pb = b.blocks[0].fields.find("pressure");
  ASSERT_TRUE(pa && pb);
  uint64_t differ = 0;
  for (uint64_t i = 0; i < pa->tuples(); ++i) differ += pa->scalar(i, 0) != pb->scalar(i, 0);
  EXPECT_GT(differ, pa->tuples() / 100) << "the wake changes";
  EXPECT_LT(differ, pa->tuples()) << "the rest of the flow is steady";
  g.time = 1.0;
  const Dataset c = generate_in_memory(g);  // kept: pc points into it
  const Field* pc = c.blocks[0].fields.find("pressure");
  ASSERT_TRUE(pc);
  double worst = 0;
  for (uint64_t i = 0; i < pa->tuples(); ++i) worst = std::max(worst, std::abs(pa->scalar(i, 0) - pc->scalar(i, 0)));
  EXPECT_LT(worst, 1e-5) << "one period later the street is where it was: a series of N steps loops";
}

TEST(TimeSeries, CliInfoAndRenderAGeneratedSeries) {
  ScratchDir dir;
  const std::string pvd = dir.file("wake.pvd");
  test::CommandResult r = test::run_ugvr("generate -o " + pvd + " --cells 3000 --time-steps 3");
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run_ugvr("info " + pvd + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["time"]["count"], 3);
  EXPECT_EQ(info["time"]["kind"], "pvd");
  EXPECT_NEAR(info["time"]["steps"][1]["time"].get<double>(), 1.0 / 3, 1e-12);
  r = test::run_ugvr("info " + pvd);
  EXPECT_NE(r.out.find("time:     3 steps (pvd)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("step 2: t = 0.666667 wake_0002.vtu"), std::string::npos) << r.out;

  const std::string out = dir.file("frames");
  r = test::run_ugvr("render " + pvd + " --time all --out " + out + " --size 32 --field pressure");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json steps = read_json_file(out + "/steps.json");
  ASSERT_EQ(steps["steps"].size(), 3u);
  EXPECT_EQ(steps["range"], "global");
  EXPECT_EQ(steps["time_step_swaps"], 2);
  EXPECT_EQ(steps["time_step_rebuilds"], 0);
  // One colour range for all steps, spanning every step's own.
  for (const auto& s : steps["steps"]) {
    EXPECT_EQ(s["tf_range"], steps["steps"][0]["tf_range"]);
    EXPECT_LE(s["tf_range"][0].get<double>(), s["field_range"][0].get<double>());
    EXPECT_GE(s["tf_range"][1].get<double>(), s["field_range"][1].get<double>());
  }
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::filesystem::exists(out + "/time_0000" + std::to_string(k) + ".png"));
  r = test::run_ugvr("render " + pvd + " --time 0:2:2 --range per-step --out " + out + " --size 16");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json strided = read_json_file(out + "/steps.json");
  ASSERT_EQ(strided["steps"].size(), 2u);
  EXPECT_EQ(strided["steps"][1]["step"], 2);
  EXPECT_EQ(strided["steps"][1]["tf_range"], strided["steps"][1]["field_range"]);
  r = test::run_ugvr("render " + pvd + " --time 3 --out " + out);
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--time: step 3 does not exist"), std::string::npos) << r.out;
  r = test::run_ugvr("render " + pvd + " --time all");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("an output image is required (or --time with --out DIR)"), std::string::npos) << r.out;
  // With ffmpeg on PATH the frames become DIR/movie.mp4 (a stand-in ffmpeg records its arguments and writes the file).
  const std::string bin = dir.file("bin");
  std::filesystem::create_directories(bin);
  write_text(bin + "/ffmpeg",
             "#!/bin/sh\necho \"$@\" > \"$(dirname \"$0\")/args\"\nfor a; do last=$a; done\n"
             ": > \"$last\"\n");
  std::filesystem::permissions(bin + "/ffmpeg", std::filesystem::perms::owner_all);
  const std::string old_path = std::getenv("PATH") ? std::getenv("PATH") : "";
  setenv("PATH", (bin + ":" + old_path).c_str(), 1);
  r = test::run_ugvr("render " + pvd + " --time all --out " + out + " --size 16");
  setenv("PATH", old_path.c_str(), 1);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(std::filesystem::exists(out + "/movie.mp4"));
  std::ifstream args_file(bin + "/args");
  const std::string args((std::istreambuf_iterator<char>(args_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(args.find(out + "/time_%05d.png"), std::string::npos) << args;
  EXPECT_NE(args.find("-pix_fmt yuv420p"), std::string::npos) << args;
  // --time-step reads one step of any series.
  r = test::run_ugvr("render " + pvd + " --time-step 0 -o " + dir.file("one.png") + " --size 16");
  EXPECT_EQ(r.status, 0) << r.out;
}

}  // namespace
}  // namespace ugvr
