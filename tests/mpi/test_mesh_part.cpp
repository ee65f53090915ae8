// The part a rank builds from the pieces it reads (cells_meeting_box per piece, mpi_part_read.h) is the part that
// restricting the whole mesh's walk mesh to its box keeps (restrict_walk_mesh): the same points, cells, neighbours and
// boundary. No MPI: the functions of src/ugvr/mpi/mesh_part.h on their own.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <tuple>

#include "test_data.h"
#include "ugvr/io/pvtu_pieces.h"
#include "ugvr/io/reader.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/mesh_part.h"
#include "ugvr/render/exact/walk_mesh.h"

namespace ugvr {
namespace {

std::vector<std::tuple<uint32_t, int, int, int, int>> boundary_set(const WalkMesh& m) {
  std::vector<std::tuple<uint32_t, int, int, int, int>> out;
  for (const BoundaryTriangle& t : m.boundary)
    out.emplace_back(t.cell, t.local_face, t.corners[0], t.corners[1], t.corners[2]);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(MeshPart, PiecesCutToABoxGiveTheRestrictedWalkMesh) {
  test::ScratchDir dir;
  ASSERT_EQ(test::run_ugvr("generate --cells 6000 --kind mixed -o " + dir.file("m.vtu")).status, 0);
  const Dataset source = read_dataset(std::vector<std::string>{dir.file("m.vtu")});
  const Block& block = source.blocks.at(0);
  const std::vector<std::string> files = write_pvtu(block, dir.file("m.pvtu"), kd_pieces(block, 6), 6);
  ASSERT_EQ(pvtu_piece_files(dir.file("m.pvtu")), files);

  const Dataset whole = read_dataset(std::vector<std::string>{dir.file("m.pvtu")});
  ASSERT_EQ(whole.cell_count(), source.cell_count());
  const WalkMesh w = build_walk_mesh(whole);
  const KdTree tree = build_kd_tree(cell_centroids(w), 4);
  // The kd boxes, and one whose face passes through vertices (cells touching it from outside must be kept: the test
  // is closed).
  std::vector<Bounds> boxes = tree.boxes;
  Bounds through = tree.boxes[0];
  through.hi = {through.hi.x, through.hi.y, to_double(w.points[w.points.size() / 2]).z};
  boxes.push_back(through);
  for (size_t part = 0; part < boxes.size(); ++part) {
    const Bounds& box = boxes[part];
    Dataset cut;
    uint64_t pieces_kept = 0;
    for (const std::string& f : files) {
      Block kept = cells_meeting_box(read_vtk_xml(f).blocks.at(0), box);
      if (std::get<UnstructuredMesh>(kept.grid).cell_count() > 0) cut.blocks.push_back(std::move(kept)), ++pieces_kept;
    }
    ASSERT_GT(pieces_kept, 0u);
    const WalkMesh p = build_walk_mesh(cut);
    const WalkMesh r = restrict_walk_mesh(w, box).mesh;
    EXPECT_LT(p.cell_count(), w.cell_count()) << "part " << part;
    EXPECT_EQ(p.cell_count(), r.cell_count()) << "part " << part;
    EXPECT_EQ(p.type_begin, r.type_begin) << "part " << part;
    EXPECT_TRUE(p.points == r.points) << "part " << part;
    EXPECT_EQ(p.connectivity, r.connectivity) << "part " << part;
    EXPECT_EQ(p.neighbors, r.neighbors) << "part " << part;
    EXPECT_EQ(p.quad_split, r.quad_split) << "part " << part;
    EXPECT_EQ(boundary_set(p), boundary_set(r)) << "part " << part;
  }
}

// Fields follow their cells and points through a cut: each kept cell's cell value and its vertices' values are the
// source's.
TEST(MeshPart, FieldsFollowTheKeptCellsAndPoints) {
  test::ScratchDir dir;
  ASSERT_EQ(test::run_ugvr("generate --cells 2000 --kind mixed -o " + dir.file("m.vtu")).status, 0);
  const Dataset source = read_dataset(std::vector<std::string>{dir.file("m.vtu")});
  const Block& block = source.blocks.at(0);
  const auto& mesh = std::get<UnstructuredMesh>(block.grid);
  const Bounds all = block_point_bounds(block);
  Bounds box = all;
  box.hi.x = 0.5 * (all.lo.x + all.hi.x);
  const Block kept = cells_meeting_box(block, box);
  const auto& part = std::get<UnstructuredMesh>(kept.grid);
  ASSERT_GT(part.cell_count(), 0u);
  ASSERT_LT(part.cell_count(), mesh.cell_count());
  const Field* wall = kept.fields.find("wall_distance");
  const Field* pressure = kept.fields.find("pressure");
  ASSERT_TRUE(wall && pressure);
  EXPECT_EQ(wall->tuples(), part.cell_count());
  EXPECT_EQ(pressure->tuples(), part.point_count());
  // Match each kept cell to its source by its first vertex's position and type, in order (cells keep their order).
  uint64_t s = 0;
  for (uint64_t c = 0; c < part.cell_count(); ++c, ++s) {
    auto same = [&](uint64_t src) {
      return mesh.cell_types[src] == part.cell_types[c] && mesh.cell(src).size() == part.cell(c).size() &&
             std::equal(part.cell(c).begin(), part.cell(c).end(), mesh.cell(src).begin(),
                        [&](uint32_t a, uint32_t b) { return part.points[a] == mesh.points[b]; });
    };
    while (s < mesh.cell_count() && !same(s)) ++s;
    ASSERT_LT(s, mesh.cell_count()) << "kept cell " << c << " has no source cell in order";
    EXPECT_EQ(wall->scalar(c, 0), block.fields.find("wall_distance")->scalar(s, 0));
    for (size_t i = 0; i < part.cell(c).size(); ++i)
      EXPECT_EQ(pressure->scalar(part.cell(c)[i], 0), block.fields.find("pressure")->scalar(mesh.cell(s)[i], 0));
  }
}

// A cut travels between ranks as bytes (append_block_bytes): two blocks back to back come back equal, in order, and
// bytes cut short are refused naming their source.
TEST(MeshPart, ABlockRoundTripsThroughItsBytes) {
  test::ScratchDir dir;
  ASSERT_EQ(test::run_ugvr("generate --cells 2000 --kind mixed -o " + dir.file("m.vtu")).status, 0);
  const Dataset source = read_dataset(std::vector<std::string>{dir.file("m.vtu")});
  const Block& block = source.blocks.at(0);
  Bounds half = block_point_bounds(block);
  half.hi.y = 0.5 * (half.lo.y + half.hi.y);
  const Block cut = cells_meeting_box(block, half);
  std::vector<std::byte> bytes;
  append_block_bytes(block, bytes);
  append_block_bytes(cut, bytes);
  std::span<const std::byte> rest(bytes);
  const Block a = read_block_bytes(rest, "test");
  const Block b = read_block_bytes(rest, "test");
  EXPECT_TRUE(rest.empty());
  EXPECT_TRUE(std::get<UnstructuredMesh>(a.grid) == std::get<UnstructuredMesh>(block.grid));
  EXPECT_TRUE(a.fields == block.fields);
  EXPECT_TRUE(std::get<UnstructuredMesh>(b.grid) == std::get<UnstructuredMesh>(cut.grid));
  EXPECT_TRUE(b.fields == cut.fields);
  std::span<const std::byte> short_bytes(bytes.data(), bytes.size() / 4);
  try {
    read_block_bytes(short_bytes, "rank 3's part");
    ADD_FAILURE() << "bytes cut short were read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rank 3's part"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ugvr
