#include "ugvr/render/lod/hybrid_select.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/view_metrics.h"

namespace ugvr {

namespace {

// A finite number spelling all of `v`, else `bad` is called.
template <class Bad>
double finite_number(std::string_view v, const Bad& bad) {
  const std::string str(v);
  char* end = nullptr;
  const double d = std::strtod(str.c_str(), &end);
  if (str.empty() || end != str.c_str() + str.size() || !std::isfinite(d))
    bad("\"" + str + "\" is not a finite number");
  return d;
}

// `text` split at every `sep` (empty pieces kept).
std::vector<std::string_view> split(std::string_view text, char sep) {
  std::vector<std::string_view> out;
  size_t start = 0;
  for (;;) {
    const size_t at = text.find(sep, start);
    out.push_back(text.substr(start, at == std::string_view::npos ? text.npos : at - start));
    if (at == std::string_view::npos) return out;
    start = at + 1;
  }
}

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::vector<FocusRange> parse_focus(std::string_view text) {
  std::vector<FocusRange> out;
  const auto bad = [&](const std::string& why) { fail_in("--focus " + std::string(text), why); };
  if (text.empty()) bad("empty (FIELD:MIN:MAX[~EDGE][+FIELD:MIN:MAX[~EDGE]...][,...])");
  uint32_t group = 0;
  for (const std::string_view any : split(text, ',')) {
    for (std::string_view item : split(any, '+')) {
      FocusRange f;
      // The edge's '~' comes after MAX, so after the last ':' (a field name's own '~' lies before it).
      const size_t tilde = item.rfind('~');
      if (tilde != std::string_view::npos && (item.rfind(':') == std::string_view::npos || tilde > item.rfind(':'))) {
        f.edge = finite_number(item.substr(tilde + 1), bad);
        if (!(f.edge >= 0)) bad("the edge in \"" + std::string(item) + "\" is negative");
        item = item.substr(0, tilde);
      }
      const size_t c2 = item.rfind(':');
      const size_t c1 = c2 == std::string_view::npos || c2 == 0 ? std::string_view::npos : item.rfind(':', c2 - 1);
      if (c1 == std::string_view::npos || c1 == 0) bad("\"" + std::string(item) + "\" is not FIELD:MIN:MAX[~EDGE]");
      f.field = std::string(item.substr(0, c1));
      f.min = finite_number(item.substr(c1 + 1, c2 - c1 - 1), bad);
      f.max = finite_number(item.substr(c2 + 1), bad);
      if (!(f.min <= f.max)) bad("MIN above MAX in \"" + std::string(item) + "\"");
      f.group = group;
      out.push_back(std::move(f));
    }
    ++group;
  }
  return out;
}

std::string focus_text(std::span<const FocusRange> focus) {
  std::string out;
  for (size_t i = 0; i < focus.size(); ++i) {
    if (i > 0) out += focus[i].group == focus[i - 1].group ? "+" : ",";
    out += focus[i].field + ":" + number_text(focus[i].min) + ":" + number_text(focus[i].max);
    if (focus[i].edge > 0) out += "~" + number_text(focus[i].edge);
  }
  return out;
}

bool RegionOfInterest::meets(const Bounds& b) const {
  if (shape == Shape::Box)
    return lo.x <= b.hi.x && hi.x >= b.lo.x && lo.y <= b.hi.y && hi.y >= b.lo.y && lo.z <= b.hi.z && hi.z >= b.lo.z;
  // The box's point nearest the centre is within the radius.
  const double dx = std::clamp(centre.x, b.lo.x, b.hi.x) - centre.x,
               dy = std::clamp(centre.y, b.lo.y, b.hi.y) - centre.y,
               dz = std::clamp(centre.z, b.lo.z, b.hi.z) - centre.z;
  return dx * dx + dy * dy + dz * dz <= radius * radius;
}

RegionOfInterest parse_roi(std::string_view text, std::string_view source) {
  const auto bad = [&](const std::string& why) {
    fail_in(std::string(source) + " " + std::string(text),
            why + " (box:X0,Y0,Z0,X1,Y1,Z1 or sphere:CX,CY,CZ,R, world coordinates)");
  };
  const size_t colon = text.find(':');
  const std::string_view shape = text.substr(0, colon);
  if (colon == std::string_view::npos || (shape != "box" && shape != "sphere")) bad("expected box:... or sphere:...");
  const std::vector<std::string_view> parts = split(text.substr(colon + 1), ',');
  std::vector<double> v;
  for (const std::string_view p : parts) v.push_back(finite_number(p, bad));
  RegionOfInterest r;
  if (shape == "box") {
    if (v.size() != 6) bad("a box takes 6 numbers, found " + std::to_string(v.size()));
    r.shape = RegionOfInterest::Shape::Box;
    r.lo = {std::min(v[0], v[3]), std::min(v[1], v[4]), std::min(v[2], v[5])};
    r.hi = {std::max(v[0], v[3]), std::max(v[1], v[4]), std::max(v[2], v[5])};
  } else {
    if (v.size() != 4) bad("a sphere takes 4 numbers, found " + std::to_string(v.size()));
    if (!(v[3] > 0)) bad("the radius must be > 0");
    r.shape = RegionOfInterest::Shape::Sphere;
    r.centre = {v[0], v[1], v[2]};
    r.radius = v[3];
  }
  return r;
}

std::string roi_text(const RegionOfInterest& r) {
  const auto n = [](double v) { return number_text(v); };
  if (r.shape == RegionOfInterest::Shape::Box)
    return "box:" + n(r.lo.x) + "," + n(r.lo.y) + "," + n(r.lo.z) + "," + n(r.hi.x) + "," + n(r.hi.y) + "," + n(r.hi.z);
  return "sphere:" + n(r.centre.x) + "," + n(r.centre.y) + "," + n(r.centre.z) + "," + n(r.radius);
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
    out.push_back({uint32_t(i), f.min, f.max, f.group, f.edge});
  }
  return out;
}

double focus_window(double distance, double edge) {
  if (distance <= 0) return 1;
  if (!(distance < edge)) return 0;
  const double x = distance / edge;
  return 1 - x * x * (3 - 2 * x);
}

double node_interest(const BrickStoreReader& store, uint64_t node, std::span<const ResolvedFocus> focus) {
  if (focus.empty()) return 1;
  // Ranges of one group are consecutive (parse_focus): a group's interest is its least range's, the focus's its
  // greatest group's.
  double best = 0;
  for (size_t i = 0; i < focus.size();) {
    double all = 1;
    const uint32_t group = focus[i].group;
    for (; i < focus.size() && focus[i].group == group; ++i) {
      const FieldStats& s = store.stats(node, focus[i].field);
      const double gap = std::max({0.0, double(s.min) - focus[i].max, focus[i].min - double(s.max)});
      all = std::min(all, focus_window(gap, focus[i].edge));
    }
    best = std::max(best, all);
  }
  return best;
}

double node_interest(const BrickStoreReader& store, uint64_t node, const NodeInterest& interest) {
  if (interest.roi && !interest.roi->meets(store.bounds(node))) return 0;
  return node_interest(store, node, interest.focus);
}

std::vector<ExactCandidate> exact_candidates(const BrickStoreReader& store, std::span<const uint64_t> cut,
                                             const Camera& camera, int width, int height, const TfNodeErrors& tf,
                                             const NodeInterest& interest, uint64_t* excluded) {
  std::vector<ExactCandidate> out;
  if (excluded) *excluded = 0;
  if (!store.has_cells()) return out;
  const ViewMetrics view(camera, width, height, store.layout().root);
  for (uint64_t n : cut) {
    if (store.cell_block(n).offset == 0) continue;
    const double doi = node_interest(store, n, interest);
    if (doi == 0) {
      if (excluded) ++*excluded;
      continue;
    }
    const double e = tf.ready() ? tf.error(n) : std::nan("");
    if (e == 0) continue;
    const double data_error = std::isnan(e) ? 1.0 : e;
    out.push_back({n, view.texel_pixels(store.bounds(n), store.resolution()) * data_error * doi});
  }
  std::sort(out.begin(), out.end(), [](const ExactCandidate& a, const ExactCandidate& b) {
    return a.priority != b.priority ? a.priority > b.priority : a.node < b.node;
  });
  return out;
}

}  // namespace ugvr
