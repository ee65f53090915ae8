#include "ugvr/report/report_text.h"

#include <cstdio>

namespace ugvr {

nlohmann::json bounds_json(const Bounds& b) {
  if (b.empty()) return nullptr;
  return {{"min", {b.lo.x, b.lo.y, b.lo.z}}, {"max", {b.hi.x, b.hi.y, b.hi.z}}};
}

std::string fmt_num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string fmt_count(uint64_t v) {
  // Appends rather than inserts: GCC 12 at -O3 warns falsely (-Wrestrict) on std::string::insert here.
  const std::string digits = std::to_string(v);
  std::string s;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) s += ',';
    s += digits[i];
  }
  return s;
}

std::string fmt_bounds(const nlohmann::json& b) {
  if (b.is_null()) return "empty";
  std::string s;
  for (int a = 0; a < 3; ++a) {
    s += (a ? " x " : "") + std::string("[") + fmt_num(b["min"][a].get<double>()) + ", " +
         fmt_num(b["max"][a].get<double>()) + "]";
  }
  return s;
}

}  // namespace ugvr
