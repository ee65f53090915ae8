// The out-of-core builder's disk check (octree/out_of_core.h): a build that cannot fit its scratch folder is refused
// before anything is written, with what it needs, what is free and what to do instead.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/octree/out_of_core.h"

namespace ugvr {
namespace {

TEST(OutOfCoreDisk, TheFloorIsTwiceTheSoupOfTetrahedra) {
  // A tetrahedron's record with one vertex field is 96 bytes (octree/soup.h); the root's file and its children's.
  EXPECT_EQ(out_of_core_scratch_floor(1000, SoupLayout{1, 0}), 2u * 1000u * 96u);
  // Two vertex fields and a cell field: 16 + 64 + 4 (2 * 4 + 1) = 116 bytes a tetrahedron.
  EXPECT_EQ(out_of_core_scratch_floor(10, SoupLayout{2, 1}), 2u * 10u * 116u);
  EXPECT_EQ(out_of_core_scratch_floor(0, SoupLayout{1, 0}), 0u);
}

TEST(OutOfCoreDisk, TooLittleFreeSpaceIsRefusedWithAdvice) {
  EXPECT_NO_THROW(check_out_of_core_scratch("/data/big.vtu", 5, 1000, 1000, "/data/big.ugvr.cells"));
  try {
    check_out_of_core_scratch("/data/big.vtu", 1000000000, uint64_t(192) << 30, uint64_t(60) << 30,
                              "/data/big.ugvr.cells");
    FAIL() << "a build needing 192 GiB of scratch with 60 GiB free was not refused";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/data/big.vtu"), std::string::npos) << m;
    EXPECT_NE(m.find("1000000000 cells"), std::string::npos) << m;
    EXPECT_NE(m.find("/data/big.ugvr.cells"), std::string::npos) << m;
    EXPECT_NE(m.find("192"), std::string::npos) << m;
    EXPECT_NE(m.find("60"), std::string::npos) << m;
    // The advice runs as written: the partitioned build, one piece's scratch at a time, to an index beside the input.
    EXPECT_NE(m.find("ugvr build /data/big.vtu --pieces 16 --out-of-core -o /data/big.json"), std::string::npos) << m;
  }
}

// $UGVR_SCRATCH_FREE_BYTES stands for the free space (tests cannot fill a disk); a value that is not a count is refused
// naming the variable; unset, the file system's own figure.
TEST(OutOfCoreDisk, TheFreeSpaceSeenCanBeSetForTests) {
  ::unsetenv(kScratchFreeBytesEnv);
  EXPECT_GT(scratch_free_bytes("."), 0u);
  ::setenv(kScratchFreeBytesEnv, "12345", 1);
  EXPECT_EQ(scratch_free_bytes("."), 12345u);
  ::setenv(kScratchFreeBytesEnv, "12k", 1);
  try {
    scratch_free_bytes(".");
    FAIL() << "12k was taken as a byte count";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(kScratchFreeBytesEnv), std::string::npos) << e.what();
  }
  ::unsetenv(kScratchFreeBytesEnv);
}

}  // namespace
}  // namespace ugvr
