// A store with time built out of core (build_octree_out_of_core_steps; docs/time-series.md, "Stores with time"):
// the same store as the in-core build of the same series, the geometry checked as the steps stream by, a progress
// bar per step, and `ugvr build SERIES --time --out-of-core` then `ugvr info`.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::run_ugvr;

// A generated series of `steps` steps (the wake's vortex street moving) as NAME.pvd and NAME_000k.vtu.
TimeSeries generated_series(const test::ScratchDir& dir, int cells, int steps) {
  const test::CommandResult g = run_ugvr("generate -o " + dir.file("w.pvd") + " --kind tet --cells " +
                                         std::to_string(cells) + " --time-steps " + std::to_string(steps));
  EXPECT_EQ(g.status, 0) << g.out;
  return list_time_steps(std::vector<std::string>{dir.file("w.pvd")});
}

OctreeBuildOptions options_at_error_0(int max_depth) {
  OctreeBuildOptions o;
  o.resolution = 5;
  o.max_depth = max_depth;
  o.error = 0;
  return o;
}

// Step `step` of both stores: the same tree (by place), each brick bit for bit (both quantized over the step's own
// range), the same leaf errors and transfer-function error entries; an interior node's error can only be lower out
// of core (measured at its children's samples alone, docs/octree-build.md).
void expect_same_step(BrickStoreReader& in_core, BrickStoreReader& ooc, uint32_t step) {
  SCOPED_TRACE("step " + std::to_string(step));
  in_core.set_step(step);
  ooc.set_step(step);
  ASSERT_EQ(in_core.node_count(), ooc.node_count());
  for (uint32_t f = 0; f < in_core.field_count(); ++f) {
    EXPECT_EQ(in_core.step_range(step, f).min, ooc.step_range(step, f).min);
    EXPECT_EQ(in_core.step_range(step, f).max, ooc.step_range(step, f).max);
  }
  test::expect_same_nodes_and_bricks(in_core, ooc, [&](uint64_t ia, uint64_t ib, uint32_t f) {
    const auto& ta = in_core.tf_errors()[ia * in_core.field_count() + f];
    const auto& tb = ooc.tf_errors()[ib * ooc.field_count() + f];
    EXPECT_EQ(ta.bound[0], tb.bound[0]) << "node " << ia;
  });
}

// Whether some brick of field `f` differs between two steps of a store (the series is not the same step thrice).
bool steps_differ(const BrickStoreReader& r, uint32_t f, uint32_t s0, uint32_t s1) {
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

TEST(OutOfCoreSteps, SameStoreAsInCore) {
  test::ScratchDir dir;
  const TimeSeries series = generated_series(dir, 4000, 3);
  ASSERT_EQ(series.size(), 3u);
  const std::vector<uint32_t> steps = {0, 1, 2};
  const std::vector<std::string> fields = {"pressure", "wall_distance"};
  for (const bool float32 : {true, false}) {
    SCOPED_TRACE(float32 ? "float32" : "quant16");
    OctreeBuildOptions o = options_at_error_0(4);
    if (float32) o.encoding.samples = SampleEncoding::Float32;
    const OctreeBuildStats a = build_octree_steps(series, steps, fields, o, dir.file("in.ugvr"));
    // A budget so small that the larger leaves are sampled in pieces, and one with room (the boundary kept).
    for (const uint64_t budget : {uint64_t(1), uint64_t(256) << 20}) {
      SCOPED_TRACE("budget " + std::to_string(budget));
      const OctreeBuildStats b = build_octree_out_of_core_steps(series, steps, fields, o, budget, dir.file("ooc.ugvr"));
      EXPECT_EQ(b.time_steps, 3u);
      EXPECT_EQ(a.nodes, b.nodes);
      EXPECT_EQ(a.leaves, b.leaves);
      EXPECT_EQ(a.cells, b.cells);
      if (budget == 1) {
        EXPECT_GT(b.leaves_in_pieces, 0u);
      }
      BrickStoreReader in_core(dir.file("in.ugvr")), ooc(dir.file("ooc.ugvr"));
      ASSERT_EQ(ooc.step_count(), 3u);
      for (uint32_t s = 0; s < 3; ++s) {
        EXPECT_EQ(ooc.step_time(s), in_core.step_time(s));
        expect_same_step(in_core, ooc, s);
      }
      // The field records hold the union of the steps' ranges, as in core.
      for (uint32_t f = 0; f < 2; ++f) {
        EXPECT_EQ(in_core.layout().fields[f].min, ooc.layout().fields[f].min);
        EXPECT_EQ(in_core.layout().fields[f].max, ooc.layout().fields[f].max);
      }
      EXPECT_TRUE(steps_differ(ooc, 0, 0, 2)) << "the steps' pressure bricks are all the same";
      EXPECT_EQ(ooc.has_boundary(), budget > 1);
      if (budget > 1) {
        EXPECT_EQ(ooc.boundary().triangles.size(), in_core.boundary().triangles.size());
      }
    }
  }
  // Nothing is left beside the output (the scratch folder of cells is gone).
  EXPECT_FALSE(std::filesystem::exists(dir.file("ooc.ugvr.cells")));
}

// One progress bar per step, for writing its cells (the first step) or its values (the later ones) and for its
// bricks, each finished.
TEST(OutOfCoreSteps, ProgressPerStep) {
  test::ScratchDir dir;
  const TimeSeries series = generated_series(dir, 2000, 2);
  OctreeBuildOptions o = options_at_error_0(3);
  std::set<std::string> finished;
  o.progress = [&](const std::string& label, double fraction) {
    if (fraction >= 1.0) finished.insert(label);
  };
  const std::vector<uint32_t> steps = {0, 1};
  build_octree_out_of_core_steps(series, steps, {}, o, uint64_t(256) << 20, dir.file("o.ugvr"));
  EXPECT_TRUE(finished.count("step 1/2 (#0, t = 0): cells to disk"));
  EXPECT_TRUE(finished.count("step 2/2 (#1, t = 0.5): values to disk"));
  EXPECT_FALSE(finished.count("step 2/2 (#1, t = 0.5): cells to disk")) << "a later step wrote a soup";
  for (const std::string k : {"1/2 (#0, t = 0)", "2/2 (#1, t = 0.5)"})
    EXPECT_TRUE(finished.count("step " + k + ": bricks")) << k;
}

// The scratch folder's files, by the name before the first '-' or digit ("node", "leaf", "values", "root", ...).
std::set<std::string> scratch_kinds(const std::string& folder) {
  std::set<std::string> kinds;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = e.path().filename().string();
    kinds.insert(name.substr(0, name.find_first_of("-0123456789")));
  }
  return kinds;
}

// A later step routes nothing: its bricks are made from the leaves the first step kept (leaf-<id>) and the step's
// values, with no soup ("root") and no interior node's files ("node-...") in the scratch folder; it samples in pieces
// the leaves the first step did (at a budget that forces pieces), and the store is still the in-core one.
TEST(OutOfCoreSteps, LaterStepsGatherTheKeptLeavesWithoutRouting) {
  test::ScratchDir dir;
  const TimeSeries series = generated_series(dir, 4000, 3);
  const std::vector<uint32_t> steps = {0, 1, 2};
  const std::vector<std::string> fields = {"pressure", "wall_distance"};
  OctreeBuildOptions o = options_at_error_0(4);
  const std::string scratch = dir.file("ooc.ugvr.cells");
  std::map<std::string, std::set<std::string>> seen;  // progress label -> the scratch folder's kinds of files
  o.progress = [&](const std::string& label, double) {
    for (const std::string& k : scratch_kinds(scratch)) seen[label].insert(k);
  };
  build_octree_out_of_core_steps(series, steps, fields, o, 1, dir.file("ooc.ugvr"));
  const std::string first = "step 1/3 (#0, t = 0): bricks", later = "step 3/3 (#2, t = 0.666667): bricks";
  ASSERT_TRUE(seen.count(first) && seen.count(later)) << seen.rbegin()->first;
  EXPECT_TRUE(seen[first].count("node")) << "the first step routes through interior nodes";
  EXPECT_TRUE(seen[later].count("leaf"));
  EXPECT_TRUE(seen[later].count("values"));
  EXPECT_FALSE(seen[later].count("node")) << "a later step routed cells through interior nodes";
  EXPECT_FALSE(seen[later].count("root")) << "a later step wrote a soup";
  EXPECT_FALSE(std::filesystem::exists(scratch));

  // Pieces in every step: three times those of the first step built alone at the same budget.
  const std::vector<uint32_t> one = {0};
  o.progress = nullptr;
  const OctreeBuildStats a = build_octree_out_of_core_steps(series, one, fields, o, 1, dir.file("one.ugvr"));
  const OctreeBuildStats b = build_octree_out_of_core_steps(series, steps, fields, o, 1, dir.file("ooc.ugvr"));
  ASSERT_GT(a.leaves_in_pieces, 0u);
  EXPECT_EQ(b.leaves_in_pieces, 3 * a.leaves_in_pieces);
  const OctreeBuildStats c = build_octree_steps(series, steps, fields, o, dir.file("in.ugvr"));
  EXPECT_EQ(c.nodes, b.nodes);
  BrickStoreReader in_core(dir.file("in.ugvr")), ooc(dir.file("ooc.ugvr"));
  for (uint32_t s = 0; s < 3; ++s) expect_same_step(in_core, ooc, s);
}

// A field that is point data in one step and cell data in the next: a later step's records are the first step's
// geometry laid out for its own fields, so the store is still the in-core one.
TEST(OutOfCoreSteps, AFieldThatMovesBetweenPointsAndCells) {
  test::ScratchDir dir;
  ASSERT_EQ(run_ugvr("generate -o " + dir.file("p_0001.vtu") + " --kind tet --cells 2000").status, 0);
  Dataset d = read_dataset(std::vector<std::string>{dir.file("p_0001.vtu")});
  const auto& mesh = std::get<UnstructuredMesh>(d.blocks[0].grid);
  const Field* pressure = d.blocks[0].fields.find("pressure");
  ASSERT_NE(pressure, nullptr);
  ASSERT_EQ(pressure->association(), Association::Vertex);
  FieldSet moved;
  for (const Field& f : d.blocks[0].fields)
    if (f.name() != "pressure") moved.add(f);
  std::vector<float> per_cell(size_t(mesh.cell_count()));
  for (size_t c = 0; c < per_cell.size(); ++c) per_cell[c] = float(c % 97) * 0.25f - 3.0f;
  moved.add(Field("pressure", Association::Cell, DataArray::from(std::move(per_cell), 1)));
  d.blocks[0].fields = std::move(moved);
  write_vtu(d, dir.file("p_0002.vtu"));
  const TimeSeries series = list_time_steps(std::vector<std::string>{dir.file("p_%04d.vtu")});
  const std::vector<uint32_t> steps = {0, 1};
  const std::vector<std::string> fields = {"pressure", "velocity:x"};
  const OctreeBuildOptions o = options_at_error_0(3);
  build_octree_steps(series, steps, fields, o, dir.file("in.ugvr"));
  for (const uint64_t budget : {uint64_t(1), uint64_t(256) << 20}) {
    SCOPED_TRACE("budget " + std::to_string(budget));
    build_octree_out_of_core_steps(series, steps, fields, o, budget, dir.file("ooc.ugvr"));
    BrickStoreReader in_core(dir.file("in.ugvr")), ooc(dir.file("ooc.ugvr"));
    for (uint32_t s = 0; s < 2; ++s) expect_same_step(in_core, ooc, s);
    EXPECT_EQ(ooc.step_range(1, 0).min, -3.0f);
  }
}

// A .vtu of 8 hexahedra on a 3 x 3 x 3 point lattice with a triangle between each two (the build drops them), a
// vertex field "p" and a cell field "c" scaled by `scale`, in ASCII.
void write_hexes_and_triangles(const std::string& path, float scale) {
  std::ofstream f(path);
  f << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n<UnstructuredGrid>\n"
    << "<Piece NumberOfPoints=\"27\" NumberOfCells=\"16\">\n<Points><DataArray type=\"Float32\" "
    << "NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (int z = 0; z < 3; ++z)
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x) f << x << " " << y << " " << z << "\n";
  f << "</DataArray></Points>\n<Cells><DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  auto id = [](int x, int y, int z) { return x + 3 * (y + 3 * z); };
  std::string offsets, types;
  int offset = 0;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) {
        f << id(x, y, z) << " " << id(x + 1, y, z) << " " << id(x + 1, y + 1, z) << " " << id(x, y + 1, z) << " "
          << id(x, y, z + 1) << " " << id(x + 1, y, z + 1) << " " << id(x + 1, y + 1, z + 1) << " "
          << id(x, y + 1, z + 1) << "\n";
        f << id(x, y, z) << " " << id(x + 1, y, z) << " " << id(x, y + 1, z) << "\n";
        offset += 8;
        offsets += std::to_string(offset) + " ";
        offset += 3;
        offsets += std::to_string(offset) + " ";
        types += "12 5 ";
      }
  f << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">" << offsets
    << "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">" << types
    << "</DataArray>\n</Cells>\n<PointData><DataArray type=\"Float32\" Name=\"p\" format=\"ascii\">\n";
  for (int i = 0; i < 27; ++i) f << scale * float((i * 7) % 11) << " ";
  f << "</DataArray></PointData>\n<CellData><DataArray type=\"Float32\" Name=\"c\" format=\"ascii\">\n";
  for (int c = 0; c < 16; ++c) f << (c % 2 ? 1000.0f : scale * float(c * c % 13)) << " ";
  f << "</DataArray></CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
}

// A later step's cell values are found by the cell's index in its file, which counts the cells the build drops
// (here a triangle after each hexahedron, with a cell value far outside the hexahedra's): the same store as in core.
TEST(OutOfCoreSteps, CellValuesOfAFileWithDroppedCells) {
  test::ScratchDir dir;
  write_hexes_and_triangles(dir.file("h_0001.vtu"), 1.0f);
  write_hexes_and_triangles(dir.file("h_0002.vtu"), -2.0f);
  const TimeSeries series = list_time_steps(std::vector<std::string>{dir.file("h_%04d.vtu")});
  ASSERT_EQ(series.size(), 2u);
  const std::vector<uint32_t> steps = {0, 1};
  const std::vector<std::string> fields = {"c", "p"};
  const OctreeBuildOptions o = options_at_error_0(2);
  build_octree_steps(series, steps, fields, o, dir.file("in.ugvr"));
  build_octree_out_of_core_steps(series, steps, fields, o, uint64_t(256) << 20, dir.file("ooc.ugvr"));
  BrickStoreReader in_core(dir.file("in.ugvr")), ooc(dir.file("ooc.ugvr"));
  for (uint32_t s = 0; s < 2; ++s) expect_same_step(in_core, ooc, s);
  EXPECT_EQ(ooc.step_range(1, 0).min, -2.0f * 12);  // the hexahedra's, not the triangles' 1000
  EXPECT_EQ(ooc.step_range(1, 0).max, 0.0f);
  EXPECT_TRUE(steps_differ(ooc, 0, 0, 1));
}

// A step of other geometry stops the build naming both steps, whether its cells differ or only a point moved; nothing
// is written.
TEST(OutOfCoreSteps, RefusesAStepOfOtherGeometry) {
  test::ScratchDir dir;
  ASSERT_EQ(run_ugvr("generate -o " + dir.file("g_0001.vtu") + " --kind tet --cells 2000").status, 0);
  ASSERT_EQ(run_ugvr("generate -o " + dir.file("g_0002.vtu") + " --kind tet --cells 3000").status, 0);
  // The same cells with one point moved by 1e-3 (read, moved, written again): the hash sees it, the routing may not.
  Dataset moved = read_dataset(std::vector<std::string>{dir.file("g_0001.vtu")});
  auto& mesh = std::get<UnstructuredMesh>(moved.blocks[0].grid);
  mesh.points[7].x += 1e-3f;
  write_vtu(moved, dir.file("m_0002.vtu"));
  std::filesystem::copy_file(dir.file("g_0001.vtu"), dir.file("m_0001.vtu"));
  for (const std::string pattern : {"g_%04d.vtu", "m_%04d.vtu"}) {
    SCOPED_TRACE(pattern);
    const TimeSeries series = list_time_steps(std::vector<std::string>{dir.file(pattern)});
    const std::vector<uint32_t> steps = {0, 1};
    const std::string e = test::error_of([&] {
      build_octree_out_of_core_steps(series, steps, {}, options_at_error_0(3), uint64_t(256) << 20, dir.file("x.ugvr"));
    });
    EXPECT_NE(e.find("the geometry of time step 1 differs from that of step 0"), std::string::npos) << e;
    EXPECT_NE(e.find("build one store per step"), std::string::npos) << e;
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.ugvr")));
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.ugvr.cells")));
  }
}

// What it cannot build, refused up front with advice: --error > 0, a step that is not one .vtu file (named).
TEST(OutOfCoreSteps, RefusesWhatItCannotBuild) {
  test::ScratchDir dir;
  const TimeSeries series = generated_series(dir, 2000, 2);
  const std::vector<uint32_t> steps = {0, 1};
  OctreeBuildOptions o = options_at_error_0(3);
  o.error = 0.01;
  std::string e = test::error_of(
      [&] { build_octree_out_of_core_steps(series, steps, {}, o, uint64_t(256) << 20, dir.file("x.ugvr")); });
  EXPECT_NE(e.find("--error 0 only"), std::string::npos) << e;
  EXPECT_NE(e.find("leave out --out-of-core"), std::string::npos) << e;
  EXPECT_NE(e.find("largest selected step is " + dir.file("w_000")), std::string::npos) << e;
  // The advice's command for one store per step builds (a series with --time-step is no out-of-core input).
  const std::string command = "ugvr build " + dir.file("w_0000.vtu") + " --out-of-core --error 0.01 -o ";
  const size_t at = e.find(command);
  ASSERT_NE(at, std::string::npos) << e;
  EXPECT_NE(e.find("likewise for the other 1 step(s)"), std::string::npos) << e;
  const std::string output = e.substr(at + command.size(), e.find(' ', at + command.size()) - at - command.size());
  EXPECT_EQ(output, dir.file("w_0000.ugvr"));
  const test::CommandResult per_step =
      run_ugvr("--quiet " + e.substr(at + 5, command.size() - 5) + output + " --max-depth 3 --memory 64MiB");
  EXPECT_EQ(per_step.status, 0) << per_step.out;
  EXPECT_TRUE(std::filesystem::exists(output));

  // A .series whose second step is a legacy .vtk file.
  std::filesystem::copy_file(dir.file("w_0001.vtu"), dir.file("b.vtk"));
  {
    std::ofstream f(dir.file("mixed.series"));
    f << R"({"files": [{"name": "w_0000.vtu", "time": 0}, {"name": "b.vtk", "time": 1}]})";
  }
  const TimeSeries mixed = list_time_steps(std::vector<std::string>{dir.file("mixed.series")});
  EXPECT_FALSE(out_of_core_steps_possible(mixed, steps));
  e = test::error_of([&] {
    build_octree_out_of_core_steps(mixed, steps, {}, options_at_error_0(3), uint64_t(256) << 20, dir.file("x.ugvr"));
  });
  EXPECT_NE(e.find("time step 1 is "), std::string::npos) << e;
  EXPECT_NE(e.find("b.vtk"), std::string::npos) << e;
  EXPECT_NE(e.find("one .vtu file each"), std::string::npos) << e;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.ugvr")));
}

// The command line: `ugvr build SERIES --time all --out-of-core`, then `ugvr info` lists the steps; without
// --out-of-core a step too large for --memory is built out of core by itself (and says so).
TEST(OutOfCoreSteps, CommandLineBuildsAndInfoListsTheSteps) {
  test::ScratchDir dir;
  generated_series(dir, 3000, 3);
  const std::string common = " --time all --brick 8 --max-depth 4 --error 0 --fields pressure ";
  const test::CommandResult b =
      run_ugvr("build " + dir.file("w.pvd") + common + "--out-of-core --memory 64MiB --json -o " + dir.file("o.ugvr"));
  ASSERT_EQ(b.status, 0) << b.out;
  EXPECT_NE(b.out.find("\"out_of_core\":true"), std::string::npos) << b.out;
  EXPECT_NE(b.out.find("\"time_steps\":3"), std::string::npos) << b.out;
  const test::CommandResult info = run_ugvr("info " + dir.file("o.ugvr"));
  ASSERT_EQ(info.status, 0) << info.out;
  EXPECT_NE(info.out.find("time:     3 steps"), std::string::npos) << info.out;
  // A --memory so small that the first step's file is over 40% of it: out of core without asking.
  const uint64_t step_bytes = std::filesystem::file_size(dir.file("w_0000.vtu"));
  const test::CommandResult a = run_ugvr("build " + dir.file("w.pvd") + common + "--memory " +
                                         std::to_string(step_bytes * 2) + " -o " + dir.file("a.ugvr"));
  ASSERT_EQ(a.status, 0) << a.out;
  EXPECT_NE(a.out.find("note: building out of core"), std::string::npos) << a.out;
  // The same store as the explicit build.
  BrickStoreReader x(dir.file("o.ugvr")), y(dir.file("a.ugvr"));
  for (uint32_t s = 0; s < 3; ++s) expect_same_step(x, y, s);
}

}  // namespace
}  // namespace ugvr
