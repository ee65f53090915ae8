#include "ugvr/render/renderer.h"

#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"

namespace ugvr {

void FrameStats::to_json(nlohmann::json& j) const {
  j["engine"] = engine;
  j["seconds"] = seconds;
  j["converged"] = converged;
  j["resting"] = resting;
  j["scale"] = scale;
  j["samples"] = samples;
  if (engine == "lod") {
    j["cut_nodes"] = cut_nodes;
    j["visible_nodes"] = visible_nodes;
    j["mean_texel_error"] = texel_error;
    j["max_texel_error"] = max_texel_error;
    j["ram_resident_bytes"] = ram_bytes;
    j["ram_budget_bytes"] = ram_budget;
    j["atlas_bytes"] = gpu_bytes;
    j["atlas_budget_bytes"] = gpu_budget;
    j["pending_bricks"] = pending;
  }
  if (detail) detail->to_json(j);
}

void check_supported(const FrameRequest& request, std::string_view engine) {
  if (request.time_step)
    fail_in(std::string(engine) + " renderer", "time steps are not supported yet (one step is read per dataset)");
}

}  // namespace ugvr
