// `mpirun --oversubscribe -np 4 ugvr render ...` (src/ugvr/mpi, docs/mpi.md): the composited image of 4 ranks equals
// the 1-rank image, and a failing rank ends the job with its message. Built and registered only with UGVR_MPI. One
// thread per rank (--threads 1); llvmpipe for the LOD engine.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "mpi_fixtures.h"
#include "test_data.h"
#include "ugvr/render/image.h"

namespace ugvr {
namespace {

using test::CommandResult;
using test::mpirun;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
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

// No flags: every rank frames one camera on what auto leaves visible (render/visible_bounds.h). Each rank holds its
// restricted part, whose visible box is its own: without the ranks' boxes united the cameras differ.
TEST_F(MpiRender, DefaultViewIsOneCameraForAllRanks) {
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + file("t.vtu")).status, 0);
  const std::string common = "render " + file("t.vtu") + " --threads 1 --size 64 --engine exact";
  const CommandResult one = mpirun(
      1, common + " -o " + file("one.png") + " --float " + file("one.pfm") + " --save-camera " + file("one.cam"));
  ASSERT_EQ(one.status, 0) << one.out;
  const CommandResult two = mpirun(
      2, common + " -o " + file("two.png") + " --float " + file("two.pfm") + " --save-camera " + file("two.cam"));
  ASSERT_EQ(two.status, 0) << two.out;
  const CommandResult whole =
      mpirun(2, common + " --tf viridis -o " + file("v.png") + " --save-camera " + file("v.cam"));
  ASSERT_EQ(whole.status, 0) << whole.out;
  EXPECT_EQ(slurp(file("one.cam")), slurp(file("two.cam")));
  EXPECT_NE(slurp(file("one.cam")), slurp(file("v.cam"))) << "the default view should be framed, not the whole domain";
  const ImageDifference d = compare_images(read_pfm(file("two.pfm")), read_pfm(file("one.pfm")));
  std::printf("2 ranks vs 1, no flags: psnr %.2f dB, max %.3g\n", d.psnr_db, d.max_abs);
  EXPECT_GE(d.psnr_db, 60);
}

// A U-shaped block of hexahedra (a slot cut out of a cube): rays leave the data and enter it again, and the kd-tree's
// planes cut through the gap.
TEST_F(MpiRender, ExactNonConvexFourRanksEqualOne) {
  test::write_u_shaped_mesh(file("u.vtk"));
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
