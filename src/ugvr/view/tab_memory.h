// What the viewer's tabs may hold, all tabs together: one server-wide byte budget (`ugvr view --tabs-memory`) that
// every tab's allocations are charged against when they are admitted, so that many tabs (or a client opening them on
// purpose) cannot take the machine's memory, and that is given back when a tab leaves. Pure bookkeeping, kept under
// the server's lock (view_server.cpp).
//
// A tab's charge has three parts:
//  - its outgoing queue: the most a client that does not read may have waiting before it is dropped
//    (kTabQueueBytes, ws_session.cpp);
//  - its canvas: width x height x kCanvasBytesPerPixel (the frame as the engines draw it in floats, its 8-bit copy,
//    the encoded JPEG/PNG and the exact engine's per-pixel state), charged again on every resize;
//  - its RAM brick cache (the level-of-detail engine's, render/lod/brick_cache.h): the per-tab `--ram-memory`, or
//    less when the budget has less left, but never under kMinTabCacheBytes (or --ram-memory if that is less).
// A tab that cannot get its queue, its canvas and the minimal cache is refused (HTTP 503 with the reason); a resize
// that does not fit is refused (an "error" message; the tab keeps its size).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace ugvr::view {

inline constexpr uint64_t kTabQueueBytes = uint64_t(16) << 20;
inline constexpr uint64_t kCanvasBytesPerPixel = 48;
inline constexpr uint64_t kMinTabCacheBytes = uint64_t(32) << 20;

struct TabCharge {
  uint64_t canvas = 0;  // bytes for the canvas at its current size
  uint64_t cache = 0;   // the tab's RAM brick cache budget
  uint64_t total() const { return kTabQueueBytes + canvas + cache; }
};

class TabMemory {
 public:
  // `budget`: all tabs together; `cache_per_tab`: what a tab's RAM cache gets when the budget allows.
  TabMemory(uint64_t budget, uint64_t cache_per_tab) : budget_(budget), cache_per_tab_(cache_per_tab) {}

  // Admits tab `id` with a canvas of width x height: its charge, or nullopt and `why` (for the 503 response).
  std::optional<TabCharge> admit(uint64_t id, int width, int height, std::string& why);
  // Tab `id`'s canvas becomes width x height: true, or false and `why` (its charge is then unchanged).
  bool resize(uint64_t id, int width, int height, std::string& why);
  // Tab `id` has left: its charge is given back (nothing for an unknown id).
  void release(uint64_t id);

  uint64_t budget() const { return budget_; }
  uint64_t used() const { return used_; }
  size_t tabs() const { return charges_.size(); }
  // The charge of tab `id` (nullopt: not admitted or released).
  std::optional<TabCharge> charge(uint64_t id) const;

 private:
  uint64_t budget_, cache_per_tab_;
  uint64_t used_ = 0;
  std::map<uint64_t, TabCharge> charges_;
};

// width x height x kCanvasBytesPerPixel.
uint64_t canvas_bytes(int width, int height);

}  // namespace ugvr::view
