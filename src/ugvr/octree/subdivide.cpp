#include "ugvr/octree/subdivide.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <numeric>

#include "ugvr/octree/cell_box_overlap.h"

namespace ugvr {

namespace {

// `splits(node, box, cells)`: whether the node splits (below max_depth). Called on several threads at once. A node
// over `max_leaf_cells` (0: none) splits without asking, down to `deepest`.
template <class Splits>
OctreeShape subdivide(const UnstructuredMesh& mesh, const BrickLattice& lattice, int max_depth, Progress* progress,
                      const Splits& splits, uint64_t max_leaf_cells = 0, int deepest = 0) {
  deepest = std::max(deepest, max_depth);
  OctreeShape shape;
  shape.nodes.push_back(OctreeNode{});
  shape.leaf_cells.emplace_back(mesh.cell_count());
  std::iota(shape.leaf_cells[0].begin(), shape.leaf_cells[0].end(), uint64_t(0));

  std::vector<uint64_t> level_ids = {0};
  for (int level = 0; !level_ids.empty(); ++level) {
    // Children's cell lists per node of this level, octant-indexed; all empty for a node that does not split.
    std::vector<std::array<std::vector<uint64_t>, 8>> children(level_ids.size());
    tbb::parallel_for(size_t(0), level_ids.size(), [&](size_t i) {
      const OctreeNode& node = shape.nodes[level_ids[i]];
      const std::vector<uint64_t>& cells = shape.leaf_cells[level_ids[i]];
      if (level >= deepest) return;
      const Bounds box = lattice.node_box(level, {node.i, node.j, node.k});
      const bool crowded = max_leaf_cells != 0 && cells.size() > max_leaf_cells;
      if (!crowded && (level >= max_depth || !splits(node, box, cells))) return;
      const BoxCellLists lists = cells_overlapping_boxes(mesh, box, {2, 2, 2}, cells);
      for (int o = 0; o < 8; ++o) {
        const auto b = lists.box(uint64_t(o));
        children[i][size_t(o)].assign(b.begin(), b.end());
      }
    });

    std::vector<uint64_t> next;
    for (size_t i = 0; i < level_ids.size(); ++i) {
      const uint64_t id = level_ids[i];
      uint8_t mask = 0;
      for (int o = 0; o < 8; ++o) mask |= uint8_t(!children[i][size_t(o)].empty()) << o;
      if (mask == 0) continue;  // a leaf (a node that splits always has a child: its cells overlap its box)
      shape.nodes[id].child_mask = mask;
      shape.nodes[id].first_child = shape.nodes.size();
      std::vector<uint64_t>().swap(shape.leaf_cells[id]);
      for (int o = 0; o < 8; ++o) {
        if (!(mask >> o & 1)) continue;
        const OctreeNode& parent = shape.nodes[id];
        OctreeNode child;
        child.parent = id;
        child.level = uint8_t(level + 1);
        child.i = 2 * parent.i + uint32_t(o & 1);
        child.j = 2 * parent.j + uint32_t((o >> 1) & 1);
        child.k = 2 * parent.k + uint32_t((o >> 2) & 1);
        next.push_back(shape.nodes.size());
        shape.nodes.push_back(child);
        shape.leaf_cells.push_back(std::move(children[i][size_t(o)]));
      }
    }
    level_ids = std::move(next);
    if (progress) progress->add(1);
  }
  if (progress) progress->finish();
  return shape;
}

}  // namespace

OctreeShape subdivide_octree(const UnstructuredMesh& mesh, const BrickLattice& lattice, const SplitTest& split,
                             int max_depth, Progress* progress, const InterpolantCheck* interpolant,
                             uint64_t max_leaf_cells, int deepest) {
  tbb::enumerable_thread_specific<VoxelSpread> scratch;
  tbb::enumerable_thread_specific<BrickScratch> sampler_scratch;
  return subdivide(
      mesh, lattice, max_depth, progress,
      [&](const OctreeNode& node, const Bounds& box, const std::vector<uint64_t>& cells) {
        // The scratch is released before the nested parallel loop that follows, in which this thread may run other
        // nodes.
        return split.needs_split(box, cells, scratch.local()) ||
               (interpolant &&
                interpolant->exceeds(node.level, {node.i, node.j, node.k}, cells, sampler_scratch.local()));
      },
      max_leaf_cells, deepest);
}

OctreeShape subdivide_octree_where(const UnstructuredMesh& mesh, const BrickLattice& lattice, int max_depth,
                                   const std::function<bool(const OctreeNode&)>& splits, Progress* progress) {
  return subdivide(mesh, lattice, max_depth, progress,
                   [&](const OctreeNode& node, const Bounds&, const std::vector<uint64_t>&) { return splits(node); });
}

}  // namespace ugvr
