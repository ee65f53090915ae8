// The point sketch of an out-of-core build (octree/point_sketch.h): on a generated mesh with a field linear in x, every
// sample the sketch holds is within half a lattice spacing of the lattice point's x (the mean of points nearest to
// it, or a blend of two such means along a line); it covers the data of the final store at its level (and little
// outside it); it claims no exactness; its depth follows the point count; a cell field gets no sketch.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/octree/point_sketch.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// `ugvr generate`'s tetrahedra with a vertex field "x" (the point's x) beside its own.
std::string mesh_with_x(const ScratchDir& dir, uint64_t cells) {
  GenerateOptions g;
  g.cells = cells;
  g.kind = GenCellKind::Tet;
  Dataset ds = generate_in_memory(g);
  Block& b = ds.blocks.at(0);
  const auto& mesh = std::get<UnstructuredMesh>(b.grid);
  std::vector<float> x(mesh.points.size());
  for (size_t i = 0; i < x.size(); ++i) x[i] = mesh.points[i].x;
  b.fields.add(Field("x", Association::Vertex, DataArray::from(std::move(x), 1)));
  const std::string path = dir.file("wing.vtu");
  write_vtu(ds, path);
  return path;
}

OctreeBuildOptions sketch_options(const ScratchDir& dir) {
  OctreeBuildOptions o;
  o.resolution = 5;
  o.max_depth = 3;
  o.error = 0.01;
  o.encoding.samples = SampleEncoding::Float32;
  o.boundary_faces_per_node = 0;
  o.preview_depth = 2;
  o.point_sketch = true;
  o.sketch_path = dir.file("sketch.ugvr");
  return o;
}

TEST(PointSketch, DepthFollowsThePointCount) {
  // R = 32: level 1's lattice has 63³ points, level 2's 125³: four points each.
  EXPECT_EQ(point_sketch_depth(999'999, 32, 3), 0);
  EXPECT_EQ(point_sketch_depth(4 * 63 * 63 * 63, 32, 3), 1);
  EXPECT_EQ(point_sketch_depth(4 * 125 * 125 * 125, 32, 3), 2);
  EXPECT_EQ(point_sketch_depth(4 * 125 * 125 * 125, 32, 1), 1);  // never deeper than asked
  EXPECT_EQ(point_sketch_depth(uint64_t(1) << 40, 32, 2), 2);
}

TEST(PointSketch, LinearFieldWithinHalfASpacingAndCoveringTheData) {
  ScratchDir dir;
  const std::string vtu = mesh_with_x(dir, 200000);
  OctreeBuildOptions o = sketch_options(dir);
  std::string seen;
  int seen_depth = -1;
  o.on_sketch = [&](const std::string& path, int depth) {
    seen = path;
    seen_depth = depth;
    EXPECT_GT(BrickStoreReader(path).node_count(), 1u);  // complete when announced
  };
  const std::vector<std::string> fields = {"x"};
  const OctreeBuildStats st = build_octree_out_of_core(vtu, fields, o, uint64_t(64) << 20, dir.file("final.ugvr"));
  EXPECT_EQ(seen, o.sketch_path);
  ASSERT_EQ(st.sketch_depth, 2);  // about 34,000 points: level 2 (17³ lattice points)
  EXPECT_EQ(seen_depth, 2);
  const BrickStoreReader sketch(o.sketch_path), final_store(dir.file("final.ugvr"));
  EXPECT_EQ(sketch.layout().root.lo, final_store.layout().root.lo);
  EXPECT_EQ(sketch.layout().root.hi, final_store.layout().root.hi);
  const BrickStoreField& fx = sketch.layout().fields.at(0);
  EXPECT_EQ(sketch.stats(0, 0).error_max, float(fx.max - fx.min)) << "a sketch never claims exactness";

  const Bounds root = sketch.layout().root;
  const uint32_t R = sketch.resolution();
  const double G = double((R - 1) << 2);  // lattice intervals per axis at level 2
  const double h = (root.hi.x - root.lo.x) / G;
  const size_t n = size_t(R) * R * R;
  std::vector<float> vs(n), vf(n);
  std::vector<uint8_t> ms(n), mf(n);
  const auto places = test::nodes_by_place(sketch), final_places = test::nodes_by_place(final_store);
  uint64_t checked = 0, worst_over = 0, both = 0, final_only = 0, sketch_only = 0;
  double worst = 0;
  for (const auto& [place, id] : places) {
    if (place[0] != 2 || !sketch.node(id).has_brick()) continue;
    sketch.read_brick(id, 0, vs.data(), ms.data());
    const auto f = final_places.find(place);
    const bool final_brick = f != final_places.end() && final_store.node(f->second).has_brick();
    if (final_brick) final_store.read_brick(f->second, 0, vf.data(), mf.data());
    for (uint32_t s = 0; s < n; ++s) {
      const uint32_t x = s % R;
      const double lattice_x = root.lo.x + h * double(place[1] * (R - 1) + x);
      if (ms[s]) {
        ++checked;
        const double err = std::abs(double(vs[s]) - lattice_x);
        worst = std::max(worst, err / h);
        if (err > 0.5 * h * (1 + 1e-4) + 1e-6) ++worst_over;
      }
      if (final_brick) {
        both += ms[s] && mf[s];
        final_only += !ms[s] && mf[s];
        sketch_only += ms[s] && !mf[s];
      }
    }
  }
  std::printf(
      "sketch level 2: %llu samples, worst |x error| %.3f spacings; against the final store: %llu both, "
      "%llu final only, %llu sketch only\n",
      (unsigned long long)checked, worst, (unsigned long long)both, (unsigned long long)final_only,
      (unsigned long long)sketch_only);
  EXPECT_GT(checked, 500u);
  EXPECT_EQ(worst_over, 0u) << "worst " << worst << " spacings";
  EXPECT_GT(both, 9 * final_only) << "the sketch misses much of the data";
  EXPECT_GT(both, 4 * sketch_only) << "the sketch spills far outside the data";
  EXPECT_TRUE(std::filesystem::exists(o.sketch_path)) << "a chosen path is kept";
}

TEST(PointSketch, NoSketchForACellFieldOrTooFewPoints) {
  ScratchDir dir;
  const std::string vtu = mesh_with_x(dir, 20000);
  OctreeBuildOptions o = sketch_options(dir);
  bool called = false;
  o.on_sketch = [&](const std::string&, int) { called = true; };
  const std::vector<std::string> cell_field = {"wall_distance"};
  OctreeBuildStats st = build_octree_out_of_core(vtu, cell_field, o, uint64_t(64) << 20, dir.file("a.ugvr"));
  EXPECT_EQ(st.sketch_depth, 0);
  EXPECT_FALSE(called);
  o.resolution = 9;  // level 1's lattice: 17³ points, more than a quarter of the mesh's
  const std::vector<std::string> x = {"x"};
  st = build_octree_out_of_core(vtu, x, o, uint64_t(64) << 20, dir.file("b.ugvr"));
  EXPECT_EQ(st.sketch_depth, 0);
  EXPECT_FALSE(called);
  EXPECT_FALSE(std::filesystem::exists(o.sketch_path));
}

}  // namespace
}  // namespace ugvr
