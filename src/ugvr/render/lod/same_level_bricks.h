// A store's bricks by (level, i, j, k): what the tricubic prefilter's same-level neighbourhood of a brick holds
// (brick_atlas.h, CubicNeighbourhood) and whether the fill of samples without data lies within two bricks of it
// (brick_atlas.h, cubic_reach). The LOD engine gathers its uploads' neighbourhoods through it (lod_engine.cpp,
// load_cubic); tests ask it the same questions the engine does.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "ugvr/store/brick_store.h"

namespace ugvr {

class SameLevelBricks {
 public:
  // Indexes every node of `store` that has a brick; the store must outlive this.
  explicit SameLevelBricks(const BrickStoreReader& store);

  // The node with a brick at (level, i, j, k), or kNoNode (none there, or outside the root cell).
  uint64_t at(uint64_t level, int64_t i, int64_t j, int64_t k) const;
  // A same-level position inside the root cell that has no brick (an empty octant, or a coarser leaf there): the
  // prefilter takes it as a brick whose samples all lack data, and fills it.
  static constexpr uint64_t kNoData = kNoNode - 1;
  // The node's 27 same-level positions (CubicNeighbourhood's order, the node itself at 13 as kNoNode): the node there,
  // kNoData inside the root cell without a brick, kNoNode outside it (the prefilter drops that side).
  std::array<uint64_t, 27> around(uint64_t node) const;
  // Whether a same-level position within two of the node's (the 5³ around it, itself included, inside the root cell)
  // has samples without data or no brick: the fill lies within its neighbours' neighbourhoods (cubic_coefficients'
  // fill_nearby). From the nodes' valid fractions (1 exactly where every sample of the brick has data: the mask is the
  // fields' shared one); each node's answer is kept (the 125 look-ups are asked again at every upload of it).
  bool fill_within_two(uint64_t node);

 private:
  const BrickStoreReader& store_;
  std::unordered_map<uint64_t, uint64_t> by_key_;
  std::vector<int8_t> fill_within_two_;  // per node: -1 not asked yet, else the answer
};

}  // namespace ugvr
