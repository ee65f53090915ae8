#include "ugvr/io/time_series_report.h"

#include <cstdio>
#include <sstream>

#include "ugvr/core/file.h"

namespace ugvr {

nlohmann::json time_series_json(const TimeSeries& s) {
  nlohmann::json steps = nlohmann::json::array();
  const bool files = s.kind == SeriesKind::Pvd || s.kind == SeriesKind::SeriesJson || s.kind == SeriesKind::Numbered ||
                     s.kind == SeriesKind::Plot3d;
  for (size_t i = 0; i < s.steps.size(); ++i) {
    const TimeStep& st = s.steps[i];
    nlohmann::json j = {{"index", i}, {"time", st.time}};
    if (files) j["files"] = st.files;
    if (st.reader_step >= 0) j["reader_step"] = st.reader_step;
    steps.push_back(std::move(j));
  }
  return {{"kind", std::string(series_kind_name(s.kind))},
          {"source", s.source},
          {"count", s.steps.size()},
          {"first_time", s.steps.empty() ? 0.0 : s.steps.front().time},
          {"last_time", s.steps.empty() ? 0.0 : s.steps.back().time},
          {"geometry", s.geometry == SeriesGeometry::Static ? "static" : "detected per step"},
          {"geometry_reason", s.geometry_reason},
          {"steps", std::move(steps)}};
}

std::string format_time_series_text(const nlohmann::json& j) {
  std::ostringstream o;
  char buf[64];
  std::snprintf(buf, sizeof buf, "t = %g .. %g", j["first_time"].get<double>(), j["last_time"].get<double>());
  const size_t n = j["count"].get<size_t>();
  o << "time:     " << n << " step" << (n == 1 ? "" : "s") << " (" << j["kind"].get<std::string>() << "), " << buf
    << "; geometry " << j["geometry"].get<std::string>() << " (" << j["geometry_reason"].get<std::string>() << ")\n";
  for (const nlohmann::json& st : j["steps"]) {
    std::snprintf(buf, sizeof buf, "  step %zu: t = %g", st["index"].get<size_t>(), st["time"].get<double>());
    o << buf;
    if (st.contains("files")) {
      o << " ";
      bool first = true;
      for (const auto& f : st["files"]) o << (first ? "" : ", ") << base_name(f.get<std::string>()), first = false;
    }
    o << "\n";
  }
  return o.str();
}

}  // namespace ugvr
