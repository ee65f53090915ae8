#include "ugvr/render/renderer.h"

#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"

namespace ugvr {

void FrameStats::to_json(nlohmann::json& j) const {
  // The level-of-detail figures are written for every engine (zero for the exact one), so that every --stats line has
  // the same keys; the engine's own follow and may refine them.
  j.update({{"engine", engine},
            {"seconds", seconds},
            {"converged", converged},
            {"resting", resting},
            {"scale", scale},
            {"samples", samples},
            {"cut_nodes", cut_nodes},
            {"visible_nodes", visible_nodes},
            {"mean_texel_error", texel_error},
            {"max_texel_error", max_texel_error},
            {"ram_resident_bytes", ram_bytes},
            {"ram_budget_bytes", ram_budget},
            {"atlas_bytes", gpu_bytes},
            {"atlas_budget_bytes", gpu_budget},
            {"pending_bricks", pending}});
  if (detail) detail->to_json(j);
}

void check_supported(const FrameRequest& request, std::string_view engine) {
  // The level-of-detail engine takes a time store's step (LodEngine::set_time_step checks it).
  if (request.time_step && engine != "lod")
    fail_in(std::string(engine) + " renderer",
            "time steps are not supported yet (stores hold one step; the exact engine renders series)");
}

}  // namespace ugvr
