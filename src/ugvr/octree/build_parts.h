// What the two octree builds, in memory (octree/builder.h) and out of core (octree/out_of_core.h), do alike: a node's
// error figures and brick once it is sampled and measured, and the statistics of the finished tree's shape.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/node_error.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// An interior node's errors, appended to `out` per field: the larger of what was measured (`measured`, one sum per
// field) and each child's own error, so that the figures are monotone up the tree (octree/node_error.h). `children`:
// the node's 8 child results by octant, null where there is none, each with its `errors` per field.
template <class Children>
void add_interior_node_errors(std::span<const ErrorSum> measured, const Children& children,
                              std::vector<FieldError>& out) {
  for (size_t f = 0; f < measured.size(); ++f) {
    FieldError e = measured[f].result();
    for (const auto& child : children) {
      if (!child) continue;
      e.max = std::max(e.max, child->errors[f].max);
      e.rms = std::max(e.rms, child->errors[f].rms);
    }
    out.push_back(e);
  }
}

// Encodes node `node`'s brick (its `fields` fields back to back, as BrickSamples keeps them) and appends it to the
// store.
// The store's layout for a build: resolution, fields, root cell and data bounds, encoding, and the provenance record
// (ugvr version, the inputs, the options that shaped the tree; no date, so that builds stay byte for byte repeatable).
BrickStoreLayout store_layout(const OctreeBuildOptions& options, std::vector<BrickStoreField> fields,
                              const Bounds& root, const Bounds& data, bool out_of_core);

void write_node_brick(BrickStoreWriter& writer, uint64_t node, const BrickSamples& brick, uint32_t fields);

// Fills the tree's shape in `stats`: nodes, leaves, nodes per level, deepest and mean leaf level.
void count_tree_shape(std::span<const OctreeNode> nodes, OctreeBuildStats& stats);

}  // namespace ugvr
