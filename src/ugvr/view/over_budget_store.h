// A mesh over the memory budget, drawn from its store (`ugvr render`, `ugvr.render`): never read whole. The in-core
// estimate and the budget are the viewer's (view/memory_budget.h: from the headers' counts, before reading; the
// budget `$UGVR_VIEW_MEMORY_BUDGET`, default half of RAM). Over it, the store is built out of core into the viewer's
// cache (view/view_store.h), as `ugvr view` builds it (with its leaves' cells), so a later view or render reuses it;
// a caller with a time budget draws what exists when three quarters of it are gone: the store, else the build's
// coarse preview (octree/coarse_preview.h), else its point sketch (octree/point_sketch.h).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/octree/builder.h"
#include "ugvr/view/background_build.h"

namespace ugvr::view {

// Builds the partitioned store of a .vtu whose one out-of-core build's scratch would not fit the cache's disk
// (scratch_pieces.h): (vtu, field selectors, pieces, ghost level, build options, memory budget, index path). The CLI
// passes mpi/piece_build_ooc.h's build_index_out_of_core, which this module does not reach; empty: no such fallback
// (the out-of-core build refuses, saying why).
using BuildPieces = std::function<void(const std::string&, const std::vector<std::string>&, int, int,
                                       const OctreeBuildOptions&, uint64_t, const std::string&)>;

struct OverBudgetStore {
  // The store to draw (a preview's or sketch's file stays readable once opened), or a partitioned store's index
  // (`pieces` > 0).
  std::string path;
  int pieces = 0;
  std::string shown;  // "store", "coarse preview", "point sketch"
  std::string why;    // "the grid would take about ... over the memory budget of ..."
  // Still running when a preview or sketch is drawn: reset it once the store is opened (the build stops, nothing is
  // kept).
  std::unique_ptr<BackgroundBuild> build;
};

// nullopt: the inputs fit (or are a store; a partitioned store's index is the caller's to leave out). `field`: the
// field to build (empty: the builder's default). `engine` "exact" over the budget throws OptionError("engine", ...); an
// input that is not one .vtu throws ugvr::Error naming it, with advice; a failed build throws its error; with
// `time_budget` (seconds since `start`) and nothing built by then, OptionError("time-budget", ...). `say`: what it does
// goes to stderr. When one out-of-core build's scratch does not fit the cache directory's disk but pieces do
// (scratch_pieces.h) and no whole store is cached: the partitioned store, built by `build_pieces` into the cache
// (cached_index_path) unless its index is there already (written last, so it names finished pieces); a time budget
// is refused then (OptionError("time-budget"): a partitioned store is drawn whole).
std::optional<OverBudgetStore> store_for_a_mesh_over_budget(const std::vector<std::string>& inputs,
                                                            const std::string& field, const std::string& engine,
                                                            std::optional<double> time_budget,
                                                            std::chrono::steady_clock::time_point start, bool say,
                                                            const BuildPieces& build_pieces = {});

}  // namespace ugvr::view
