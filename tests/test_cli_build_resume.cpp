// `ugvr build ... --pieces N --resume` (mpi/piece_record.h): an interrupted partitioned build keeps the pieces it
// finished and builds the rest; a piece made otherwise (another input, split, ghost layer or options) is built again.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "test_data.h"

namespace ugvr {
namespace {

namespace fs = std::filesystem;
using test::run_ugvr;

std::string contents(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The pieces a --json build kept from an earlier run, and the ones it built.
struct Outcome {
  std::vector<int> kept, built;
};
Outcome outcome(const test::CommandResult& r) {
  EXPECT_EQ(r.status, 0) << r.out;
  // The JSON summary is the one line that starts with '{' (notes about pieces built again are lines of their own).
  std::istringstream lines(r.out);
  nlohmann::json summary;
  for (std::string line; std::getline(lines, line);)
    if (!line.empty() && line[0] == '{') summary = nlohmann::json::parse(line);
  Outcome o;
  for (const auto& p : summary["built"])
    (p.value("resumed", false) ? o.kept : o.built).push_back(p["piece"].get<int>());
  return o;
}

TEST(CliBuildResume, KeepsFinishedPiecesAndBuildsTheRest) {
  test::ScratchDir dir;
  const std::string mesh = dir.file("m.vtu"), index = dir.file("m.json");
  ASSERT_EQ(run_ugvr("generate --cells 5000 --kind tet -o " + mesh).status, 0);
  const std::string build =
      "build " + mesh + " -o " + index + " --fields pressure --brick 8 --max-depth 4 --pieces 4 --out-of-core --json";
  Outcome first = outcome(run_ugvr(build));
  EXPECT_EQ(first.built, (std::vector<int>{0, 1, 2, 3}));
  const std::string whole_index = contents(index);
  for (int k = 0; k < 4; ++k)
    ASSERT_TRUE(fs::exists(dir.file("m.d/piece-" + std::to_string(k) + ".ugvr.built.json"))) << k;

  // Interrupted during piece 2: its store never written; piece 3 never started.
  fs::remove(dir.file("m.d/piece-2.ugvr"));
  fs::remove(dir.file("m.d/piece-3.ugvr"));
  fs::remove(dir.file("m.d/piece-3.ugvr.built.json"));
  fs::remove(index);
  Outcome resumed = outcome(run_ugvr(build + " --resume"));
  EXPECT_EQ(resumed.kept, (std::vector<int>{0, 1}));
  EXPECT_EQ(resumed.built, (std::vector<int>{2, 3}));
  EXPECT_EQ(contents(index), whole_index) << "the index of a resumed build is the uninterrupted build's";

  // Without --resume every piece is built again.
  EXPECT_EQ(outcome(run_ugvr(build)).built.size(), 4u);

  // Another ghost layer or field selection: nothing kept, and a note says why.
  const test::CommandResult ghost = run_ugvr(build + " --resume --ghost-level 2");
  EXPECT_EQ(outcome(ghost).kept.size(), 0u);
  EXPECT_NE(ghost.out.find("ghost layer differs"), std::string::npos) << ghost.out;
  ASSERT_EQ(outcome(run_ugvr(build)).built.size(), 4u);

  // The input changed since (its modification time): nothing kept.
  fs::last_write_time(mesh, fs::last_write_time(mesh) + std::chrono::seconds(5));
  const test::CommandResult touched = run_ugvr(build + " --resume");
  EXPECT_EQ(outcome(touched).kept.size(), 0u);
  EXPECT_NE(touched.out.find("input file"), std::string::npos) << touched.out;

  // A damaged record: that piece built again.
  std::ofstream(dir.file("m.d/piece-1.ugvr.built.json")) << "{\"piece\": 1";
  const test::CommandResult damaged = run_ugvr(build + " --resume");
  EXPECT_EQ(outcome(damaged).built, (std::vector<int>{1}));
  EXPECT_NE(damaged.out.find("damaged"), std::string::npos) << damaged.out;
  EXPECT_EQ(contents(index), whole_index);
}

TEST(CliBuildResume, OnlyWithPieces) {
  test::ScratchDir dir;
  ASSERT_EQ(run_ugvr("generate --cells 2000 --kind tet -o " + dir.file("x.vtu")).status, 0);
  const test::CommandResult r = run_ugvr("build " + dir.file("x.vtu") + " -o " + dir.file("x.ugvr") + " --resume");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--resume applies with --pieces only"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ugvr
