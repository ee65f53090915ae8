// The leaves' cells written by the out-of-core build (`ugvr build --out-of-core --cells`; octree/out_of_core.h,
// octree/node_cells.h gather_welded_cells): every leaf's block decodes equal to the in-core store's (same cells, local
// indices, neighbour marks and values), with budgets so small that leaves are sampled in pieces and with room, over
// tetrahedra, a mixed mesh (hexahedra, wedges, pyramids: quadrilateral faces) around a wing (a boundary inside the
// box), and a face met three times (a duplicated cell: boundary, not a neighbour); and the hybrid engine draws both
// stores alike.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "gl_test_support.h"
#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// Hexahedra in a 3 x 1 x 1 row and a copy of the first: the face the first two share is met three times, which both
// topologies, the whole mesh's and a node's (the copies overlap the same nodes), call boundary.
Dataset duplicated_hexahedra() {
  UnstructuredMesh m;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 4; ++x) m.points.push_back({float(x), float(y), float(z)});
  auto id = [](int x, int y, int z) { return uint32_t(x + 4 * (y + 2 * z)); };
  for (int c : {0, 1, 2, 0}) {
    const uint32_t v[8] = {id(c, 0, 0), id(c + 1, 0, 0), id(c + 1, 1, 0), id(c, 1, 0),
                           id(c, 0, 1), id(c + 1, 0, 1), id(c + 1, 1, 1), id(c, 1, 1)};
    m.add_cell(CellType::Hexahedron, v);
  }
  std::vector<float> values(m.points.size());
  for (size_t i = 0; i < values.size(); ++i) values[i] = float(i % 5) + 0.25f * float(i);
  Dataset ds;
  ds.sources = {"dup"};
  Block b;
  b.name = "dup";
  b.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(values), 1)));
  b.grid = std::move(m);
  ds.blocks.push_back(std::move(b));
  return ds;
}

struct Compared {
  uint64_t blocks = 0, boundary = 0, outside = 0, inside = 0;
};

// Every node's cell block in `ooc` equals the in-core store's at the same place.
Compared expect_same_cells(const BrickStoreReader& in_core, const BrickStoreReader& ooc) {
  Compared c;
  EXPECT_TRUE(ooc.has_cells());
  EXPECT_EQ(in_core.cells_header().total_cells, ooc.cells_header().total_cells);
  EXPECT_EQ(in_core.cells_header().block_count, ooc.cells_header().block_count);
  const auto pa = test::nodes_by_place(in_core), pb = test::nodes_by_place(ooc);
  EXPECT_EQ(pa.size(), pb.size());
  for (const auto& [place, ia] : pa) {
    const auto it = pb.find(place);
    if (it == pb.end()) {
      ADD_FAILURE() << "node " << ia << " missing out of core";
      continue;
    }
    const uint64_t ib = it->second;
    EXPECT_EQ(in_core.cell_block(ia).offset == 0, ooc.cell_block(ib).offset == 0) << "node " << ia;
    if (in_core.cell_block(ia).offset == 0 || ooc.cell_block(ib).offset == 0) continue;
    const NodeCells a = in_core.read_cells(ia), b = ooc.read_cells(ib);
    EXPECT_EQ(a.ids, b.ids) << "node " << ia;
    EXPECT_EQ(a.types, b.types) << "node " << ia;
    EXPECT_EQ(a.connectivity, b.connectivity) << "node " << ia;
    EXPECT_EQ(a.across, b.across) << "node " << ia;
    EXPECT_EQ(a.points, b.points) << "node " << ia;
    EXPECT_EQ(a.values, b.values) << "node " << ia;
    ++c.blocks;
    for (uint32_t x : a.across) {
      c.boundary += x == store_format::kCellAcrossBoundary;
      c.outside += x == store_format::kCellAcrossOutside;
      c.inside += x < a.cell_count();
    }
  }
  return c;
}

OctreeBuildOptions cell_options(int depth, double error) {
  OctreeBuildOptions o;
  o.resolution = 8;
  o.max_depth = depth;
  o.error = error;
  o.leaf_cells = true;
  o.threads = 2;
  return o;
}

struct Case {
  const char* name;
  Dataset ds;
  std::vector<std::string> fields;
  int depth;
  double error;
  uint64_t max_leaf_cells = kDefaultMaxLeafCells;
};

TEST(OutOfCoreCells, SameBlocksAsInCore) {
  ScratchDir dir;
  std::vector<Case> cases;
  cases.push_back(
      {"tetrahedra", test::generated_with_cell_field(GenCellKind::Tet, 3000), {"pressure", "cell97"}, 3, 0.01});
  cases.push_back(
      {"mixed", test::generated_with_cell_field(GenCellKind::Mixed, 3000), {"pressure", "cell97"}, 3, 0.02});
  cases.push_back(
      {"mixed, root only", test::generated_with_cell_field(GenCellKind::Mixed, 3000), {"pressure"}, 0, 0.02});
  cases.push_back({"duplicated hexahedra", duplicated_hexahedra(), {"f"}, 1, 0.0});
  // Leaves capped at 150 cells: split past --max-depth 1 where the split test alone would keep them whole.
  cases.push_back({"tetrahedra, leaves capped",
                   test::generated_with_cell_field(GenCellKind::Tet, 3000),
                   {"pressure"},
                   1,
                   0.01,
                   150});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string vtu = dir.file("m.vtu");
    write_vtu(c.ds, vtu);
    // In core from the file as read back, so that both builds see the same floats.
    const Dataset back = read_dataset(std::vector<std::string>{vtu});
    const OctreeInput in = prepare_octree_input(back, c.fields);
    OctreeBuildOptions o = cell_options(c.depth, c.error);
    o.max_leaf_cells = c.max_leaf_cells;
    const OctreeBuildStats a = build_octree(in, o, dir.file("in.ugvr"));
    const BrickStoreReader in_core(dir.file("in.ugvr"));
    if (c.max_leaf_cells < 3000) {
      EXPECT_GT(a.max_level, c.depth) << "no leaf split past --max-depth";
      EXPECT_LE(a.max_level, c.depth + kLeafCellsExtraDepth);
      for (uint64_t n = 0; n < in_core.node_count(); ++n) {
        const OctreeNode& node = in_core.nodes()[n];
        if (!node.is_leaf() || in_core.cell_block(n).offset == 0 || node.level >= deepest_level(o)) continue;
        EXPECT_LE(in_core.cell_block_header(n).cell_count, c.max_leaf_cells) << "leaf " << n;
      }
    }
    // A budget of 1 byte (64 KiB of records per worker: leaves sampled in pieces), and one with room.
    for (const uint64_t budget : {uint64_t(1), uint64_t(256) << 20}) {
      SCOPED_TRACE("budget " + std::to_string(budget));
      const OctreeBuildStats b = build_octree_out_of_core(vtu, c.fields, o, budget, dir.file("ooc.ugvr"));
      EXPECT_EQ(a.nodes, b.nodes);
      EXPECT_EQ(a.leaves, b.leaves);
      EXPECT_EQ(a.cell_blocks, b.cell_blocks);
      EXPECT_EQ(a.leaf_cells, b.leaf_cells);
      EXPECT_EQ(a.cell_bytes, b.cell_bytes);
      const BrickStoreReader ooc(dir.file("ooc.ugvr"));
      const Compared k = expect_same_cells(in_core, ooc);
      EXPECT_EQ(k.blocks, b.cell_blocks);
      EXPECT_GT(k.boundary, 0u);
      if (a.leaves > 1) {  // a cell across a leaf border
        EXPECT_GT(k.outside, 0u);
      }
      std::printf(
          "%s, budget %llu: %llu blocks, %llu cells, %llu bytes, %llu leaves in pieces; faces %llu inside, %llu "
          "outside, %llu boundary\n",
          c.name, (unsigned long long)budget, (unsigned long long)b.cell_blocks, (unsigned long long)b.leaf_cells,
          (unsigned long long)b.cell_bytes, (unsigned long long)b.leaves_in_pieces, (unsigned long long)k.inside,
          (unsigned long long)k.outside, (unsigned long long)k.boundary);
      if (budget == 1 && std::string(c.name) != "duplicated hexahedra" && c.max_leaf_cells >= 3000) {
        EXPECT_GT(b.leaves_in_pieces, 0u) << "no leaf in pieces";
      }
      // 150 cells of records fit the 64 KiB a worker has at the least: no leaf is sampled (and welded) in pieces.
      if (c.max_leaf_cells < 3000) {
        EXPECT_EQ(b.leaves_in_pieces, 0u);
      }
    }
  }
}

// The hybrid engine, converged (every leaf with cells exact), draws the out-of-core store as the in-core one, bit for
// bit, from an oblique view and along an axis.
TEST(OutOfCoreCells, HybridImageAsInCore) {
  UGVR_REQUIRE_FILE_GL(gl);
  ScratchDir dir;
  const std::string vtu = dir.file("m.vtu");
  write_vtu(test::generated_with_cell_field(GenCellKind::Mixed, 3000), vtu);
  const Dataset back = read_dataset(std::vector<std::string>{vtu});
  const std::vector<std::string> fields = {"pressure"};
  const OctreeBuildOptions o = cell_options(3, 0.02);
  build_octree(prepare_octree_input(back, fields), o, dir.file("in.ugvr"));
  build_octree_out_of_core(vtu, fields, o, 1, dir.file("ooc.ugvr"));
  const BrickStoreReader probe(dir.file("in.ugvr"));
  const BrickStoreField& fd = probe.layout().fields[0];
  const auto at = [&](double u) { return fd.min + u * (fd.max - fd.min); };
  TransferFunction tf;
  tf.color_points = {{at(0), {0.1, 0.2, 0.9}}, {at(0.5), {0.2, 0.9, 0.3}}, {at(1), {0.95, 0.2, 0.1}}};
  tf.opacity_points = {{at(0), 0.0}, {at(0.45), 0.0}, {at(0.55), 0.9}, {at(1), 0.9}};
  tf.opacity_unit_distance = 0.05 * probe.layout().data.size().x;
  RenderSettings rs;
  rs.width = rs.height = 64;
  rs.background = {0, 0, 0, 1};
  LodOptions ho;
  ho.hybrid = true;
  LodEngine a(dir.file("in.ugvr"), *gl, ho), b(dir.file("ooc.ugvr"), *gl, ho);
  a.set_field("pressure");
  b.set_field("pressure");
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  for (const char* view : {"iso", "+x"}) {
    const Camera cam = camera_preset(view, probe.layout().data);
    LodRenderStats sa, sb;
    const Image ia = a.render(cam, tf, rs, leaves, &sa);
    const Image ib = b.render(cam, tf, rs, leaves, &sb);
    EXPECT_TRUE(sb.hybrid) << view;
    EXPECT_GT(sb.exact_nodes, 4u) << view;
    EXPECT_EQ(sa.exact_nodes, sb.exact_nodes) << view;
    EXPECT_EQ(sa.exact_cells, sb.exact_cells) << view;
    EXPECT_EQ(sa.cell_steps, sb.cell_steps) << view;
    EXPECT_EQ(compare_images(ia, ib).max_abs, 0.0) << view;
  }
}

// `ugvr view MESH.vtu` over its memory budget builds the store out of core with the leaves' cells (the viewer then
// draws it hybrid, exact at rest): the store that appears in the cache keeps them, under a name of its own.
TEST(OutOfCoreCells, ViewerOverItsBudgetBuildsTheStoreWithCells) {
  ScratchDir dir;
  const std::string mesh = dir.file("tets.vtu");
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + mesh).status, 0);
  const std::string cache = dir.file("cache");
  const std::string log = dir.file("view.txt");
  // --tabs-memory: the tabs' budget is the memory budget by default, too small here for a tab (not needed anyway).
  const std::string r =
      test::run_command(
          "UGVR_CACHE_DIR=" + cache + " timeout 120 " + std::string(UGVR_BINARY) + " view " + mesh +
          " --size 64 --max-depth 3 --memory-budget 100kB --tabs-memory 1GiB > " + log +
          " 2>&1 & pid=$!; for i in $(seq 1200); do ls " + cache +
          "/tets-*.ugvr >/dev/null 2>&1 && break; sleep 0.1; done; kill -TERM $pid; wait $pid; echo rc=$?; cat " + log)
          .out;
  if (r.find("OpenGL") != std::string::npos && std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << r;
  EXPECT_NE(r.find("rc=0"), std::string::npos) << r;
  EXPECT_NE(r.find("out of core with its cells"), std::string::npos) << r;
  std::vector<std::string> stores;
  for (const auto& e : std::filesystem::directory_iterator(cache))
    if (e.path().extension() == ".ugvr") stores.push_back(e.path().string());
  ASSERT_EQ(stores.size(), 1u) << r;
  const BrickStoreReader store(stores[0]);
  EXPECT_TRUE(store.has_cells());
  EXPECT_GT(store.cells_header().block_count, 1u);
}

}  // namespace
}  // namespace ugvr
