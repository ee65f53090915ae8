// `ugvr view`'s memory budget (view/memory_budget.h): the in-core estimate made before reading, the byte sizes the
// flag and the variable take, and which of them wins.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/view/memory_budget.h"

namespace ugvr::view {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("ugvr-test-budget-" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

TEST(ViewMemoryBudget, ParsesByteSizesAsTheFlagsDo) {
  EXPECT_EQ(parse_byte_size("1048576", "x"), 1048576u);
  EXPECT_EQ(parse_byte_size("12GiB", "x"), uint64_t(12) << 30);
  EXPECT_EQ(parse_byte_size("512 MiB", "x"), uint64_t(512) << 20);
  EXPECT_EQ(parse_byte_size("800MB", "x"), 800'000'000u);
  EXPECT_EQ(parse_byte_size("100kB", "x"), 100'000u);
  EXPECT_EQ(parse_byte_size("1.5gib", "x"), uint64_t(3) << 29);
  for (const char* bad : {"", "GiB", "-1GiB", "12 parsecs", "nan", "1e30"}) {
    try {
      parse_byte_size(bad, "UGVR_VIEW_MEMORY_BUDGET");
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("UGVR_VIEW_MEMORY_BUDGET"), std::string::npos) << e.what();
    }
  }
}

TEST(ViewMemoryBudget, TheFlagWinsThenTheVariableThenHalfTheMachine) {
  ::unsetenv(kViewMemoryBudgetEnv);
  std::string source;
  EXPECT_EQ(view_memory_budget(uint64_t(1) << 30, &source), uint64_t(1) << 30);
  EXPECT_EQ(source, "--memory-budget");
  const uint64_t ram = physical_memory_bytes();
  ASSERT_NE(ram, UINT64_MAX);
  EXPECT_EQ(view_memory_budget(std::nullopt, &source), uint64_t(double(ram) * kViewMemoryFraction));
  EXPECT_NE(source.find("half of the machine's"), std::string::npos) << source;
  ::setenv(kViewMemoryBudgetEnv, "3GiB", 1);
  EXPECT_EQ(view_memory_budget(std::nullopt, &source), uint64_t(3) << 30);
  EXPECT_EQ(source, kViewMemoryBudgetEnv);
  EXPECT_EQ(view_memory_budget(uint64_t(5), &source), 5u) << "the flag beats the variable";
  ::setenv(kViewMemoryBudgetEnv, "lots", 1);
  EXPECT_THROW(view_memory_budget(std::nullopt), Error);
  ::unsetenv(kViewMemoryBudgetEnv);
}

// A .vtu's counts come from its header, whatever its size on disk (compressed or not); other inputs by their size.
TEST(ViewMemoryBudget, EstimatesFromAVtuHeaderElseFromTheSizeOnDisk) {
  TempDir dir;
  const fs::path vtu = dir.path / "big.vtu";
  write(vtu,
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
        "compressor=\"vtkZLibDataCompressor\">"
        "<UnstructuredGrid><Piece NumberOfPoints=\"1790000\" NumberOfCells=\"10000000\">");
  const InCoreEstimate e = estimate_in_core({vtu.string()});
  EXPECT_EQ(e.cells, 10'000'000u);
  EXPECT_EQ(e.points, 1'790'000u);
  EXPECT_EQ(e.bytes, uint64_t(10'000'000 * kViewBytesPerCell + 1'790'000 * kViewBytesPerPoint));
  EXPECT_EQ(e.basis, "10000000 cells, 1790000 points");

  const fs::path msh = dir.path / "mesh.msh";
  write(msh, std::string(1000, 'x'));
  const InCoreEstimate m = estimate_in_core({msh.string()});
  EXPECT_EQ(m.cells, 0u);
  EXPECT_EQ(m.input_bytes, 1000u);
  EXPECT_EQ(m.bytes, uint64_t(1000 * kViewBytesPerInputByte));

  // A case directory: its files, recursively; a .vtu without a readable header: its size.
  fs::create_directories(dir.path / "case" / "constant" / "polyMesh");
  write(dir.path / "case" / "constant" / "polyMesh" / "points", std::string(300, 'p'));
  write(dir.path / "case" / "controlDict", std::string(200, 'c'));
  EXPECT_EQ(estimate_in_core({(dir.path / "case").string()}).input_bytes, 500u);
  write(vtu, std::string(700, ' '));
  EXPECT_EQ(estimate_in_core({vtu.string()}).bytes, uint64_t(700 * kViewBytesPerInputByte));
  EXPECT_THROW(estimate_in_core({(dir.path / "missing.vtu").string()}), Error);
}

}  // namespace
}  // namespace ugvr::view
