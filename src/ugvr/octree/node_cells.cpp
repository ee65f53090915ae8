#include "ugvr/octree/node_cells.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <numeric>
#include <unordered_map>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

// The store's fields at a block's points (`global`: the input points, in the block's order) or cells: the block's last
// array (NodeCells::values).
std::vector<float> block_values(std::span<const ScalarRef> scalars, std::span<const uint64_t> cells,
                                std::span<const uint32_t> global) {
  std::vector<float> values;
  for (const ScalarRef& s : scalars) {
    if (s.field->association() == Association::Cell) {
      for (uint64_t c : cells) values.push_back(float(s.field->scalar(c, s.component)));
    } else {
      for (uint32_t v : global) values.push_back(float(s.field->scalar(v, s.component)));
    }
  }
  return values;
}

}  // namespace

std::vector<float> gather_node_values(const UnstructuredMesh& mesh, std::span<const ScalarRef> scalars,
                                      std::span<const uint64_t> cells) {
  // The points in order of first use, as gather_node_cells numbers them.
  std::unordered_map<uint32_t, uint32_t> local;
  local.reserve(cells.size() * 2);
  std::vector<uint32_t> global;
  for (uint64_t c : cells)
    for (uint32_t v : mesh.cell(c))
      if (local.try_emplace(v, uint32_t(global.size())).second) global.push_back(v);
  return block_values(scalars, cells, global);
}

NodeCells gather_node_cells(const UnstructuredMesh& mesh, const MeshTopology& topology,
                            std::span<const ScalarRef> scalars, std::span<const uint64_t> cells) {
  NodeCells out;
  out.ids.assign(cells.begin(), cells.end());
  if (!std::is_sorted(out.ids.begin(), out.ids.end())) throw Error("gather_node_cells: cell ids are not ascending");
  // Points in order of first use, so that a block's points follow its cells.
  std::unordered_map<uint32_t, uint32_t> local;
  local.reserve(cells.size() * 2);
  std::vector<uint32_t> global;
  out.types.reserve(cells.size());
  for (uint64_t c : cells) {
    out.types.push_back(mesh.cell_types[c]);
    for (uint32_t v : mesh.cell(c)) {
      auto [it, fresh] = local.try_emplace(v, uint32_t(global.size()));
      if (fresh) global.push_back(v);
      out.connectivity.push_back(it->second);
    }
  }
  for (uint64_t i = 0; i < cells.size(); ++i) {
    const uint64_t c = cells[i];
    const uint32_t faces = cell_face_count(mesh.cell_types[c]);
    for (uint32_t f = 0; f < faces; ++f) {
      const uint64_t across = topology.neighbor(c, f);
      if (across == kNoNeighbor) {
        out.across.push_back(store_format::kCellAcrossBoundary);
        continue;
      }
      const auto it = std::lower_bound(out.ids.begin(), out.ids.end(), face_cell(across));
      out.across.push_back(it != out.ids.end() && *it == face_cell(across) ? uint32_t(it - out.ids.begin())
                                                                           : store_format::kCellAcrossOutside);
    }
  }
  out.points.reserve(global.size());
  for (uint32_t v : global) out.points.push_back(mesh.points[v]);
  out.values = block_values(scalars, cells, global);
  return out;
}

NodeCells gather_welded_cells(const UnstructuredMesh& mesh, const MeshTopology& topology,
                              std::span<const ScalarRef> scalars, std::span<const uint64_t> ids,
                              std::span<const uint64_t> boundary_faces) {
  if (ids.size() != mesh.cell_count()) throw Error("gather_welded_cells: one input id per cell expected");
  if (!std::is_sorted(ids.begin(), ids.end())) throw Error("gather_welded_cells: cell ids are not ascending");
  std::vector<uint64_t> all(mesh.cell_count());
  std::iota(all.begin(), all.end(), uint64_t(0));
  // The node's own topology first: across a local cell, or (no match in the node) boundary.
  NodeCells out = gather_node_cells(mesh, topology, scalars, all);
  std::vector<uint64_t>().swap(all);
  out.ids.assign(ids.begin(), ids.end());
  // Then the whole mesh's boundary decides: its faces are boundary, the other unmatched faces lead outside the node.
  size_t slot = 0;
  for (size_t i = 0; i < out.ids.size(); ++i) {
    const uint32_t faces = cell_face_count(out.types[i]);
    for (uint32_t f = 0; f < faces; ++f, ++slot) {
      if (std::binary_search(boundary_faces.begin(), boundary_faces.end(), pack_face(out.ids[i], f))) {
        out.across[slot] = store_format::kCellAcrossBoundary;
      } else if (out.across[slot] == store_format::kCellAcrossBoundary) {
        out.across[slot] = store_format::kCellAcrossOutside;
      }
    }
  }
  return out;
}

LeafCellStats write_leaf_cells(BrickStoreWriter& writer, const UnstructuredMesh& mesh, const MeshTopology& topology,
                               std::span<const ScalarRef> scalars, std::span<const OctreeNode> nodes,
                               std::span<const std::vector<uint64_t>> leaf_cells) {
  std::atomic<uint64_t> blocks{0}, cells{0}, bytes{0};
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, nodes.size(), 16), [&](const tbb::blocked_range<uint64_t>& r) {
    for (uint64_t id = r.begin(); id != r.end(); ++id) {
      if (!nodes[id].is_leaf() || id >= leaf_cells.size() || leaf_cells[id].empty()) continue;
      const EncodedCells e = writer.encode_cells(gather_node_cells(mesh, topology, scalars, leaf_cells[id]));
      writer.append_cells(id, e);
      blocks += 1;
      cells += e.cells;
      bytes += e.bytes.size();
    }
  });
  return {blocks.load(), cells.load(), bytes.load()};
}

LeafCellStats write_leaf_cell_values(BrickStoreWriter& writer, const UnstructuredMesh& mesh,
                                     std::span<const ScalarRef> scalars, std::span<const OctreeNode> nodes,
                                     std::span<const std::vector<uint64_t>> leaf_cells) {
  std::atomic<uint64_t> blocks{0}, bytes{0};
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, nodes.size(), 16), [&](const tbb::blocked_range<uint64_t>& r) {
    for (uint64_t id = r.begin(); id != r.end(); ++id) {
      if (!nodes[id].is_leaf() || id >= leaf_cells.size() || leaf_cells[id].empty()) continue;
      const EncodedCells e = writer.encode_cell_values(gather_node_values(mesh, scalars, leaf_cells[id]));
      writer.append_cell_values(id, e);
      blocks += 1;
      bytes += e.bytes.size();
    }
  });
  return {blocks.load(), 0, bytes.load()};
}

}  // namespace ugvr
