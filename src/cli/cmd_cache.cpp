// `ugvr cache`: the stores `ugvr view` and `ugvr render` keep in the cache directory (view/view_store.h), listed,
// pruned to a size, or cleared. A store is built once per file version and options and reused, so the directory
// grows with every edited input; nothing prunes it behind the user's back (a running viewer may hold any store).
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/view/view_store.h"

namespace ugvr::cli {
namespace {

std::string age_text(std::filesystem::file_time_type built) {
  const double s = std::chrono::duration<double>(std::filesystem::file_time_type::clock::now() - built).count();
  char buf[32];
  if (s < 120)
    std::snprintf(buf, sizeof buf, "%.0f s", std::max(0.0, s));
  else if (s < 7200)
    std::snprintf(buf, sizeof buf, "%.0f min", s / 60);
  else if (s < 172800)
    std::snprintf(buf, sizeof buf, "%.0f h", s / 3600);
  else
    std::snprintf(buf, sizeof buf, "%.0f days", s / 86400);
  return buf;
}

}  // namespace

void register_cache(CLI::App& app) {
  struct Options {
    uint64_t prune = 0;
    bool prune_given = false, clear = false, json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd =
      app.add_subcommand("cache",
                         "List the stores ugvr view / render keep in the cache directory ($UGVR_CACHE_DIR, else "
                         "$XDG_CACHE_HOME/ugvr or ~/.cache/ugvr); prune them to a size, or clear them");
  cmd->add_option("--prune", o->prune, "Remove the oldest stores until the rest take at most SIZE (e.g. 10GiB)")
      ->transform(CLI::AsSizeValue(true))
      ->type_name("SIZE")
      ->each([o](const std::string&) { o->prune_given = true; });
  cmd->add_flag("--clear", o->clear, "Remove every store (a viewer still showing one keeps its open file)");
  cmd->add_flag("--json", o->json, "Print the directory and its stores as one JSON object");
  cmd->callback([o] {
    if (o->clear && o->prune_given) throw Error("--clear and --prune: give one of them");
    const std::string dir = view::view_cache_dir();
    std::vector<view::CachedStore> removed;
    if (o->clear)
      removed = view::prune_cached_stores(dir, 0);
    else if (o->prune_given)
      removed = view::prune_cached_stores(dir, o->prune);
    const std::vector<view::CachedStore> kept = view::cached_stores(dir);
    uint64_t total = 0, freed = 0;
    for (const view::CachedStore& s : kept) total += s.bytes;
    for (const view::CachedStore& s : removed) freed += s.bytes;
    if (o->json) {
      nlohmann::json j{
          {"dir", dir}, {"bytes", total}, {"stores", nlohmann::json::array()}, {"removed", nlohmann::json::array()}};
      for (const view::CachedStore& s : kept) j["stores"].push_back({{"path", s.path}, {"bytes", s.bytes}});
      for (const view::CachedStore& s : removed) j["removed"].push_back({{"path", s.path}, {"bytes", s.bytes}});
      std::printf("%s\n", j.dump().c_str());
      return;
    }
    for (const view::CachedStore& s : removed)
      std::printf("removed %s (%s)\n", s.path.c_str(), format_bytes(s.bytes).c_str());
    std::printf("%s: %zu stores, %s%s\n", dir.c_str(), kept.size(), format_bytes(total).c_str(),
                removed.empty() ? "" : (", " + format_bytes(freed) + " freed").c_str());
    for (const view::CachedStore& s : kept)
      std::printf("  %10s  built %8s ago  %s\n", format_bytes(s.bytes).c_str(), age_text(s.built).c_str(),
                  std::filesystem::path(s.path).filename().c_str());
  });
}

}  // namespace ugvr::cli
