// The viewer's server-wide budget over every tab's allocations (view/tab_memory.h); the server's use of it is in
// test_view_server.cpp (ViewServer.TabsShareOneMemoryBudget).
#include <gtest/gtest.h>

#include "ugvr/view/tab_memory.h"

namespace ugvr::view {
namespace {

constexpr uint64_t MiB = uint64_t(1) << 20;

TEST(TabMemory, LaterTabsGetWhatIsLeftThenAreRefused) {
  const uint64_t canvas = canvas_bytes(256, 256);  // 3 MiB
  const uint64_t tab = kTabQueueBytes + canvas + 64 * MiB;
  TabMemory m(2 * tab + 40 * MiB, 64 * MiB);
  std::string why;
  const auto a = m.admit(1, 256, 256, why);
  ASSERT_TRUE(a) << why;
  EXPECT_EQ(a->cache, 64 * MiB);
  EXPECT_EQ(a->canvas, canvas);
  const auto b = m.admit(2, 256, 256, why);
  ASSERT_TRUE(b) << why;
  EXPECT_EQ(b->cache, 64 * MiB);
  // 40 MiB left: the queue and canvas (19 MiB) and a cache of what remains (21 MiB, under the 32 MiB minimum): refused.
  EXPECT_FALSE(m.admit(3, 256, 256, why));
  EXPECT_NE(why.find("--tabs-memory"), std::string::npos) << why;
  EXPECT_NE(why.find("2 tabs"), std::string::npos) << why;
  EXPECT_EQ(m.used(), 2 * tab);
  // A tab leaves: its charge comes back, and the next one is admitted with the full cache.
  m.release(1);
  EXPECT_EQ(m.used(), tab);
  EXPECT_FALSE(m.charge(1));
  const auto c = m.admit(3, 256, 256, why);
  ASSERT_TRUE(c) << why;
  EXPECT_EQ(c->cache, 64 * MiB);
  m.release(1);  // twice: nothing
  EXPECT_EQ(m.used(), 2 * tab);
}

TEST(TabMemory, ACacheShortOfItsShareTakesTheRest) {
  const uint64_t fixed = kTabQueueBytes + canvas_bytes(128, 128);
  TabMemory m(fixed + 100 * MiB + fixed + 40 * MiB, 100 * MiB);
  std::string why;
  ASSERT_TRUE(m.admit(1, 128, 128, why));
  const auto b = m.admit(2, 128, 128, why);
  ASSERT_TRUE(b) << why;
  EXPECT_EQ(b->cache, 40 * MiB);  // less than its 100 MiB share, above the minimum
  EXPECT_EQ(m.used(), m.budget());
}

TEST(TabMemory, AResizeThatDoesNotFitIsRefusedAndChangesNothing) {
  TabMemory m(uint64_t(256) * MiB, 32 * MiB);
  std::string why;
  ASSERT_TRUE(m.admit(7, 512, 512, why));
  const uint64_t used = m.used();
  EXPECT_FALSE(m.resize(7, 4096, 4096, why));  // 768 MiB of canvas
  EXPECT_NE(why.find("4096x4096"), std::string::npos) << why;
  EXPECT_EQ(m.used(), used);
  EXPECT_EQ(m.charge(7)->canvas, canvas_bytes(512, 512));
  ASSERT_TRUE(m.resize(7, 1024, 1024, why)) << why;
  EXPECT_EQ(m.used(), used - canvas_bytes(512, 512) + canvas_bytes(1024, 1024));
  ASSERT_TRUE(m.resize(7, 16, 16, why)) << why;
  EXPECT_EQ(m.charge(7)->canvas, canvas_bytes(16, 16));
  EXPECT_TRUE(m.resize(99, 4096, 4096, why));  // a tab not charged (closed meanwhile): nothing to check
}

TEST(TabMemory, ABudgetSmallerThanOneTabAdmitsNone) {
  TabMemory m(8 * MiB, 64 * MiB);
  std::string why;
  EXPECT_FALSE(m.admit(1, 16, 16, why));
  EXPECT_EQ(m.used(), 0u);
  EXPECT_EQ(m.tabs(), 0u);
}

}  // namespace
}  // namespace ugvr::view
