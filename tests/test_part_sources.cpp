// The pieces an input is read by under MPI (src/ugvr/mpi/part_source.h), without MPI: read in order, an Exodus file's
// cell ranges, a .vtu's <Piece>s and a raw-appended .vtu's cell ranges give the whole read's cells (types, vertex
// positions), cell values and vertex values (for the time step asked); each piece holds fewer points than the file; the
// Exodus ranges tile the cells; a piece that cannot be read is refused naming the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/io/exodus_parts.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_pieces.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/mpi/mesh_part.h"
#include "ugvr/mpi/part_source.h"

namespace ugvr {
namespace {

const UnstructuredMesh& mesh_of(const Dataset& ds) { return std::get<UnstructuredMesh>(ds.blocks.at(0).grid); }

// Every piece of `source`, in order, against `whole`: cell c of the pieces is cell c of the whole read, with the same
// corner positions, cell values and vertex values at its corners, and the corners' point numbers
// (kPartPointIdField, where the source gives them) are the whole read's point indices. `most_points`: the largest
// piece's point count. (Call it under ASSERT_NO_FATAL_FAILURE.)
void expect_pieces_equal_whole(const mpi::PartSource& source, const Dataset& whole, uint64_t& most_points) {
  const UnstructuredMesh& w = mesh_of(whole);
  const FieldSet& wf = whole.blocks[0].fields;
  uint64_t cell = 0;
  most_points = 0;
  for (size_t k = 0; k < source.pieces(); ++k) {
    const Dataset piece = source.read_piece(k);
    const UnstructuredMesh& p = mesh_of(piece);
    FieldSet pf;  // the piece's fields in the whole read's order (the point numbers apart)
    for (const Field& f : wf)
      if (const Field* same = piece.blocks[0].fields.find(f.name(), f.association())) pf.add(*same);
    const Field* ids = piece.blocks[0].fields.find(mpi::kPartPointIdField, Association::Vertex);
    most_points = std::max<uint64_t>(most_points, p.point_count());
    EXPECT_EQ(piece.blocks[0].fields.size(), wf.size() + (ids ? 1 : 0)) << "piece " << k;
    if (pf.size() != wf.size()) return;
    for (uint64_t c = 0; c < p.cell_count(); ++c, ++cell) {
      if (cell >= w.cell_count()) {
        ADD_FAILURE() << "the pieces have more cells than the whole read";
        return;
      }
      const auto pv = p.cell(c), wv = w.cell(cell);
      ASSERT_EQ(p.cell_types[c], w.cell_types[cell]) << "cell " << cell;
      ASSERT_EQ(pv.size(), wv.size());
      for (size_t i = 0; i < pv.size(); ++i) {
        ASSERT_EQ(p.points[pv[i]], w.points[wv[i]]) << "cell " << cell << " corner " << i;
        if (ids) {
          ASSERT_EQ(ids->scalar(pv[i], 0), double(wv[i])) << "cell " << cell << " corner " << i;
        }
        for (size_t f = 0; f < wf.size(); ++f) {
          if (wf[f].association() != Association::Vertex) continue;
          ASSERT_EQ(pf[f].name(), wf[f].name());
          for (int a = 0; a < wf[f].components(); ++a) {
            ASSERT_EQ(pf[f].scalar(pv[i], a), wf[f].scalar(wv[i], a)) << wf[f].name() << " cell " << cell;
          }
        }
      }
      for (size_t f = 0; f < wf.size(); ++f) {
        if (wf[f].association() != Association::Cell) continue;
        ASSERT_EQ(pf[f].name(), wf[f].name());
        ASSERT_EQ(pf[f].data().type(), wf[f].data().type()) << wf[f].name();
        for (int a = 0; a < wf[f].components(); ++a) {
          ASSERT_EQ(pf[f].scalar(c, a), wf[f].scalar(cell, a)) << wf[f].name() << " cell " << cell;
        }
      }
    }
  }
  EXPECT_EQ(cell, w.cell_count());
}

// mug.e: 1,716 hexahedra in block 1 and 760 in block 76 (its only blocks: ids 1 and 76), 21 time
// steps of nodal and element variables; 7 even ranges: block 1 is cut, and one range spans the end of block 1 and the
// start of block 76.
TEST(PartSources, ExodusCellRangesEqualTheWholeReadAtEveryStepAsked) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  for (const int64_t step : {int64_t(-1), int64_t(3)}) {
    const Dataset whole = read_exodus(relative_data_path, step);
    const auto source = mpi::exodus_part_source(relative_data_path, step, 7);
    EXPECT_EQ(source->kind(), "exodus-blocks");
    EXPECT_EQ(source->cells_from_headers(), mesh_of(whole).cell_count());
    EXPECT_EQ(source->pieces(), 7u);
    uint64_t most_points = 0;
    ASSERT_NO_FATAL_FAILURE(expect_pieces_equal_whole(*source, whole, most_points));
    EXPECT_LT(most_points, mesh_of(whole).point_count()) << "a piece read every node";
  }
}

// mesh_fs8: wedges (reordered on read) in 3 blocks; disk_out_ref: one block of 7,472 hexahedra, 3-component V.
TEST(PartSources, ExodusWedgeBlocksAndASlicedBlock) {
  for (const char* file : {"exodus-misc/mesh_fs8.exo", "disk-out-ref/disk_out_ref.ex2"}) {
    const std::string path = test::data_path(file);
    if (!std::filesystem::exists(path)) continue;  // skipped piecewise: the data set is optional
    const Dataset whole = read_exodus(path, -1);
    const auto source = mpi::exodus_part_source(path, -1, 5);
    uint64_t most_points = 0;
    ASSERT_NO_FATAL_FAILURE(expect_pieces_equal_whole(*source, whole, most_points)) << file;
    EXPECT_LT(most_points, mesh_of(whole).point_count()) << file << ": a piece read every node";
  }
}

TEST(PartSources, ExodusRangesAreEvenAndFallBetweenBlocksWhenNear) {
  // Blocks of 10, 3, 3, 3, 100 and 1 cells, 6 ranges asked: even cuts at 20, 40, 60, 80 and 100; the first moves to
  // block 5's start (19: within 20 / 8), the others have no block start near. Every range holds 17 to 23 cells.
  const ExodusLayout layout{{0, 10, 13, 16, 19, 119}, 120};
  const std::vector<ExodusCellRange> ranges = exodus_cell_ranges(layout, 6);
  std::vector<std::pair<uint64_t, uint64_t>> got;
  for (const ExodusCellRange& r : ranges) got.emplace_back(r.first, r.count);
  const std::vector<std::pair<uint64_t, uint64_t>> want{{0, 19}, {19, 21}, {40, 20}, {60, 20}, {80, 20}, {100, 20}};
  EXPECT_EQ(got, want);
  EXPECT_TRUE(ranges.front().from_first_node);
  EXPECT_TRUE(ranges.back().to_last_node);
  EXPECT_FALSE(ranges[2].from_first_node || ranges[2].to_last_node);
  // More ranges asked than cells: one a cell.
  EXPECT_EQ(exodus_cell_ranges(ExodusLayout{{0}, 3}, 8).size(), 3u);
}

TEST(PartSources, ExodusRangePastTheCellsNamesTheFile) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  const std::string e = test::error_of([&] { read_exodus_cells(relative_data_path, -1, {2400, 100}); });
  EXPECT_NE(e.find("mug.e"), std::string::npos) << e;
  EXPECT_NE(e.find("2476"), std::string::npos) << e;
}

// A generated mixed mesh written as one .vtu of 5 <Piece>s (slabs): each <Piece> read alone, in order, gives the
// whole read's cells and values; a <Piece> out of range and a truncated file are refused naming the file.
TEST(PartSources, VtuPiecesEqualTheWholeRead) {
  test::ScratchDir dir;
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind mixed -o " + dir.file("m.vtu")).status, 0);
  const Dataset mesh = read_dataset(std::vector<std::string>{dir.file("m.vtu")});
  write_vtu_pieces(mesh.blocks.at(0), dir.file("p.vtu"), slab_pieces(mesh.blocks.at(0), 5, 1), 5);
  const Dataset whole = read_vtk_xml(dir.file("p.vtu"));
  const auto source = mpi::vtu_piece_source(dir.file("p.vtu"));
  EXPECT_EQ(source->kind(), "vtu-pieces");
  ASSERT_EQ(source->pieces(), 5u);
  EXPECT_EQ(source->cells_from_headers(), mesh_of(whole).cell_count());
  uint64_t most_points = 0;
  ASSERT_NO_FATAL_FAILURE(expect_pieces_equal_whole(*source, whole, most_points));
  EXPECT_LT(most_points, mesh_of(whole).point_count() / 2);
  const std::string e = test::error_of([&] { source->read_piece(5); });
  EXPECT_NE(e.find("p.vtu"), std::string::npos) << e;
  std::filesystem::resize_file(dir.file("p.vtu"), std::filesystem::file_size(dir.file("p.vtu")) - 5000);
  const std::string t = test::error_of([&] { source->read_piece(4); });
  EXPECT_NE(t.find("p.vtu"), std::string::npos) << t;
}

// The generated mesh (20 K cells) as written (one <Piece>, raw appended data) read by 7 cell ranges: in order they give
// the whole read's cells and values, and the last range reads its own bytes only (XmlArrayReader::skip seeks): well
// under half the file; joined on their point numbers (join_blocks) they are the whole mesh again. A compressed .vtu
// and one of several <Piece>s are not read by ranges.
TEST(PartSources, VtuCellRangesEqualTheWholeReadAndReadTheirBytesOnly) {
  test::ScratchDir dir;
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind mixed -o " + dir.file("m.vtu")).status, 0);
  const std::string path = dir.file("m.vtu");
  ASSERT_TRUE(vtu_reads_by_cell_ranges(path));
  const Dataset whole = read_vtk_xml(path);
  const auto source = mpi::vtu_range_source(path, 7);
  EXPECT_EQ(source->kind(), "vtu-ranges");
  ASSERT_EQ(source->pieces(), 7u);
  EXPECT_EQ(source->cells_from_headers(), mesh_of(whole).cell_count());
  uint64_t most_points = 0;
  ASSERT_NO_FATAL_FAILURE(expect_pieces_equal_whole(*source, whole, most_points));
  EXPECT_LT(most_points, mesh_of(whole).point_count());
  const uint64_t before = test::bytes_read_so_far();
  if (before == 0) GTEST_SKIP() << "no /proc/self/io";
  source->read_piece(6);
  const uint64_t bytes = test::bytes_read_so_far() - before;
  EXPECT_LT(bytes, std::filesystem::file_size(path) / 2) << bytes << " bytes read for 1/7 of the cells";
  // The ranges joined on their point numbers are the whole mesh: its points (each once), cells and fields.
  std::vector<Block> blocks;
  for (size_t k = 0; k < source->pieces(); ++k) blocks.push_back(source->read_piece(k).blocks.at(0));
  const Block joined = join_blocks(std::move(blocks), mpi::kPartPointIdField, path);
  const UnstructuredMesh& j = std::get<UnstructuredMesh>(joined.grid);
  EXPECT_EQ(j.point_count(), mesh_of(whole).point_count());
  EXPECT_EQ(j.cell_types, mesh_of(whole).cell_types);
  EXPECT_EQ(joined.fields.size(), whole.blocks[0].fields.size());
  uint64_t moved = 0;  // corners whose position differs from the whole read's
  for (uint64_t c = 0; c < j.cell_count(); ++c)
    for (size_t i = 0; i < j.cell(c).size(); ++i)
      moved += !(j.points[j.cell(c)[i]] == mesh_of(whole).points[mesh_of(whole).cell(c)[i]]);
  EXPECT_EQ(moved, 0u);

  const std::string e = test::error_of([&] { read_vtu_cells(path, 20000, 5000); });
  EXPECT_NE(e.find("m.vtu"), std::string::npos) << e;

  write_vtu(whole, dir.file("z.vtu"), {Codec::Zlib, 0});
  EXPECT_FALSE(vtu_reads_by_cell_ranges(dir.file("z.vtu")));
  write_vtu_pieces(whole.blocks.at(0), dir.file("p.vtu"), slab_pieces(whole.blocks.at(0), 2, 0), 2);
  EXPECT_FALSE(vtu_reads_by_cell_ranges(dir.file("p.vtu")));
}

}  // namespace
}  // namespace ugvr
