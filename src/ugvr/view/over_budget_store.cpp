#include "ugvr/view/over_budget_store.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "ugvr/core/error.h"
#include "ugvr/octree/coarse_preview.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/view/memory_budget.h"
#include "ugvr/view/scratch_pieces.h"
#include "ugvr/view/view_store.h"

namespace ugvr::view {

std::optional<OverBudgetStore> store_for_a_mesh_over_budget(const std::vector<std::string>& inputs,
                                                            const std::string& field, const std::string& engine,
                                                            std::optional<double> time_budget,
                                                            std::chrono::steady_clock::time_point start, bool say,
                                                            const BuildPieces& build_pieces) {
  if (inputs.empty() || is_brick_store(inputs[0])) return std::nullopt;
  std::string source;
  const uint64_t budget = view_memory_budget(std::nullopt, &source);
  const InCoreEstimate need = estimate_in_core(inputs);
  if (need.bytes <= budget) return std::nullopt;
  OverBudgetStore out;
  out.why = over_budget_reason(need, budget, source);
  require_out_of_core_input(inputs, out.why, std::string("$") + kViewMemoryBudgetEnv);
  if (engine == "exact")
    throw OptionError("engine", "exact: " + out.why + "; the store's engines (lod, hybrid) draw it");
  OctreeBuildOptions build;
  build.inputs = inputs;
  build.leaf_cells = true;  // as `ugvr view` builds it: one cache entry
  build.threads = 0;
  const std::vector<std::string> fields = field.empty() ? std::vector<std::string>{} : std::vector<std::string>{field};
  out.path = cached_store_path(inputs, fields, build);
  out.shown = "store";
  if (store_opens(out.path)) {  // one that exists but does not open is built again
    if (say) std::fprintf(stderr, "%s: drawing the store built earlier, %s\n", out.why.c_str(), out.path.c_str());
    return out;
  }
  std::filesystem::create_directories(std::filesystem::path(out.path).parent_path());
  if (build_pieces) {
    const std::string cache = std::filesystem::path(out.path).parent_path().string();
    const ScratchPieces sp =
        pieces_for_scratch(need.cells, fields.size(), build.resolution, scratch_free_bytes(cache), cache);
    if (sp.pieces > 1) {
      if (time_budget)
        throw OptionError("time-budget", out.why + "; " + sp.why +
                                             ": a partitioned store is drawn whole (leave "
                                             "--time-budget out)");
      OctreeBuildOptions pieces_build;  // as `ugvr build --pieces N --out-of-core` builds them: the LOD engine's
      pieces_build.threads = 0;
      out.path = cached_index_path(inputs, fields, pieces_build, sp.pieces, kScratchPiecesGhostLevel);
      out.pieces = sp.pieces;
      out.shown = "partitioned store";
      if (std::filesystem::exists(out.path)) {
        if (say)
          std::fprintf(stderr, "%s: drawing the partitioned store built earlier, %s\n", out.why.c_str(),
                       out.path.c_str());
        return out;
      }
      if (say) std::fprintf(stderr, "%s; %s, into %s\n", out.why.c_str(), sp.why.c_str(), out.path.c_str());
      build_pieces(inputs[0], fields, sp.pieces, kScratchPiecesGhostLevel, pieces_build, budget, out.path);
      return out;
    }
  }
  build.preview_depth = coarse_preview_depth_for(budget, build.resolution, 1);
  build.point_sketch = true;
  if (say)
    std::fprintf(stderr, "%s: building its store out of core into %s%s\n", out.why.c_str(), out.path.c_str(),
                 time_budget ? " (drawing what exists when the time is up)" : "");
  out.build = std::make_unique<BackgroundBuild>(BackgroundBuild::OutOfCore{inputs[0], budget}, fields, build, out.path);
  // A quarter of the time, at least half a second, is kept for drawing.
  const double deadline = time_budget ? *time_budget - std::max(0.25 * *time_budget, 0.5) : INFINITY;
  for (;;) {
    const BackgroundBuild::State st = out.build->state();
    if (st.stage == BackgroundBuild::Stage::Done) {
      if (say && !st.note.empty()) std::fprintf(stderr, "warning: %s\n", st.note.c_str());
      out.build.reset();
      return out;
    }
    if (st.stage == BackgroundBuild::Stage::Failed) fail_in(inputs[0], "building its store: " + st.error);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (elapsed >= deadline) {
      if (st.preview.empty())
        throw OptionError("time-budget", "nothing to draw within " + std::to_string(*time_budget) + " s: " + out.why +
                                             ", and its store's first level is not built yet (raise the budget)");
      out.path = st.preview;
      out.shown = st.preview_sketch ? "point sketch" : "coarse preview";
      return out;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace ugvr::view
