// A collective frame cut short (mpi_frame_stop.h): rank 0's keep_going decides for every rank. Three ranks of the
// probe (tests/mpi/probe/mpi_stop_probe.cpp, which says what each frame does) under mpirun, killed after 120 s so that
// a hang fails the test: every rank drops an interrupted frame, the next frame is the uninterrupted image bit for bit,
// a slow rank finishes normally once rank 0's part is done, and a slow rank is stopped by a question rank 0 asks after
// its own part is drawn.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "mpi_fixtures.h"
#include "test_data.h"

namespace ugvr {
namespace {

using nlohmann::json;

constexpr int kRanks = 3;

std::string probe_path() { return (std::filesystem::path(UGVR_BINARY).parent_path() / "ugvr_mpi_stop_probe").string(); }

TEST(MpiFrameStop, RankZeroStopsEveryRankAndTheNextFrameIsUnchanged) {
  test::ScratchDir dir;
  test::write_u_shaped_mesh(dir.file("u.vtk"), 8);
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  const test::CommandResult r =
      test::run_command("timeout 120 " + std::string(UGVR_MPIEXEC) + " --oversubscribe -np " + std::to_string(kRanks) +
                        " " + probe_path() + " " + dir.file("u.vtk") + " " + dir.file(""));
  ASSERT_EQ(r.status, 0) << "the probe hung (124) or failed\n" << r.out;
  json ranks[kRanks];
  for (int k = 0; k < kRanks; ++k) {
    std::ifstream in(dir.file("rank" + std::to_string(k) + ".json"));
    ASSERT_TRUE(in) << "rank " << k << " wrote nothing\n" << r.out;
    ranks[k] = json::parse(in);
  }
  const json& zero = ranks[0];
  for (int k = 0; k < kRanks; ++k) {
    SCOPED_TRACE("rank " + std::to_string(k));
    for (const char* drawn : {"whole", "after_stop", "slow_done", "after_slow_stop"})
      EXPECT_FALSE(ranks[k][drawn]["interrupted"].get<bool>()) << drawn;
    EXPECT_TRUE(ranks[k]["stop_first"]["interrupted"].get<bool>()) << "rank 0's first question said stop";
    EXPECT_TRUE(ranks[k]["slow_stop"]["interrupted"].get<bool>()) << "rank 0 said stop while rank 1 was held";
    // Rank 1 is held 60 s unless it hears Stop: rank 0 said it 0.5 s in.
    EXPECT_LT(ranks[k]["slow_stop"]["seconds"].get<double>(), 20.0);
  }
  EXPECT_EQ(zero["stop_first"]["questions"], 1) << "nothing is asked after the answer stop";
  for (const char* drawn : {"after_stop", "slow_done", "after_slow_stop"}) {
    EXPECT_TRUE(zero[drawn]["same_as_whole"].get<bool>()) << drawn << ": not the uninterrupted image bit for bit";
    EXPECT_GT(zero[drawn]["questions"].get<int>(), 0) << drawn << ": rank 0's question was never asked";
  }
  // Rank 0 drew its part (milliseconds) long before rank 1 began its own, and waited for it, asking meanwhile. Rank 1
  // may have started the frame a little before rank 0 (rank 0 ends the previous one last, with the composited image),
  // so rank 0's time is only bounded well below rank 1's hold.
  EXPECT_GE(zero["slow_done"]["seconds"].get<double>(), 0.5);
  EXPECT_GE(ranks[1]["slow_done"]["seconds"].get<double>(), 1.0);
  EXPECT_GE(zero["slow_stop"]["seconds"].get<double>(), 0.5);
}

}  // namespace
}  // namespace ugvr
