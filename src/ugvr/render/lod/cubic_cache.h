// The tricubic prefilter's coefficients per brick, kept in RAM within a byte budget (least recently used first out),
// so that a brick is not prefiltered again when the engine uploads it again: its coarser cut neighbours changed (the
// level blend is redone on the kept coefficients), it comes back into the cut after eviction, or it is the ancestor
// that several batches' bricks blend into (docs/tricubic.md, "The coefficient cache").
//
// What is kept is cubic_coefficients' result before any level blend (brick_atlas.h): for one store, field, time step
// and the atlas's prefilter settings (reach, fill) a function of the node alone, because a node's same-level
// neighbourhood and where the fill lies are the store's (SameLevelBricks). So the key is the node; the engine clears
// the cache when any of the others changes (`Settings`). Not thread-safe: the engine's render thread only.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <unordered_map>
#include <vector>

namespace ugvr {

class CubicCoefficientCache {
 public:
  // What the coefficients depend on besides the node: a change empties the cache.
  struct Settings {
    uint32_t field = 0, step = 0;
    double lo = 0, hi = 0;  // the normalisation of the samples (make_atlas_slot)
    int extension = 0;      // BrickAtlas::extension()
    bool fill = true;       // BrickAtlas::fill()
    bool operator==(const Settings&) const = default;
  };
  // A prefilter's result: the coefficients ((R+2)³ doubles), or `prefiltered` false where the brick keeps its samples
  // (cubic_coefficients returned false).
  struct Entry {
    bool prefiltered = false;
    std::vector<double> coefficients;
  };
  using Shared = std::shared_ptr<const Entry>;

  explicit CubicCoefficientCache(uint64_t budget_bytes) : budget_(budget_bytes) {}

  // Empties the cache unless it holds entries for `settings`.
  void use(const Settings& settings);
  // The node's entry (and it becomes the most recently used), or null.
  Shared find(uint64_t node);
  // Keeps the node's entry, dropping the least recently used ones until the cache is within its budget; an entry
  // larger than the whole budget is not kept. Returns the entry.
  Shared put(uint64_t node, Entry entry);
  void clear();

  uint64_t bytes() const { return bytes_; }  // held now: the coefficients' bytes of every entry
  uint64_t budget() const { return budget_; }
  size_t size() const { return entries_.size(); }
  uint64_t hits() const { return hits_; }      // find() calls that found an entry, since construction
  uint64_t misses() const { return misses_; }  // and those that did not
  uint64_t evictions() const { return evictions_; }
  static uint64_t bytes_of(const Entry& e) { return e.coefficients.size() * sizeof(double); }

 private:
  struct Slot {
    Shared entry;
    std::list<uint64_t>::iterator order;  // its place in recency_
  };
  uint64_t budget_;
  uint64_t bytes_ = 0;
  uint64_t hits_ = 0, misses_ = 0, evictions_ = 0;
  bool have_settings_ = false;
  Settings settings_;
  std::unordered_map<uint64_t, Slot> entries_;
  std::list<uint64_t> recency_;  // most recently used first
};

}  // namespace ugvr
