// The RAM side of the brick cache (Leven et al. 2002, sections 5.1-5.2, time-critical LOD): an LRU cache of
// atlas-ready bricks, filled by background threads, so that a frame never waits on disk or decompression.
//
// What it holds. For one field of one store, per node, the texels make_atlas_slot (brick_atlas.h) builds from the
// decoded brick, normalised with the field's global [min, max] from the store layout: (R+2)³ × 2 uint16, RG16 order.
// Keeping the upload-ready form instead of the decoded floats and mask costs no more memory ((R+2)³·4 bytes against
// R³·5; at R = 32, 0.96 times) and moves the padding and normalisation off the render thread too, so that a cache hit
// is a plain upload. The budget counts these texel bytes; capacity = budget / brick bytes (at least
// one brick).
//
// How a frame uses it. The render thread calls request() once per frame with the nodes its cut wants and a priority
// per node (higher = sooner), then get()s the bricks it needs: whatever is resident it uploads and renders, whatever
// is not it replaces by an ancestor (refines once the children arrive). Disk reads and decoding run on the workers.
//
// Admission and eviction. request() replaces the previous list. It takes the requested nodes by priority and admits
// as many as the budget holds; the rest are "over budget" (stats) and are not loaded this frame. Admitted nodes are
// protected: a load for this frame only ever evicts bricks outside the current admitted set, least recently used
// first, so a brick the frame needs is never evicted to make room for a less important one. Use = a get() hit or
// being requested. A load reserves its slot before it starts (evicting then if need be), so resident bytes plus the
// bricks being decoded never exceed the budget. Workers take the highest-priority pending request; a request dropped
// by a newer list before it starts is cancelled (stats), one already running completes and is cached.
//
// Time stores (format version 6): a cache holds one step's bricks, the store's step (BrickStoreReader::set_step) when
// it was made, and reads that step whatever the store's step is later; the LOD session that owns it makes a new one
// when the step changes.
//
// Errors. A failed load (a corrupt block: ugvr::Error naming file, node, field and offset) marks the node failed: it
// is never retried for this field (so a bad brick is reported once, not once per frame) and is never resident; the
// first error since the last call is rethrown on the render thread by rethrow_load_error().
//
// Threading. Every public function is thread-safe. One mutex guards all bookkeeping and is never held across I/O or
// decoding, so request(), get(), resident() and stats() do not wait on disk (only, briefly, on another thread's
// bookkeeping). wait_all() blocks by design. Workers sleep on a condition variable when there is nothing to do or
// no slot to load into (no busy waiting). A brick returned by get() is shared: it stays valid after its eviction, so
// memory may exceed the budget by the bricks a caller still holds. The store must outlive the cache; its reads are
// thread-safe (store/brick_store.h). No OpenGL here: the GPU atlas has its own cache.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace ugvr {

class BrickStoreReader;

struct BrickCacheStats {
  // Cumulative counters (reset_stats() zeroes them; diff two snapshots for one frame: stats_since).
  uint64_t hits = 0, misses = 0;  // get() calls that found / did not find the brick resident
  uint64_t requests = 0;          // nodes with a brick named by request() (duplicates and failed nodes not counted)
  uint64_t over_budget = 0;       // of those, not admitted: beyond what the budget holds at their priority
  uint64_t cancelled = 0;         // pending loads dropped by a newer request list before they started
  uint64_t loads_completed = 0, load_errors = 0;
  uint64_t evictions = 0;
  uint64_t bytes_read = 0;  // compressed bytes read from the store by completed loads
  double load_seconds = 0;  // read + decode + slot building, summed over workers
  // Gauges: the state now.
  uint64_t resident_bytes = 0, resident_bricks = 0;
  uint64_t queued = 0;   // admitted, waiting for a worker
  uint64_t loading = 0;  // being read or decoded now
};

// Counters of `now` minus those of `before`; the gauges of `now`.
BrickCacheStats stats_since(const BrickCacheStats& now, const BrickCacheStats& before);

class BrickCache {
 public:
  using Brick = std::shared_ptr<const std::vector<uint16_t>>;

  // budget_bytes: RAM for resident bricks (raised to one brick if smaller). threads: workers (0 = hardware
  // concurrency). step: the time step whose bricks it reads (default: the store's step now). Throws ugvr::Error for
  // a field or step out of range.
  BrickCache(const BrickStoreReader& store, uint32_t field, uint64_t budget_bytes, int threads = 0,
             std::optional<uint32_t> step = {});
  // Drops pending requests, lets running loads finish, joins the workers.
  ~BrickCache();
  BrickCache(const BrickCache&) = delete;
  BrickCache& operator=(const BrickCache&) = delete;

  // Bytes of one brick's texels, (R+2)³ × 4, and how many bricks the budget holds.
  uint64_t brick_bytes() const { return brick_bytes_; }
  uint64_t capacity() const { return capacity_; }
  uint32_t field() const;
  uint32_t step() const { return step_; }  // the time step whose bricks it holds

  // The nodes this frame wants, with a priority each (higher = sooner; NaN = lowest); order among equal priorities
  // is the list's. Replaces the previous list (see the header comment). Nodes without a brick and nodes whose load
  // failed are ignored. Throws ugvr::Error, changing nothing, for a node id out of range.
  void request(std::span<const std::pair<uint64_t, float>> nodes);
  // The resident brick of node (texels as make_atlas_slot lays them out), or null. Counts a hit or a miss; a hit is a
  // use.
  Brick get(uint64_t node);
  // Whether node's brick is resident; no use, no statistics.
  bool resident(uint64_t node) const;
  // Blocks until no admitted request is pending or loading, or timeout_seconds pass. True when every node of the
  // current list is resident (false if any was over budget, failed, or the time ran out).
  bool wait_all(double timeout_seconds);
  // Rethrows (on the calling thread) the first load error since the last call; returns if there was none.
  void rethrow_load_error();
  // Switches to another field: drops every brick, request and failure (loads running finish and are discarded); a
  // no-op for the current field. A recorded load error stays until rethrown. Throws ugvr::Error for a field out of
  // range.
  void set_field(uint32_t field);
  // Raises the budget to budget_bytes (never lowers it: that would mean evicting): a prefetch made in what another
  // cache left free takes over the whole budget when that cache goes.
  void raise_budget(uint64_t budget_bytes);
  // While paused, workers start no load (running ones finish). For callers that batch, and for deterministic tests.
  void set_paused(bool paused);

  BrickCacheStats stats() const;
  void reset_stats();

 private:
  struct Entry {
    Brick data;                         // null while loading
    std::list<uint64_t>::iterator lru;  // valid when resident
    uint64_t wanted = 0;                // generation of the last request list that admitted the node
  };

  void worker();
  // The rest under mutex_. evict_one needs an unprotected resident brick; touch a resident entry.
  bool can_start() const;
  void evict_one();
  void touch(Entry& e) { lru_.splice(lru_.begin(), lru_, e.lru); }
  bool is_protected(const Entry& e) const { return e.wanted == generation_; }

  const BrickStoreReader& store_;
  const uint32_t step_;
  const uint64_t brick_bytes_;
  uint64_t capacity_ = 1;

  mutable std::mutex mutex_;
  std::condition_variable work_cv_;  // workers: a request, a slot, an unpause, or the end
  std::condition_variable idle_cv_;  // wait_all: a load finished
  uint32_t field_ = 0;
  uint64_t epoch_ = 0;                           // bumped by set_field: loads started before it are discarded
  uint64_t generation_ = 0;                      // bumped by request(): which list protects a brick
  std::unordered_map<uint64_t, Entry> entries_;  // resident or loading
  std::list<uint64_t> lru_;                      // resident nodes, most recently used first
  uint64_t resident_count_ = 0, protected_resident_ = 0, loading_ = 0;
  std::vector<std::pair<uint64_t, float>> pending_;  // admitted, not started; ascending priority (back = next)
  std::vector<uint64_t> wanted_;                     // the current list's nodes (with a brick, not failed)
  std::unordered_set<uint64_t> failed_;
  std::exception_ptr error_;
  BrickCacheStats stats_;
  bool paused_ = false, stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace ugvr
