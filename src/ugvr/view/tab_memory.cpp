#include "ugvr/view/tab_memory.h"

#include <algorithm>

#include "ugvr/core/memory.h"

namespace ugvr::view {

uint64_t canvas_bytes(int width, int height) {
  return uint64_t(std::max(width, 0)) * uint64_t(std::max(height, 0)) * kCanvasBytesPerPixel;
}

namespace {

std::string in_use(const TabMemory& m) {
  return format_bytes(m.used()) + " of " + format_bytes(m.budget()) + " in use by " + std::to_string(m.tabs()) +
         (m.tabs() == 1 ? " tab" : " tabs");
}

}  // namespace

std::optional<TabCharge> TabMemory::admit(uint64_t id, int width, int height, std::string& why) {
  TabCharge c;
  c.canvas = canvas_bytes(width, height);
  const uint64_t fixed = kTabQueueBytes + c.canvas;
  const uint64_t left = budget_ > used_ ? budget_ - used_ : 0;
  const uint64_t least = fixed + std::min(kMinTabCacheBytes, cache_per_tab_);
  if (charges_.count(id) || left < least) {
    why = "the viewer's memory for tabs is taken (" + in_use(*this) + "; a tab needs at least " + format_bytes(least) +
          "): close a tab, or start `ugvr view` with a larger --tabs-memory";
    return std::nullopt;
  }
  c.cache = std::min(cache_per_tab_, left - fixed);
  charges_[id] = c;
  used_ += c.total();
  return c;
}

bool TabMemory::resize(uint64_t id, int width, int height, std::string& why) {
  const auto it = charges_.find(id);
  if (it == charges_.end()) return true;  // not charged (closed meanwhile)
  const uint64_t canvas = canvas_bytes(width, height);
  const uint64_t others = used_ - it->second.canvas;
  if (others + canvas > budget_) {
    why = "width: a " + std::to_string(width) + "x" + std::to_string(height) + " canvas needs " + format_bytes(canvas) +
          ", more than the viewer's memory for tabs has left (" + in_use(*this) +
          "); close a tab, use a smaller window, or start `ugvr view` with a larger --tabs-memory";
    return false;
  }
  used_ = others + canvas;
  it->second.canvas = canvas;
  return true;
}

void TabMemory::release(uint64_t id) {
  const auto it = charges_.find(id);
  if (it == charges_.end()) return;
  used_ -= it->second.total();
  charges_.erase(it);
}

std::optional<TabCharge> TabMemory::charge(uint64_t id) const {
  const auto it = charges_.find(id);
  if (it == charges_.end()) return std::nullopt;
  return it->second;
}

}  // namespace ugvr::view
