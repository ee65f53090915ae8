// A mesh over the memory budget, drawn from its store (`ugvr render`, `ugvr.render`): never read whole. The in-core
// estimate and the budget are the viewer's (view/memory_budget.h: from the headers' counts, before reading; the
// budget `$UGVR_VIEW_MEMORY_BUDGET`, default half of RAM). Over it, the store is built out of core into the viewer's
// cache (view/view_store.h), as `ugvr view` builds it (with its leaves' cells), so a later view or render reuses it;
// a caller with a time budget draws what exists when three quarters of it are gone: the store, else the build's
// coarse preview (octree/coarse_preview.h), else its point sketch (octree/point_sketch.h).
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/view/background_build.h"

namespace ugvr::view {

struct OverBudgetStore {
  std::string path;   // the store to draw (a preview's or sketch's file stays readable once opened)
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
// goes to stderr.
std::optional<OverBudgetStore> store_for_a_mesh_over_budget(const std::vector<std::string>& inputs,
                                                            const std::string& field, const std::string& engine,
                                                            std::optional<double> time_budget,
                                                            std::chrono::steady_clock::time_point start, bool say);

}  // namespace ugvr::view
