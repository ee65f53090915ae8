// Formatting shared by the text reports of `ugvr info` (datasets and brick stores), so both read alike.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "ugvr/core/vec.h"

namespace ugvr {

// {"min": [x, y, z], "max": [x, y, z]}, or null for an empty box.
nlohmann::json bounds_json(const Bounds& b);
// "0.193" (6 significant digits)
std::string fmt_num(double v);
// "12,192"
std::string fmt_count(uint64_t v);
// "[x0, x1] x [y0, y1] x [z0, z1]" from bounds_json; "empty" for null.
std::string fmt_bounds(const nlohmann::json& b);

}  // namespace ugvr
