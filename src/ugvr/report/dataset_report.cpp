#include "ugvr/report/dataset_report.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>

#include "ugvr/core/memory.h"
#include "ugvr/grid/topology.h"
#include "ugvr/report/report_text.h"

namespace ugvr {

namespace {

using nlohmann::json;

json field_json(const Field& f) {
  const Range r = f.range(kMagnitude);
  json j{{"name", f.name()},
         {"location", association_name(f.association())},
         {"type", scalar_type_name(f.data().type())},
         {"components", f.components()},
         {"range", {r.min, r.max}},
         {"nan_count", r.nan_count}};
  if (f.components() > 1) {
    json comps = json::array();
    for (int c = 0; c < f.components(); ++c) {
      const Range rc = f.range(c);
      comps.push_back({rc.min, rc.max});
    }
    j["component_ranges"] = comps;
  }
  return j;
}

json block_json(const Block& b, const ReportOptions& opts) {
  json j{{"name", b.name},
         {"kind", grid_kind_name(b.grid)},
         {"points", grid_point_count(b.grid)},
         {"cells", grid_cell_count(b.grid)},
         {"bounds", bounds_json(grid_bounds(b.grid))},
         {"memory_bytes", b.memory_bytes()}};
  if (const auto* m = std::get_if<UnstructuredMesh>(&b.grid)) {
    const CellTypeCounts c = m->cell_type_counts();
    j["cell_types"] = {{"tetra", c.tetra}, {"pyramid", c.pyramid}, {"wedge", c.wedge}, {"hexahedron", c.hexahedron}};
    j["inverted_cells"] = count_inverted_cells(*m);
    if (opts.topology) {
      const auto t0 = std::chrono::steady_clock::now();
      const MeshTopology topo = build_topology(*m);
      j["topology"] = {{"boundary_faces", topo.boundary.size()},
                       {"nonmanifold_faces", topo.nonmanifold_faces},
                       {"memory_bytes", topo.memory_bytes()},
                       {"seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()}};
    }
  } else {
    const GridDims d = std::visit(
        [](const auto& g) -> GridDims {
          if constexpr (requires { g.dims; })
            return g.dims;
          else
            return {};
        },
        b.grid);
    j["dimensions"] = d.points;
    if (const auto* s = std::get_if<StructuredGrid>(&b.grid); s && s->has_iblank()) {
      // 0 = no data (blanked); negative = overset fringe points interpolated from another block (still in use).
      j["iblank"] = {{"blanked_points", uint64_t(std::count(s->iblank.begin(), s->iblank.end(), 0))},
                     {"overset_points",
                      uint64_t(std::count_if(s->iblank.begin(), s->iblank.end(), [](int32_t v) { return v < 0; }))}};
    }
  }
  json fields = json::array();
  for (const Field& f : b.fields) fields.push_back(field_json(f));
  j["fields"] = fields;
  return j;
}

}  // namespace

nlohmann::json dataset_report(const Dataset& ds, double load_seconds, const ReportOptions& opts) {
  json blocks = json::array();
  for (const Block& b : ds.blocks) blocks.push_back(block_json(b, opts));
  return {{"format", ds.format},
          {"sources", ds.sources},
          {"load_seconds", load_seconds},
          {"points", ds.point_count()},
          {"cells", ds.cell_count()},
          {"bounds", bounds_json(ds.bounds())},
          {"memory_bytes", ds.memory_bytes()},
          {"peak_rss_bytes", peak_rss_bytes()},
          {"warnings", ds.warnings},
          {"blocks", blocks}};
}

std::string format_report_text(const nlohmann::json& r) {
  std::ostringstream o;
  o << "format:   " << r["format"].get<std::string>() << "\n";
  o << "points:   " << fmt_count(r["points"]) << "\n";
  o << "cells:    " << fmt_count(r["cells"]) << "\n";
  o << "bounds:   " << fmt_bounds(r["bounds"]) << "\n";
  o << "memory:   " << format_bytes(r["memory_bytes"]) << " in memory, peak RSS " << format_bytes(r["peak_rss_bytes"])
    << "\n";
  char t[32];
  std::snprintf(t, sizeof t, "%.3f s", r["load_seconds"].get<double>());
  o << "load:     " << t << "\n";
  const auto& blocks = r["blocks"];
  for (size_t i = 0; i < blocks.size(); ++i) {
    const json& b = blocks[i];
    o << "block " << i << (b["name"].get<std::string>().empty() ? "" : " (" + b["name"].get<std::string>() + ")")
      << ": " << b["kind"].get<std::string>();
    if (b.contains("dimensions")) {
      o << " " << b["dimensions"][0] << " x " << b["dimensions"][1] << " x " << b["dimensions"][2] << " points";
    }
    o << ", " << fmt_count(b["points"]) << " points, " << fmt_count(b["cells"]) << " cells\n";
    if (b.contains("iblank")) {
      o << "  IBLANK: " << fmt_count(b["iblank"]["blanked_points"]) << " points blanked, "
        << fmt_count(b["iblank"]["overset_points"]) << " overset fringe points\n";
    }
    if (b.contains("cell_types")) {
      o << "  cells:";
      for (const char* k : {"tetra", "pyramid", "wedge", "hexahedron"}) {
        if (b["cell_types"][k].get<uint64_t>() > 0) o << " " << fmt_count(b["cell_types"][k]) << " " << k;
      }
      o << "\n";
      if (b["inverted_cells"].get<uint64_t>() > 0) o << "  inverted cells: " << fmt_count(b["inverted_cells"]) << "\n";
    }
    if (b.contains("topology")) {
      const json& tp = b["topology"];
      std::snprintf(t, sizeof t, "%.3f s", tp["seconds"].get<double>());
      o << "  topology: " << fmt_count(tp["boundary_faces"]) << " boundary faces, "
        << fmt_count(tp["nonmanifold_faces"]) << " non-manifold, " << format_bytes(tp["memory_bytes"]) << ", built in "
        << t << "\n";
    }
    if (blocks.size() == 1 || i == 0) o << "  bounds: " << fmt_bounds(b["bounds"]) << "\n";
    for (const json& f : b["fields"]) {
      o << "  " << (f["location"] == "vertex" ? "vertex" : "cell  ") << " " << f["name"].get<std::string>() << " ("
        << f["type"].get<std::string>();
      if (f["components"].get<int>() > 1) o << " x" << f["components"];
      o << "): [" << fmt_num(f["range"][0]) << ", " << fmt_num(f["range"][1]) << "]"
        << (f["components"].get<int>() > 1 ? " magnitude" : "");
      if (f["nan_count"].get<uint64_t>() > 0) o << ", " << fmt_count(f["nan_count"]) << " NaN";
      o << "\n";
    }
  }
  for (const json& w : r["warnings"]) o << "warning: " << w.get<std::string>() << "\n";
  return o.str();
}

}  // namespace ugvr
