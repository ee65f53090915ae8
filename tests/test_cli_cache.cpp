// `ugvr cache`: the stores of the cache directory listed, pruned oldest first to a size, cleared.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "test_data.h"
#include "ugvr/view/view_store.h"

namespace ugvr {
namespace {

namespace fs = std::filesystem;
using test::run_command;

// A file of `bytes` bytes built `hours_ago` (its modification time).
void put(const fs::path& path, size_t bytes, int hours_ago) {
  std::ofstream(path, std::ios::binary) << std::string(bytes, 'x');
  fs::last_write_time(path, fs::file_time_type::clock::now() - std::chrono::hours(hours_ago));
}

TEST(CliCache, ListsPrunesOldestFirstAndClears) {
  test::ScratchDir dir;
  const fs::path cache = dir.file("cache");
  fs::create_directories(cache);
  put(cache / "old-1.ugvr", 100, 30);
  put(cache / "mid-2.ugvr", 200, 20);
  put(cache / "new-3.ugvr", 300, 10);
  put(cache / "notes.txt", 50, 40);  // not a store: never listed nor removed
  const std::string env = "UGVR_CACHE_DIR=" + cache.string() + " ";
  const auto ugvr = [&](const std::string& args) { return run_command(env + UGVR_BINARY + " cache " + args); };

  const auto listed = view::cached_stores(cache.string());
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(fs::path(listed[0].path).filename(), "new-3.ugvr");  // newest first
  EXPECT_EQ(fs::path(listed[2].path).filename(), "old-1.ugvr");

  const test::CommandResult list = ugvr("");
  ASSERT_EQ(list.status, 0) << list.out;
  EXPECT_NE(list.out.find("3 stores, 600 B"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("old-1.ugvr"), std::string::npos) << list.out;
  EXPECT_EQ(list.out.find("notes.txt"), std::string::npos) << list.out;

  // To 500 bytes: the oldest goes.
  const test::CommandResult pruned = ugvr("--prune 500");
  ASSERT_EQ(pruned.status, 0) << pruned.out;
  EXPECT_NE(pruned.out.find("removed " + (cache / "old-1.ugvr").string()), std::string::npos) << pruned.out;
  EXPECT_FALSE(fs::exists(cache / "old-1.ugvr"));
  EXPECT_TRUE(fs::exists(cache / "mid-2.ugvr"));
  EXPECT_TRUE(fs::exists(cache / "new-3.ugvr"));

  // To 300 bytes, as JSON: the older of the two goes.
  const test::CommandResult json = ugvr("--prune 300 --json");
  ASSERT_EQ(json.status, 0) << json.out;
  const nlohmann::json j = nlohmann::json::parse(json.out);
  EXPECT_EQ(j["bytes"], 300);
  ASSERT_EQ(j["removed"].size(), 1u);
  EXPECT_EQ(fs::path(j["removed"][0]["path"].get<std::string>()).filename(), "mid-2.ugvr");
  ASSERT_EQ(j["stores"].size(), 1u);

  EXPECT_NE(ugvr("--clear --prune 1").status, 0);
  const test::CommandResult cleared = ugvr("--clear");
  ASSERT_EQ(cleared.status, 0) << cleared.out;
  EXPECT_NE(cleared.out.find("0 stores"), std::string::npos) << cleared.out;
  EXPECT_FALSE(fs::exists(cache / "new-3.ugvr"));
  EXPECT_TRUE(fs::exists(cache / "notes.txt"));

  // A cache directory that does not exist yet: nothing to list.
  EXPECT_TRUE(view::cached_stores((cache / "none").string()).empty());
}

// A partitioned store the viewer built for want of scratch (view/scratch_pieces.h) is one entry: its index and its
// pieces' folder, counted together and removed together; a pieces folder without its index (an interrupted build) is
// an entry of its own.
TEST(CliCache, APartitionedStoreIsOneEntryWithItsPieces) {
  test::ScratchDir dir;
  const fs::path cache = dir.file("cache");
  fs::create_directories(cache / "mesh-1.d");
  fs::create_directories(cache / "mesh-2.d");
  put(cache / "mesh-1.json", 10, 30);
  put(cache / "mesh-1.d" / "piece-0.ugvr", 100, 30);
  put(cache / "mesh-1.d" / "piece-1.ugvr", 200, 30);
  put(cache / "mesh-2.d" / "piece-0.ugvr", 40, 20);  // no index: unfinished
  fs::last_write_time(cache / "mesh-2.d", fs::file_time_type::clock::now() - std::chrono::hours(20));
  put(cache / "other.ugvr", 50, 10);
  put(cache / "notes.json", 5, 40);  // a .json without a pieces folder: not a store

  const auto listed = view::cached_stores(cache.string());
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(fs::path(listed[0].path).filename(), "other.ugvr");
  EXPECT_EQ(fs::path(listed[1].path).filename(), "mesh-2.d");
  EXPECT_EQ(listed[1].bytes, 40u);
  EXPECT_EQ(fs::path(listed[2].path).filename(), "mesh-1.json");
  EXPECT_EQ(listed[2].bytes, 310u);

  // To 50 bytes: the index with its pieces, then the unfinished pieces go.
  const auto removed = view::prune_cached_stores(cache.string(), 50);
  ASSERT_EQ(removed.size(), 2u);
  EXPECT_FALSE(fs::exists(cache / "mesh-1.json"));
  EXPECT_FALSE(fs::exists(cache / "mesh-1.d"));
  EXPECT_FALSE(fs::exists(cache / "mesh-2.d"));
  EXPECT_TRUE(fs::exists(cache / "other.ugvr"));
  EXPECT_TRUE(fs::exists(cache / "notes.json"));
}

}  // namespace
}  // namespace ugvr
