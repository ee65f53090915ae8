// Partitioned stores built out of core (`ugvr build MESH.vtu --pieces N --out-of-core`; mpi/piece_build_ooc.h): the
// plan's sample is the in-core mesh's centroids bit for bit, and each piece's store equals the in-core piece build of
// the same plan (the tree, every brick bit for bit, the leaves' errors, the counts), at budgets small enough that
// leaves are sampled in pieces; a file changed since the plan is refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/mesh_part.h"
#include "ugvr/mpi/piece_build.h"
#include "ugvr/mpi/piece_build_ooc.h"
#include "ugvr/octree/input.h"
#include "ugvr/octree/vtu_cells.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

OctreeBuildOptions small_options(uint32_t resolution, int max_depth, double error) {
  OctreeBuildOptions o;
  o.resolution = resolution;
  o.max_depth = max_depth;
  o.error = error;
  o.encoding.samples = SampleEncoding::Float32;  // lossless: the samples compare bit for bit
  return o;
}

// The same tree (by place: out of core, node ids follow the schedule), the same bricks bit for bit, the same leaf
// errors; an interior node's error can only be lower out of core (measured at its children's samples alone).
void expect_same_piece(const BrickStoreReader& in_core, const BrickStoreReader& ooc) {
  ASSERT_EQ(in_core.node_count(), ooc.node_count());
  EXPECT_EQ(in_core.layout().root.lo, ooc.layout().root.lo);
  EXPECT_EQ(in_core.layout().root.hi, ooc.layout().root.hi);
  EXPECT_EQ(in_core.layout().data.lo, ooc.layout().data.lo);
  EXPECT_EQ(in_core.layout().data.hi, ooc.layout().data.hi);
  ASSERT_EQ(in_core.field_count(), ooc.field_count());
  for (uint32_t f = 0; f < in_core.field_count(); ++f) {
    EXPECT_EQ(in_core.layout().fields[f].min, ooc.layout().fields[f].min);
    EXPECT_EQ(in_core.layout().fields[f].max, ooc.layout().fields[f].max);
  }
  test::expect_same_nodes_and_bricks(in_core, ooc, [](uint64_t, uint64_t, uint32_t) {});
}

TEST(PiecesOutOfCore, SampleStrideIsOneRule) {
  EXPECT_EQ(split_sample_stride(0), 1u);
  EXPECT_EQ(split_sample_stride(kMaxSplitSamples), 1u);
  EXPECT_EQ(split_sample_stride(kMaxSplitSamples + 1), 2u);
  EXPECT_EQ(split_sample_stride(1000000000), 3815u);  // 1e9 cells: 262,123 samples
}

// The centroids the streamed plan splits are the in-core mesh's (cell_centroid) of cells 0, s, 2s, ..., bit for bit,
// with the points streamed in many slices; the pass also finds the cell field's range as the in-core input does.
TEST(PiecesOutOfCore, SampledCentroidsAreTheInCoreMeshs) {
  ScratchDir dir;
  const std::string vtu = dir.file("mixed.vtu");
  write_vtu(test::generated_with_cell_field(GenCellKind::Mixed, 3000), vtu);
  const std::vector<std::string> fields = {"pressure", "cell97"};
  const Dataset ds = read_dataset(std::vector<std::string>{vtu});
  const OctreeInput in = prepare_octree_input(ds, fields);
  VtuCellSource source(vtu, fields);
  const uint64_t stride = 7;
  std::vector<uint64_t> indices;
  std::vector<Vec3d> centroids;
  const uint64_t cells = source.for_each_sampled_cell(
      stride, 100 * (12 + 4), nullptr, [&](uint64_t index, CellType type, std::span<const Vec3f> corners) {
        ASSERT_LT(index, in.mesh->cell_count());
        EXPECT_EQ(type, in.mesh->cell_types[index]);
        indices.push_back(index);
        centroids.push_back(centroid_of(corners));
      });
  EXPECT_EQ(cells, in.mesh->cell_count());
  ASSERT_EQ(indices.size(), (cells + stride - 1) / stride);
  for (size_t s = 0; s < indices.size(); ++s) {
    EXPECT_EQ(indices[s], s * stride);
    const Vec3d c = cell_centroid(*in.mesh, indices[s]);
    EXPECT_EQ(centroids[s].x, c.x);
    EXPECT_EQ(centroids[s].y, c.y);
    EXPECT_EQ(centroids[s].z, c.z);
  }
  ASSERT_EQ(source.fields().size(), in.fields.size());
  for (size_t f = 0; f < in.fields.size(); ++f) {
    EXPECT_EQ(source.fields()[f].name, in.fields[f].name);
    EXPECT_EQ(source.fields()[f].min, in.fields[f].min);
    EXPECT_EQ(source.fields()[f].max, in.fields[f].max);
  }
}

// Each out-of-core piece against the in-core piece of the same plan (the streamed plan's tree given to plan_pieces):
// a mixed mesh with a vertex and a cell field, 4 pieces, the full ghost layer and the narrower one of level 1, a
// budget so small (64 KiB of records per worker) that leaves are sampled in pieces, and one with room for the exact
// boundary.
TEST(PiecesOutOfCore, EachPieceIsTheInCorePieceOfTheSamePlan) {
  ScratchDir dir;
  const std::string vtu = dir.file("mixed.vtu");
  write_vtu(test::generated_with_cell_field(GenCellKind::Mixed, 3000), vtu);
  const std::vector<std::string> fields = {"pressure", "cell97"};
  const Dataset ds = read_dataset(std::vector<std::string>{vtu});
  const OctreeInput in = prepare_octree_input(ds, fields);
  const OctreeBuildOptions o = small_options(5, 3, 0.02);
  std::array<uint64_t, 4> small_budget_leaves_in_pieces{};
  for (int ghost_level : {0, 1}) {
    SCOPED_TRACE("ghost level " + std::to_string(ghost_level));
    OutOfCorePiecePlan streamed = plan_pieces_out_of_core(vtu, fields, 4, o.resolution, ghost_level, 1);
    EXPECT_EQ(streamed.cells, in.mesh->cell_count());
    EXPECT_EQ(streamed.split_samples, in.mesh->cell_count());  // under kMaxSplitSamples: every cell
    const PiecePlan in_plan = plan_pieces(in, 4, o.resolution, ghost_level, &streamed.plan.tree);
    EXPECT_EQ(streamed.plan.bounds.lo, in_plan.bounds.lo);
    EXPECT_EQ(streamed.plan.bounds.hi, in_plan.bounds.hi);
    EXPECT_EQ(streamed.plan.ghost_margin, in_plan.ghost_margin);
    ASSERT_EQ(streamed.fields.size(), in.fields.size());
    for (size_t f = 0; f < in.fields.size(); ++f) {
      EXPECT_EQ(streamed.fields[f].min, in.fields[f].min);
      EXPECT_EQ(streamed.fields[f].max, in.fields[f].max);
    }
    uint64_t in_pieces = 0, owned = 0;
    for (int k = 0; k < 4; ++k) {
      SCOPED_TRACE("piece " + std::to_string(k));
      const std::string level = "-g" + std::to_string(ghost_level) + "-" + std::to_string(k) + ".ugvr";
      const std::string a = dir.file("in" + level), b = dir.file("ooc" + level);
      build_piece(in, in_plan, k, o, a);
      const OctreeBuildStats s = build_piece_out_of_core(vtu, fields, streamed, k, o, 1, b);
      in_pieces += s.leaves_in_pieces;
      if (ghost_level == 0) small_budget_leaves_in_pieces[size_t(k)] = s.leaves_in_pieces;
      // The budget cannot hold the boundary's triangles: the piece's build says it leaves the section out.
      EXPECT_NE(s.boundary_note.find("memory budget"), std::string::npos) << s.boundary_note;
      EXPECT_EQ(streamed.plan.cells[size_t(k)], in_plan.cells[size_t(k)]);
      EXPECT_EQ(streamed.plan.ghost_cells[size_t(k)], in_plan.ghost_cells[size_t(k)]);
      EXPECT_EQ(s.cells, in_plan.cells[size_t(k)] + in_plan.ghost_cells[size_t(k)]);
      EXPECT_GT(in_plan.ghost_cells[size_t(k)], 0u);
      owned += streamed.plan.cells[size_t(k)];
      expect_same_piece(BrickStoreReader(a), BrickStoreReader(b));
      EXPECT_FALSE(std::filesystem::exists(b + ".cells")) << "the piece's scratch is removed";
    }
    EXPECT_EQ(owned, in.mesh->cell_count());
    EXPECT_GT(in_pieces, 0u);
  }
  // With room: the exact boundary, the same triangles as the in-core piece's; and, beside the boundary, the same
  // store as the small budget's, whose leaves were sampled in pieces (the piece with the most of them).
  const int k = int(std::max_element(small_budget_leaves_in_pieces.begin(), small_budget_leaves_in_pieces.end()) -
                    small_budget_leaves_in_pieces.begin());
  ASSERT_GT(small_budget_leaves_in_pieces[size_t(k)], 0u);
  OutOfCorePiecePlan streamed = plan_pieces_out_of_core(vtu, fields, 4, o.resolution, 0, uint64_t(256) << 20);
  const PiecePlan in_plan = plan_pieces(in, 4, o.resolution, 0, &streamed.plan.tree);
  const OctreeBuildStats a = build_piece(in, in_plan, k, o, dir.file("in.ugvr"));
  const OctreeBuildStats b =
      build_piece_out_of_core(vtu, fields, streamed, k, o, uint64_t(256) << 20, dir.file("ooc.ugvr"));
  EXPECT_TRUE(b.boundary_note.empty()) << b.boundary_note;
  EXPECT_EQ(b.leaves_in_pieces, 0u);
  EXPECT_GT(b.boundary_triangles, 0u);
  EXPECT_EQ(a.boundary_triangles, b.boundary_triangles);
  EXPECT_EQ(a.boundary_bytes, b.boundary_bytes);
  expect_same_piece(BrickStoreReader(dir.file("in.ugvr")), BrickStoreReader(dir.file("ooc.ugvr")));
  test::expect_same_store_at_any_budget(BrickStoreReader(dir.file("ooc.ugvr")),
                                        BrickStoreReader(dir.file("ooc-g0-" + std::to_string(k) + ".ugvr")));
}

// A file that is not the one planned (other values, other bounds) is refused naming the piece, not built on a lattice
// or ranges of another mesh; a preview for a piece is refused.
TEST(PiecesOutOfCore, AFileChangedSinceThePlanIsRefused) {
  ScratchDir dir;
  const std::string vtu = dir.file("t.vtu");
  write_vtu(test::generated_with_cell_field(GenCellKind::Tet, 2000), vtu);
  const std::vector<std::string> fields = {"pressure"};
  const OctreeBuildOptions o = small_options(5, 2, 0.02);
  OutOfCorePiecePlan plan = plan_pieces_out_of_core(vtu, fields, 2, o.resolution, 0, uint64_t(64) << 20);
  write_vtu(test::generated_with_cell_field(GenCellKind::Tet, 5000), vtu);
  try {
    build_piece_out_of_core(vtu, fields, plan, 1, o, uint64_t(64) << 20, dir.file("p.ugvr"));
    ADD_FAILURE() << "a changed file was built";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("piece 1"), std::string::npos) << what;
    EXPECT_NE(what.find("from the plan's"), std::string::npos) << what;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("p.ugvr")));
  OctreeBuildOptions preview = o;
  preview.preview_depth = 1;
  EXPECT_THROW(build_piece_out_of_core(vtu, fields, plan, 0, preview, uint64_t(64) << 20, dir.file("p.ugvr")), Error);
}

}  // namespace
}  // namespace ugvr
