#include "ugvr/render/lod/same_level_bricks.h"

namespace ugvr {

namespace {
// A node by (level, i, j, k): 4 bits of level and 20 of each index (the store's depth limit).
uint64_t key_of(uint64_t level, int64_t i, int64_t j, int64_t k) {
  return level << 60 | uint64_t(i) << 40 | uint64_t(j) << 20 | uint64_t(k);
}

bool inside_root(uint64_t level, int64_t i, int64_t j, int64_t k) {
  const int64_t side = int64_t(1) << level;  // nodes of a level per axis of the root cell
  return i >= 0 && j >= 0 && k >= 0 && i < side && j < side && k < side;
}
}  // namespace

SameLevelBricks::SameLevelBricks(const BrickStoreReader& store)
    : store_(store), fill_within_two_(store.node_count(), -1) {
  for (uint64_t n = 0; n < store.node_count(); ++n) {
    const BrickNode& b = store.node(n);
    if (b.has_brick()) by_key_.emplace(key_of(b.level, b.i, b.j, b.k), n);
  }
}

uint64_t SameLevelBricks::at(uint64_t level, int64_t i, int64_t j, int64_t k) const {
  if (!inside_root(level, i, j, k)) return kNoNode;
  const auto it = by_key_.find(key_of(level, i, j, k));
  return it == by_key_.end() ? kNoNode : it->second;
}

std::array<uint64_t, 27> SameLevelBricks::around(uint64_t node) const {
  std::array<uint64_t, 27> out;
  const BrickNode& b = store_.node(node);
  for (int d = 0; d < 27; ++d) {
    const int64_t q[3] = {int64_t(b.i) + d % 3 - 1, int64_t(b.j) + d / 3 % 3 - 1, int64_t(b.k) + d / 9 - 1};
    const uint64_t m = d == 13 ? kNoNode : at(b.level, q[0], q[1], q[2]);
    out[size_t(d)] = d != 13 && m == kNoNode && inside_root(b.level, q[0], q[1], q[2]) ? kNoData : m;
  }
  return out;
}

bool SameLevelBricks::fill_within_two(uint64_t node) {
  int8_t& known = fill_within_two_[node];
  if (known >= 0) return known != 0;
  const BrickNode& b = store_.node(node);
  bool near = false;
  for (int64_t dz = -2; dz <= 2 && !near; ++dz)
    for (int64_t dy = -2; dy <= 2 && !near; ++dy)
      for (int64_t dx = -2; dx <= 2 && !near; ++dx) {
        const int64_t q[3] = {int64_t(b.i) + dx, int64_t(b.j) + dy, int64_t(b.k) + dz};
        if (!inside_root(b.level, q[0], q[1], q[2])) continue;
        const uint64_t m = at(b.level, q[0], q[1], q[2]);
        near = m == kNoNode || store_.node(m).valid_fraction < 1.0f;
      }
  known = near ? 1 : 0;
  return near;
}

}  // namespace ugvr
