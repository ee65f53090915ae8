#include "ugvr/render/field_histogram.h"

#include <cmath>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

// Bins values into counts over [lo, hi] (see the header for the edge cases).
class Binner {
 public:
  Binner(double lo, double hi, int bins) : lo_(lo), counts_(check_bins(bins), 0) {
    scale_ = hi > lo ? bins / (hi - lo) : 0;
  }
  void add(double v) {
    if (!std::isfinite(v)) return;
    const int n = int(counts_.size());
    int i = n / 2;
    if (scale_ > 0) {
      const double t = std::floor((v - lo_) * scale_);
      i = t < 0 ? 0 : t >= n ? n - 1 : int(t);
    }
    ++counts_[size_t(i)];
  }
  std::vector<uint64_t> take() { return std::move(counts_); }

 private:
  static size_t check_bins(int bins) {
    if (bins < 1 || bins > kMaxHistogramBins)
      fail_in("histogram",
              "bins must be in [1, " + std::to_string(kMaxHistogramBins) + "], found " + std::to_string(bins));
    return size_t(bins);
  }
  double lo_, scale_ = 0;
  std::vector<uint64_t> counts_;
};

template <class T>
std::vector<uint64_t> histogram_of(std::span<const T> values, double lo, double hi, int bins) {
  Binner b(lo, hi, bins);
  for (const T v : values) b.add(double(v));
  return b.take();
}

}  // namespace

std::vector<uint64_t> value_histogram(std::span<const float> values, double lo, double hi, int bins) {
  return histogram_of(values, lo, hi, bins);
}

std::vector<uint64_t> value_histogram(std::span<const double> values, double lo, double hi, int bins) {
  return histogram_of(values, lo, hi, bins);
}

std::vector<uint64_t> field_histogram(const Field& field, int component, int bins) {
  const Range r = field.range(component);
  return field_histogram(field, component, r.min, r.max, bins);
}

std::vector<uint64_t> field_histogram(const Field& field, int component, double lo, double hi, int bins) {
  Binner b(lo, hi, bins);
  for (uint64_t t = 0; t < field.tuples(); ++t) b.add(field.scalar(t, component));
  return b.take();
}

std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, int bins, int max_level) {
  if (field >= store.field_count()) return store_histogram(store, field, 0, 1, bins, max_level);  // its error
  const BrickStoreField& f = store.layout().fields[field];
  return store_histogram(store, field, f.min, f.max, bins, max_level);
}

std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, double lo, double hi, int bins,
                                      int max_level) {
  if (field >= store.field_count())
    fail_in("histogram", "field index " + std::to_string(field) + " out of range (the store has " +
                             std::to_string(store.field_count()) + " fields)");
  Binner b(lo, hi, bins);
  const size_t r = store.resolution();
  std::vector<float> samples(r * r * r);
  std::vector<uint8_t> mask(r * r * r);
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& n = store.node(id);
    if (int(n.level) > max_level || !n.has_brick()) continue;
    store.read_brick(id, field, samples.data(), mask.data());
    for (size_t i = 0; i < samples.size(); ++i)
      if (mask[i]) b.add(samples[i]);
  }
  return b.take();
}

}  // namespace ugvr
