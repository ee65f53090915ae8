#include "ugvr/grid/field.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <charconv>
#include <cmath>
#include <limits>

#include "ugvr/core/error.h"

namespace ugvr {

std::string_view association_name(Association a) { return a == Association::Vertex ? "vertex" : "cell"; }

Field::Field(std::string name, Association association, DataArray data)
    : name_(std::move(name)),
      association_(association),
      data_(std::move(data)),
      cache_(std::make_unique<RangeCache>()) {}

Field::Field(const Field& o)
    : name_(o.name_), association_(o.association_), data_(o.data_), cache_(std::make_unique<RangeCache>()) {}

Field& Field::operator=(Field o) noexcept {
  name_ = std::move(o.name_);
  association_ = o.association_;
  data_ = std::move(o.data_);
  cache_ = std::move(o.cache_);
  return *this;
}

DataArray& Field::mutable_data() {
  std::lock_guard lock(cache_->mutex);
  cache_->ranges.clear();
  return data_;
}

double Field::scalar(uint64_t tuple, int component) const {
  const int nc = data_.components();
  if (component >= 0 || nc == 1) return data_.get(tuple, component >= 0 ? component : 0);
  double s = 0;
  for (int c = 0; c < nc; ++c) {
    const double v = data_.get(tuple, c);
    s += v * v;
  }
  return std::sqrt(s);
}

Range Field::range(int component) const {
  if (component < kMagnitude || component >= components()) {
    throw Error("field '" + name_ + "': component " + std::to_string(component) + " out of range (it has " +
                std::to_string(components()) + ")");
  }
  const size_t slot = size_t(component + 1);
  {
    std::lock_guard lock(cache_->mutex);
    if (cache_->ranges.size() > slot && cache_->ranges[slot]) return *cache_->ranges[slot];
  }
  const Range r = compute_range(component);
  std::lock_guard lock(cache_->mutex);
  if (cache_->ranges.size() <= slot) cache_->ranges.resize(slot + 1);
  cache_->ranges[slot] = r;
  return r;
}

Range Field::compute_range(int component) const {
  struct Acc {
    double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
    uint64_t nans = 0;
  };
  const int nc = components();
  const bool magnitude = component == kMagnitude && nc > 1;
  const int comp = component >= 0 ? component : 0;
  Acc acc = data_.visit([&](auto values) {
    return tbb::parallel_reduce(
        tbb::blocked_range<uint64_t>(0, tuples(), 1 << 16), Acc{},
        [&](const tbb::blocked_range<uint64_t>& r, Acc a) {
          for (uint64_t t = r.begin(); t != r.end(); ++t) {
            double v;
            if (magnitude) {
              double s = 0;
              for (int c = 0; c < nc; ++c) {
                const double x = double(values[t * uint64_t(nc) + uint64_t(c)]);
                s += x * x;
              }
              v = std::sqrt(s);
            } else {
              v = double(values[t * uint64_t(nc) + uint64_t(comp)]);
            }
            if (std::isnan(v)) {
              ++a.nans;
              continue;
            }
            a.lo = std::min(a.lo, v);
            a.hi = std::max(a.hi, v);
          }
          return a;
        },
        [](Acc a, const Acc& b) {
          a.lo = std::min(a.lo, b.lo);
          a.hi = std::max(a.hi, b.hi);
          a.nans += b.nans;
          return a;
        });
  });
  if (acc.lo > acc.hi) return Range{0, 0, acc.nans};  // empty or all NaN
  return Range{acc.lo, acc.hi, acc.nans};
}

void FieldSet::add(Field f) { fields_.push_back(std::move(f)); }

const Field* FieldSet::find(std::string_view name) const {
  if (const Field* f = find(name, Association::Vertex)) return f;
  return find(name, Association::Cell);
}

const Field* FieldSet::find(std::string_view name, Association a) const {
  for (const Field& f : fields_) {
    if (f.name() == name && f.association() == a) return &f;
  }
  return nullptr;
}

ScalarRef FieldSet::scalar(std::string_view selector) const {
  std::string_view name = selector, comp;
  // Field names may themselves contain ':', so prefer an exact match of the whole selector.
  const Field* f = find(selector);
  if (!f) {
    const auto colon = selector.rfind(':');
    if (colon != std::string_view::npos) {
      name = selector.substr(0, colon);
      comp = selector.substr(colon + 1);
      f = find(name);
    }
  }
  if (!f) {
    std::string names;
    for (const Field& g : fields_) names += (names.empty() ? "" : ", ") + g.name();
    throw Error("no field named '" + std::string(selector) + "' (fields: " + (names.empty() ? "none" : names) + ")");
  }
  ScalarRef ref{f, kMagnitude};
  if (comp.empty() || comp == "magnitude" || comp == "mag") return ref;
  if (comp == "x" || comp == "X")
    ref.component = 0;
  else if (comp == "y" || comp == "Y")
    ref.component = 1;
  else if (comp == "z" || comp == "Z")
    ref.component = 2;
  else {
    int k = -1;
    const auto [p, ec] = std::from_chars(comp.data(), comp.data() + comp.size(), k);
    if (ec != std::errc() || p != comp.data() + comp.size()) k = -1;
    ref.component = k;
  }
  if (ref.component < 0 || ref.component >= f->components()) {
    throw Error("field '" + f->name() + "' has " + std::to_string(f->components()) + " component(s); '" +
                std::string(comp) + "' is not one of them");
  }
  return ref;
}

bool FieldSet::operator==(const FieldSet& o) const {
  if (fields_.size() != o.fields_.size()) return false;
  for (size_t i = 0; i < fields_.size(); ++i) {
    const Field &a = fields_[i], &b = o.fields_[i];
    if (a.name() != b.name() || a.association() != b.association() || !(a.data() == b.data())) return false;
  }
  return true;
}

}  // namespace ugvr
