#include "ugvr/render/lod/cubic_cache.h"

namespace ugvr {

void CubicCoefficientCache::use(const Settings& settings) {
  if (have_settings_ && settings == settings_) return;
  clear();
  settings_ = settings;
  have_settings_ = true;
}

CubicCoefficientCache::Shared CubicCoefficientCache::find(uint64_t node) {
  const auto it = entries_.find(node);
  if (it == entries_.end()) {
    ++misses_;
    return nullptr;
  }
  ++hits_;
  recency_.splice(recency_.begin(), recency_, it->second.order);
  return it->second.entry;
}

CubicCoefficientCache::Shared CubicCoefficientCache::put(uint64_t node, Entry entry) {
  Shared shared = std::make_shared<const Entry>(std::move(entry));
  const uint64_t size = bytes_of(*shared);
  if (const auto it = entries_.find(node); it != entries_.end()) {
    bytes_ -= bytes_of(*it->second.entry);
    recency_.erase(it->second.order);
    entries_.erase(it);
  }
  if (size > budget_) return shared;
  while (bytes_ + size > budget_ && !recency_.empty()) {
    const uint64_t oldest = recency_.back();
    recency_.pop_back();
    const auto it = entries_.find(oldest);
    bytes_ -= bytes_of(*it->second.entry);
    entries_.erase(it);
    ++evictions_;
  }
  recency_.push_front(node);
  entries_.emplace(node, Slot{shared, recency_.begin()});
  bytes_ += size;
  return shared;
}

void CubicCoefficientCache::clear() {
  entries_.clear();
  recency_.clear();
  bytes_ = 0;
}

}  // namespace ugvr
