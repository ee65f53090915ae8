// Test support: octree shapes for synthetic brick stores (tests of the cut selection and the active cut).
#pragma once

#include <algorithm>
#include <vector>

#include "ugvr/store/brick_store.h"

namespace ugvr::test {

// Root [0,1]³. A node exists where its box meets the ball of radius 0.5 around the centre, except in the root's
// octant 7 (x, y, z > 0.5: a missing child); nodes with x <= 0.25 stop at level 2, the rest at `depth`. Nodes are
// numbered breadth first (children after their parent, contiguous, in octant order: store/brick_store.h's convention).
inline std::vector<OctreeNode> ball_octree(int depth) {
  const Bounds root{{0, 0, 0}, {1, 1, 1}};
  auto exists = [](const Bounds& b) {
    if (b.lo.x >= 0.5 && b.lo.y >= 0.5 && b.lo.z >= 0.5) return false;
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double c = std::clamp(0.5, b.lo[a], b.hi[a]) - 0.5;
      d2 += c * c;
    }
    return d2 <= 0.25;
  };
  std::vector<OctreeNode> nodes(1);
  for (size_t q = 0; q < nodes.size(); ++q) {
    const Bounds b = node_bounds(root, nodes[q]);
    const int level = nodes[q].level;
    if (level == depth || (level >= 2 && b.hi.x <= 0.25)) continue;
    OctreeNode parent = nodes[q];
    parent.first_child = nodes.size();
    for (int oct = 0; oct < 8; ++oct) {
      OctreeNode c;
      c.parent = q;
      c.level = uint8_t(level + 1);
      c.i = 2 * parent.i + (oct & 1);
      c.j = 2 * parent.j + ((oct >> 1) & 1);
      c.k = 2 * parent.k + ((oct >> 2) & 1);
      if (!exists(node_bounds(root, c))) continue;
      parent.child_mask |= uint8_t(1 << oct);
      nodes.push_back(c);
    }
    if (!parent.child_mask) parent.first_child = kNoNode;
    nodes[q] = parent;
  }
  return nodes;
}

}  // namespace ugvr::test
