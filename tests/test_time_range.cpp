// The global colour range over a series' steps (`ugvr render --time all`, the viewer's time panel) from fields-only
// reads: a step with the shown step's mesh as stored is read without its mesh (a step whose mesh cannot be decoded
// still gives its range), a changing mesh falls back to the whole read, and the range equals the one of whole reads
// (cubes, a generated series through the CLI, mug.e).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "hex_fixtures.h"
#include "test_data.h"
#include "ugvr/core/file.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/render/exact/exact_renderer.h"
#include "ugvr/view/grid_load.h"

namespace ugvr {
namespace {

using test::bytes_read_so_far;
using test::ScratchDir;

// An n x n x n block of unit hexahedra, vertex field f = x + y + z + offset, cell field c = cell index + offset.
Dataset cube(int n, double offset) {
  UnstructuredMesh m = test::unit_hex_mesh(n);
  std::vector<float> f, c;
  for (const Vec3f& q : m.points) f.push_back(float(q.x + q.y + q.z + offset));
  for (uint64_t i = 0; i < m.cell_count(); ++i) c.push_back(float(double(i) + offset));
  Block b;
  b.grid = std::move(m);
  b.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(f), 1)));
  b.fields.add(Field("c", Association::Cell, DataArray::from(std::move(c), 1)));
  Dataset ds;
  ds.blocks.push_back(std::move(b));
  return ds;
}

// Overwrites the first cell's first corner in a .vtu as write_vtu writes it (raw appended data, UInt64 headers) with
// a point id that does not exist: a mesh no reader accepts, its fields intact.
void break_first_corner(const std::string& path) {
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string attr = "Name=\"connectivity\" format=\"appended\" offset=\"";
  const size_t at = text.find(attr);
  ASSERT_NE(at, std::string::npos) << path;
  const bool wide = text.rfind("type=\"Int64\"", at) == text.rfind("type=", at);
  const uint64_t offset = std::stoull(text.substr(at + attr.size()));
  const size_t data = text.find('_', text.find("<AppendedData encoding=\"raw\">")) + 1;
  const size_t first = data + offset + 8;  // past the array's byte count
  ASSERT_LT(first + 8, text.size()) << path;
  const int64_t missing = 1000000;
  if (wide) {
    std::memcpy(&text[first], &missing, 8);
  } else {
    const int32_t narrow = int32_t(missing);
    std::memcpy(&text[first], &narrow, 4);
  }
  std::ofstream(path, std::ios::binary) << text;
}

std::shared_ptr<const TimeSeries> series_of(const std::string& path) {
  return std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
}

// Steps 0..count-1 (step(k)) as step_k.vtu and flow.pvd.
std::string write_series(const ScratchDir& dir, int count, const std::function<Dataset(int)>& step) {
  std::vector<std::pair<double, std::string>> steps;
  for (int k = 0; k < count; ++k) {
    const std::string name = "step_" + std::to_string(k) + ".vtu";
    write_vtu(step(k), dir.file(name), {});
    steps.emplace_back(double(k), name);
  }
  write_pvd(dir.file("flow.pvd"), steps);
  return dir.file("flow.pvd");
}

struct MinMax {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  void unite(const FieldSet& fields, const std::string& selector) {
    const ScalarRef r = fields.scalar(selector);
    const Range range = r.field->range(r.component);
    lo = std::min(lo, range.min), hi = std::max(hi, range.max);
  }
};

// The range as before fields-only reads: every step read whole.
MinMax whole_read_range(const TimeSeries& series, const std::string& selector) {
  MinMax m;
  for (size_t k = 0; k < series.size(); ++k)
    for (const Block& b : read_time_step(series, k).blocks) m.unite(b.fields, selector);
  return m;
}

// The range pass of `ugvr render --time all` with step `mesh_step` shown.
MinMax values_range(const std::shared_ptr<const TimeSeries>& series, size_t mesh_step, const std::string& selector) {
  StepFieldReader reader(series);
  MinMax m;
  for (size_t k = 0; k < series->size(); ++k)
    for (const FieldSet& f : reader.read_values(k, mesh_step).blocks) m.unite(f, selector);
  return m;
}

// Runs a viewer's load of `series` from step `step` to its end.
view::GridLoad::State load_to_end(view::GridLoad& load) {
  for (;;) {
    const view::GridLoad::State s = load.state();
    if (s.stage == view::GridLoad::Stage::Done || s.stage == view::GridLoad::Stage::Failed) return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

TEST(TimeRange, StaticVtuStepsGiveTheirRangeWithoutReadingTheMesh) {
  ScratchDir dir;
  const auto series = series_of(write_series(dir, 3, [](int k) { return cube(4, 10.0 * k); }));
  const MinMax f = whole_read_range(*series, "f"), c = whole_read_range(*series, "c");
  EXPECT_EQ(f.hi, 32.0) << "12 at the far corner, + 20 at step 2";
  // Every step's connectivity now names a point that does not exist: the same stored geometry, unreadable.
  for (const TimeStep& step : series->steps) break_first_corner(step.files[0]);
  ASSERT_NE(test::error_of([&] { read_time_step(*series, 1); }).find("point id 1000000 is outside"), std::string::npos)
      << "the broken mesh is refused when read whole";
  EXPECT_TRUE(StepFieldReader(series).has_mesh_of(2, 0));
  const MinMax f_values = values_range(series, 0, "f"), c_values = values_range(series, 0, "c");
  EXPECT_EQ(f_values.lo, f.lo);
  EXPECT_EQ(f_values.hi, f.hi);
  EXPECT_EQ(c_values.lo, c.lo);
  EXPECT_EQ(c_values.hi, c.hi);
}

TEST(TimeRange, AChangingMeshFallsBackToTheWholeRead) {
  ScratchDir dir;
  // Step 1 is a larger cube (other counts, the largest values): its fields do not fit step 0's mesh.
  const auto series = series_of(write_series(dir, 3, [](int k) { return k == 1 ? cube(6, 10.0) : cube(3, 0.0); }));
  StepFieldReader reader(series);
  EXPECT_FALSE(reader.has_mesh_of(1, 0));
  EXPECT_TRUE(reader.has_mesh_of(2, 0));
  EXPECT_TRUE(reader.read_values(1, 0).blocks[0] == read_time_step(*series, 1).blocks[0].fields);
  for (const char* field : {"f", "c"}) {
    SCOPED_TRACE(field);
    const MinMax expected = whole_read_range(*series, field), got = values_range(series, 0, field);
    EXPECT_EQ(got.lo, expected.lo);
    EXPECT_EQ(got.hi, expected.hi);
    EXPECT_EQ(expected.hi, std::string(field) == "f" ? 18.0 + 10 : 6 * 6 * 6 - 1 + 10.0) << "step 1's maximum";
  }
  // The viewer's load from step 0 and from step 1 (the odd mesh shown): the same ranges.
  for (uint32_t shown : {0u, 1u}) {
    view::GridLoad load(series, shown, {"f", "c"}, 8);
    const view::GridLoad::State s = load_to_end(load);
    ASSERT_EQ(s.stage, view::GridLoad::Stage::Done) << s.error;
    ASSERT_EQ(load.grid().fields.size(), 2u);
    for (size_t i = 0; i < 2; ++i) {
      const MinMax expected = whole_read_range(*series, load.grid().names[i]);
      EXPECT_EQ(load.grid().fields[i].min, expected.lo) << shown << " " << load.grid().names[i];
      EXPECT_EQ(load.grid().fields[i].max, expected.hi) << shown << " " << load.grid().names[i];
    }
  }
}

TEST(TimeRange, TheViewersLoadReadsLaterStaticStepsWithoutTheirMesh) {
  if (bytes_read_so_far() == 0) GTEST_SKIP() << "no /proc/self/io";
  ScratchDir dir;
  const auto series = series_of(write_series(dir, 4, [](int k) { return cube(40, 10.0 * k); }));
  const uint64_t file = InputFile(series->steps[0].files[0]).size();
  const uint64_t before = bytes_read_so_far();
  view::GridLoad load(series, 0, {"f"}, 8);
  const view::GridLoad::State s = load_to_end(load);
  const uint64_t read = bytes_read_so_far() - before;
  ASSERT_EQ(s.stage, view::GridLoad::Stage::Done) << s.error;
  const MinMax expected = whole_read_range(*series, "f");
  EXPECT_EQ(load.grid().fields[0].min, expected.lo);
  EXPECT_EQ(load.grid().fields[0].max, expected.hi);
  // Step 0 whole; the geometry keys of steps 0..3, each the geometry's stored bytes hashed (read through pread since
  // the keys stopped mapping the file: under a file each, about 0.86 here); then steps 1..3: their fields (f and c,
  // 4 bytes a point or cell: a tenth of a file), the types array and the markup. About 5 files in all; steps 1..3
  // read whole would add 3 files less their fields (about 7.6).
  EXPECT_GE(read, file);
  EXPECT_LT(read, 6 * file) << "steps 1..3 read whole";
}

uint64_t bytes_under(const std::filesystem::path& dir) {
  uint64_t n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file()) n += e.file_size();
  return n;
}

// The viewer's load of an OpenFOAM case (the cavity fixture: 4 time directories on the constant mesh): step 0 read
// whole, steps 1..3 for the range without the mesh (the layout kept by step 0's read), the range the whole reads';
// the scene it hands over shares that reader, so its first switch reads the step's time directory only.
TEST(TimeRange, TheViewersLoadOfAnOpenFoamCaseReadsLaterStepsWithoutTheMesh) {
  if (bytes_read_so_far() == 0) GTEST_SKIP() << "no /proc/self/io";
  const std::filesystem::path root = std::filesystem::path(UGVR_SOURCE_DIR) / "tests/data/openfoam/cavity";
  const auto series = series_of(root.string());
  ASSERT_EQ(series->size(), 4u);
  const uint64_t mesh = bytes_under(root / "constant" / "polyMesh");
  uint64_t times = 0;
  for (const char* t : {"0", "0.1", "0.2", "0.3"}) times += bytes_under(root / t);
  const uint64_t before = bytes_read_so_far();
  view::GridLoad load(series, 0, {"p"}, 8);
  const view::GridLoad::State s = load_to_end(load);
  const uint64_t read = bytes_read_so_far() - before;
  ASSERT_EQ(s.stage, view::GridLoad::Stage::Done) << s.error;
  const MinMax expected = whole_read_range(*series, "p");
  EXPECT_EQ(load.grid().fields[0].min, expected.lo);
  EXPECT_EQ(load.grid().fields[0].max, expected.hi);
  // The mesh once, every time directory's files (each once, and its first 4 KiB once more: 11 files); steps 1..3
  // read whole would add the mesh three times more.
  EXPECT_GE(read, mesh + times);
  EXPECT_LT(read, 2 * mesh + times) << "steps 1..3 read whole";
  const std::shared_ptr<ExactScene> scene = load.exact();
  ASSERT_NE(scene, nullptr);
  const uint64_t before_switch = bytes_read_so_far();
  scene->set_step(1);
  EXPECT_LE(bytes_read_so_far() - before_switch, bytes_under(root / "0.1") + 3 * 4096 + 1024);
  EXPECT_EQ(scene->fields_only, 1u);
}

TEST(TimeRange, GeometryKeysAreKeptUntilTheFileChanges) {
  if (bytes_read_so_far() == 0) GTEST_SKIP() << "no /proc/self/io";
  ScratchDir dir;
  const auto series = series_of(write_series(dir, 2, [](int k) { return cube(6, 10.0 * k); }));
  StepFieldReader reader(series);
  const auto first = reader.geometry_keys(1);
  ASSERT_TRUE(first.has_value());
  EXPECT_TRUE(reader.has_mesh_of(1, 0));
  const uint64_t before = bytes_read_so_far();
  EXPECT_EQ(reader.geometry_keys(1), first);
  EXPECT_TRUE(reader.has_mesh_of(1, 0));
  // Beside the counter's own read of /proc/self/io: a key read again would read the file's markup (kilobytes).
  EXPECT_LT(bytes_read_so_far() - before, 1024u) << "the keys of files seen before are not read again";
  // Rewritten with another mesh (another size): its key is read again.
  write_vtu(cube(7, 10.0), series->steps[1].files[0], {});
  EXPECT_NE(reader.geometry_keys(1), first);
  EXPECT_FALSE(reader.has_mesh_of(1, 0));
  EXPECT_TRUE(reader.read_values(1, 0).blocks[0] == read_time_step(*series, 1).blocks[0].fields);
}

TEST(TimeRange, AGeneratedSeriesRendersWithTheWholeReadsRange) {
  ScratchDir dir;
  const std::string pvd = dir.file("s.pvd");
  const test::CommandResult g = test::run_ugvr("generate --cells 20000 --time-steps 4 -o " + pvd);
  ASSERT_EQ(g.status, 0) << g.out;
  const auto series = series_of(pvd);
  ASSERT_EQ(series->size(), 4u);
  StepFieldReader reader(series);
  EXPECT_TRUE(reader.has_mesh_of(3, 0)) << "the generator's steps share one mesh";
  const Dataset first = read_time_step(*series, 0);
  for (const Field& field : first.blocks[0].fields) {
    SCOPED_TRACE(field.name());
    const MinMax expected = whole_read_range(*series, field.name()), got = values_range(series, 1, field.name());
    EXPECT_EQ(got.lo, expected.lo);
    EXPECT_EQ(got.hi, expected.hi);
  }
  const test::CommandResult r = test::run_ugvr("render " + pvd + " --time all --size 16 --out " + dir.file("frames"));
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(dir.file("frames") + "/steps.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["range"], "global");
  const MinMax expected = whole_read_range(*series, j["field"].get<std::string>());
  ASSERT_TRUE(expected.lo < expected.hi);
  for (const nlohmann::json& step : j["steps"]) {
    EXPECT_FLOAT_EQ(step["tf_range"][0].get<double>(), expected.lo);
    EXPECT_FLOAT_EQ(step["tf_range"][1].get<double>(), expected.hi);
  }
}

TEST(TimeRange, ExodusStepsGiveTheWholeReadsRange) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  const auto series = series_of(relative_data_path);
  StepFieldReader reader(series);
  EXPECT_TRUE(reader.has_mesh_of(20, 3));
  for (const char* field : {"convected", "diffused", "aux_elem"}) {
    SCOPED_TRACE(field);
    const MinMax expected = whole_read_range(*series, field), got = values_range(series, 0, field);
    EXPECT_EQ(got.lo, expected.lo);
    EXPECT_EQ(got.hi, expected.hi);
  }
  view::GridLoad load(series, 20, {"diffused", "aux_elem"}, 8);
  const view::GridLoad::State s = load_to_end(load);
  ASSERT_EQ(s.stage, view::GridLoad::Stage::Done) << s.error;
  for (size_t i = 0; i < 2; ++i) {
    const MinMax expected = whole_read_range(*series, load.grid().names[i]);
    EXPECT_EQ(load.grid().fields[i].min, expected.lo) << load.grid().names[i];
    EXPECT_EQ(load.grid().fields[i].max, expected.hi) << load.grid().names[i];
  }
}

}  // namespace
}  // namespace ugvr
