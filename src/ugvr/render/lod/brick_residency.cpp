#include "ugvr/render/lod/brick_residency.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/brick_atlas.h"
#include "ugvr/render/lod/brick_cache.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

void BrickSlotTable::reset(uint64_t capacity) {
  resident_.clear();
  slot_owner_.assign(capacity, kNoNode);
  slot_frame_.assign(capacity, 0);
}

void BrickSlotTable::clear() {
  resident_.clear();
  std::fill(slot_owner_.begin(), slot_owner_.end(), kNoNode);
  std::fill(slot_frame_.begin(), slot_frame_.end(), 0);
}

uint64_t BrickSlotTable::slot(uint64_t node) const {
  const auto it = resident_.find(node);
  return it == resident_.end() ? kNoSlot : it->second;
}

uint64_t BrickSlotTable::owner(uint64_t slot) const { return slot < slot_owner_.size() ? slot_owner_[slot] : kNoNode; }

BrickSlotTable::Plan BrickSlotTable::begin_frame(std::span<const uint64_t> nodes) {
  ++frame_;
  Plan plan;
  for (uint64_t n : nodes) {
    auto it = resident_.find(n);
    if (it != resident_.end())
      slot_frame_[it->second] = frame_;
    else
      plan.missing.push_back(n);
  }
  if (plan.missing.empty()) return plan;
  for (uint64_t s = 0; s < slot_owner_.size(); ++s)
    if (slot_frame_[s] != frame_) plan.slots.push_back(s);
  if (plan.slots.size() < plan.missing.size())
    fail_in("brick residency", "a cut of " + std::to_string(nodes.size()) + " bricks does not fit the atlas's " +
                                   std::to_string(slot_owner_.size()) + " slots");
  // Never-used slots have frame 0 and come first.
  std::partial_sort(plan.slots.begin(), plan.slots.begin() + std::ptrdiff_t(plan.missing.size()), plan.slots.end(),
                    [&](uint64_t a, uint64_t b) {
                      return slot_frame_[a] != slot_frame_[b] ? slot_frame_[a] < slot_frame_[b] : a < b;
                    });
  plan.slots.resize(plan.missing.size());
  return plan;
}

void BrickSlotTable::place(uint64_t node, uint64_t slot) {
  if (slot >= slot_owner_.size()) fail_in("brick residency", "slot " + std::to_string(slot) + " out of range");
  if (slot_owner_[slot] != kNoNode) resident_.erase(slot_owner_[slot]);
  slot_owner_[slot] = node;
  slot_frame_[slot] = frame_;
  resident_[node] = slot;
}

BrickResidency::BrickResidency(const BrickStoreReader& store, BrickSlotTable& gpu, BrickCache* ram)
    : store_(store), gpu_(gpu), ram_(ram) {}

bool BrickResidency::in_ram(uint64_t node) const { return ram_ && ram_->resident(node); }

BrickSlotTable::Plan BrickResidency::plan(std::span<const uint64_t> nodes) {
  sync_reads_ = 0;
  return gpu_.begin_frame(nodes);
}

void BrickResidency::fetch(const BrickSlotTable::Plan& plan, size_t first, size_t count, uint32_t field, double lo,
                           double hi, std::vector<Texels>& ram, std::vector<std::vector<uint16_t>>& read) {
  const uint32_t r = store_.resolution();
  const size_t n3 = size_t(r) * r * r;
  for (size_t i = 0; i < count; ++i) ram[i] = ram_ ? ram_->get(plan.missing[first + i]) : nullptr;
  tbb::parallel_for(size_t(0), count, [&](size_t i) {
    if (ram[i]) return;
    thread_local std::vector<float> samples;
    thread_local std::vector<uint8_t> mask;
    samples.resize(n3);
    mask.resize(n3);
    store_.read_brick(plan.missing[first + i], field, samples.data(), mask.data());
    make_atlas_slot(r, samples.data(), mask.data(), lo, hi, read[i]);
  });
  for (size_t i = 0; i < count; ++i)
    if (!ram[i]) ++sync_reads_;
}

}  // namespace ugvr
