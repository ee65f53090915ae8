// Where `ugvr view MESH` keeps the brick store it builds for a grid file, and which fields it builds.
//
// A store is built once per (input files, their sizes and modification times, fields, build options) and kept in the
// cache directory: $UGVR_CACHE_DIR, else $XDG_CACHE_HOME/ugvr, else $HOME/.cache/ugvr. Its name is the first input's
// stem and a 64-bit hash of that key ("blunt-fin-3f2a....ugvr"), so opening the same file again shows the store at
// once; editing the file (new size or time) or choosing other fields or options builds a new one.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/octree/builder.h"

namespace ugvr::view {

std::string view_cache_dir();

// The stores in a cache directory (its *.ugvr files; previews and sketches are stores too), newest first by
// modification time, which is when each was built (a build writes a temporary file and renames it). Nothing removes
// them by itself: a viewer may hold any of them open, and only the user knows which are still wanted (`ugvr cache`).
// A partitioned store the viewer built for want of scratch space (scratch_pieces.h) is one entry: its index NAME.json
// with its pieces' folder NAME.d (mpi/piece_build.h, piece_folder), whose files are counted in `bytes`; a folder
// NAME.d without its index (a build interrupted: the next view of the mesh keeps its finished pieces) is an entry too,
// named by the folder.
struct CachedStore {
  std::string path;
  uint64_t bytes = 0;
  std::filesystem::file_time_type built;
};
std::vector<CachedStore> cached_stores(const std::string& dir);
// Removes the oldest stores of `dir` until the others take at most `max_bytes` (0: all of them); returns those
// removed, oldest first. Throws ugvr::Error naming a store that cannot be removed.
std::vector<CachedStore> prune_cached_stores(const std::string& dir, uint64_t max_bytes);
// Above this total the viewer reminds the user of `ugvr cache` when it starts.
inline constexpr uint64_t kCacheReminderBytes = uint64_t(20) << 30;

// Whether `path` is a brick store that opens (header, node table and field records check out); when it exists but
// does not open, `why` (if given) says what is wrong (the caller builds it again).
bool store_opens(const std::string& path, std::string* why = nullptr);

// What identifies input files in a cache key: per file its canonical path, size and modification time (a file that
// cannot be read: size 0), as a JSON array of [path, size, time].
nlohmann::json files_identity(std::span<const std::string> inputs);

// The cached store's path for these input files (their canonical paths, sizes and modification times), the fields
// asked for (empty: the default ones) and build settings. The directory is not created here.
std::string cached_store_path(std::span<const std::string> inputs, std::span<const std::string> fields,
                              const OctreeBuildOptions& build);
// The index of the partitioned store built for these inputs, fields and settings in `pieces` pieces at `ghost_level`
// (scratch_pieces.h): "STEM-HASH.json" in the cache directory, its pieces in "STEM-HASH.d/".
std::string cached_index_path(std::span<const std::string> inputs, std::span<const std::string> fields,
                              const OctreeBuildOptions& build, int pieces, int ghost_level);
// The same for data that is not a file (the built-in demo): `stem` names it, `key` says what it is.
std::string cached_store_path(const std::string& stem, const std::string& key, std::span<const std::string> fields,
                              const OctreeBuildOptions& build);

// The fields the viewer builds when none are named: every field of the first block that is not constant (vectors by
// magnitude), without the IBLANK of structured grids, at most `max_fields`, in the dataset's order. A dataset whose
// fields are all constant gets its first one.
std::vector<std::string> default_view_fields(const Dataset& dataset, size_t max_fields = 4);

}  // namespace ugvr::view
