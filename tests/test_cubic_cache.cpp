// The tricubic coefficient cache (src/ugvr/render/lod/cubic_cache.h): entries kept within the byte budget, least
// recently used out first, emptied when what the coefficients depend on changes. The engine's use of it (a brick
// uploaded again is not prefiltered again, and draws what a fresh engine draws) is LodTricubic.LevelBlendFollowsTheCut.
#include <gtest/gtest.h>

#include "ugvr/render/lod/cubic_cache.h"

namespace ugvr {
namespace {

CubicCoefficientCache::Entry entry(double value, size_t count = 100) {
  CubicCoefficientCache::Entry e;
  e.prefiltered = true;
  e.coefficients.assign(count, value);
  return e;
}

TEST(CubicCoefficientCache, KeepsEntriesWithinItsBudgetLeastRecentlyUsedOutFirst) {
  const uint64_t one = CubicCoefficientCache::bytes_of(entry(0));  // 800 bytes
  CubicCoefficientCache cache(3 * one);
  cache.use({});
  cache.put(1, entry(1));
  cache.put(2, entry(2));
  cache.put(3, entry(3));
  EXPECT_EQ(cache.bytes(), 3 * one);
  ASSERT_TRUE(cache.find(1));  // 1 is now the most recently used: 2 goes first
  cache.put(4, entry(4));
  EXPECT_EQ(cache.size(), 3u);
  EXPECT_LE(cache.bytes(), cache.budget());
  EXPECT_FALSE(cache.find(2));
  ASSERT_TRUE(cache.find(1));
  EXPECT_EQ(cache.find(1)->coefficients, entry(1).coefficients);
  EXPECT_TRUE(cache.find(3));
  EXPECT_TRUE(cache.find(4));
  EXPECT_EQ(cache.evictions(), 1u);
  EXPECT_EQ(cache.misses(), 1u);
  EXPECT_EQ(cache.hits(), 5u);
  // A node put again replaces its entry (and its bytes).
  cache.put(4, entry(5, 50));
  EXPECT_EQ(cache.bytes(), 2 * one + one / 2);
  EXPECT_EQ(cache.find(4)->coefficients.front(), 5.0);
  // An entry larger than the budget is handed back but not kept; a brick that keeps its samples costs nothing.
  const CubicCoefficientCache::Shared big = cache.put(9, entry(9, 1000));
  EXPECT_EQ(big->coefficients.size(), 1000u);
  EXPECT_FALSE(cache.find(9));
  EXPECT_LE(cache.bytes(), cache.budget());
  cache.put(10, CubicCoefficientCache::Entry{});
  ASSERT_TRUE(cache.find(10));
  EXPECT_FALSE(cache.find(10)->prefiltered);
}

TEST(CubicCoefficientCache, AChangeOfWhatTheCoefficientsDependOnEmptiesIt) {
  CubicCoefficientCache cache(uint64_t(1) << 20);
  CubicCoefficientCache::Settings s;
  s.field = 0, s.lo = 0, s.hi = 1, s.extension = 4;
  cache.use(s);
  cache.put(1, entry(1));
  cache.use(s);  // the same: kept
  EXPECT_TRUE(cache.find(1));
  for (int change = 0; change < 6; ++change) {
    CubicCoefficientCache::Settings t = s;
    if (change == 0) t.field = 1;
    if (change == 1) t.step = 1;
    if (change == 2) t.lo = -1;
    if (change == 3) t.hi = 2;
    if (change == 4) t.extension = 0;
    if (change == 5) t.fill = false;
    cache.use(s);
    cache.put(1, entry(1));
    cache.use(t);
    EXPECT_FALSE(cache.find(1)) << "change " << change;
    EXPECT_EQ(cache.bytes(), 0u);
  }
  // No budget: nothing kept.
  CubicCoefficientCache none(0);
  none.put(1, entry(1));
  EXPECT_FALSE(none.find(1));
}

}  // namespace
}  // namespace ugvr
