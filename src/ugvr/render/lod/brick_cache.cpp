#include "ugvr/render/lod/brick_cache.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/brick_atlas.h"  // for make_atlas_slot, which is CPU-only: nothing here calls OpenGL
#include "ugvr/store/brick_store.h"

namespace ugvr {

namespace {

uint64_t slot_bytes(uint32_t r) {
  const uint64_t s = uint64_t(r) + 2;
  return s * s * s * 2 * sizeof(uint16_t);
}

void check_field(const BrickStoreReader& store, uint32_t field) {
  if (field >= store.field_count())
    fail_in(store.path(), "brick cache: field " + std::to_string(field) + " out of range (the store has " +
                              std::to_string(store.field_count()) + ")");
}

}  // namespace

BrickCacheStats stats_since(const BrickCacheStats& now, const BrickCacheStats& before) {
  BrickCacheStats d = now;
  d.hits -= before.hits;
  d.misses -= before.misses;
  d.requests -= before.requests;
  d.over_budget -= before.over_budget;
  d.cancelled -= before.cancelled;
  d.loads_completed -= before.loads_completed;
  d.load_errors -= before.load_errors;
  d.evictions -= before.evictions;
  d.bytes_read -= before.bytes_read;
  d.load_seconds -= before.load_seconds;
  return d;
}

BrickCache::BrickCache(const BrickStoreReader& store, uint32_t field, uint64_t budget_bytes, int threads,
                       std::optional<uint32_t> step)
    : store_(store), step_(step.value_or(store.step())), brick_bytes_(slot_bytes(store.resolution())) {
  check_field(store, field);
  if (step_ >= store.step_count())
    fail_in(store.path(), "brick cache: time step " + std::to_string(step_) + " out of range (the store has " +
                              std::to_string(store.step_count()) + ")");
  field_ = field;
  capacity_ = std::max<uint64_t>(1, budget_bytes / brick_bytes_);
  const int n = std::max(1, threads > 0 ? threads : int(std::thread::hardware_concurrency()));
  threads_.reserve(size_t(n));
  try {
    for (int i = 0; i < n; ++i) threads_.emplace_back([this] { worker(); });
  } catch (...) {
    // The destructor does not run for a half-built object: stop the workers already started.
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    work_cv_.notify_all();
    for (std::thread& t : threads_) t.join();
    throw;
  }
}

BrickCache::~BrickCache() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    pending_.clear();
  }
  work_cv_.notify_all();
  for (std::thread& t : threads_) t.join();
}

uint32_t BrickCache::field() const {
  std::lock_guard lock(mutex_);
  return field_;
}

void BrickCache::request(std::span<const std::pair<uint64_t, float>> nodes) {
  // Validation, filtering and sorting before taking the lock: the workers should not wait on a long list.
  std::vector<std::pair<uint64_t, float>> order;
  order.reserve(nodes.size());
  for (const auto& [node, priority] : nodes) {
    if (node >= store_.node_count())
      fail_in(store_.path(), "brick cache: node " + std::to_string(node) + " requested, the store has " +
                                 std::to_string(store_.node_count()));
    if (!store_.node(node).has_brick()) continue;
    // NaN would break the sort's ordering.
    order.emplace_back(node, std::isnan(priority) ? -std::numeric_limits<float>::infinity() : priority);
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.second > b.second; });

  std::lock_guard lock(mutex_);
  ++generation_;  // every brick the previous list protected is unprotected now, unless admitted again below
  protected_resident_ = 0;
  std::unordered_set<uint64_t> seen;
  seen.reserve(order.size());
  std::vector<std::pair<uint64_t, float>> fresh;  // admitted, neither resident nor loading; descending priority
  std::vector<uint64_t> used;                     // resident, descending priority
  wanted_.clear();
  uint64_t admitted = 0;
  for (const auto& [node, priority] : order) {
    if (failed_.contains(node) || !seen.insert(node).second) continue;
    ++stats_.requests;
    wanted_.push_back(node);
    const bool admit = admitted < capacity_;
    if (admit)
      ++admitted;
    else
      ++stats_.over_budget;
    auto it = entries_.find(node);
    if (it != entries_.end()) {
      Entry& e = it->second;
      if (admit) {
        e.wanted = generation_;
        if (e.data) ++protected_resident_;
      }
      if (e.data) used.push_back(node);
    } else if (admit) {
      fresh.emplace_back(node, priority);
    }
  }
  // Being requested is a use; touching the least important first leaves the most important most recently used.
  for (auto it = used.rbegin(); it != used.rend(); ++it) touch(entries_.find(*it)->second);

  std::unordered_set<uint64_t> kept;
  kept.reserve(fresh.size());
  for (const auto& f : fresh) kept.insert(f.first);
  for (const auto& p : pending_) stats_.cancelled += !kept.contains(p.first);
  pending_.assign(fresh.rbegin(), fresh.rend());
  work_cv_.notify_all();
  idle_cv_.notify_all();
}

BrickCache::Brick BrickCache::get(uint64_t node) {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(node);
  if (it == entries_.end() || !it->second.data) {
    ++stats_.misses;
    return nullptr;
  }
  ++stats_.hits;
  touch(it->second);
  return it->second.data;
}

bool BrickCache::resident(uint64_t node) const {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(node);
  return it != entries_.end() && it->second.data;
}

bool BrickCache::wait_all(double timeout_seconds) {
  using clock = std::chrono::steady_clock;
  // Clamped so that the deadline cannot overflow the clock.
  const double t = std::clamp(std::isnan(timeout_seconds) ? 0.0 : timeout_seconds, 0.0, 1e7);
  const auto deadline = clock::now() + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(t));
  std::unique_lock lock(mutex_);
  if (!idle_cv_.wait_until(lock, deadline, [&] { return pending_.empty() && loading_ == 0; })) return false;
  for (uint64_t node : wanted_) {
    auto it = entries_.find(node);
    if (it == entries_.end() || !it->second.data) return false;
  }
  return true;
}

void BrickCache::rethrow_load_error() {
  std::exception_ptr e;
  {
    std::lock_guard lock(mutex_);
    e = std::exchange(error_, nullptr);
  }
  if (e) std::rethrow_exception(e);
}

void BrickCache::set_field(uint32_t field) {
  check_field(store_, field);
  std::lock_guard lock(mutex_);
  if (field == field_) return;
  field_ = field;
  ++epoch_;
  ++generation_;
  entries_.clear();
  lru_.clear();
  resident_count_ = protected_resident_ = 0;
  stats_.cancelled += pending_.size();
  pending_.clear();
  wanted_.clear();
  failed_.clear();
  // loading_ stays: the loads still running keep their reservation until they finish, so the budget holds.
  idle_cv_.notify_all();
}

void BrickCache::raise_budget(uint64_t budget_bytes) {
  {
    std::lock_guard lock(mutex_);
    capacity_ = std::max(capacity_, budget_bytes / brick_bytes_);
  }
  work_cv_.notify_all();  // loads that waited for a slot may start
}

void BrickCache::set_paused(bool paused) {
  {
    std::lock_guard lock(mutex_);
    paused_ = paused;
  }
  work_cv_.notify_all();
}

BrickCacheStats BrickCache::stats() const {
  std::lock_guard lock(mutex_);
  BrickCacheStats s = stats_;
  s.resident_bricks = resident_count_;
  s.resident_bytes = resident_count_ * brick_bytes_;
  s.queued = pending_.size();
  s.loading = loading_;
  return s;
}

void BrickCache::reset_stats() {
  std::lock_guard lock(mutex_);
  stats_ = BrickCacheStats{};
}

bool BrickCache::can_start() const {
  if (paused_ || pending_.empty()) return false;
  // A free slot, or a brick the current list does not protect.
  return resident_count_ + loading_ < capacity_ || resident_count_ > protected_resident_;
}

void BrickCache::evict_one() {
  for (auto it = lru_.rbegin(); it != lru_.rend(); ++it) {
    auto e = entries_.find(*it);
    if (is_protected(e->second)) continue;
    lru_.erase(std::next(it).base());
    entries_.erase(e);
    --resident_count_;
    ++stats_.evictions;
    return;
  }
}

void BrickCache::worker() {
  const uint32_t r = store_.resolution();
  const size_t n3 = size_t(r) * r * r;
  std::vector<float> samples(n3);
  std::vector<uint8_t> mask(n3);
  std::unique_lock lock(mutex_);
  for (;;) {
    work_cv_.wait(lock, [&] { return stop_ || can_start(); });
    if (stop_) return;
    const uint64_t node = pending_.back().first;
    pending_.pop_back();
    // Reserve the slot now, so that resident bricks plus those being built stay within the budget.
    if (resident_count_ + loading_ >= capacity_) evict_one();
    // pending_ only holds nodes without an entry, each once, all admitted by the current list.
    Entry& entry = entries_.try_emplace(node).first->second;
    entry.wanted = generation_;
    ++loading_;
    const uint32_t field = field_;
    const uint64_t epoch = epoch_;
    const double lo = store_.layout().fields[field].min, hi = store_.layout().fields[field].max;
    lock.unlock();

    const auto t0 = std::chrono::steady_clock::now();
    Brick brick;
    std::exception_ptr error;
    try {
      store_.read_brick(node, field, samples.data(), mask.data(), step_);
      auto texels = std::make_shared<std::vector<uint16_t>>();
      make_atlas_slot(r, samples.data(), mask.data(), lo, hi, *texels);
      brick = std::move(texels);
    } catch (...) {
      error = std::current_exception();
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    lock.lock();
    --loading_;
    stats_.load_seconds += seconds;
    // After set_field the entry (if any) belongs to the new field: the result, good or bad, is dropped.
    if (epoch == epoch_) {
      auto it = entries_.find(node);
      if (error) {
        entries_.erase(it);
        failed_.insert(node);
        ++stats_.load_errors;
        if (!error_) error_ = error;
      } else {
        Entry& e = it->second;
        e.data = std::move(brick);
        lru_.push_front(node);
        e.lru = lru_.begin();
        ++resident_count_;
        if (is_protected(e)) ++protected_resident_;
        ++stats_.loads_completed;
        stats_.bytes_read += store_.block(node, field).size;
      }
    }
    // A failure frees a slot and an unprotected arrival can be evicted: a worker waiting for room may go on.
    if (!pending_.empty()) work_cv_.notify_all();
    if (pending_.empty() && loading_ == 0) idle_cv_.notify_all();
  }
}

}  // namespace ugvr
