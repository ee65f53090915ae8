#include "ugvr/render/lod/tf_error.h"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/lod_cut.h"

namespace ugvr {
namespace {

// Maximum over any index range in O(1): level l holds the maxima of the 2^l-long runs.
class RangeMax {
 public:
  explicit RangeMax(std::vector<float> v) {
    levels_.push_back(std::move(v));
    const size_t n = levels_[0].size();
    for (size_t len = 2; len <= n; len *= 2) {
      const std::vector<float>& prev = levels_.back();
      std::vector<float> next(n - len + 1);
      for (size_t i = 0; i < next.size(); ++i) next[i] = std::max(prev[i], prev[i + len / 2]);
      levels_.push_back(std::move(next));
    }
  }
  // Over [lo, hi], lo <= hi, both in range.
  float query(size_t lo, size_t hi) const {
    const int l = std::bit_width(hi - lo + 1) - 1;
    const std::vector<float>& t = levels_[size_t(l)];
    return std::max(t[lo], t[hi + 1 - (size_t(1) << l)]);
  }

 private:
  std::vector<std::vector<float>> levels_;
};

// The transfer function over the field's range, as range queries on g = (opacity, opacity · rgb).
class SampledTf {
 public:
  SampledTf(const TransferFunction& tf, double lo, double hi) : lo_(lo), hi_(hi) {
    const size_t n = kTfSamples;
    std::array<std::vector<float>, 4> g;
    for (auto& c : g) c.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const double s = lo + (hi - lo) * double(i) / double(n - 1);
      const double a = tf.opacity(s);
      const Vec3d rgb = tf.color(s);
      g[0][i] = float(a), g[1][i] = float(a * rgb.x), g[2][i] = float(a * rgb.y), g[3][i] = float(a * rgb.z);
    }
    std::vector<float> slope(n - 1, 0.0f);
    for (size_t i = 0; i + 1 < n; ++i)
      for (const auto& c : g) slope[i] = std::max(slope[i], std::abs(c[i + 1] - c[i]));
    slope_.emplace_back(std::move(slope));
    for (const auto& c : g) {
      max_.emplace_back(c);
      std::vector<float> neg(c.size());
      for (size_t i = 0; i < c.size(); ++i) neg[i] = -c[i];
      min_.emplace_back(std::move(neg));
    }
  }

  // Sample index of a value (fractional), clamped to the table.
  double index(double v) const {
    const double t = hi_ > lo_ ? (v - lo_) / (hi_ - lo_) : 0.0;
    return std::clamp(t, 0.0, 1.0) * double(kTfSamples - 1);
  }
  double step() const { return (hi_ - lo_) / double(kTfSamples - 1); }
  // Largest variation of one channel of g over samples [a, b].
  double variation(size_t a, size_t b) const {
    double v = 0;
    for (size_t c = 0; c < 4; ++c) v = std::max(v, double(max_[c].query(a, b)) + double(min_[c].query(a, b)));
    return v;
  }
  // Largest change of one channel of g between neighbouring samples in [a, b].
  double slope(size_t a, size_t b) const { return b > a ? double(slope_[0].query(a, b - 1)) : 0.0; }

 private:
  double lo_, hi_;
  std::vector<RangeMax> max_, min_, slope_;
};

}  // namespace

TfNodeErrors::TfNodeErrors(const BrickStoreReader& store, uint32_t field) : store_(store) { set_field(field); }

void TfNodeErrors::set_field(uint32_t field) {
  if (field >= store_.field_count()) {
    fail_in(store_.path(), "transfer-function error: field " + std::to_string(field) + " out of range");
  }
  if (field != field_) ready_ = false;
  field_ = field;
}

double TfNodeErrors::weight(uint64_t node) const {
  const double e = errors_[node];
  if (std::isnan(e)) return 1.0;
  if (e == 0) return 0.0;
  return 1.0 + std::min(1.0, e / kTfNoticeable);
}

bool TfNodeErrors::update(const TransferFunction& tf) {
  if (ready_ && tf == tf_ && step_ == store_.step()) return false;
  step_ = store_.step();  // a time store's step: its own entries (the store's tables are coded over one range)
  const auto t0 = std::chrono::steady_clock::now();
  const BrickStoreField& field = store_.layout().fields[field_];
  const uint32_t F = store_.field_count();
  const uint64_t n = store_.node_count();
  const SampledTf table(tf, field.min, field.max);
  const double code_to_value = (field.max - field.min) / 65535.0;
  const double unit = tf.opacity_unit_distance > 0 ? tf.opacity_unit_distance : 1.0;
  const std::span<const store_format::TfErrorEntry> entries = store_.tf_errors();
  errors_.assign(n, NAN);
  for (uint64_t id = 0; id < n; ++id) {
    const FieldStats& s = store_.stats(id, field_);
    if (std::isnan(s.min) || std::isnan(s.max)) continue;
    // Transparent or constant over every value of the subtree: its image is its finest data's.
    if (tf_transparent_over(tf, s.min, s.max)) {
      errors_[id] = 0;
      continue;
    }
    const size_t a = size_t(std::floor(table.index(s.min))), b = size_t(std::ceil(table.index(s.max)));
    if (table.variation(a, b) == 0) {
      errors_[id] = 0;
      continue;
    }
    if (entries.empty()) continue;
    const store_format::TfErrorEntry& e = entries[id * F + field_];
    double sum = 0, weights = 0;
    for (int g = 0; g < store_format::kTfErrorGroups; ++g) {
      if (e.weight[g] == 0) continue;
      const double spread = e.spread[g] * code_to_value;
      const double f0 = field.min + e.bound[g] * code_to_value - spread;
      const double f1 = field.min + e.bound[g + 1] * code_to_value + spread;
      const size_t lo = size_t(std::floor(table.index(f0))), hi = size_t(std::ceil(table.index(f1)));
      const double steps = table.step() > 0 ? spread / table.step() : 0.0;
      sum += e.weight[g] * std::min(table.variation(lo, hi), steps * table.slope(lo, hi));
      weights += e.weight[g];
    }
    if (weights == 0) continue;  // no pair measured: unknown
    const Vec3d size = store_.bounds(id).size();
    const double slabs = std::max(1.0, std::max({size.x, size.y, size.z}) / unit);
    errors_[id] = std::min(1.0, sum / weights * slabs);
  }
  // Monotone up the tree: children follow their parents, so one pass in reverse id order.
  for (uint64_t id = n; id-- > 1;) {
    const uint64_t p = store_.node(id).parent;
    const double c = errors_[id];
    if (!std::isnan(c) && !std::isnan(errors_[p]) && c > errors_[p]) errors_[p] = c;
  }
  tf_ = tf;
  ready_ = true;
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return true;
}

}  // namespace ugvr
