#include "ugvr/view/view_store.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <system_error>

#include "ugvr/core/error.h"
#include "ugvr/octree/input.h"
#include "ugvr/store/brick_store.h"

namespace ugvr::view {
namespace {

uint64_t fnv1a(std::string_view text) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (const char c : text) h = (h ^ uint8_t(c)) * 0x100000001b3ull;
  return h;
}

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

}  // namespace

std::string view_cache_dir() {
  if (const std::string d = env("UGVR_CACHE_DIR"); !d.empty()) return d;
  if (const std::string d = env("XDG_CACHE_HOME"); !d.empty()) return d + "/ugvr";
  if (const std::string d = env("HOME"); !d.empty()) return d + "/.cache/ugvr";
  return (std::filesystem::temp_directory_path() / "ugvr-cache").string();
}

namespace {

// A partitioned store's pieces folder "NAME.d" (mpi/piece_build.h, piece_folder: this module does not reach mpi) as
// one entry: its index NAME.json when there is one, the folder's files counted with it.
std::optional<CachedStore> cached_partitioned_store(const std::filesystem::path& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path index = fs::path(folder).replace_extension(".json");
  CachedStore s;
  s.path = fs::is_regular_file(index, ec) ? index.string() : folder.string();
  s.built = fs::last_write_time(s.path, ec);
  if (ec) return std::nullopt;
  if (s.path == index.string()) s.bytes += uint64_t(fs::file_size(index, ec));
  for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    std::error_code e;
    if (it->is_regular_file(e)) s.bytes += uint64_t(it->file_size(e));
  }
  return s;
}

}  // namespace

std::vector<CachedStore> cached_stores(const std::string& dir) {
  namespace fs = std::filesystem;
  std::vector<CachedStore> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    std::error_code e;
    if (it->path().extension() == ".d" && it->is_directory(e)) {
      if (std::optional<CachedStore> s = cached_partitioned_store(it->path())) out.push_back(std::move(*s));
      continue;
    }
    if (it->path().extension() != ".ugvr" || !it->is_regular_file(e)) continue;
    CachedStore s{it->path().string(), uint64_t(it->file_size(e)), it->last_write_time(e)};
    if (!e) out.push_back(std::move(s));
  }
  std::sort(out.begin(), out.end(), [](const CachedStore& a, const CachedStore& b) {
    return a.built != b.built ? a.built > b.built : a.path < b.path;
  });
  return out;
}

std::vector<CachedStore> prune_cached_stores(const std::string& dir, uint64_t max_bytes) {
  std::vector<CachedStore> stores = cached_stores(dir);
  uint64_t total = 0;
  for (const CachedStore& s : stores) total += s.bytes;
  std::vector<CachedStore> removed;
  while (!stores.empty() && (total > max_bytes || max_bytes == 0)) {
    const CachedStore oldest = stores.back();
    stores.pop_back();
    const std::filesystem::path path(oldest.path);
    std::error_code ec;
    if (path.extension() == ".d") {
      std::filesystem::remove_all(path, ec);  // an unfinished partitioned store's pieces
    } else {
      std::filesystem::remove(path, ec);  // a partitioned store's index first: it never names missing pieces
      if (!ec && path.extension() == ".json")
        std::filesystem::remove_all(std::filesystem::path(path).replace_extension(".d"), ec);
    }
    if (ec) fail_in(oldest.path, "cannot remove it: " + ec.message());
    total -= oldest.bytes;
    removed.push_back(oldest);
  }
  return removed;
}

namespace {

// "DIR/STEM-HASH.EXT": the hash of the key with the fields and build settings (and `extra`, when not null).
std::string cache_entry_path(const std::string& stem, const std::string& key, std::span<const std::string> fields,
                             const OctreeBuildOptions& build, const nlohmann::json& extra, const std::string& ext) {
  nlohmann::json k;
  k["data"] = key;
  k["fields"] = std::vector<std::string>(fields.begin(), fields.end());
  k["build"] = {build.resolution, build.max_depth, build.error, int(build.encoding.samples), build.tolerance};
  k["store_version"] = kBrickStoreVersion;
  // Only when set, so that the names of the stores built without cells stay those of before.
  if (build.leaf_cells) k["cells"] = true;
  if (build.leaf_cells) k["max_leaf_cells"] = build.max_leaf_cells;
  if (!extra.is_null()) k["extra"] = extra;
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(fnv1a(k.dump())));
  return view_cache_dir() + "/" + stem + "-" + hash + ext;
}

}  // namespace

std::string cached_store_path(const std::string& stem, const std::string& key, std::span<const std::string> fields,
                              const OctreeBuildOptions& build) {
  return cache_entry_path(stem, key, fields, build, nullptr, ".ugvr");
}

nlohmann::json files_identity(std::span<const std::string> inputs) {
  namespace fs = std::filesystem;
  nlohmann::json files = nlohmann::json::array();
  for (const std::string& in : inputs) {
    std::error_code ec;
    const fs::path p = fs::weakly_canonical(in, ec);
    const auto size = fs::file_size(in, ec);
    const auto time = fs::last_write_time(in, ec).time_since_epoch().count();
    files.push_back({p.string(), ec ? 0 : uint64_t(size), int64_t(time)});
  }
  return files;
}

std::string cached_store_path(std::span<const std::string> inputs, std::span<const std::string> fields,
                              const OctreeBuildOptions& build) {
  namespace fs = std::filesystem;
  const nlohmann::json key = files_identity(inputs);
  const std::string stem = inputs.empty() ? "store" : fs::path(inputs[0]).stem().string();
  return cached_store_path(stem, key.dump(), fields, build);
}

std::string cached_index_path(std::span<const std::string> inputs, std::span<const std::string> fields,
                              const OctreeBuildOptions& build, int pieces, int ghost_level) {
  const std::string stem = inputs.empty() ? "store" : std::filesystem::path(inputs[0]).stem().string();
  const nlohmann::json extra = {{"pieces", pieces}, {"ghost_level", ghost_level}};
  return cache_entry_path(stem, files_identity(inputs).dump(), fields, build, extra, ".json");
}

std::vector<std::string> default_view_fields(const Dataset& dataset, size_t max_fields) {
  return dataset.blocks.empty() ? std::vector<std::string>{} : default_field_names(dataset.blocks[0], max_fields);
}

bool store_opens(const std::string& path, std::string* why) {
  if (!std::filesystem::exists(path)) return false;
  try {
    const BrickStoreReader reader(path);
    return true;
  } catch (const std::exception& e) {
    if (why) *why = e.what();
    return false;
  }
}

}  // namespace ugvr::view
