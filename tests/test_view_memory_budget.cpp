// `ugvr view`'s memory budget (view/memory_budget.h): the in-core estimate made before reading, the byte sizes the
// flag and the variable take, and which of them wins.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/io/reader.h"
#include "ugvr/view/memory_budget.h"
#include "ugvr/view/scratch_pieces.h"

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
  EXPECT_EQ(e.bytes, uint64_t(kViewFixedBytes + 10'000'000 * kViewBytesPerCell + 1'790'000 * kViewBytesPerPoint));
  EXPECT_EQ(e.basis, "10000000 cells, 1790000 points");
  // The viewer's measured peaks (memory_budget.h): 10M tetrahedra 2.83 GB; 300,000 tetrahedra (53,100 points) 218 MB
  // and 300,000 hexahedra (312,000 points) 253 MB, which the per-cell terms alone put at 40 % of that.
  const auto model = [](double cells, double points) {
    return kViewFixedBytes + cells * kViewBytesPerCell + points * kViewBytesPerPoint;
  };
  EXPECT_NEAR(model(10e6, 1.79e6) / 2.83e9, 1.0, 0.05);
  EXPECT_NEAR(model(3e5, 5.31e4) / 218e6, 1.0, 0.11);
  EXPECT_NEAR(model(3e5, 3.12e5) / 253e6, 1.0, 0.11);

  const fs::path msh = dir.path / "mesh.msh";
  write(msh, std::string(1000, 'x'));
  const InCoreEstimate m = estimate_in_core({msh.string()});
  EXPECT_EQ(m.cells, 0u);
  EXPECT_EQ(m.input_bytes, 1000u);
  EXPECT_EQ(m.bytes, uint64_t(kViewFixedBytes + 1000 * kViewBytesPerInputByte));

  // A case directory: its files, recursively; a .vtu without a readable header: its size.
  fs::create_directories(dir.path / "case" / "constant" / "polyMesh");
  write(dir.path / "case" / "constant" / "polyMesh" / "points", std::string(300, 'p'));
  write(dir.path / "case" / "controlDict", std::string(200, 'c'));
  EXPECT_EQ(estimate_in_core({(dir.path / "case").string()}).input_bytes, 500u);
  write(vtu, std::string(700, ' '));
  EXPECT_EQ(estimate_in_core({vtu.string()}).bytes, uint64_t(kViewFixedBytes + 700 * kViewBytesPerInputByte));
  EXPECT_THROW(estimate_in_core({(dir.path / "missing.vtu").string()}), Error);
}

// The counts the headers say, for the formats that say them, against what reading the file gives. OpenFOAM: the
// fixtures (plain, gzip, decomposed: pieces summed as the reader concatenates them; a polyhedral mesh: counted before
// its decomposition, so fewer than read); a .pvtu of two pieces (their headers only: nothing else is read).
TEST(GridCountsFromHeaders, OpenFoamCasesAndPvtuPieces) {
  const std::string foam = std::string(UGVR_SOURCE_DIR) + "/tests/data/openfoam/";
  for (const char* name : {"cavity", "cavity_gzip", "cavity_ascii_gz", "cavity_binary"}) {
    const std::vector<std::string> in{foam + name};
    const std::optional<GridCounts> c = grid_counts_from_headers(in);
    ASSERT_TRUE(c) << name;
    EXPECT_EQ(c->points, 882u) << name;
    EXPECT_EQ(c->cells, 400u) << name;
  }
  const std::vector<std::string> decomposed{foam + "cavity_decomposed/cavity_decomposed.foam"};
  const std::optional<GridCounts> d = grid_counts_from_headers(decomposed);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->points, 924u) << "processor boundary points counted by each piece, as read";
  EXPECT_EQ(d->cells, 400u);
  const std::vector<std::string> dual{foam + "dual"};
  const std::optional<GridCounts> p = grid_counts_from_headers(dual);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->points, 692u);
  EXPECT_EQ(p->cells, 343u) << "187 hexahedra + 156 polyhedra, before the decomposition";

  TempDir dir;
  for (const auto& [file, points, cells] : {std::tuple{"a.vtu", 1000, 4000}, std::tuple{"b.vtu", 300, 700}})
    write(dir.path / file,
          "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece "
          "NumberOfPoints=\"" +
              std::to_string(points) + "\" NumberOfCells=\"" + std::to_string(cells) + "\">");
  write(dir.path / "all.pvtu",
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\"><PUnstructuredGrid><PPoints/>"
        "<Piece Source=\"a.vtu\"/><Piece Source=\"b.vtu\"/></PUnstructuredGrid></VTKFile>");
  const std::vector<std::string> pvtu{(dir.path / "all.pvtu").string()};
  const std::optional<GridCounts> v = grid_counts_from_headers(pvtu);
  ASSERT_TRUE(v);
  EXPECT_EQ(v->points, 1300u);
  EXPECT_EQ(v->cells, 4700u);
  const InCoreEstimate e = estimate_in_core(pvtu);
  EXPECT_EQ(e.basis, "4700 cells, 1300 points") << "the viewer's estimate uses them";
  // A piece that is missing: the .pvtu cannot be counted, and the estimate falls back to the size on disk.
  fs::remove(dir.path / "b.vtu");
  EXPECT_THROW(grid_counts_from_headers(pvtu), Error);
  EXPECT_EQ(estimate_in_core(pvtu).cells, 0u);
}

// Exodus (netCDF dimensions) and CGNS (zone sizes) on the shared samples: the counts that reading them gives.
TEST(GridCountsFromHeaders, ExodusAndCgnsSamplesMatchTheirRead) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  for (const char* name :
       {"exodus-misc/mug.e", "exodus-misc/box-noglom.ex2", "exodus-misc/mesh_fs8.exo", "cgns-sqnz/sqnz_s.adf.cgns"}) {
    const std::vector<std::string> in{test::data_path(name)};
    if (!fs::exists(in[0])) continue;
    const std::optional<GridCounts> c = grid_counts_from_headers(in);
    ASSERT_TRUE(c) << name;
    const Dataset ds = read_dataset(in);
    EXPECT_EQ(c->points, ds.point_count()) << name;
    EXPECT_EQ(c->cells, ds.cell_count()) << name;
  }
}

// Too little free space for one out-of-core build's scratch: the least power of two whose piece fits (its kd box grown
// by the ghost margin, kScratchPieceMargin over it); none up to kMaxScratchPieces keeps the refusal.
TEST(ScratchPieces, TheLeastPowerOfTwoWhosePieceFits) {
  // 2,000 cells, one field: the floor is 2 x 2,000 x 96 bytes.
  const ScratchPieces fits = pieces_for_scratch(2000, 0, 32, 384000, "/cache");
  EXPECT_EQ(fits.pieces, 1);
  EXPECT_EQ(fits.whole, 384000u);
  EXPECT_TRUE(fits.why.empty());
  // Two pieces hold 0.629 of the cells (half the x axis and twice 2/31 of it), 302 KB with the margin; four
  // 0.629^2, 190 KB.
  const ScratchPieces four = pieces_for_scratch(2000, 1, 32, 200000, "/cache");
  EXPECT_EQ(four.pieces, 4);
  EXPECT_LE(four.piece, 200000u);
  EXPECT_NE(four.why.find("building 4 pieces, one at a time"), std::string::npos) << four.why;
  EXPECT_NE(four.why.find("/cache"), std::string::npos) << four.why;
  EXPECT_NE(four.why.find("2000 cells"), std::string::npos) << four.why;
  // Named fields are counted as vertex fields, the larger record: 2 x 2,000 x 112 for two.
  EXPECT_EQ(pieces_for_scratch(2000, 2, 32, 0, "/cache").whole, 448000u);
  // More pieces never hold less than the ghost layers: with 1 KB free none fits.
  const ScratchPieces none = pieces_for_scratch(2000, 1, 32, 1000, "/cache");
  EXPECT_EQ(none.pieces, 0);
  EXPECT_TRUE(none.why.empty());
}

}  // namespace
}  // namespace ugvr::view
