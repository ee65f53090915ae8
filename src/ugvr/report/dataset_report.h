// What `ugvr info` reports about a dataset, as JSON (the --json output, and what tests assert on) and as text.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "ugvr/grid/dataset.h"

namespace ugvr {

struct ReportOptions {
  bool topology = false;  // also build face connectivity: boundary faces, non-manifold faces, build time
};

// Keys: format, sources, load_seconds, points, cells, bounds {min, max}, memory_bytes, warnings, blocks[] with
// name, kind, dimensions (structured: point dims; iblank {blanked_points, overset_points}), cell_types {tetra, ...} and
// inverted_cells (unstructured), fields[] {name, location, type, components, range: [min, max], nan_count,
// component_ranges: [[min, max], ...] (vectors)}, topology {boundary_faces, nonmanifold_faces, seconds}.
nlohmann::json dataset_report(const Dataset& ds, double load_seconds, const ReportOptions& opts = {});
std::string format_report_text(const nlohmann::json& report);

}  // namespace ugvr
