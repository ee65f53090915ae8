#include "ugvr/render/lod/active_cut.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <queue>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/lod_cut.h"

namespace ugvr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// std::priority_queue keeps the largest element on top: "a < b" means b comes first.
struct SplitFirst {  // highest error first, then the smallest id
  bool operator()(const QueueEntry& a, const QueueEntry& b) const {
    return a.error < b.error || (a.error == b.error && a.node > b.node);
  }
};
struct MergeFirst {  // lowest error first, then the smallest id
  bool operator()(const QueueEntry& a, const QueueEntry& b) const {
    return a.error > b.error || (a.error == b.error && a.node > b.node);
  }
};
using SplitQueue = std::priority_queue<QueueEntry, std::vector<QueueEntry>, SplitFirst>;
using MergeQueue = std::priority_queue<QueueEntry, std::vector<QueueEntry>, MergeFirst>;

void check_options(const BrickStoreReader& store, const ActiveCutOptions& o) {
  if (o.field >= store.field_count()) {
    fail_in(store.path(), "active cut: field " + std::to_string(o.field) + " out of range (the store has " +
                              std::to_string(store.field_count()) + " fields)");
  }
  if (!(o.pixels > 0 && std::isfinite(o.pixels))) fail_in("active cut", "the pixel threshold must be finite and > 0");
  if (!(o.error_weight >= 0 && std::isfinite(o.error_weight)))
    fail_in("active cut", "the error weight must be finite and >= 0");
}

// Advances a stamp; on wrap-around, clears the stamped arrays so that no stale stamp can equal the new one.
template <class... Arrays>
uint32_t next_stamp(uint32_t& stamp, Arrays&... arrays) {
  if (++stamp == 0) {
    (std::fill(arrays.begin(), arrays.end(), 0u), ...);
    stamp = 1;
  }
  return stamp;
}

}  // namespace

ActiveCut::ActiveCut(const BrickStoreReader& store, ActiveCutOptions options)
    : store_(store), options_(options), tf_errors_(store, options.field < store.field_count() ? options.field : 0) {
  check_options(store, options);
  const BrickStoreField& f = store.layout().fields[options.field];
  range_ = f.max - f.min;
  const uint64_t n = store.node_count();

  // The brick tree. Children come after their parent and brickless subtrees are walked to their brick nodes, so each
  // node's brick children are found from it alone; each node with a brick gets exactly one brick parent.
  parent_.assign(n, kNoNode);
  kid_begin_.assign(n + 1, 0);
  std::vector<uint64_t> stack;
  auto collect = [&](uint64_t id, std::vector<uint64_t>& out) {
    const size_t first = out.size();
    stack.assign(1, id);
    while (!stack.empty()) {
      const BrickNode& node = store.node(stack.back());
      stack.pop_back();
      const uint64_t end = node.first_child + uint64_t(std::popcount(unsigned(node.child_mask)));
      for (uint64_t c = node.is_leaf() ? end : node.first_child; c < end; ++c) {
        if (store.node(c).has_brick()) {
          out.push_back(c);
        } else if (!store.node(c).is_leaf()) {
          stack.push_back(c);
        }
      }
    }
    std::sort(out.begin() + std::ptrdiff_t(first), out.end());
  };
  for (uint64_t id = 0; id < n; ++id) {
    kid_begin_[id] = kids_.size();
    if (!store.node(id).has_brick()) continue;
    collect(id, kids_);
    for (uint64_t k = kid_begin_[id]; k < kids_.size(); ++k) parent_[kids_[k]] = id;
  }
  kid_begin_[n] = kids_.size();
  if (store.node(0).has_brick()) {
    roots_ = {0};
  } else {
    collect(0, roots_);
  }

  pos_.assign(n, 0);
  moved_.assign(n, 0);
  marked_.assign(n, 0);
  eval_stamp_.assign(n, 0);
  errors_.assign(n, {});
  reset();
}

void ActiveCut::reset() {
  cut_.clear();
  on_cut_.assign(store_.node_count(), 0);
  kids_on_cut_.assign(store_.node_count(), 0);
  for (uint64_t r : roots_) add(r);
}

void ActiveCut::set_options(const ActiveCutOptions& options) {
  check_options(store_, options);
  const BrickStoreField& f = store_.layout().fields[options.field];
  options_ = options;
  range_ = f.max - f.min;
  tf_errors_.set_field(options.field);
  next_stamp(view_stamp_, eval_stamp_);  // the cached errors used the old weighting and culling
}

std::span<const uint64_t> ActiveCut::nodes() const {
  if (!sorted_valid_) {
    sorted_ = cut_;
    std::sort(sorted_.begin(), sorted_.end());
    sorted_valid_ = true;
  }
  return sorted_;
}

void ActiveCut::check_node(uint64_t node, const char* what) const {
  if (node >= store_.node_count()) {
    fail_in("active cut", std::string(what) + ": node " + std::to_string(node) + " out of range (the store has " +
                              std::to_string(store_.node_count()) + " nodes)");
  }
}

std::span<const uint64_t> ActiveCut::brick_children(uint64_t node) const {
  check_node(node, "brick_children");
  return std::span<const uint64_t>(kids_).subspan(kid_begin_[node], kid_count(node));
}

uint64_t ActiveCut::brick_parent(uint64_t node) const {
  check_node(node, "brick_parent");
  return parent_[node];
}

void ActiveCut::add(uint64_t node) {
  on_cut_[node] = 1;
  pos_[node] = cut_.size();
  cut_.push_back(node);
  if (parent_[node] != kNoNode) ++kids_on_cut_[parent_[node]];
  sorted_valid_ = false;
}

void ActiveCut::remove(uint64_t node) {
  const uint64_t last = cut_.back();
  cut_[pos_[node]] = last;
  pos_[last] = pos_[node];
  cut_.pop_back();
  on_cut_[node] = 0;
  if (parent_[node] != kNoNode) --kids_on_cut_[parent_[node]];
  sorted_valid_ = false;
}

void ActiveCut::do_split(uint64_t node) {
  remove(node);
  for (uint64_t k = kid_begin_[node]; k < kid_begin_[node + 1]; ++k) add(kids_[k]);
}

void ActiveCut::do_merge(uint64_t node) {
  for (uint64_t k = kid_begin_[node]; k < kid_begin_[node + 1]; ++k) remove(kids_[k]);
  add(node);
}

void ActiveCut::split(uint64_t node) {
  check_node(node, "split");
  if (!on_cut_[node]) fail_in("active cut", "split: node " + std::to_string(node) + " is not on the cut");
  if (kid_count(node) == 0) fail_in("active cut", "split: node " + std::to_string(node) + " has no brick children");
  do_split(node);
}

void ActiveCut::merge(uint64_t node) {
  check_node(node, "merge");
  if (!mergeable(node)) {
    fail_in("active cut", "merge: node " + std::to_string(node) +
                              (kid_count(node) ? " has brick children off the cut" : " has no brick children"));
  }
  do_merge(node);
}

const NodeError& ActiveCut::eval(uint64_t node) const {
  if (eval_stamp_[node] == view_stamp_) return errors_[node];
  NodeError e;
  const Bounds box = store_.bounds(node);
  const FieldStats& s = store_.stats(node, options_.field);
  e.culled =
      (options_.frustum_cull && view_->outside(box)) || (options_.tf_cull && tf_transparent_over(tf_, s.min, s.max));
  e.texel_pixels = view_->texel_pixels(box, store_.resolution());
  double w = e.texel_pixels;
  if (options_.error_weight > 0) {
    double relative = range_ > 0 ? double(s.error_max) / range_ : (s.error_max > 0 ? 1.0 : 0.0);
    relative = std::isnan(relative) ? 1.0 : std::clamp(relative, 0.0, 1.0);  // unknown error: assume the worst
    w *= std::pow(relative, options_.error_weight);
  }
  if (options_.tf_error) w *= tf_errors_.weight(node);
  if (std::isnan(w)) w = kInf;  // unknown: split first, as select_cut does
  if (e.culled) w = 0;
  if (parent_[node] != kNoNode) w = std::min(w, eval(parent_[node]).weighted);
  e.weighted = w;
  errors_[node] = e;
  eval_stamp_[node] = view_stamp_;
  return errors_[node];
}

NodeError ActiveCut::error(uint64_t node) const {
  check_node(node, "error");
  if (!view_) fail_in("active cut", "error: no view yet (call update first)");
  return eval(node);
}

std::vector<QueueEntry> ActiveCut::split_queue() const {
  if (!view_) fail_in("active cut", "split_queue: no view yet (call update first)");
  std::vector<QueueEntry> out;
  for (uint64_t n : cut_)
    if (kid_count(n) > 0) out.push_back({n, eval(n).weighted});
  std::sort(out.begin(), out.end(), [](const QueueEntry& a, const QueueEntry& b) { return SplitFirst()(b, a); });
  return out;
}

std::vector<QueueEntry> ActiveCut::merge_queue() const {
  if (!view_) fail_in("active cut", "merge_queue: no view yet (call update first)");
  std::vector<QueueEntry> out;
  for (uint64_t n : cut_) {
    const uint64_t p = parent_[n];
    if (p != kNoNode && mergeable(p) && kids_[kid_begin_[p]] == n) out.push_back({p, eval(p).weighted});
  }
  std::sort(out.begin(), out.end(), [](const QueueEntry& a, const QueueEntry& b) { return MergeFirst()(b, a); });
  return out;
}

CutUpdate ActiveCut::update(const Camera& camera, int width, int height, const TransferFunction& tf,
                            const CutBudget& budget, const std::function<bool(uint64_t)>& is_resident) {
  if (budget.max_nodes == 0) fail_in("active cut", "max_nodes must be >= 1");
  if (budget.max_new_nodes_per_frame == 0) fail_in("active cut", "max_new_nodes_per_frame must be >= 1");
  view_.emplace(ViewMetrics(camera, width, height, store_.layout().root));  // validates before anything changes
  tf_ = tf;
  if (options_.tf_error) tf_errors_.update(tf);  // only when the transfer function (or field) changed
  next_stamp(view_stamp_, eval_stamp_);
  const uint32_t frame = next_stamp(frame_, moved_);
  const double threshold = options_.pixels;
  const uint64_t max_nodes = budget.max_nodes, max_new = budget.max_new_nodes_per_frame;
  const uint64_t max_reads = budget.max_reads_per_frame;

  CutUpdate out;
  // The queues, lazily pruned: an entry is acted on only if its node is still a candidate when it comes to the top
  // (errors do not change within an update, so an entry's error is always current).
  // Walked in id order: siblings and cousins are stored together (children follow their parents), so the per-node
  // arrays and the store's node table are read nearly sequentially.
  const std::span<const uint64_t> start = nodes();
  std::vector<QueueEntry> split_entries, merge_entries;
  next_stamp(mark_, marked_);
  for (uint64_t n : start) {
    const NodeError& e = eval(n);
    if (kid_count(n) > 0) split_entries.push_back({n, e.weighted});
    const uint64_t p = parent_[n];
    if (p != kNoNode && marked_[p] != mark_ && mergeable(p)) {
      marked_[p] = mark_;
      merge_entries.push_back({p, eval(p).weighted});
    }
  }
  SplitQueue splits(SplitFirst(), std::move(split_entries));  // O(n) heapify
  MergeQueue merges(MergeFirst(), std::move(merge_entries));
  auto can_merge = [&](uint64_t n) { return mergeable(n) && moved_[n] != frame; };
  auto apply_merge = [&](uint64_t n) {
    do_merge(n);
    moved_[n] = frame;
    ++out.merges;
    ++out.new_nodes;
    const uint64_t p = parent_[n];
    if (p != kNoNode && can_merge(p)) merges.push({p, eval(p).weighted});
  };

  // Wanted bricks. `ahead` counts the entries with priority > 0, which the final order puts before any pending
  // split found later (those have lower errors): it says whether a pending split's reads fit in this frame.
  next_stamp(mark_, marked_);
  std::vector<QueueEntry> wanted;
  uint64_t ahead = 0;
  auto want = [&](uint64_t n, double priority) {
    if (marked_[n] == mark_) return;
    marked_[n] = mark_;
    wanted.push_back({n, priority});
    if (priority > 0) ++ahead;
  };
  for (uint64_t n : start)
    if (!is_resident(n)) want(n, eval(n).culled ? 0.0 : kInf);

  // 1. Capacity.
  while (cut_.size() > max_nodes && !merges.empty()) {
    const QueueEntry m = merges.top();
    merges.pop();
    if (!can_merge(m.node) || kid_count(m.node) < 2) continue;  // a one-child merge frees nothing
    if (!is_resident(m.node)) {
      want(m.node, kInf);
      continue;
    }
    apply_merge(m.node);
  }
  if (cut_.size() > max_nodes) out.budget_limited = true;

  // 2. Splits.
  uint64_t reserved = 0;  // room promised to pending splits whose reads fit in this frame
  uint64_t deferred = 0;  // children of splits left to later updates for want of uploads
  std::vector<QueueEntry> planned, aside;
  auto room_needed = [&](uint64_t k) -> uint64_t {
    const uint64_t after = cut_.size() - 1 + k + reserved;
    return after > max_nodes ? after - max_nodes : 0;
  };
  auto lowest_merge_error = [&]() {
    while (!merges.empty() && !can_merge(merges.top().node)) merges.pop();
    return merges.empty() ? kInf : merges.top().error;
  };
  while (!splits.empty()) {
    const QueueEntry x = splits.top();
    splits.pop();
    if (!on_cut_[x.node] || moved_[x.node] == frame || kid_count(x.node) == 0) continue;
    if (!(x.error > threshold)) break;  // the rest are no larger
    if (out.new_nodes >= max_new && (ahead >= max_reads || deferred >= max_new)) {
      // No upload left, and the reads (or the next update's uploads) are spoken for by higher-error candidates:
      // scanning on would only find reads for later updates.
      out.upload_limited = true;
      break;
    }
    const std::span<const uint64_t> kids = brick_children(x.node);
    const uint64_t k = kids.size();
    bool ready = true;
    for (uint64_t c : kids) ready = is_resident(c) && ready;
    if (!ready) {
      if (room_needed(k) > 0 && !(lowest_merge_error() < x.error)) {
        out.budget_limited = true;  // could not be done even when loaded: do not read for it
        continue;
      }
      const bool reads_fit = ahead < max_reads;
      for (uint64_t c : kids)
        if (!is_resident(c)) want(c, x.error);
      out.pending.push_back(x.node);
      if (reads_fit) reserved += k - 1;
      if (out.new_nodes >= max_new) deferred += k;
      continue;
    }
    if (out.new_nodes > 0 && out.new_nodes + k > max_new) {
      out.upload_limited = true;
      deferred += k;
      continue;
    }
    if (const uint64_t need = room_needed(k); need > 0) {
      // Lower-error merges to make room, planned before any is applied: all or none.
      planned.clear();
      aside.clear();
      uint64_t freed = 0;
      while (freed < need && !merges.empty()) {
        const QueueEntry m = merges.top();
        if (!can_merge(m.node)) {
          merges.pop();
          continue;
        }
        if (!(m.error < x.error)) break;
        merges.pop();
        // Merging the splitting node's own parent would take it off the cut (the error clamp makes that
        // impossible, but the test is cheap); a one-child merge frees nothing; a missing brick cannot be merged.
        if (m.node == parent_[x.node] || kid_count(m.node) < 2 || !is_resident(m.node)) {
          aside.push_back(m);
          continue;
        }
        planned.push_back(m);
        freed += kid_count(m.node) - 1;
      }
      for (const QueueEntry& m : aside) merges.push(m);
      const bool uploads_fit = out.new_nodes == 0 || out.new_nodes + k + planned.size() <= max_new;
      if (freed < need || !uploads_fit) {
        for (const QueueEntry& m : planned) merges.push(m);
        if (freed < need) {
          out.budget_limited = true;
          break;
        }
        out.upload_limited = true;
        continue;
      }
      for (const QueueEntry& m : planned) apply_merge(m.node);
    }
    do_split(x.node);
    moved_[x.node] = frame;
    ++out.splits;
    out.new_nodes += k;
    for (uint64_t c : kids)
      if (kid_count(c) > 0) splits.push({c, eval(c).weighted});
  }

  // 3. Free merges: nothing is lost at this view.
  while (!merges.empty()) {
    const QueueEntry m = merges.top();
    if (!can_merge(m.node)) {
      merges.pop();
      continue;
    }
    if (!(m.error <= threshold) || out.new_nodes >= max_new) break;
    merges.pop();
    if (!is_resident(m.node)) {
      want(m.node, 0);
      continue;
    }
    apply_merge(m.node);
  }

  out.converged = out.splits == 0 && out.merges == 0 && wanted.empty();
  std::sort(wanted.begin(), wanted.end(), [](const QueueEntry& a, const QueueEntry& b) { return SplitFirst()(b, a); });
  if (wanted.size() > max_reads) wanted.resize(max_reads);
  out.wanted.reserve(wanted.size());
  out.wanted_priority.reserve(wanted.size());
  for (const QueueEntry& w : wanted) {
    out.wanted.push_back(w.node);
    out.wanted_priority.push_back(w.error);
  }
  double sum = 0;
  for (uint64_t n : nodes()) {
    const NodeError& e = eval(n);
    if (e.culled) continue;
    out.visible.push_back(n);
    out.max_error = std::max(out.max_error, e.weighted);
    sum += e.weighted;
  }
  if (!out.visible.empty()) out.mean_error = sum / double(out.visible.size());
  return out;
}

}  // namespace ugvr
