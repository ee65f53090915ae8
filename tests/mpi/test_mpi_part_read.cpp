// `mpirun -np N ugvr render MESH.pvtu --engine exact`: each rank reads only the pieces its kd box needs and keeps only
// the cells meeting it (src/ugvr/mpi/mpi_part_read.h, docs/mpi.md). The composited image of 2 and 4 ranks equals the
// one-rank image (which reads the whole .pvtu), the colour range is the whole mesh's, and every rank reports in
// --stats that it decoded and kept fewer cells than the mesh has, every piece decoded once in the job. The same for an
// Exodus file read by cell ranges.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "mpi_fixtures.h"
#include "test_data.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/mpi/mesh_part.h"
#include "ugvr/render/image.h"

namespace ugvr {
namespace {

using test::CommandResult;
using test::mpirun;

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

class PvtuPartRead : public ::testing::Test {
 protected:
  std::string file(const std::string& name) const { return dir_.file(name); }

  // `input` (one unstructured block) written as OUT.pvtu of `pieces` pieces, as bench_write_pvtu does.
  std::string write_pieces(const std::string& input, const std::string& out, uint32_t pieces, bool kd) {
    const Dataset ds = read_dataset(std::vector<std::string>{input});
    const Block& block = ds.blocks.at(0);
    write_pvtu(block, file(out), kd ? kd_pieces(block, pieces) : slab_pieces(block, pieces, 0), pieces);
    return file(out);
  }

  // `ugvr render` of `input` under mpirun with `ranks` ranks: its float image and --stats.
  struct Run {
    Image image;
    nlohmann::json stats;
  };
  Run render(int ranks, const std::string& input, const std::string& flags) {
    const std::string out = file("r" + std::to_string(ranks));
    const CommandResult r = mpirun(ranks, "render " + input + " --threads 1 " + flags + " -o " + out + ".png --float " +
                                              out + ".pfm --stats " + out + ".json");
    EXPECT_EQ(r.status, 0) << r.out;
    if (r.status != 0) return {};
    return {read_pfm(out + ".pfm"), read_json(out + ".json")};
  }

  test::ScratchDir dir_;
};

// The generated mixed mesh (tetrahedra, pyramids, wedges, hexahedra) as 16 compact pieces: 2 and 4 ranks against 1,
// for the default vertex field and a cell field.
TEST_F(PvtuPartRead, RanksReadTheirPiecesAndTheImageEqualsOneRanks) {
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind mixed -o " + file("m.vtu")).status, 0);
  const std::string pvtu = write_pieces(file("m.vtu"), "m.pvtu", 16, true);
  for (const std::string field : {"", "--field wall_distance"}) {
    const std::string flags = "--size 96 --engine exact " + field;
    const Run one = render(1, pvtu, flags);
    ASSERT_FALSE(one.stats.is_null());
    const CommandResult plain =
        test::run_ugvr("render " + pvtu + " --threads 1 " + flags + " --early-termination 1 -o " + file("p.png") +
                       " --float " + file("p.pfm"));
    ASSERT_EQ(plain.status, 0) << plain.out;
    ASSERT_TRUE(one.stats["mpi"].contains("cells_total")) << "no read figures in --stats";
    const uint64_t cells = one.stats["mpi"]["cells_total"].get<uint64_t>();
    EXPECT_GT(cells, 19000u);
    for (int ranks : {2, 4}) {
      const Run part = render(ranks, pvtu, flags);
      ASSERT_FALSE(part.stats.is_null());
      const ImageDifference d1 = compare_images(part.image, one.image);
      const ImageDifference dp = compare_images(part.image, read_pfm(file("p.pfm")));
      std::printf("%s, %d ranks vs 1: %.2f dB, vs plain: %.2f dB\n", field.c_str(), ranks, d1.psnr_db, dp.psnr_db);
      EXPECT_GE(d1.psnr_db, 60) << ranks << " ranks " << field;
      EXPECT_GE(dp.psnr_db, 60) << ranks << " ranks " << field;
      // The colour range is the whole mesh's on every rank (a part's own range would map colours otherwise).
      EXPECT_EQ(part.stats["field_range"], one.stats["field_range"]) << ranks << " ranks " << field;
      EXPECT_EQ(part.stats["field"], one.stats["field"]);
      const nlohmann::json& m = part.stats["mpi"];
      ASSERT_EQ(m.value("read", ""), "pvtu-part") << m.dump();
      EXPECT_EQ(m["cells_total"].get<uint64_t>(), cells);
      uint64_t read_sum = 0, kept_sum = 0;
      for (int r = 0; r < ranks; ++r) {
        const double read = m["rank_cells_read"][size_t(r)].get<double>();
        const double kept = m["rank_cells_kept"][size_t(r)].get<double>();
        EXPECT_LT(read, double(cells)) << "rank " << r << " of " << ranks << " decoded every cell";
        EXPECT_LT(kept, double(cells)) << "rank " << r << " of " << ranks << " kept every cell";
        EXPECT_GT(kept, 0);
        read_sum += uint64_t(read);
        kept_sum += uint64_t(kept);
      }
      // Every piece is decoded once in the whole job (by its owner), and the parts cover the mesh (cells meeting two
      // boxes are in both).
      EXPECT_EQ(read_sum, cells);
      EXPECT_GE(kept_sum, cells);
    }
  }
}

// A non-convex mesh (rays leave and enter again) as 8 slabs, looking into the slot.
TEST_F(PvtuPartRead, NonConvexSlabsFourRanksEqualOne) {
  test::write_u_shaped_mesh(file("u.vtk"));
  const std::string pvtu = write_pieces(file("u.vtk"), "u.pvtu", 8, false);
  for (const std::string view : {"--view +y", ""}) {
    const std::string flags = "--size 96 --engine exact " + view;
    const Run one = render(1, pvtu, flags);
    const Run four = render(4, pvtu, flags);
    ASSERT_FALSE(four.stats.is_null());
    const ImageDifference d = compare_images(four.image, one.image);
    std::printf("U-shaped %s: 4 ranks vs 1: %.2f dB\n", view.c_str(), d.psnr_db);
    EXPECT_GE(d.psnr_db, 60) << view;
    EXPECT_EQ(four.stats["mpi"].value("read", ""), "pvtu-part");
  }
}

// The U-shaped mesh as one .vtu of 8 <Piece>s (vtu_part_source.cpp), looking into the slot, and the generated mixed
// mesh as written, one <Piece> in raw appended data, read by cell ranges (vtu_range_source.cpp): 4 ranks equal 1,
// every rank reading fewer cells than the file has, each cell once in the job. The ranges' cuts are joined on their
// point numbers (join_blocks): unjoined, the mixed mesh gave 90.0 dB (rays leaving and re-entering at every piece
// boundary), hence the bound of 120 dB there (every other image here is 157 dB or more).
TEST_F(PvtuPartRead, VtuPiecesAndCellRangesFourRanksEqualOne) {
  test::write_u_shaped_mesh(file("u.vtk"));
  const Dataset u = read_dataset(std::vector<std::string>{file("u.vtk")});
  write_vtu_pieces(u.blocks.at(0), file("u8.vtu"), slab_pieces(u.blocks.at(0), 8, 0), 8);
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind mixed -o " + file("m.vtu")).status, 0);
  for (const auto& [input, read] : {std::pair{file("u8.vtu"), "vtu-pieces"}, std::pair{file("m.vtu"), "vtu-ranges"}}) {
    const std::string flags = std::string("--size 96 --engine exact") + (input == file("u8.vtu") ? " --view +y" : "");
    const Run one = render(1, input, flags);
    const Run four = render(4, input, flags);
    ASSERT_FALSE(four.stats.is_null());
    const ImageDifference d = compare_images(four.image, one.image);
    std::printf("%s: 4 ranks vs 1: %.2f dB\n", read, d.psnr_db);
    EXPECT_GE(d.psnr_db, read == std::string("vtu-ranges") ? 120 : 60) << read;
    const uint64_t cells = one.stats["mpi"]["cells_total"].get<uint64_t>();
    const nlohmann::json& m = four.stats["mpi"];
    EXPECT_EQ(m.value("read", ""), read);
    uint64_t read_sum = 0;
    for (int r = 0; r < 4; ++r) {
      EXPECT_LT(m["rank_cells_read"][size_t(r)].get<double>(), double(cells)) << read << " rank " << r;
      read_sum += uint64_t(m["rank_cells_read"][size_t(r)].get<double>());
    }
    EXPECT_EQ(read_sum, cells) << read;
  }
}

// mug.e (Exodus, 2,476 hexahedra in two volume blocks, 21 time steps) read by cell ranges (part_source.h): 4 ranks
// equal 1 rank's whole read at the last step and at step 3 (nodal and element fields), and every rank decodes fewer
// cells than the file has, each cell once in the job.
TEST_F(PvtuPartRead, ExodusCellRangesFourRanksEqualOneWholeRead) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  for (const std::string step : {"", "--time-step 3 --field aux_elem"}) {
    const std::string flags = "--size 96 --engine exact " + step;
    const Run one = render(1, relative_data_path, flags);
    const Run four = render(4, relative_data_path, flags);
    ASSERT_FALSE(four.stats.is_null());
    const ImageDifference d = compare_images(four.image, one.image);
    std::printf("mug.e %s: 4 ranks vs 1: %.2f dB\n", step.c_str(), d.psnr_db);
    EXPECT_GE(d.psnr_db, 60) << step;
    EXPECT_EQ(four.stats["field_range"], one.stats["field_range"]) << step;
    EXPECT_EQ(four.stats["field"], one.stats["field"]) << step;
    const nlohmann::json& m = four.stats["mpi"];
    ASSERT_EQ(m.value("read", ""), "exodus-blocks") << m.dump();
    const uint64_t cells = m["cells_total"].get<uint64_t>();
    EXPECT_EQ(cells, 2476u);
    uint64_t read_sum = 0;
    for (int r = 0; r < 4; ++r) {
      const double read = m["rank_cells_read"][size_t(r)].get<double>();
      EXPECT_LT(read, double(cells)) << "rank " << r << " decoded every cell";
      EXPECT_GT(m["rank_cells_kept"][size_t(r)].get<double>(), 0);
      read_sum += uint64_t(read);
    }
    EXPECT_EQ(read_sum, cells);
  }
}

// A truncated Exodus file: the ranks fail naming the file and what is missing, and the job ends (no rank waits).
TEST_F(PvtuPartRead, ATruncatedExodusFileEndsTheJobNamingIt) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  const std::string cut = file("cut.e");
  std::filesystem::copy_file(relative_data_path, cut);
  std::filesystem::resize_file(cut, std::filesystem::file_size(cut) * 3 / 4);
  const CommandResult r = mpirun(2, "render " + cut + " --engine exact --threads 1 --size 32 -o " + file("c.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.status, 124) << "the job hung until the timeout:\n" << r.out;
  EXPECT_NE(r.out.find("cut.e"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("truncated"), std::string::npos) << r.out;
}

// A piece without an array the first piece has: the job ends with the piece's name and the array's.
TEST_F(PvtuPartRead, APieceLackingAFieldEndsTheJobNamingIt) {
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + file("t.vtu")).status, 0);
  const std::string pvtu = write_pieces(file("t.vtu"), "t.pvtu", 4, true);
  Dataset piece = read_dataset(std::vector<std::string>{file("t_3.vtu")});
  FieldSet kept;
  for (const Field& f : piece.blocks[0].fields)
    if (f.name() != "pressure") kept.add(f);
  piece.blocks[0].fields = kept;
  write_vtu(piece, file("t_3.vtu"));
  const CommandResult r = mpirun(2, "render " + pvtu + " --engine exact --threads 1 --size 32 -o " + file("t.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.status, 124) << "the job hung until the timeout:\n" << r.out;
  EXPECT_NE(r.out.find("t_3.vtu"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'pressure'"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ugvr
