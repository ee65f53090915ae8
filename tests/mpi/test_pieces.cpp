// Partitioned stores (`ugvr build --pieces N`, src/ugvr/mpi/piece_*.h, docs/mpi.md): 4 ranks rendering a 4- or
// 8-piece index, and one process rendering every piece, equal one rank rendering the whole store; a missing or
// damaged piece is named; the build under mpirun gives the same index and images; pieces built out of core render as
// the whole store and build alike under mpirun.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mpi_fixtures.h"
#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/render/image.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::CommandResult;
using test::mpirun;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class Pieces : public ::testing::Test {
 protected:
  std::string file(const std::string& name) const { return dir_.file(name); }

  // Builds INPUT whole (W.ugvr) and in 4 and 8 pieces (P4.json, P8.json) with the same options.
  void build_all(const std::string& input, const std::string& build_flags) {
    const CommandResult whole = test::run_ugvr("build " + input + " " + build_flags + " -o " + file("W.ugvr"));
    ASSERT_EQ(whole.status, 0) << whole.out;
    for (int n : {4, 8}) {
      const std::string index = file("P" + std::to_string(n) + ".json");
      const CommandResult r =
          test::run_ugvr("build " + input + " " + build_flags + " --pieces " + std::to_string(n) + " -o " + index);
      ASSERT_EQ(r.status, 0) << r.out;
      const nlohmann::json j = nlohmann::json::parse(slurp(index));
      EXPECT_EQ(j["format"], "ugvr-pieces");
      EXPECT_EQ(j["version"], 1);
      ASSERT_EQ(j["pieces"].size(), size_t(n));
      uint64_t owned = 0;
      for (const auto& p : j["pieces"]) {
        owned += p["cells"].get<uint64_t>();
        EXPECT_TRUE(std::filesystem::exists(file(p["store"].get<std::string>()))) << p["store"];
      }
      const CommandResult info = test::run_ugvr("info " + index);
      ASSERT_EQ(info.status, 0) << info.out;
      EXPECT_NE(info.out.find(std::to_string(n) + " (kd-tree"), std::string::npos) << info.out;
      // Every cell is owned by exactly one piece (its centroid's box): checked against the mesh's count by the caller.
      cells_ = owned;
    }
  }

  // The lower PSNR of: 4 ranks on the 4-piece index, 4 ranks on the 8-piece index, and one plain process on the
  // 8-piece index, each against one rank on the whole store.
  double psnr_pieces_vs_whole(const std::string& flags) {
    // One transfer function for both: the whole store's and the pieces' default (auto, from their coarse levels'
    // histograms) may differ, and these compare the compositing.
    const std::string common = " --threads 1 --tf viridis " + flags;
    CommandResult r =
        mpirun(1, "render " + file("W.ugvr") + common + " -o " + file("w.png") + " --float " + file("w.pfm"));
    EXPECT_EQ(r.status, 0) << r.out;
    if (r.status != 0) return 0;
    const Image whole = read_pfm(file("w.pfm"));
    double worst = 1e9;
    for (const char* run : {"4:P4", "4:P8", "0:P8"}) {
      const int ranks = run[0] - '0';
      const std::string index = file(std::string(run + 2) + ".json"), out = file(std::string("o") + run[0] + (run + 2));
      const std::string args = "render " + index + common + " -o " + out + ".png --float " + out + ".pfm";
      r = ranks ? mpirun(ranks, args) : test::run_ugvr(args);
      EXPECT_EQ(r.status, 0) << r.out;
      if (r.status != 0) return 0;
      const ImageDifference d = compare_images(read_pfm(out + ".pfm"), whole);
      std::printf("%s (%d ranks) vs the whole store on 1 rank: psnr %.2f dB, max %.3g\n", run + 2, ranks, d.psnr_db,
                  d.max_abs);
      worst = std::min(worst, d.psnr_db);
    }
    return worst;
  }
  test::ScratchDir dir_;
  uint64_t cells_ = 0;
};

TEST_F(Pieces, OxygenPostFourRanksEqualTheWholeStore) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const std::string input = test::data_path("lox-post/postxyz.bin") + " " + test::data_path("lox-post/postq.bin");
  build_all(input, "--brick 16 --max-depth 3");
  EXPECT_EQ(cells_, 102675u);
  EXPECT_GE(psnr_pieces_vs_whole("--size 128"), 50);
}

TEST_F(Pieces, MixedMeshFourRanksEqualTheWholeStore) {
  ASSERT_EQ(test::run_ugvr("generate --cells 4000 --kind mixed -o " + file("mixed.vtu")).status, 0);
  build_all(file("mixed.vtu"), "--brick 16 --max-depth 4");
  EXPECT_GE(psnr_pieces_vs_whole("--size 96"), 50);
}

// The U-shaped mesh: rays leave the data and enter it again, and the kd planes cut through the slot.
TEST_F(Pieces, NonConvexMeshFourRanksEqualTheWholeStore) {
  test::write_u_shaped_mesh(file("u.vtk"), 16);
  build_all(file("u.vtk"), "--brick 16 --max-depth 4");
  EXPECT_GE(psnr_pieces_vs_whole("--size 96 --view +y"), 50);
  EXPECT_GE(psnr_pieces_vs_whole("--size 96"), 50);
}

TEST_F(Pieces, BuildUnderMpirunGivesTheSameIndexAndImage) {
  ASSERT_EQ(test::run_ugvr("generate --cells 2000 --kind tet -o " + file("t.vtu")).status, 0);
  const CommandResult one = test::run_ugvr("build " + file("t.vtu") + " --brick 16 --pieces 4 -o " + file("A.json"));
  ASSERT_EQ(one.status, 0) << one.out;
  const CommandResult two = mpirun(2, "build " + file("t.vtu") + " --brick 16 --pieces 4 -o " + file("B.json"));
  ASSERT_EQ(two.status, 0) << two.out;
  // Blocks land in a store in the order parallel bricks finish, so files differ byte for byte between any two builds;
  // the stores' images may not.
  for (const char* name : {"A", "B"}) {
    const CommandResult r =
        test::run_ugvr("render " + file(std::string(name) + ".json") + " --size 64 --view +z -o " +
                       file(std::string(name) + ".png") + " --float " + file(std::string(name) + ".pfm"));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const ImageDifference d = compare_images(read_pfm(file("A.pfm")), read_pfm(file("B.pfm")));
  EXPECT_EQ(d.max_abs, 0);
  std::string a = slurp(file("A.json")), b = slurp(file("B.json"));
  EXPECT_NE(a.find("A.d/piece-3.ugvr"), std::string::npos);
  // The same index (tree, boxes, cells, ranges, store sizes) but for the folder's name.
  for (size_t p = 0; (p = b.find("B.d/", p)) != std::string::npos;) b.replace(p, 4, "A.d/");
  EXPECT_EQ(a, b);
}

// A 4 x 1 x 1 box of n^3 hexahedra (long in x: the kd-tree's first cut, between the ranks, is across x) whose field is
// a free stream (7) on the x < 2 side and spread evenly over [0, 10] (smoothly in y and z) on the other: the two
// halves' histograms differ (one is a single bin), and so would transfer functions made from one half alone.
void write_half_free_stream(const std::string& path, int n) {
  std::ofstream out(path);
  const int m = n + 1;
  out << "# vtk DataFile Version 3.0\nhalf\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS " << m * m * m << " double\n";
  auto id = [&](int i, int j, int k) { return (k * m + j) * m + i; };
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) out << 4.0 * i / n << " " << double(j) / n << " " << double(k) / n << "\n";
  out << "CELLS " << n * n * n << " " << n * n * n * 9 << "\n";
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        out << "8 " << id(i, j, k) << " " << id(i + 1, j, k) << " " << id(i + 1, j + 1, k) << " " << id(i, j + 1, k)
            << " " << id(i, j, k + 1) << " " << id(i + 1, j, k + 1) << " " << id(i + 1, j + 1, k + 1) << " "
            << id(i, j + 1, k + 1) << "\n";
  out << "CELL_TYPES " << n * n * n << "\n";
  for (int c = 0; c < n * n * n; ++c) out << "12\n";
  out << "POINT_DATA " << m * m * m << "\nSCALARS s double 1\nLOOKUP_TABLE default\n";
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) out << (i < m / 2 ? 7.0 : 10.0 * (j * m + k) / (m * m - 1)) << "\n";
}

// The default transfer function ("auto") is made from the field's histogram, and under MPI every rank MUST draw with
// the same one: a rank holds only its pieces, so the counts are summed over the ranks (MpiRenderer::value_histogram).
// 2 ranks on a 4-piece index equal one process drawing all 4 pieces: the same opacity points and the same image. Here
// a rank with only its own pieces' counts draws with another transfer function (rank 0, the free stream alone, hides
// 7; the whole has no dominant mode in its stores' coarse levels): 22.7 dB against one process when tried.
TEST_F(Pieces, DefaultTransferFunctionIsOneForAllRanks) {
  write_half_free_stream(file("half.vtk"), 16);
  ASSERT_EQ(
      test::run_ugvr("build " + file("half.vtk") + " --brick 8 --max-depth 3 --pieces 4 -o " + file("P.json")).status,
      0);
  const std::string common = "render " + file("P.json") + " --threads 1 --size 64";
  const CommandResult one = test::run_ugvr(common + " -o " + file("one.png") + " --float " + file("one.pfm") +
                                           " --stats " + file("one.json"));
  ASSERT_EQ(one.status, 0) << one.out;
  const CommandResult two =
      mpirun(2, common + " -o " + file("two.png") + " --float " + file("two.pfm") + " --stats " + file("two.json"));
  ASSERT_EQ(two.status, 0) << two.out;
  const nlohmann::json a = nlohmann::json::parse(slurp(file("one.json")));
  const nlohmann::json b = nlohmann::json::parse(slurp(file("two.json")));
  EXPECT_EQ(a["tf"]["name"], "auto");
  EXPECT_EQ(a["tf"], b["tf"]);
  const ImageDifference d = compare_images(read_pfm(file("two.pfm")), read_pfm(file("one.pfm")));
  std::printf("2 ranks vs one process, default tf: psnr %.2f dB, max %.3g\n", d.psnr_db, d.max_abs);
  EXPECT_GE(d.psnr_db, 50);
}

TEST_F(Pieces, AMissingOrDamagedPieceIsNamed) {
  ASSERT_EQ(test::run_ugvr("generate --cells 2000 --kind tet -o " + file("t.vtu")).status, 0);
  ASSERT_EQ(test::run_ugvr("build " + file("t.vtu") + " --brick 16 --pieces 4 -o " + file("P.json")).status, 0);
  // What a partitioned store does not do yet is refused, not ignored.
  CommandResult u = test::run_ugvr("render " + file("P.json") + " --size 32 --time-budget 1 -o " + file("b.png"));
  EXPECT_NE(u.status, 0);
  EXPECT_NE(u.out.find("--time-budget"), std::string::npos) << u.out;
  u = test::run_ugvr("render " + file("P.json") + " --size 32 --engine exact -o " + file("b.png"));
  EXPECT_NE(u.status, 0);
  EXPECT_NE(u.out.find("renders with the lod engine"), std::string::npos) << u.out;
  u = test::run_ugvr("render " + file("P.json") + " --size 32 --mode mip -o " + file("b.png"));
  EXPECT_NE(u.status, 0);
  EXPECT_NE(u.out.find("mip is not supported for a partitioned store"), std::string::npos) << u.out;
  // 3 ranks cannot share 4 pieces.
  CommandResult r = mpirun(3, "render " + file("P.json") + " --size 32 -o " + file("x.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("3 ranks cannot share its 4 pieces"), std::string::npos) << r.out;
  // A damaged piece: cut short.
  const std::string piece1 = file("P.d/piece-1.ugvr");
  std::filesystem::resize_file(piece1, std::filesystem::file_size(piece1) / 2);
  r = mpirun(4, "render " + file("P.json") + " --size 32 -o " + file("d.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.status, 124) << "the job hung until the timeout:\n" << r.out;
  EXPECT_NE(r.out.find("piece-1.ugvr"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(file("d.png")));
  // A missing piece: every rank reads the index and names it before rendering.
  std::filesystem::remove(file("P.d/piece-2.ugvr"));
  r = mpirun(4, "render " + file("P.json") + " --size 32 -o " + file("m.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.status, 124) << "the job hung until the timeout:\n" << r.out;
  EXPECT_NE(r.out.find("piece 2's store"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("piece-2.ugvr is missing"), std::string::npos) << r.out;
  r = test::run_ugvr("render " + file("P.json") + " --size 32 -o " + file("m.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("piece-2.ugvr is missing"), std::string::npos) << r.out;
  r = test::run_ugvr("info " + file("P.json"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("piece-2.ugvr is missing"), std::string::npos) << r.out;
  // An index of another version, and one cut short, are refused naming the index.
  std::string index = slurp(file("P.json"));
  const size_t v = index.find("\"version\": 1");
  ASSERT_NE(v, std::string::npos);
  std::ofstream(file("V.json")) << index.substr(0, v) << "\"version\": 2" << index.substr(v + 12);
  r = test::run_ugvr("render " + file("V.json") + " --size 32 -o " + file("v.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("V.json: piece index: version 2"), std::string::npos) << r.out;
  std::ofstream(file("T.json")) << index.substr(0, index.size() / 2);
  r = test::run_ugvr("info " + file("T.json"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("T.json: invalid JSON"), std::string::npos) << r.out;
}

// Out of core (mpi/piece_build_ooc.h): the index of pieces built from the streamed file renders, in one process, as
// the whole store does; under mpirun -np 2 the same index and the same stores (tree and bricks by place) as one
// process; the pieces' scratch is gone.
TEST_F(Pieces, OutOfCorePiecesRenderAsTheWholeStoreAndBuildAlikeUnderMpirun) {
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind tet -o " + file("t.vtu")).status, 0);
  const std::string flags = " --brick 16 --max-depth 4 --out-of-core --memory 64MiB --json";
  CommandResult r = test::run_ugvr("build " + file("t.vtu") + flags + " -o " + file("W.ugvr"));
  ASSERT_EQ(r.status, 0) << r.out;
  const size_t line = r.out.rfind("{\"");
  ASSERT_NE(line, std::string::npos) << r.out;
  const uint64_t cells = nlohmann::json::parse(r.out.substr(line, r.out.find('\n', line) - line))["cells"];
  r = test::run_ugvr("build " + file("t.vtu") + flags + " --pieces 4 -o " + file("A.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("\"out_of_core\":true"), std::string::npos) << r.out;
  r = mpirun(2, "build " + file("t.vtu") + flags + " --pieces 4 -o " + file("B.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json a = nlohmann::json::parse(slurp(file("A.json")));
  uint64_t owned = 0;
  for (const auto& p : a["pieces"]) {
    owned += p["cells"].get<uint64_t>();
    EXPECT_GT(p["ghost_cells"].get<uint64_t>(), 0u);
  }
  EXPECT_EQ(owned, cells) << "every cell owned by one piece";
  std::string ia = slurp(file("A.json")), ib = slurp(file("B.json"));
  for (size_t p = 0; (p = ib.find("B.d/", p)) != std::string::npos;) ib.replace(p, 4, "A.d/");
  EXPECT_EQ(ia, ib) << "the index of 2 ranks (tree, boxes, counts summed across ranks, ranges, sizes)";
  for (int k = 0; k < 4; ++k) {
    const std::string piece = "piece-" + std::to_string(k) + ".ugvr";
    const BrickStoreReader sa(file("A.d/" + piece)), sb(file("B.d/" + piece));
    ASSERT_EQ(sa.node_count(), sb.node_count()) << piece;
    const auto pa = test::nodes_by_place(sa), pb = test::nodes_by_place(sb);
    const size_t n = size_t(sa.resolution()) * sa.resolution() * sa.resolution();
    std::vector<float> va(n), vb(n);
    std::vector<uint8_t> ma(n), mb(n);
    for (const auto& [place, na] : pa) {
      ASSERT_EQ(pb.count(place), 1u) << piece;
      const uint64_t nb = pb.at(place);
      EXPECT_EQ(sa.node(na).child_mask, sb.node(nb).child_mask);
      ASSERT_EQ(sa.node(na).has_brick(), sb.node(nb).has_brick());
      if (!sa.node(na).has_brick()) continue;
      sa.read_brick(na, 0, va.data(), ma.data());
      sb.read_brick(nb, 0, vb.data(), mb.data());
      EXPECT_EQ(ma, mb) << piece;
      EXPECT_EQ(va, vb) << piece;
    }
    EXPECT_FALSE(std::filesystem::exists(file("A.d/" + piece + ".cells")));
  }
  // An explicit transfer function: with `auto` the default view is framed on what is visible, which the pieces'
  // node tables bound a little differently from the whole store's (render/visible_bounds.h); this test compares the
  // stores, not the framing.
  const std::string view = " --size 96 --threads 1 --tf viridis";
  for (const char* name : {"W.ugvr", "A.json"}) {
    r = test::run_ugvr("render " + file(name) + view + " -o " + file(std::string(name) + ".png") + " --float " +
                       file(std::string(name) + ".pfm"));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const ImageDifference d = compare_images(read_pfm(file("A.json.pfm")), read_pfm(file("W.ugvr.pfm")));
  std::printf("4 out-of-core pieces (1 process) vs the whole out-of-core store: psnr %.2f dB, max %.3g\n", d.psnr_db,
              d.max_abs);
  EXPECT_GE(d.psnr_db, 50);
}

// Was "...AndOutOfCoreAreRefused": --pieces with --out-of-core builds now (above); what is refused is an input the
// out-of-core build cannot stream and a preview or sketch per piece.
TEST_F(Pieces, BadPieceCountsAndOutOfCoreAreRefused) {
  ASSERT_EQ(test::run_ugvr("generate --cells 1000 --kind tet -o " + file("t.vtu")).status, 0);
  CommandResult r = test::run_ugvr("build " + file("t.vtu") + " --pieces 6 -o " + file("P.json"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("power of two"), std::string::npos) << r.out;
  r = test::run_ugvr("build " + file("t.vtu") + " --pieces 4 -o " + file("P.ugvr"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("a .json file"), std::string::npos) << r.out;
  test::write_u_shaped_mesh(file("u.vtk"), 4);
  r = test::run_ugvr("build " + file("u.vtk") + " --pieces 4 --out-of-core -o " + file("P.json"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("u.vtk: --out-of-core reads a single .vtu file"), std::string::npos) << r.out;
  r = test::run_ugvr("build " + file("t.vtu") + " --pieces 4 --out-of-core --preview " + file("p.ugvr") + " -o " +
                     file("P.json"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--preview and --sketch are not made with --pieces"), std::string::npos) << r.out;
  // A .vtu: built, each piece out of core (it was refused before).
  r = test::run_ugvr("build " + file("t.vtu") + " --pieces 2 --out-of-core --brick 16 -o " + file("O.json"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("2 pieces out of core"), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(file("O.json")));
  r = test::run_ugvr("build " + file("t.vtu") + " --ghost-level 2 -o " + file("G.ugvr"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--ghost-level applies with --pieces only"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(file("P.json")));
}

}  // namespace
}  // namespace ugvr
