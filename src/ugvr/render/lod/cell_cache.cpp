#include "ugvr/render/lod/cell_cache.h"

#include <epoxy/gl.h>

#include <algorithm>

#include "lod_shared.h"  // shaders/lod_shared.h: the bindings and the node record's size
#include "ugvr/core/error.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/render/exact/walk_mesh.h"

namespace ugvr {

PreparedNodeCells prepare_node_cells(const BrickStoreReader& store, uint64_t node, uint32_t field) {
  const NodeCells nc = store.read_cells(node);
  const BrickStoreLayout& layout = store.layout();
  if (field >= layout.fields.size()) fail_in(store.path(), "no field " + std::to_string(field));
  // The node's cells as a mesh of their own: the walk mesh gives the exact engine's order, neighbours, diagonals and
  // boundary (here: the faces whose neighbour the node does not keep, or the mesh lacks).
  Dataset ds;
  Block block;
  UnstructuredMesh mesh;
  mesh.points = nc.points;
  size_t at = 0;
  for (size_t c = 0; c < nc.types.size(); ++c) {
    const size_t n = cell_vertex_count(nc.types[c]);
    mesh.add_cell(nc.types[c], std::span<const uint32_t>(nc.connectivity.data() + at, n));
    at += n;
  }
  block.grid = std::move(mesh);
  ds.blocks.push_back(std::move(block));
  const WalkMesh w = build_walk_mesh(ds);

  PreparedNodeCells p;
  p.cells = w.cell_count();
  p.points = uint32_t(w.points.size());
  for (int k = 0; k < 4; ++k) p.type_begin[size_t(k)] = w.type_begin[size_t(k)];
  for (int k = 0; k < 4; ++k) p.conn_begin[size_t(k)] = uint32_t(w.conn_begin[size_t(k)]);
  const uint32_t face0 = uint32_t(w.connectivity.size());
  for (int k = 0; k < 4; ++k) p.face_begin[size_t(k)] = face0 + uint32_t(w.face_begin[size_t(k)]);
  p.ints = w.connectivity;
  p.ints.insert(p.ints.end(), w.neighbors.begin(), w.neighbors.end());
  p.quad_begin = uint32_t(p.ints.size());
  p.ints.resize(p.ints.size() + (w.quad_split.size() + 3) / 4, 0u);
  for (size_t i = 0; i < w.quad_split.size(); ++i)
    p.ints[p.quad_begin + i / 4] |= uint32_t(w.quad_split[i]) << (8 * (i % 4));
  p.entry_begin = uint32_t(p.ints.size());
  p.entry_count = uint32_t(w.boundary.size());
  for (const BoundaryTriangle& b : w.boundary) {
    p.ints.push_back(b.cell << 3 | b.local_face);
    p.ints.push_back(uint32_t(b.corners[0]) | uint32_t(b.corners[1]) << 2 | uint32_t(b.corners[2]) << 4);
  }
  // The cells' ids in the input mesh (per walk cell, low word then high word), and the walk cells in ascending id
  // order: the next exact node along a ray finds the cell a walk leaves the node in (the shader's handover).
  const std::vector<uint32_t> order = block_cell_order(ds, w, 0);
  if (order.size() != nc.ids.size()) fail_in(store.path(), "node " + std::to_string(node) + ": cells lost");
  p.id_begin = uint32_t(p.ints.size());
  p.ints.resize(p.ints.size() + 2 * size_t(p.cells), 0u);
  for (size_t c = 0; c < order.size(); ++c) {
    if (order[c] >= p.cells) fail_in(store.path(), "node " + std::to_string(node) + ": a cell the walk mesh dropped");
    p.ints[p.id_begin + 2 * size_t(order[c])] = uint32_t(nc.ids[c]);
    p.ints[p.id_begin + 2 * size_t(order[c]) + 1] = uint32_t(nc.ids[c] >> 32);
  }
  p.order_begin = uint32_t(p.ints.size());
  p.ints.insert(p.ints.end(), order.begin(), order.end());
  // Positions normalised to the root cell, as the LOD shader's rays are; values as stored (the optical table takes the
  // field's own units).
  const Bounds& root = layout.root;
  const Vec3d size = root.size();
  p.floats.reserve(w.points.size() * 3 + std::max<size_t>(w.points.size(), p.cells));
  for (const Vec3f& q : w.points) {
    p.floats.push_back(float((double(q.x) - root.lo.x) / size.x));
    p.floats.push_back(float((double(q.y) - root.lo.y) / size.y));
    p.floats.push_back(float((double(q.z) - root.lo.z) / size.z));
  }
  size_t offset = 0;
  for (uint32_t f = 0; f < field; ++f)
    offset += layout.fields[f].association == Association::Cell ? nc.ids.size() : nc.points.size();
  const BrickStoreField& fd = layout.fields[field];
  if (fd.association == Association::Cell) {
    std::vector<float> values(p.cells, 0.0f);
    for (size_t c = 0; c < order.size(); ++c)
      if (order[c] != kWalkBoundary) values[order[c]] = nc.values[offset + c];
    p.floats.insert(p.floats.end(), values.begin(), values.end());
  } else {
    for (size_t v = 0; v < nc.points.size(); ++v) p.floats.push_back(nc.values[offset + v]);
  }
  return p;
}

CellCache::CellCache(const BrickStoreReader& store, uint64_t budget_bytes) : store_(store), budget_(budget_bytes) {
  GLint64 block = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &block);
  max_block_ = block > 0 ? uint64_t(block) : uint64_t(128) << 20;
}

const PreparedNodeCells& CellCache::get(uint64_t node, uint32_t field, bool& fresh) {
  auto it = ram_.find(node);
  fresh = it == ram_.end();
  if (fresh) {
    it = ram_.emplace(node, Entry{prepare_node_cells(store_, node, field), 0}).first;
    ram_bytes_ += it->second.cells.bytes();
  }
  it->second.last_used = tick_;
  return it->second.cells;
}

CellCache::Grant CellCache::grant(std::span<const uint64_t> candidates, uint32_t field, uint64_t max_nodes) {
  if (field != field_) {
    ram_.clear();
    ram_bytes_ = 0;
    uploaded_.clear();
    field_ = field;
  }
  ++tick_;
  Grant g;
  uint64_t ints = 0, floats = 0, records = 0;
  for (uint64_t n : candidates) {
    if (g.nodes.size() >= max_nodes) break;
    if (store_.cell_block(n).offset == 0) continue;
    // A node's size is known once it is prepared (the block's header counts would do, but reading it is the cost).
    bool fresh = false;
    const PreparedNodeCells& p = get(n, field, fresh);
    if (fresh) ++g.prepared;
    const uint64_t rec = uint64_t(lod_gpu::CELL_NODE_UVEC4S) * 16;
    if (g.bytes + p.bytes() > budget_ || (ints + p.ints.size()) * 4 > max_block_ ||
        (floats + p.floats.size()) * 4 > max_block_ || records + rec > max_block_) {
      g.budget_full = true;
      continue;
    }
    g.nodes.push_back(n);
    g.entries.push_back(uint32_t(g.entries.size()));
    g.bytes += p.bytes();
    g.cells += p.cells;
    ints += p.ints.size(), floats += p.floats.size(), records += rec;
  }
  if (g.nodes != uploaded_) {
    std::vector<uint32_t> node_words, all_ints;
    std::vector<float> all_floats;
    all_ints.reserve(ints), all_floats.reserve(floats);
    for (uint64_t n : g.nodes) {
      const PreparedNodeCells& p = ram_.at(n).cells;
      const uint32_t ib = uint32_t(all_ints.size()), fb = uint32_t(all_floats.size());
      for (int k = 0; k < 4; ++k) node_words.push_back(p.type_begin[size_t(k)]);
      for (int k = 0; k < 4; ++k) node_words.push_back(ib + p.conn_begin[size_t(k)]);
      for (int k = 0; k < 4; ++k) node_words.push_back(ib + p.face_begin[size_t(k)]);
      node_words.insert(node_words.end(), {fb, fb + 3 * p.points, ib + p.quad_begin, ib + p.entry_begin});
      node_words.insert(node_words.end(), {p.entry_count, p.cells, ib + p.id_begin, ib + p.order_begin});
      all_ints.insert(all_ints.end(), p.ints.begin(), p.ints.end());
      all_floats.insert(all_floats.end(), p.floats.begin(), p.floats.end());
    }
    // Empty buffers cannot be bound: one word stands in.
    if (node_words.empty()) node_words.assign(size_t(lod_gpu::CELL_NODE_UVEC4S) * 4, 0u);
    if (all_ints.empty()) all_ints.push_back(0u);
    if (all_floats.empty()) all_floats.push_back(0.0f);
    nodes_buf_.upload(node_words.data(), node_words.size() * 4);
    ints_buf_.upload(all_ints.data(), all_ints.size() * 4);
    floats_buf_.upload(all_floats.data(), all_floats.size() * 4);
    check_gl("uploading cells");
    uploaded_ = g.nodes;
    g.uploaded = true;
  }
  // RAM: drop the least recently granted beyond twice the budget.
  if (ram_bytes_ > 2 * budget_) {
    std::vector<std::pair<uint64_t, uint64_t>> by_age;
    for (const auto& [n, e] : ram_)
      if (e.last_used != tick_) by_age.emplace_back(e.last_used, n);
    std::sort(by_age.begin(), by_age.end());
    for (const auto& [age, n] : by_age) {
      if (ram_bytes_ <= 2 * budget_) break;
      ram_bytes_ -= ram_.at(n).cells.bytes();
      ram_.erase(n);
    }
  }
  return g;
}

std::vector<uint64_t> CellCache::nodes_in_ram() const {
  std::vector<uint64_t> out;
  for (const auto& [n, e] : ram_) out.push_back(n);
  std::sort(out.begin(), out.end());
  return out;
}

void CellCache::bind() const {
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::CELL_NODE_BUFFER_BINDING, nodes_buf_.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::CELL_INT_BUFFER_BINDING, ints_buf_.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::CELL_FLOAT_BUFFER_BINDING, floats_buf_.id());
}

}  // namespace ugvr
