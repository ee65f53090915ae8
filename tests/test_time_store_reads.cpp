// How the in-core build of a store with time reads its steps (build_octree_steps, octree/step_loader.h; docs/
// time-series.md, "Stores with time"): the first step whole, every later step's fields alone where its files hold the
// first's mesh, read once per pass; the store the same, byte for byte, as the one built reading every step whole (the
// reads before). A .vtu series and an OpenFOAM case (the cavity fixture), each counted in bytes read; a step whose
// files are keyed otherwise (another encoding of the same mesh) is read whole and accepted, one with another mesh is
// refused.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "hex_fixtures.h"
#include "openfoam_fixtures.h"
#include "test_data.h"
#include "ugvr/core/file.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/octree/builder.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::bytes_read_so_far;
using test::ScratchDir;

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Step k of a series on unit_hex_mesh(n): a vertex field "f" whose waves move with k (so each step's own tree and
// bricks differ) and a cell field "c"; `moved` shifts point 0 (another mesh of the same counts).
Dataset wave_step(int n, int k, bool moved = false) {
  Block b = test::step_cube_block(n, 0.0, moved);
  const auto& mesh = std::get<UnstructuredMesh>(b.grid);
  std::vector<float> f, c;
  for (const Vec3f& q : mesh.points)
    f.push_back(float(std::sin(0.9 * q.x - 0.7 * k) * std::cos(0.5 * q.y + 0.3 * k) + 0.05 * q.z * k));
  for (uint64_t i = 0; i < mesh.cell_count(); ++i) c.push_back(float(std::sin(0.37 * double(i) + k)));
  b.fields = FieldSet();
  b.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(f), 1)));
  b.fields.add(Field("c", Association::Cell, DataArray::from(std::move(c), 1)));
  Dataset ds;
  ds.blocks.push_back(std::move(b));
  return ds;
}

// `count` steps as step_k.vtu and flow.pvd; step k written with `options(k)`, its dataset `step(k)`.
std::string write_series(const ScratchDir& dir, int count, const std::function<Dataset(int)>& step,
                         const std::function<VtuWriteOptions(int)>& options = {}) {
  std::vector<std::pair<double, std::string>> steps;
  for (int k = 0; k < count; ++k) {
    const std::string name = "step_" + std::to_string(k) + ".vtu";
    write_vtu(step(k), dir.file(name), options ? options(k) : VtuWriteOptions{});
    steps.emplace_back(0.5 * k, name);
  }
  write_pvd(dir.file("flow.pvd"), steps);
  return dir.file("flow.pvd");
}

// Options for stores compared byte for byte: one thread (the bricks are appended in the order they are made), an
// error above 0 (each step's own tree, then its bricks: two passes over the steps).
OctreeBuildOptions compared_options(bool whole_reads) {
  OctreeBuildOptions o;
  o.resolution = 5;
  o.max_depth = 3;
  o.error = 0.02;
  o.threads = 1;
  o.whole_step_reads = whole_reads;
  return o;
}

// The two builds of one series (fields-only reads, then whole reads): each one's stats and bytes read, and the two
// stores compared byte for byte. Returns {fields-only build, whole-read build}.
struct TwoBuilds {
  OctreeBuildStats fields_only, whole;
  uint64_t fields_only_bytes = 0, whole_bytes = 0;
};
TwoBuilds build_both_ways(const ScratchDir& dir, const TimeSeries& series, const std::vector<std::string>& fields) {
  std::vector<uint32_t> steps(series.size());
  for (uint32_t k = 0; k < steps.size(); ++k) steps[k] = k;
  TwoBuilds r;
  uint64_t before = bytes_read_so_far();
  r.fields_only = build_octree_steps(series, steps, fields, compared_options(false), dir.file("fields_only.ugvr"));
  r.fields_only_bytes = bytes_read_so_far() - before;
  before = bytes_read_so_far();
  r.whole = build_octree_steps(series, steps, fields, compared_options(true), dir.file("whole.ugvr"));
  r.whole_bytes = bytes_read_so_far() - before;
  const std::string a = file_bytes(dir.file("fields_only.ugvr")), b = file_bytes(dir.file("whole.ugvr"));
  EXPECT_GT(a.size(), 0u);
  EXPECT_TRUE(a == b) << "the stores differ (" << a.size() << " and " << b.size() << " bytes)";
  return r;
}

// Whether field `f` of some brick differs between steps s0 and s1 of a store.
bool steps_differ(const std::string& path, uint32_t f, uint32_t s0, uint32_t s1) {
  const BrickStoreReader r(path);
  const size_t n = size_t(r.resolution()) * r.resolution() * r.resolution();
  std::vector<float> a(n), b(n);
  for (uint64_t id = 0; id < r.node_count(); ++id) {
    if (!r.node(id).has_brick()) continue;
    r.read_brick(id, f, a.data(), nullptr, s0);
    r.read_brick(id, f, b.data(), nullptr, s1);
    if (a != b) return true;
  }
  return false;
}

// A .vtu series at --error > 0: step 0 read whole, then each step's fields alone (pass 1: steps 1..3; pass 2, the
// bricks: steps 0..3); the same store, byte for byte, as reading every step whole (8 whole reads). The bytes: step 0's
// file, the steps' geometry keys (their geometry's stored bytes hashed, once: the keys are cached) and their fields,
// against eight whole files.
TEST(TimeStoreReads, VtuStepsReadFieldsOnlyAndTheStoreIsTheSame) {
  ScratchDir dir;
  const int steps = 4;
  const TimeSeries series =
      list_time_steps(std::vector<std::string>{write_series(dir, steps, [](int k) { return wave_step(28, k); })});
  ASSERT_EQ(series.size(), size_t(steps));
  const TwoBuilds r = build_both_ways(dir, series, {"f", "c"});
  EXPECT_EQ(r.fields_only.whole_reads, 1u);
  EXPECT_EQ(r.fields_only.fields_only_reads, uint32_t(2 * steps - 1));
  EXPECT_EQ(r.whole.whole_reads, uint32_t(2 * steps));
  EXPECT_EQ(r.whole.fields_only_reads, 0u);
  EXPECT_GT(r.fields_only.nodes, 1u);
  EXPECT_TRUE(steps_differ(dir.file("whole.ugvr"), 0, 0, 3)) << "the steps' bricks are all the same";
  EXPECT_TRUE(steps_differ(dir.file("whole.ugvr"), 1, 1, 2)) << "the steps' cell-field bricks are all the same";
  if (bytes_read_so_far() != 0) {
    const uint64_t file = InputFile(series.steps[1].files[0]).size();
    EXPECT_GE(r.whole_bytes, uint64_t(2 * steps) * file) << "the counter sees the whole reads";
    // Step 0 whole, 4 keys (under a file each: 0.86 here), then 7 times the fields (8 bytes a point and cell), the
    // types array and the markup (0.2 a read): about 5.8 files.
    EXPECT_LT(r.fields_only_bytes, uint64_t(steps + 3) * file) << "later steps read whole";
  }
}

// A step whose files are keyed otherwise (written compressed: the same mesh, other stored bytes) is read whole; its
// geometry is the first step's by the fingerprint, so it is taken, and the steps after it with its keys read
// fields-only. A step with a moved point is read whole and refused, naming both steps.
TEST(TimeStoreReads, AStepKeyedOtherwiseIsReadWholeAndAMovedMeshRefused) {
  ScratchDir dir;
  const TimeSeries series = list_time_steps(std::vector<std::string>{write_series(
      dir, 4, [](int k) { return wave_step(8, k); },
      [](int k) {
        return VtuWriteOptions{k >= 2 ? Codec::Zlib : Codec::None, k >= 2 ? 6 : 0};
      })});
  const TwoBuilds r = build_both_ways(dir, series, {"f"});
  // Pass 1: 0 whole, 1 fields-only, 2 whole (zlib), 3 fields-only (2's keys); pass 2: 0..3 fields-only.
  EXPECT_EQ(r.fields_only.whole_reads, 2u);
  EXPECT_EQ(r.fields_only.fields_only_reads, 6u);

  ScratchDir moved_dir;
  const TimeSeries moved = list_time_steps(
      std::vector<std::string>{write_series(moved_dir, 3, [](int k) { return wave_step(8, k, /*moved=*/k == 2); })});
  const std::vector<uint32_t> all = {0, 1, 2};
  const std::vector<std::string> fields = {"f"};
  const std::string e = test::error_of(
      [&] { build_octree_steps(moved, all, fields, compared_options(false), moved_dir.file("m.ugvr")); });
  EXPECT_NE(e.find("the geometry of time step 2 differs from that of step 0"), std::string::npos) << e;
  EXPECT_FALSE(std::filesystem::exists(moved_dir.file("m.ugvr")));
}

// The cavity case (4 time directories on the constant mesh) with a point field in every step: step 0 read whole (the
// mesh's layout kept), the later steps' time directories alone; the same store as reading every step whole. The mesh's
// files are read once, against 8 times.
TEST(TimeStoreReads, OpenFoamStepsReadFieldsOnlyAndTheStoreIsTheSame) {
  ScratchDir dir;
  const std::string root = test::copy_openfoam_case(dir, "cavity");
  for (int k = 0; k <= 3; ++k)
    test::write_point_field(std::filesystem::path(root) / (k == 0 ? std::string("0") : "0." + std::to_string(k)), 882,
                            0.5 * (k + 1));
  const TimeSeries series = list_time_steps(std::vector<std::string>{root});
  ASSERT_EQ(series.kind, SeriesKind::OpenFoam);
  ASSERT_EQ(series.size(), 4u);
  const TwoBuilds r = build_both_ways(dir, series, {"p", "pw"});
  EXPECT_EQ(r.fields_only.whole_reads, 1u);
  EXPECT_EQ(r.fields_only.fields_only_reads, 7u);
  EXPECT_EQ(r.whole.whole_reads, 8u);
  EXPECT_TRUE(steps_differ(dir.file("whole.ugvr"), 0, 1, 3)) << "the steps' p bricks are all the same";
  if (bytes_read_so_far() != 0) {
    const uint64_t mesh = test::bytes_under(std::filesystem::path(root) / "constant" / "polyMesh");
    uint64_t times = 0;
    for (const char* t : {"0", "0.1", "0.2", "0.3"}) times += test::bytes_under(std::filesystem::path(root) / t);
    EXPECT_GE(r.whole_bytes, 8 * mesh) << "the counter sees the whole reads";
    // The mesh once; each time directory twice (a field file's first 4 KiB once more: has_foam_header), the
    // case's controlDict and such.
    EXPECT_LT(r.fields_only_bytes, mesh + 3 * times + 64 * 1024) << "later steps read the mesh";
  }
}

}  // namespace
}  // namespace ugvr
