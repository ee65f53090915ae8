#include "ugvr/render/lod/hybrid_select.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/view_metrics.h"

namespace ugvr {

std::vector<FocusRange> parse_focus(std::string_view text) {
  std::vector<FocusRange> out;
  const auto bad = [&](const std::string& why) { fail_in("--focus " + std::string(text), why); };
  if (text.empty()) bad("empty (FIELD:MIN:MAX[,FIELD:MIN:MAX...])");
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string_view item = text.substr(start, comma == std::string_view::npos ? text.npos : comma - start);
    const size_t c2 = item.rfind(':');
    const size_t c1 = c2 == std::string_view::npos || c2 == 0 ? std::string_view::npos : item.rfind(':', c2 - 1);
    if (c1 == std::string_view::npos || c1 == 0) bad("\"" + std::string(item) + "\" is not FIELD:MIN:MAX");
    FocusRange f;
    f.field = std::string(item.substr(0, c1));
    const auto number = [&](std::string_view v) {
      const std::string str(v);
      char* end = nullptr;
      const double d = std::strtod(str.c_str(), &end);
      if (str.empty() || end != str.c_str() + str.size() || !std::isfinite(d))
        bad("\"" + str + "\" is not a finite number");
      return d;
    };
    f.min = number(item.substr(c1 + 1, c2 - c1 - 1));
    f.max = number(item.substr(c2 + 1));
    if (!(f.min <= f.max)) bad("MIN above MAX in \"" + std::string(item) + "\"");
    out.push_back(std::move(f));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

std::vector<ResolvedFocus> resolve_focus(const BrickStoreReader& store, std::span<const FocusRange> focus) {
  std::vector<ResolvedFocus> out;
  for (const FocusRange& f : focus) {
    const int i = store.field_index(f.field);
    if (i < 0) {
      std::string names;
      for (const BrickStoreField& fd : store.layout().fields) names += (names.empty() ? "" : ", ") + fd.name;
      fail_in(store.path(), "--focus: no field \"" + f.field + "\" in the store (fields: " + names + ")");
    }
    out.push_back({uint32_t(i), f.min, f.max});
  }
  return out;
}

double node_interest(const BrickStoreReader& store, uint64_t node, std::span<const ResolvedFocus> focus) {
  if (focus.empty()) return 1;
  for (const ResolvedFocus& f : focus) {
    const FieldStats& s = store.stats(node, f.field);
    if (double(s.min) <= f.max && double(s.max) >= f.min) return 1;
  }
  return 0;
}

std::vector<ExactCandidate> exact_candidates(const BrickStoreReader& store, std::span<const uint64_t> cut,
                                             const Camera& camera, int width, int height, const TfNodeErrors& tf,
                                             std::span<const ResolvedFocus> focus, uint64_t* excluded) {
  std::vector<ExactCandidate> out;
  if (excluded) *excluded = 0;
  if (!store.has_cells()) return out;
  const ViewMetrics view(camera, width, height, store.layout().root);
  for (uint64_t n : cut) {
    if (store.cell_block(n).offset == 0) continue;
    if (node_interest(store, n, focus) == 0) {
      if (excluded) ++*excluded;
      continue;
    }
    const double e = tf.ready() ? tf.error(n) : std::nan("");
    if (e == 0) continue;
    const double data_error = std::isnan(e) ? 1.0 : e;
    out.push_back({n, view.texel_pixels(store.bounds(n), store.resolution()) * data_error});
  }
  std::sort(out.begin(), out.end(), [](const ExactCandidate& a, const ExactCandidate& b) {
    return a.priority != b.priority ? a.priority > b.priority : a.node < b.node;
  });
  return out;
}

}  // namespace ugvr
