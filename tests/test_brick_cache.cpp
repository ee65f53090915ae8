// The RAM brick cache: what it loads is bit for bit what the synchronous path builds, it keeps to its budget, evicts
// the least recently used brick outside the current request list, loads by priority and admits only what the budget
// holds, drops requests a newer list no longer wants, reports a corrupt brick instead of rendering it, and stays
// consistent while the render thread requests and reads as the workers load.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/render/lod/brick_atlas.h"
#include "ugvr/render/lod/brick_cache.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;
using Request = std::vector<std::pair<uint64_t, float>>;

constexpr double kWait = 10;  // seconds; a bound, never reached when the cache works

// A complete octree of `levels` levels below the root, breadth first.
std::vector<OctreeNode> full_tree(int levels) {
  std::vector<OctreeNode> nodes(1);
  for (size_t id = 0; id < nodes.size(); ++id) {
    const OctreeNode n = nodes[id];
    if (n.level >= levels) continue;
    nodes[id].first_child = nodes.size();
    nodes[id].child_mask = 0xff;
    for (int o = 0; o < 8; ++o) {
      OctreeNode c;
      c.parent = id;
      c.level = uint8_t(n.level + 1);
      c.i = 2 * n.i + (o & 1);
      c.j = 2 * n.j + (o >> 1 & 1);
      c.k = 2 * n.k + (o >> 2 & 1);
      nodes.push_back(c);
    }
  }
  return nodes;
}

bool has_brick(uint64_t id) { return id % 11 != 7; }  // a few nodes without data

// Two fields over a 73-node tree of R = 8 bricks; some nodes have no brick, some bricks have samples without data
// (so that make_atlas_slot's padding is exercised).
void write_store(const std::string& path) {
  constexpr uint32_t r = 8;
  BrickStoreLayout layout;
  layout.resolution = r;
  layout.root = layout.data = Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
  layout.fields = {{"pressure", Association::Vertex, -2.0, 2.0}, {"density", Association::Cell, 0.0, 10.0}};
  const std::vector<OctreeNode> nodes = full_tree(2);
  BrickStoreWriter w(path, layout);
  const size_t n3 = size_t(r) * r * r;
  std::vector<float> a(n3), b(n3);
  std::vector<uint8_t> mask(n3);
  for (uint64_t id = 0; id < nodes.size(); ++id) {
    if (!has_brick(id)) continue;
    const Bounds cell = node_bounds(layout.root, nodes[id]);
    size_t s = 0;
    for (uint32_t z = 0; z < r; ++z) {
      for (uint32_t y = 0; y < r; ++y) {
        for (uint32_t x = 0; x < r; ++x, ++s) {
          const double px = cell.lo.x + x * (cell.hi.x - cell.lo.x) / (r - 1);
          const double py = cell.lo.y + y * (cell.hi.y - cell.lo.y) / (r - 1);
          const double pz = cell.lo.z + z * (cell.hi.z - cell.lo.z) / (r - 1);
          a[s] = float(std::sin(5 * px) * std::cos(3 * py) + pz);
          b[s] = float(5 + 4 * std::sin(7 * px * py + pz));
          mask[s] = !(id % 3 == 0 && (x + y + z) % 5 == 0);
        }
      }
    }
    const float* fields[2] = {a.data(), b.data()};
    w.add_brick(id, fields, mask.data());
  }
  w.commit(nodes);
}

// The synchronous path's texels (lod_engine.cpp): read_brick, then make_atlas_slot with the field's global range.
std::vector<uint16_t> expected_texels(const BrickStoreReader& store, uint64_t node, uint32_t field) {
  const uint32_t r = store.resolution();
  std::vector<float> samples(size_t(r) * r * r);
  std::vector<uint8_t> mask(samples.size());
  store.read_brick(node, field, samples.data(), mask.data());
  std::vector<uint16_t> texels;
  make_atlas_slot(r, samples.data(), mask.data(), store.layout().fields[field].min, store.layout().fields[field].max,
                  texels);
  return texels;
}

class BrickCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.file("cache.ubs");
    write_store(path_);
    store_ = std::make_unique<BrickStoreReader>(path_);
    for (uint64_t n = 0; n < store_->node_count(); ++n)
      if (store_->node(n).has_brick()) bricked_.push_back(n);
    ASSERT_EQ(store_->node_count(), 73u);
    ASSERT_LT(bricked_.size(), 73u);
  }

  // Bytes of one R = 8 brick's texels: 10³ texels of 2 uint16.
  static uint64_t cache_brick_bytes() { return 10 * 10 * 10 * 4; }

  // A request list naming `nodes` with falling priority.
  static Request ranked(const std::vector<uint64_t>& nodes) {
    Request req;
    for (size_t i = 0; i < nodes.size(); ++i) req.emplace_back(nodes[i], float(nodes.size() - i));
    return req;
  }

  ScratchDir dir_;
  std::string path_;
  std::unique_ptr<BrickStoreReader> store_;
  std::vector<uint64_t> bricked_;  // nodes with a brick
};

TEST_F(BrickCacheTest, LoadsEqualTheSynchronousPathBitForBit) {
  BrickCache cache(*store_, 0, uint64_t(1) << 30, 3);
  EXPECT_EQ(cache.brick_bytes(), cache_brick_bytes());
  std::vector<uint64_t> all(store_->node_count());
  for (uint64_t n = 0; n < all.size(); ++n) all[n] = n;  // nodes without a brick are ignored
  const Request req = ranked(all);
  cache.request(req);
  ASSERT_TRUE(cache.wait_all(kWait));
  cache.rethrow_load_error();

  for (uint32_t field : {0u, 1u}) {
    if (field == 1) {
      cache.set_field(1);
      EXPECT_FALSE(cache.resident(bricked_[0]));  // everything dropped
      cache.request(req);
      ASSERT_TRUE(cache.wait_all(kWait));
    }
    uint64_t block_bytes = 0;
    for (uint64_t n : all) {
      const BrickCache::Brick b = cache.get(n);
      if (!store_->node(n).has_brick()) {
        EXPECT_EQ(b, nullptr) << n;
        continue;
      }
      block_bytes += store_->block(n, field).size;
      ASSERT_NE(b, nullptr) << n;
      EXPECT_EQ(*b, expected_texels(*store_, n, field)) << "node " << n << " field " << field;
    }
    const BrickCacheStats s = cache.stats();
    EXPECT_EQ(s.requests, bricked_.size());
    EXPECT_EQ(s.loads_completed, bricked_.size());
    EXPECT_EQ(s.bytes_read, block_bytes);
    EXPECT_EQ(s.hits, bricked_.size());
    EXPECT_EQ(s.misses, all.size() - bricked_.size());
    EXPECT_EQ(s.resident_bricks, bricked_.size());
    EXPECT_EQ(s.resident_bytes, bricked_.size() * cache.brick_bytes());
    EXPECT_EQ(s.over_budget + s.evictions + s.load_errors + s.queued + s.loading, 0u);
    EXPECT_GT(s.load_seconds, 0.0);
    cache.reset_stats();
  }
}

TEST_F(BrickCacheTest, NeverExceedsTheBudget) {
  // Five bricks and a bit: the remainder must not buy a sixth.
  const uint64_t budget = 6 * cache_brick_bytes() - 1;
  BrickCache cache(*store_, 0, budget, 3);
  ASSERT_EQ(cache.capacity(), 5u);
  std::mt19937 rng(1);
  for (int round = 0; round < 40; ++round) {
    Request req;
    for (int i = 0; i < 9; ++i) req.emplace_back(bricked_[rng() % bricked_.size()], float(rng() % 100));
    cache.request(req);
    BrickCacheStats s = cache.stats();
    ASSERT_LE(s.resident_bytes, budget);
    ASSERT_LE(s.resident_bricks + s.loading, cache.capacity());
    if (round % 2) {
      cache.wait_all(kWait);  // false when the list names more than 5 distinct nodes
      s = cache.stats();
      ASSERT_EQ(s.queued + s.loading, 0u);
      ASSERT_LE(s.resident_bytes, budget);
    }
  }
  EXPECT_GT(cache.stats().evictions, 0u);
  EXPECT_GT(cache.stats().over_budget, 0u);
  // A budget below one brick still holds one.
  BrickCache tiny(*store_, 0, 1, 1);
  EXPECT_EQ(tiny.capacity(), 1u);
  tiny.request(ranked({bricked_[0], bricked_[1]}));
  EXPECT_FALSE(tiny.wait_all(kWait));
  EXPECT_TRUE(tiny.resident(bricked_[0]));
  EXPECT_EQ(tiny.stats().over_budget, 1u);
}

TEST_F(BrickCacheTest, EvictsTheLeastRecentlyUsedBrick) {
  BrickCache cache(*store_, 0, 3 * cache_brick_bytes(), 1);
  const uint64_t a = bricked_[0], b = bricked_[1], c = bricked_[2], d = bricked_[3], e = bricked_[4], f = bricked_[5];
  for (uint64_t n : {a, b, c}) {
    cache.request(ranked({n}));
    ASSERT_TRUE(cache.wait_all(kWait));
  }
  // Most recent first: c b a. A get() is a use: a c b.
  ASSERT_NE(cache.get(a), nullptr);
  cache.request(ranked({d}));
  ASSERT_TRUE(cache.wait_all(kWait));
  EXPECT_FALSE(cache.resident(b));
  EXPECT_TRUE(cache.resident(a) && cache.resident(c) && cache.resident(d));
  // d a c: c goes.
  cache.request(ranked({e}));
  ASSERT_TRUE(cache.wait_all(kWait));
  EXPECT_FALSE(cache.resident(c));
  EXPECT_TRUE(cache.resident(a) && cache.resident(d) && cache.resident(e));
  // e d a; being requested is a use and protects a: d goes.
  cache.request(ranked({a, f}));
  ASSERT_TRUE(cache.wait_all(kWait));
  EXPECT_FALSE(cache.resident(d));
  EXPECT_TRUE(cache.resident(a) && cache.resident(e) && cache.resident(f));
  EXPECT_EQ(cache.stats().evictions, 3u);
  EXPECT_EQ(cache.stats().resident_bytes, 3 * cache.brick_bytes());
}

TEST_F(BrickCacheTest, HighestPrioritiesAreLoadedFirstAndWithinTheBudget) {
  constexpr uint64_t kCapacity = 4;
  BrickCache cache(*store_, 0, kCapacity * cache_brick_bytes(), 1);
  // Ten nodes, priorities in an order unrelated to the list's.
  std::vector<uint64_t> nodes(bricked_.begin() + 10, bricked_.begin() + 20);
  Request req;
  std::mt19937 rng(3);
  std::vector<float> priorities = {0.5f, 9.f, 3.f, -1.f, 7.f, 2.f, 8.f, 1.f, 6.f, 4.f};
  for (size_t i = 0; i < nodes.size(); ++i) req.emplace_back(nodes[i], priorities[i]);
  std::shuffle(req.begin(), req.end(), rng);
  Request by_priority = req;
  std::sort(by_priority.begin(), by_priority.end(), [](auto& x, auto& y) { return x.second > y.second; });

  cache.request(req);
  EXPECT_FALSE(cache.wait_all(kWait));  // six are over budget
  for (size_t i = 0; i < by_priority.size(); ++i)
    EXPECT_EQ(cache.resident(by_priority[i].first), i < kCapacity) << "priority " << by_priority[i].second;
  BrickCacheStats s = cache.stats();
  EXPECT_EQ(s.requests, 10u);
  EXPECT_EQ(s.over_budget, 6u);
  EXPECT_EQ(s.loads_completed, kCapacity);
  EXPECT_EQ(s.evictions, 0u);

  // The order of the loads shows in the LRU order: the single worker loaded the highest priority first, so it is
  // the least recently used and the first to go for an unrelated node.
  cache.request(ranked({bricked_[30]}));
  ASSERT_TRUE(cache.wait_all(kWait));
  EXPECT_FALSE(cache.resident(by_priority[0].first));
  for (size_t i = 1; i < kCapacity; ++i) EXPECT_TRUE(cache.resident(by_priority[i].first));
}

TEST_F(BrickCacheTest, ANewListDropsRequestsNotYetStarted) {
  BrickCache cache(*store_, 0, uint64_t(1) << 30, 1);
  cache.set_paused(true);
  const std::vector<uint64_t> old_list(bricked_.begin(), bricked_.begin() + 20);
  const std::vector<uint64_t> new_list(bricked_.begin() + 15, bricked_.begin() + 30);  // 5 nodes in common
  cache.request(ranked(old_list));
  EXPECT_EQ(cache.stats().queued, 20u);
  cache.request(ranked(new_list));
  EXPECT_EQ(cache.stats().queued, 15u);
  EXPECT_EQ(cache.stats().cancelled, 15u);
  EXPECT_FALSE(cache.wait_all(0.01));  // paused: nothing moves
  cache.set_paused(false);
  ASSERT_TRUE(cache.wait_all(kWait));
  EXPECT_EQ(cache.stats().loads_completed, 15u);
  for (size_t i = 0; i < 15; ++i) EXPECT_FALSE(cache.resident(old_list[i]));
  for (uint64_t n : new_list) EXPECT_TRUE(cache.resident(n));
}

TEST_F(BrickCacheTest, ACorruptBrickIsReportedAndNeverResident) {
  const uint64_t bad = bricked_[12];
  const BlockRef block = store_->block(bad, 0);
  const std::string copy = dir_.file("corrupt.ubs");
  std::filesystem::copy_file(path_, copy);
  {
    std::fstream f(copy, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(block.offset + block.size / 2));
    char c = 0;
    f.read(&c, 1);
    c = char(c ^ 0x5a);
    f.seekp(std::streamoff(block.offset + block.size / 2));
    f.write(&c, 1);
  }
  const BrickStoreReader store(copy);  // the node table is intact: opening succeeds
  BrickCache cache(store, 0, uint64_t(1) << 30, 2);
  const std::vector<uint64_t> nodes(bricked_.begin() + 8, bricked_.begin() + 16);
  cache.request(ranked(nodes));
  EXPECT_FALSE(cache.wait_all(kWait));
  try {
    cache.rethrow_load_error();
    ADD_FAILURE() << "no error reported";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(copy), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(cache.rethrow_load_error());  // reported once
  EXPECT_FALSE(cache.resident(bad));
  EXPECT_EQ(cache.get(bad), nullptr);
  for (uint64_t n : nodes) {
    if (n != bad) {
      EXPECT_TRUE(cache.resident(n)) << n;
    }
  }
  EXPECT_EQ(cache.stats().load_errors, 1u);
  // A failed node is not retried frame after frame; switching fields forgets the failure.
  cache.request(ranked(nodes));
  cache.wait_all(kWait);
  EXPECT_EQ(cache.stats().load_errors, 1u);
  EXPECT_NO_THROW(cache.rethrow_load_error());
  cache.set_field(1);
  cache.request(ranked({bad}));
  EXPECT_TRUE(cache.wait_all(kWait));  // field 1's block of that node is intact
}

TEST_F(BrickCacheTest, ABrickOutlivesItsEviction) {
  BrickCache cache(*store_, 0, cache_brick_bytes(), 1);
  cache.request(ranked({bricked_[0]}));
  ASSERT_TRUE(cache.wait_all(kWait));
  const BrickCache::Brick held = cache.get(bricked_[0]);
  ASSERT_NE(held, nullptr);
  cache.request(ranked({bricked_[1]}));
  ASSERT_TRUE(cache.wait_all(kWait));
  EXPECT_FALSE(cache.resident(bricked_[0]));
  EXPECT_EQ(*held, expected_texels(*store_, bricked_[0], 0));
}

TEST_F(BrickCacheTest, BadArguments) {
  EXPECT_THROW((BrickCache{*store_, 2, 1 << 20, 1}), Error);
  BrickCache cache(*store_, 0, 1 << 20, 1);
  cache.set_paused(true);
  cache.request(ranked({bricked_[0]}));
  EXPECT_THROW(cache.request(ranked({bricked_[1], store_->node_count()})), Error);
  EXPECT_EQ(cache.stats().queued, 1u);  // the bad list changed nothing
  EXPECT_THROW(cache.set_field(5), Error);
  EXPECT_EQ(cache.field(), 0u);
  // NaN priorities and duplicates are harmless.
  cache.request(Request{{bricked_[2], NAN}, {bricked_[3], 1.f}, {bricked_[3], 2.f}});
  EXPECT_EQ(cache.stats().queued, 2u);
  cache.set_paused(false);
  EXPECT_TRUE(cache.wait_all(kWait));
}

TEST_F(BrickCacheTest, DestroyingWithWorkQueuedDoesNotHang) {
  for (int i = 0; i < 5; ++i) {
    BrickCache cache(*store_, 0, 8 * cache_brick_bytes(), 4);
    cache.request(ranked(bricked_));
  }
  SUCCEED();
}

// The render thread's pattern under load: a new list every "frame", gets in between, four workers loading. Checks the
// invariants and every brick read against the synchronous path, then switches fields under the same load.
TEST_F(BrickCacheTest, ConcurrentRequestsAndGetsStayConsistent) {
  std::vector<std::vector<uint16_t>> expected[2];
  for (uint32_t f = 0; f < 2; ++f) {
    expected[f].resize(store_->node_count());
    for (uint64_t n : bricked_) expected[f][n] = expected_texels(*store_, n, f);
  }
  const uint64_t budget = 12 * cache_brick_bytes();
  BrickCache cache(*store_, 0, budget, 4);
  std::mt19937 rng(11);
  uint64_t gets = 0, hits = 0;
  // A cut that drifts (two nodes replaced per frame, priorities jittered; it may exceed the budget), so that some
  // requests survive from frame to frame as in a real view, and some frames wait for the loads.
  Request cut;
  for (int i = 0; i < 16; ++i) cut.emplace_back(rng() % store_->node_count(), float(rng() % 100));
  for (int phase = 0; phase < 2; ++phase) {
    for (int frame = 0; frame < 300; ++frame) {
      if (phase == 1 && frame % 30 == 0) cache.set_field(uint32_t(frame / 30 % 2));
      for (int i = 0; i < 2; ++i) cut[rng() % cut.size()] = {rng() % store_->node_count(), float(rng() % 100)};
      for (auto& c : cut) c.second += float(int(rng() % 5) - 2);
      cache.request(cut);
      if (frame % 10 == 0) cache.wait_all(kWait);
      const uint32_t field = cache.field();
      for (int i = 0; i < 20; ++i) {
        const uint64_t n = i % 2 ? cut[rng() % cut.size()].first : rng() % store_->node_count();
        const BrickCache::Brick b = cache.get(n);
        ++gets;
        if (!b) continue;
        ++hits;
        ASSERT_EQ(*b, expected[field][n]) << "node " << n << " field " << field;
      }
      const BrickCacheStats s = cache.stats();
      ASSERT_LE(s.resident_bytes, budget);
      ASSERT_LE(s.resident_bricks + s.loading, cache.capacity());
      ASSERT_EQ(s.resident_bytes, s.resident_bricks * cache.brick_bytes());
      ASSERT_EQ(s.hits + s.misses, gets);
      ASSERT_EQ(s.hits, hits);
      if (phase == 0) {  // no field switch yet: every completed load is resident or was evicted
        ASSERT_EQ(s.loads_completed, s.evictions + s.resident_bricks);
      }
    }
    cache.wait_all(kWait);
    const BrickCacheStats s = cache.stats();
    EXPECT_EQ(s.queued + s.loading, 0u);
    EXPECT_EQ(s.load_errors, 0u);
    if (phase == 0) {
      EXPECT_EQ(s.loads_completed, s.evictions + s.resident_bricks);
    }
  }
  EXPECT_GT(hits, 0u);
  cache.rethrow_load_error();
}

}  // namespace
}  // namespace ugvr
