// `mpirun --oversubscribe -np 4 ugvr render ...` (src/ugvr/mpi, docs/mpi.md): the composited image of 4 ranks equals
// the 1-rank image, and a failing rank ends the job with its message. Built and registered only with UGVR_MPI. One
// thread per rank (--threads 1); llvmpipe for the LOD engine.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "test_data.h"
#include "ugvr/render/image.h"

namespace ugvr {
namespace {

using test::CommandResult;

// `ranks` processes of `ugvr ARGS` under mpirun, killed after 120 s (a hang fails the test rather than the suite).
CommandResult mpirun(int ranks, const std::string& args) {
  // Open MPI refuses root unless told (CI containers run as root); one thread per rank.
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  return test::run_command("timeout 120 " + std::string(UGVR_MPIEXEC) + " --oversubscribe -np " +
                           std::to_string(ranks) + " " + UGVR_BINARY + " --quiet " + args);
}

class MpiRender : public ::testing::Test {
 protected:
  std::string file(const std::string& name) const { return dir_.file(name); }
  // Renders `input` with 1 and with 4 ranks under mpirun (same flags) and without MPI at all (early termination off,
  // as under MPI); returns the lower PSNR of the 4-rank image against the other two.
  double psnr_4_vs_1(const std::string& input, const std::string& flags) {
    const std::string common = "render " + input + " --threads 1 " + flags;
    for (int ranks : {1, 4}) {
      const std::string out = file("r" + std::to_string(ranks));
      const CommandResult r = mpirun(ranks, common + " -o " + out + ".png --float " + out + ".pfm");
      EXPECT_EQ(r.status, 0) << r.out;
      if (r.status != 0) return 0;
    }
    const CommandResult plain =
        test::run_ugvr(common + " --early-termination 1 -o " + file("p.png") + " --float " + file("p.pfm"));
    EXPECT_EQ(plain.status, 0) << plain.out;
    if (plain.status != 0) return 0;
    const Image four = read_pfm(file("r4.pfm"));
    const ImageDifference d1 = compare_images(four, read_pfm(file("r1.pfm")));
    const ImageDifference dp = compare_images(four, read_pfm(file("p.pfm")));
    std::printf("4 ranks vs mpirun -np 1: psnr %.2f dB, max %.3g; vs plain: psnr %.2f dB, max %.3g\n", d1.psnr_db,
                d1.max_abs, dp.psnr_db, dp.max_abs);
    return std::min(d1.psnr_db, dp.psnr_db);
  }
  test::ScratchDir dir_;
};

TEST_F(MpiRender, ExactMixedCellsFourRanksEqualOne) {
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind mixed -o " + file("mixed.vtu")).status, 0);
  EXPECT_GE(psnr_4_vs_1(file("mixed.vtu"), "--size 96 --engine exact"), 60);
  // The compositor without IceT (direct send over plain MPI) gives the same image.
  setenv("UGVR_COMPOSITOR", "direct-send", 1);
  EXPECT_GE(psnr_4_vs_1(file("mixed.vtu"), "--size 96 --engine exact"), 60);
  unsetenv("UGVR_COMPOSITOR");
}

// A U-shaped block of hexahedra (a slot cut out of a cube): rays leave the data and enter it again, and the kd-tree's
// planes cut through the gap.
TEST_F(MpiRender, ExactNonConvexFourRanksEqualOne) {
  const int n = 8;
  std::ofstream out(file("u.vtk"));
  out << "# vtk DataFile Version 3.0\nU\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS " << (n + 1) * (n + 1) * (n + 1)
      << " double\n";
  auto id = [&](int i, int j, int k) { return (k * (n + 1) + j) * (n + 1) + i; };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) out << i << " " << j << " " << k << "\n";
  std::vector<std::array<int, 8>> cells;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        if (i >= 2 && i < 6 && k >= 3) continue;  // the slot
        cells.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                         id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
      }
  out << "CELLS " << cells.size() << " " << cells.size() * 9 << "\n";
  for (const auto& c : cells) {
    out << 8;
    for (int v : c) out << " " << v;
    out << "\n";
  }
  out << "CELL_TYPES " << cells.size() << "\n";
  for (size_t c = 0; c < cells.size(); ++c) out << "12\n";
  out << "POINT_DATA " << (n + 1) * (n + 1) * (n + 1) << "\nSCALARS s double 1\nLOOKUP_TABLE default\n";
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) out << std::sin(0.7 * i) * std::cos(0.5 * j) + 0.1 * k << "\n";
  out.close();
  // Looking into the slot from the side, so rays cross the gap.
  EXPECT_GE(psnr_4_vs_1(file("u.vtk"), "--size 96 --engine exact --view +y"), 60);
  EXPECT_GE(psnr_4_vs_1(file("u.vtk"), "--size 96 --engine exact"), 60);
}

TEST_F(MpiRender, ExactOxygenPostFourRanksEqualOne) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  EXPECT_GE(psnr_4_vs_1(test::data_path("lox-post/postxyz.bin") + " " + test::data_path("lox-post/postq.bin"),
                        "--size 128 --engine exact"),
            60);
}

// The level-of-detail engine over a store of the post (llvmpipe): each rank's rays clipped to its box in the shader.
TEST_F(MpiRender, LodOxygenPostFourRanksEqualOne) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const std::string input = test::data_path("lox-post/postxyz.bin") + " " + test::data_path("lox-post/postq.bin");
  const CommandResult b = test::run_ugvr("build " + input + " --brick 16 --max-depth 3 -o " + file("post.ugvr"));
  ASSERT_EQ(b.status, 0) << b.out;
  EXPECT_GE(psnr_4_vs_1(file("post.ugvr"), "--size 128"), 50);
}

TEST_F(MpiRender, AFailingRankEndsTheJobWithItsMessage) {
  ASSERT_EQ(test::run_ugvr("generate --cells 1000 --kind tet -o " + file("t.vtu")).status, 0);
  setenv("UGVR_MPI_FAIL_RANK", "2", 1);
  const CommandResult r = mpirun(4, "render " + file("t.vtu") + " --threads 1 --size 32 -o " + file("t.png"));
  unsetenv("UGVR_MPI_FAIL_RANK");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.status, 124) << "the job hung until the timeout:\n" << r.out;
  EXPECT_NE(r.out.find("rank 2 of 4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fails on purpose"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(file("t.png")));
}

TEST_F(MpiRender, MipIsRefusedNotComposited) {
  ASSERT_EQ(test::run_ugvr("generate --cells 1000 --kind tet -o " + file("t.vtu")).status, 0);
  const CommandResult r = mpirun(2, "render " + file("t.vtu") + " --mode mip --size 32 -o " + file("t.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("mip is not supported under MPI"), std::string::npos) << r.out;
}

TEST_F(MpiRender, ABadFileOnTheCommandLineEndsTheJob) {
  const CommandResult r = mpirun(4, "render " + file("missing.vtu") + " --threads 1 --size 32 -o " + file("m.png"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.status, 124) << "the job hung until the timeout:\n" << r.out;
  EXPECT_NE(r.out.find("missing.vtu"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ugvr
