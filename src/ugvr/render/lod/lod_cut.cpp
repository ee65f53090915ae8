#include "ugvr/render/lod/lod_cut.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <optional>
#include <queue>
#include <system_error>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/tf_error.h"
#include "ugvr/render/lod/view_metrics.h"

namespace ugvr {
namespace {

[[noreturn]] void fail_spec(std::string_view text, std::string_view message) {
  fail_in("cut spec \"" + std::string(text) + "\"", message);
}

enum class Verdict { Empty, FrustumCulled, TfCulled, Forced, Keep };

// Nodes a refinement adds, and the culling it did, applied only if the refinement is accepted.
struct Expansion {
  std::vector<uint64_t> nodes;
  uint64_t culled_frustum = 0, culled_tf = 0;
};

class Selector {
 public:
  Selector(const BrickStoreReader& store, const CutSpec& spec, const ViewMetrics& view, const TransferFunction& tf,
           const CutOptions& options, const TfNodeErrors* tf_errors)
      : store_(store), spec_(spec), view_(view), tf_(tf), options_(options), tf_errors_(tf_errors) {
    const BrickStoreField& f = store.layout().fields[options.field];
    error_threshold_ = spec.value * (f.max - f.min);
  }

  Verdict classify(uint64_t id) const {
    const BrickNode& n = store_.node(id);
    const FieldStats& s = store_.stats(id, options_.field);
    if (!n.has_brick() && n.is_leaf()) return Verdict::Empty;
    if (s.min > s.max) return Verdict::Empty;  // the writer's "no data in the subtree" (false for NaN)
    if (options_.frustum_cull && view_.outside(store_.bounds(id))) return Verdict::FrustumCulled;
    if (options_.tf_cull && tf_transparent_over(tf_, s.min, s.max)) return Verdict::TfCulled;
    return n.has_brick() ? Verdict::Keep : Verdict::Forced;
  }

  // Adds what replaces node `id` (assumed kept or forced) to `out`: its children that survive, recursively through
  // children without brick.
  void expand(uint64_t id, Expansion& out) const {
    const BrickNode& n = store_.node(id);
    if (n.is_leaf()) return;
    const uint64_t end = n.first_child + uint64_t(std::popcount(unsigned(n.child_mask)));
    for (uint64_t c = n.first_child; c < end; ++c) take(c, out);
  }

  // Classifies `id` and adds it (or its forced refinement) to `out`.
  void take(uint64_t id, Expansion& out) const {
    switch (classify(id)) {
      case Verdict::Empty: break;
      case Verdict::FrustumCulled: ++out.culled_frustum; break;
      case Verdict::TfCulled: ++out.culled_tf; break;
      case Verdict::Forced: expand(id, out); break;
      case Verdict::Keep: out.nodes.push_back(id); break;
    }
  }

  // Priority of refining `id` and whether the criterion wants it.
  std::pair<double, bool> need(uint64_t id) const {
    double p = 0;
    const double w = tf_errors_ ? tf_errors_->weight(id) : 1.0;
    if (spec_.kind == CutSpec::Kind::Error) {
      p = store_.stats(id, options_.field).error_max;
    } else {
      p = view_.texel_pixels(store_.bounds(id), store_.resolution());
      if (spec_.kind == CutSpec::Kind::Pixels) p *= w;
    }
    if (std::isnan(p)) p = std::numeric_limits<double>::infinity();  // unknown: refine, first
    switch (spec_.kind) {
      case CutSpec::Kind::Leaves: return {p, true};
      case CutSpec::Kind::Error: return {p, p > error_threshold_};
      case CutSpec::Kind::Pixels: return {p, p > spec_.value};
    }
    return {p, true};
  }

 private:
  const BrickStoreReader& store_;
  const CutSpec& spec_;
  const ViewMetrics& view_;
  const TransferFunction& tf_;
  const CutOptions& options_;
  const TfNodeErrors* tf_errors_;
  double error_threshold_ = 0;
};

struct Entry {
  double priority;
  uint64_t id;
  bool wanted;
  // Max-heap order: highest priority first, then the smallest id (determinism).
  bool operator<(const Entry& o) const { return priority < o.priority || (priority == o.priority && id > o.id); }
};

double parse_value(std::string_view text, std::string_view digits) {
  double v = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (digits.empty() || ec != std::errc() || end != digits.data() + digits.size())
    fail_spec(text, "\"" + std::string(digits) + "\" is not a number");
  if (!std::isfinite(v)) fail_spec(text, "the value must be finite");
  return v;
}

}  // namespace

CutSpec parse_cut_spec(std::string_view text) {
  if (text == "leaves") return {CutSpec::Kind::Leaves, 0};
  const size_t colon = text.find(':');
  const std::string_view kind = text.substr(0, colon);
  if (colon != std::string_view::npos && (kind == "error" || kind == "pixels")) {
    const double v = parse_value(text, text.substr(colon + 1));
    if (kind == "error") {
      if (!(v >= 0)) fail_spec(text, "the error must be >= 0 (a fraction of the field's range)");
      return {CutSpec::Kind::Error, v};
    }
    if (!(v > 0)) fail_spec(text, "the pixel size must be > 0");
    return {CutSpec::Kind::Pixels, v};
  }
  fail_spec(text, "expected leaves, error:E (E >= 0, relative to the field's range) or pixels:P (P > 0)");
}

std::string cut_spec_name(const CutSpec& spec) {
  if (spec.kind == CutSpec::Kind::Leaves) return "leaves";
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, spec.value);  // shortest round-trip form
  const std::string value = ec == std::errc() ? std::string(buf, end) : std::to_string(spec.value);
  return (spec.kind == CutSpec::Kind::Error ? "error:" : "pixels:") + value;
}

bool tf_transparent_over(const TransferFunction& tf, double lo, double hi) {
  if (std::isnan(lo) || std::isnan(hi)) return false;
  if (lo > hi) return true;
  if (tf.opacity_points.empty()) return true;
  // Piecewise linear: the maximum over [lo, hi] is at an end or at a point inside.
  if (tf.opacity(lo) != 0 || tf.opacity(hi) != 0) return false;
  for (const OpacityPoint& p : tf.opacity_points)
    if (p.x > lo && p.x < hi && p.opacity != 0) return false;
  return true;
}

Cut select_cut(const BrickStoreReader& store, const CutSpec& spec, const Camera& camera, int width, int height,
               const TransferFunction& tf, const CutOptions& options) {
  if (options.field >= store.field_count()) {
    fail_in(store.path(), "lod cut: field " + std::to_string(options.field) + " out of range (the store has " +
                              std::to_string(store.field_count()) + " fields)");
  }
  if (options.max_nodes == 0) fail_in("lod cut", "max_nodes must be >= 1");
  if (spec.kind == CutSpec::Kind::Error && !(spec.value >= 0 && std::isfinite(spec.value)))
    fail_in("lod cut", "cut spec " + cut_spec_name(spec) + ": the error must be finite and >= 0");
  if (spec.kind == CutSpec::Kind::Pixels && !(spec.value > 0 && std::isfinite(spec.value)))
    fail_in("lod cut", "cut spec " + cut_spec_name(spec) + ": the pixel size must be finite and > 0");
  const ViewMetrics view(camera, width, height, store.layout().root);
  std::optional<TfNodeErrors> own;
  const TfNodeErrors* tf_errors = nullptr;
  if (options.tf_error && spec.kind != CutSpec::Kind::Leaves) {
    tf_errors = options.tf_errors;
    if (!tf_errors) {
      own.emplace(store, options.field);
      own->update(tf);
      tf_errors = &*own;
    }
  }
  const Selector selector(store, spec, view, tf, options, tf_errors);

  Cut cut;
  Expansion start;
  selector.take(0, start);
  cut.culled_frustum = start.culled_frustum;
  cut.culled_tf = start.culled_tf;
  if (start.nodes.size() > options.max_nodes) cut.budget_limited = true;
  uint64_t count = start.nodes.size();

  std::priority_queue<Entry> queue;
  auto push = [&](uint64_t id) {
    const auto [priority, wanted] = selector.need(id);
    queue.push({priority, id, wanted});
  };
  for (uint64_t id : start.nodes) push(id);
  while (!queue.empty()) {
    const Entry e = queue.top();
    queue.pop();
    if (!e.wanted || store.node(e.id).is_leaf()) {
      cut.nodes.push_back(e.id);
      continue;
    }
    Expansion x;
    selector.expand(e.id, x);
    if (count - 1 + x.nodes.size() > options.max_nodes) {  // count >= 1: e.id is in it
      cut.budget_limited = true;
      cut.nodes.push_back(e.id);
      continue;
    }
    count = count - 1 + x.nodes.size();
    cut.culled_frustum += x.culled_frustum;
    cut.culled_tf += x.culled_tf;
    for (uint64_t id : x.nodes) push(id);
  }

  std::sort(cut.nodes.begin(), cut.nodes.end());
  double level_sum = 0;
  for (uint64_t id : cut.nodes) {
    const int level = store.node(id).level;
    cut.max_level = std::max(cut.max_level, level);
    level_sum += level;
  }
  if (!cut.nodes.empty()) cut.mean_level = level_sum / double(cut.nodes.size());
  return cut;
}

}  // namespace ugvr
