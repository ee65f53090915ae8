#include "ugvr/octree/build_parts.h"

#include <algorithm>
#include <nlohmann/json.hpp>

namespace ugvr {

void write_node_brick(BrickStoreWriter& writer, uint64_t node, const BrickSamples& brick, uint32_t fields) {
  const size_t n = brick.mask.size();
  std::vector<const float*> values(fields);
  for (uint32_t f = 0; f < fields; ++f) values[f] = brick.values.data() + f * n;
  writer.append(node, writer.encode(values, brick.mask.data()));
}

void count_tree_shape(std::span<const OctreeNode> nodes, OctreeBuildStats& stats) {
  stats.nodes = nodes.size();
  double level_sum = 0;
  for (const OctreeNode& n : nodes) {
    if (stats.nodes_per_level.size() <= n.level) stats.nodes_per_level.resize(n.level + 1u, 0);
    ++stats.nodes_per_level[n.level];
    if (!n.is_leaf()) continue;
    ++stats.leaves;
    level_sum += n.level;
    stats.max_level = std::max(stats.max_level, int(n.level));
  }
  stats.mean_leaf_level = level_sum / double(stats.leaves);
}

BrickStoreLayout store_layout(const OctreeBuildOptions& options, std::vector<BrickStoreField> fields,
                              const Bounds& root, const Bounds& data, bool out_of_core) {
  BrickStoreLayout layout;
  layout.resolution = options.resolution;
  layout.fields = std::move(fields);
  layout.root = root;
  layout.data = data;
  layout.encoding = options.encoding;
  layout.tolerance = options.tolerance;
  nlohmann::json p = {{"ugvr", UGVR_VERSION},
                      {"inputs", options.inputs},
                      {"brick", options.resolution},
                      {"max_depth", options.max_depth},
                      {"error", options.error},
                      {"samples", options.encoding.samples == SampleEncoding::Float32 ? "float32" : "quant16"},
                      {"out_of_core", out_of_core}};
  // Only with cells, so that stores without them stay byte for byte those of before.
  if (options.leaf_cells) p["max_leaf_cells"] = options.max_leaf_cells;
  layout.provenance = p.dump();
  return layout;
}

}  // namespace ugvr
