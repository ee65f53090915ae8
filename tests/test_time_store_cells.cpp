// A store with time keeping the leaves' cells (`ugvr build SERIES --time all --cells`; store_format::kStepsHaveCells,
// docs/time-series.md "Stores with time"): the cell blocks are shared and each later step adds its values. Each step's
// cells, in core and out of core, are those of a store of that step alone; a corrupt values block is named; the hybrid
// engine draws a step after a switch as it draws the step's own store.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gl_test_support.h"
#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/time_series.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

const std::vector<std::string> kFields = {"pressure", "wall_distance"};  // a vertex field and a cell field

OctreeBuildOptions cell_options() {
  OctreeBuildOptions o;
  o.resolution = 5;
  o.max_depth = 3;
  o.error = 0;  // the tree is the geometry's: every step's own store has the time store's tree
  o.leaf_cells = true;
  return o;
}

// The generated series (the wake moving: pressure changes, wall_distance does not), 3 steps, and the stores of steps
// 0 and 2 alone, in core.
struct Series {
  ScratchDir dir;
  TimeSeries series;
  std::string step0, step2;
};
const Series& series() {
  static Series s;
  static const bool built = [] {
    const test::CommandResult g =
        test::run_ugvr("generate -o " + s.dir.file("w.pvd") + " --kind tet --cells 1500 --time-steps 3");
    EXPECT_EQ(g.status, 0) << g.out;
    s.series = list_time_steps(std::vector<std::string>{s.dir.file("w.pvd")});
    s.step0 = s.dir.file("s0.ugvr");
    s.step2 = s.dir.file("s2.ugvr");
    build_octree_steps(s.series, std::vector<uint32_t>{0}, kFields, cell_options(), s.step0);
    build_octree_steps(s.series, std::vector<uint32_t>{2}, kFields, cell_options(), s.step2);
    return true;
  }();
  (void)built;
  return s;
}

// Step `step` of `store` has, at every node with cells, the cells (geometry and values) of `alone` at that place.
void expect_step_cells(const BrickStoreReader& store, uint32_t step, const BrickStoreReader& alone) {
  SCOPED_TRACE("step " + std::to_string(step) + " of " + store.path());
  const auto at = test::nodes_by_place(alone);
  uint64_t blocks = 0;
  for (uint64_t n = 0; n < store.node_count(); ++n) {
    if (store.cell_block(n).offset == 0) continue;
    const BrickNode& node = store.node(n);
    const auto it = at.find({uint32_t(node.level), node.i, node.j, node.k});
    ASSERT_NE(it, at.end()) << "node " << n;
    EXPECT_EQ(store.read_cells(n, step), alone.read_cells(it->second)) << "node " << n;
    EXPECT_EQ(store.read_cell_values(n, step), alone.read_cells(it->second).values) << "node " << n;
    ++blocks;
  }
  EXPECT_EQ(blocks, alone.cells_header().block_count);
}

TEST(TimeStoreCells, EachStepsCellsAreThoseOfItsOwnStore) {
  const Series& s = series();
  const std::vector<uint32_t> steps = {0, 2};
  const std::string in_core = s.dir.file("t.ugvr"), ooc = s.dir.file("o.ugvr");
  const OctreeBuildStats a = build_octree_steps(s.series, steps, kFields, cell_options(), in_core);
  EXPECT_EQ(a.time_steps, 2u);
  const BrickStoreReader alone0(s.step0), alone2(s.step2);
  {
    const BrickStoreReader t(in_core);
    ASSERT_EQ(t.step_count(), 2u);
    EXPECT_NE(t.steps_header().flags & store_format::kStepsHaveCells, 0u);
    expect_step_cells(t, 0, alone0);
    expect_step_cells(t, 1, alone2);
  }
  // Out of core: with room, and at a budget so small that leaves are sampled (and their cells welded) in pieces.
  for (const uint64_t budget : {uint64_t(1), uint64_t(256) << 20}) {
    SCOPED_TRACE("budget " + std::to_string(budget));
    const OctreeBuildStats b = build_octree_out_of_core_steps(s.series, steps, kFields, cell_options(), budget, ooc);
    EXPECT_EQ(b.cell_blocks, a.cell_blocks);
    EXPECT_EQ(b.cell_bytes, a.cell_bytes);
    const BrickStoreReader o(ooc);
    expect_step_cells(o, 0, alone0);
    expect_step_cells(o, 1, alone2);
  }
}

// A byte of a values block changed: the store opens (the blocks are checked when read), step 0's cells still read, and
// the step's are refused naming the store, the step and the node.
TEST(TimeStoreCells, ACorruptValuesBlockIsNamed) {
  const Series& s = series();
  const std::string path = s.dir.file("corrupt.ugvr");
  build_octree_steps(s.series, std::vector<uint32_t>{0, 2}, kFields, cell_options(), path);
  uint64_t node = 0;
  store_format::CellBlockRecord r;
  {
    const BrickStoreReader t(path);
    while (node < t.node_count() && t.cell_block(node).offset == 0) ++node;
    ASSERT_LT(node, t.node_count());
    r = t.cell_values_block(node, 1);
    ASSERT_NE(r.offset, 0u);
  }
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(r.offset + r.size / 2));
    char c = 0;
    f.get(c);
    f.seekp(std::streamoff(r.offset + r.size / 2));
    f.put(char(c ^ 0x20));
  }
  const BrickStoreReader t(path);
  EXPECT_NO_THROW(t.read_cells(node, 0));
  for (const bool values_only : {false, true}) {
    try {
      if (values_only) {
        t.read_cell_values(node, 1);
      } else {
        t.read_cells(node, 1);
      }
      ADD_FAILURE() << "a corrupt values block was read";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find("time step 1 values of the cells of node " + std::to_string(node)), std::string::npos)
          << what;
      EXPECT_NE(what.find("checksum"), std::string::npos) << what;
    }
  }
}

// The hybrid engine on the time store: step 0, then (the prepared cells kept, their values swapped) step 1 draw as the
// stores of steps 0 and 2 alone, and the two steps differ.
TEST(TimeStoreCells, HybridDrawsEachStepAsItsOwnStore) {
  UGVR_REQUIRE_FILE_GL(gl);
  const Series& s = series();
  const std::string path = s.dir.file("hybrid.ugvr");
  build_octree_steps(s.series, std::vector<uint32_t>{0, 2}, kFields, cell_options(), path);
  const BrickStoreReader probe(path);
  const BrickStoreField& fd = probe.layout().fields[0];  // pressure, over the union of the steps' ranges
  const auto at = [&](double u) { return fd.min + u * (fd.max - fd.min); };
  TransferFunction tf;
  tf.color_points = {{at(0), {0.1, 0.2, 0.9}}, {at(0.5), {0.2, 0.9, 0.3}}, {at(1), {0.95, 0.2, 0.1}}};
  // Opaque over the low pressures of the vortex cores, which move between the steps; clear elsewhere.
  tf.opacity_points = {{at(0), 0.0}, {at(0.3), 0.0}, {at(0.35), 0.9}, {at(0.53), 0.9}, {at(0.56), 0.0}, {at(1), 0.0}};
  tf.opacity_unit_distance = 0.05 * probe.layout().data.size().x;
  RenderSettings rs;
  rs.width = rs.height = 48;
  rs.background = {0, 0, 0, 1};
  LodOptions ho;
  ho.hybrid = true;
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  const Camera cam = camera_preset("iso", probe.layout().data);
  auto draw = [&](LodEngine& e, LodRenderStats* st = nullptr) {
    e.set_field("pressure");
    return e.render(cam, tf, rs, leaves, st);
  };
  LodEngine time_store(path, *gl, ho), one0(s.step0, *gl, ho), one2(s.step2, *gl, ho);
  LodRenderStats st0, st1;
  const Image t0 = draw(time_store, &st0);
  time_store.set_time_step(1);
  const Image t1 = draw(time_store, &st1);
  EXPECT_GT(st1.exact_nodes, 2u);
  EXPECT_EQ(st1.exact_nodes, st0.exact_nodes);
  EXPECT_EQ(st1.cells_prepared, 0u) << "a step switch prepared the cells again";
  EXPECT_EQ(st1.cells_swapped, st1.exact_nodes);
  const Image a0 = draw(one0), a2 = draw(one2);
  const ImageDifference d0 = compare_images(t0, a0), d2 = compare_images(t1, a2);
  std::printf("step 0 vs its own store %.1f dB, step 2 %.1f dB, steps 0 vs 2 max difference %.3f\n", d0.psnr_db,
              d2.psnr_db, compare_images(t0, t1).max_abs);
  EXPECT_GE(d0.psnr_db, 60.0);
  EXPECT_GE(d2.psnr_db, 60.0);
  EXPECT_GT(compare_images(t0, t1).max_abs, 0.03) << "steps 0 and 2 draw the same";
}

}  // namespace
}  // namespace ugvr
