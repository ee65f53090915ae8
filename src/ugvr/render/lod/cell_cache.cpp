#include "ugvr/render/lod/cell_cache.h"

#include <epoxy/gl.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string_view>

#include "lod_shared.h"  // shaders/lod_shared.h: the bindings and the node record's size
#include "ugvr/core/error.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/render/exact/walk_mesh.h"

namespace ugvr {

namespace {

// The entry grid of cell_cache.h: a uniform grid over the box of the entry triangles (grown by kEntryGridMargin),
// with about one cell per two triangles (their boxes are small and mostly on the node's shell, so a ray's stretch
// through the grid meets a few each), each triangle listed in every grid cell its grown box meets, in ascending order.
// Appended to p.ints (offsets, lists) and p.floats (low corner, step), from the normalised positions already there.
void build_entry_grid(const WalkMesh& w, bool entry_grid, PreparedNodeCells& p) {
  const uint32_t n = p.entry_count;
  std::vector<std::array<double, 6>> boxes(n);
  std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t i = 0; i < n; ++i) {
    const BoundaryTriangle& b = w.boundary[i];
    const int k = w.type_index(b.cell);
    const CellFace face = cell_info(kAllCellTypes[size_t(k)]).faces[b.local_face];
    const uint32_t* vid = w.cell_vertices(b.cell, k);
    std::array<double, 6>& box = boxes[i];
    box = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int j = 0; j < 3; ++j) {
      const uint32_t v = vid[face.v[b.corners[size_t(j)]]];
      for (size_t a = 0; a < 3; ++a) {
        const double x = p.floats[3 * size_t(v) + a];  // the shader's own (normalised, float) position
        box[a] = std::min(box[a], x - kEntryGridMargin);
        box[a + 3] = std::max(box[a + 3], x + kEntryGridMargin);
      }
    }
    for (size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], box[a]), hi[a] = std::max(hi[a], box[a + 3]);
  }
  if (n == 0) lo = {0, 0, 0}, hi = {1, 1, 1};
  std::array<uint32_t, 3> size{1, 1, 1};
  if (entry_grid && n > 1 && n <= kEntryGridMaxTriangles) {
    // Cubic cells, about n / 2 of them (at most n + 8), at most 64 a side; a flat or long box gets fewer along its
    // short side. Blunt fin at 256² (bench/README.md, "Hybrid entry grid"): triangles tested per frame with n, n / 2,
    // n / 4, n / 8 grid cells: 173K, 206K, 278K, 425K (8.4M without the grid); the nodes' GPU bytes with n / 2:
    // 17.6 MB, with n: 19.9 MB (12.5 MB without the grid).
    constexpr uint32_t kMaxSide = 64;
    double h = std::cbrt((hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) / (0.5 * double(n)));
    for (;;) {
      for (size_t a = 0; a < 3; ++a)
        size[a] = uint32_t(std::clamp(std::ceil((hi[a] - lo[a]) / h), 1.0, double(kMaxSide)));
      if (uint64_t(size[0]) * size[1] * size[2] <= uint64_t(n) + 8) break;
      h *= 1.25;
    }
  }
  p.grid_size = size;
  std::array<float, 3> lo_f{}, step_f{};
  for (size_t a = 0; a < 3; ++a) lo_f[a] = float(lo[a]), step_f[a] = float((hi[a] - lo[a]) / size[a]);
  // Binned with the shader's float box; the margin absorbs the difference to the double box.
  const auto range = [&](const std::array<double, 6>& box, size_t a) {
    const auto at = [&](double x) {
      return uint32_t(std::clamp(std::floor((x - double(lo_f[a])) / double(step_f[a])), 0.0, double(size[a] - 1)));
    };
    return std::array<uint32_t, 2>{at(box[a]), at(box[a + 3])};
  };
  const size_t cells = size_t(size[0]) * size[1] * size[2];
  std::vector<uint32_t> offsets(cells + 1, 0);
  const auto for_cells = [&](const std::array<double, 6>& box, auto&& f) {
    const auto rx = range(box, 0), ry = range(box, 1), rz = range(box, 2);
    for (uint32_t z = rz[0]; z <= rz[1]; ++z)
      for (uint32_t y = ry[0]; y <= ry[1]; ++y)
        for (uint32_t x = rx[0]; x <= rx[1]; ++x) f(x + size_t(size[0]) * (y + size_t(size[1]) * z));
  };
  for (uint32_t i = 0; i < n; ++i) for_cells(boxes[i], [&](size_t c) { ++offsets[c + 1]; });
  for (size_t c = 0; c < cells; ++c) offsets[c + 1] += offsets[c];
  p.grid_begin = uint32_t(p.ints.size());
  p.ints.insert(p.ints.end(), offsets.begin(), offsets.end());
  // One grid cell lists every triangle in order: the shader then takes the index for the triangle, no list is kept.
  if (cells > 1) {
    const size_t list = p.ints.size();
    p.ints.resize(list + (offsets[cells] + 1) / 2, 0u);
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (uint32_t i = 0; i < n; ++i)
      for_cells(boxes[i], [&](size_t c) {
        const uint32_t j = fill[c]++;
        p.ints[list + j / 2] |= i << (16 * (j % 2));
      });
  }
  p.grid_float_begin = uint32_t(p.floats.size());
  p.floats.insert(p.floats.end(), lo_f.begin(), lo_f.end());
  p.floats.insert(p.floats.end(), step_f.begin(), step_f.end());
}

// Field `field`'s values in the walk mesh's order, from `all` (every field's, in the cell block's order: per point, or
// per cell, the cell block's cell c being walk cell order[c]).
std::vector<float> walk_values(const BrickStoreLayout& layout, uint32_t field, std::span<const float> all,
                               uint64_t cells, uint64_t points, std::span<const uint32_t> order) {
  size_t offset = 0;
  for (uint32_t f = 0; f < field; ++f) offset += layout.fields[f].association == Association::Cell ? cells : points;
  if (layout.fields[field].association == Association::Cell) {
    std::vector<float> values(cells, 0.0f);
    for (size_t c = 0; c < order.size(); ++c)
      if (order[c] != kWalkBoundary) values[order[c]] = all[offset + c];
    return values;
  }
  return std::vector<float>(all.begin() + std::ptrdiff_t(offset), all.begin() + std::ptrdiff_t(offset + points));
}

}  // namespace

uint64_t PreparedNodeCells::bytes() const {
  return ints.size() * 4 + floats.size() * 4 + uint64_t(lod_gpu::CELL_NODE_UVEC4S) * 16;
}

std::vector<uint32_t> PreparedNodeCells::grid_cell(uint32_t x, uint32_t y, uint32_t z) const {
  const size_t n = size_t(grid_size[0]) * grid_size[1] * grid_size[2];
  const size_t c = x + size_t(grid_size[0]) * (y + size_t(grid_size[1]) * z), list = grid_begin + n + 1;
  std::vector<uint32_t> out;
  for (uint32_t j = ints[grid_begin + c]; j < ints[grid_begin + c + 1]; ++j)
    out.push_back(n == 1 ? j : (ints[list + j / 2] >> (16 * (j % 2))) & 0xFFFFu);
  return out;
}

PreparedNodeCells prepare_node_cells(const BrickStoreReader& store, uint64_t node, uint32_t field, bool entry_grid) {
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
  if (p.cells != nc.ids.size() || p.points != nc.points.size())
    fail_in(store.path(), "node " + std::to_string(node) + ": the walk mesh's cells or points are not the block's");
  const std::vector<float> values = walk_values(layout, field, nc.values, p.cells, p.points, order);
  p.floats.insert(p.floats.end(), values.begin(), values.end());
  build_entry_grid(w, entry_grid, p);
  return p;
}

void swap_step_values(const BrickStoreReader& store, uint64_t node, uint32_t field, uint32_t step,
                      PreparedNodeCells& p) {
  const std::vector<float> all = store.read_cell_values(node, step);
  const std::span<const uint32_t> order(p.ints.data() + p.order_begin, p.cells);
  const std::vector<float> values = walk_values(store.layout(), field, all, p.cells, p.points, order);
  // The values follow the points' coordinates (the node record's "first value").
  std::copy(values.begin(), values.end(), p.floats.begin() + 3 * std::ptrdiff_t(p.points));
}

uint64_t PreparedSize::bytes() const { return 4 * (ints + floats) + uint64_t(lod_gpu::CELL_NODE_UVEC4S) * 16; }

PreparedSize prepared_size_at_least(const store_format::CellBlockHeader& h) {
  // Every one of these is in PreparedNodeCells: in `ints` the connectivity (a word a vertex reference), a neighbour
  // word a face slot, and per cell its id (two words) and its place in the id order (one word); in `floats` the points'
  // three coordinates. (The values, entry triangles and grid come on top.)
  return {uint64_t(h.vertex_references) + h.face_slots + 3 * uint64_t(h.cell_count), 3 * uint64_t(h.point_count)};
}

CellCache::CellCache(const BrickStoreReader& store, uint64_t budget_bytes) : store_(store), budget_(budget_bytes) {
  const char* grid = std::getenv("UGVR_HYBRID_ENTRY_GRID");
  entry_grid_ = !(grid && std::string_view(grid) == "0");
  GLint64 block = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &block);
  max_block_ = block > 0 ? uint64_t(block) : uint64_t(128) << 20;
  if (const char* cap = std::getenv("UGVR_CELL_BUFFER_MAX_BYTES"); cap && std::strtoull(cap, nullptr, 10) > 0)
    max_block_ = std::min<uint64_t>(max_block_, std::strtoull(cap, nullptr, 10));
}

const PreparedNodeCells& CellCache::get(uint64_t node, uint32_t field, bool& fresh, bool& swapped) {
  auto it = ram_.find(node);
  fresh = it == ram_.end();
  swapped = false;
  const uint32_t step = store_.step();
  if (fresh) {
    const uint64_t bytes = known_size(node).bytes();
    if (ram_bytes_ + bytes > 2 * budget_) drop_from_ram(2 * budget_ > bytes ? 2 * budget_ - bytes : 0);
    it = ram_.emplace(node, Entry{prepare_node_cells(store_, node, field, entry_grid_), 0, step}).first;
    const PreparedNodeCells& p = it->second.cells;
    ram_bytes_ += p.bytes();
    sizes_[node] = {{p.ints.size(), p.floats.size()}, true};
  } else if (it->second.step != step) {
    // Another time step: the same cells (a time store shares them), that step's values.
    swap_step_values(store_, node, field, step, it->second.cells);
    it->second.step = step;
    swapped = true;
  }
  return it->second.cells;
}

PreparedSize CellCache::known_size(uint64_t node) {
  auto it = sizes_.find(node);
  if (it == sizes_.end())
    it = sizes_.emplace(node, KnownSize{prepared_size_at_least(store_.cell_block_header(node))}).first;
  return it->second.size;
}

void CellCache::drop_from_ram(uint64_t limit) {
  if (ram_bytes_ <= limit) return;
  std::vector<std::pair<uint64_t, uint64_t>> by_age;
  for (const auto& [n, e] : ram_)
    if (e.last_used != tick_) by_age.emplace_back(e.last_used, n);
  std::sort(by_age.begin(), by_age.end());
  for (const auto& [age, n] : by_age) {
    if (ram_bytes_ <= limit) break;
    ram_bytes_ -= ram_.at(n).cells.bytes();
    ram_.erase(n);
  }
}

CellCache::Grant CellCache::grant(std::span<const uint64_t> candidates, uint32_t field, uint64_t max_nodes) {
  if (field != field_) {
    ram_.clear();
    ram_bytes_ = 0;
    uploaded_.clear();
    field_ = field;
    // The values' count may differ between fields (per point or per cell): back to the headers' bounds.
    std::erase_if(sizes_, [](const auto& kv) { return kv.second.prepared; });
  }
  if (store_.step() != step_) {
    step_ = store_.step();
    uploaded_.clear();  // the granted nodes' values change: the buffers are rewritten even for the same set
  }
  ++tick_;
  Grant g;
  uint64_t ints = 0, floats = 0, records = 0;
  const uint64_t rec = uint64_t(lod_gpu::CELL_NODE_UVEC4S) * 16;
  // Whether a node of size `s` fits what is left of the budget and of each buffer (the driver's cap on one storage
  // block: llvmpipe's is 128 MiB, below the default budget, so on it the buffers fill before the budget does).
  const auto fits = [&](const PreparedSize& s) {
    return g.bytes + s.bytes() <= budget_ && (ints + s.ints) * 4 <= max_block_ &&
           (floats + s.floats) * 4 <= max_block_ && records + rec <= max_block_;
  };
  for (uint64_t n : candidates) {
    if (g.nodes.size() >= max_nodes) break;
    if (store_.cell_block(n).offset == 0) continue;
    // A node not in RAM is first sized without reading its cells (known_size): one that cannot fit what is left is
    // never read or prepared. A leaf of millions of cells (the wing's, in a 250M-cell store) took minutes and gigabytes
    // to prepare before the budget refused it; and once the buffers were full, every remaining candidate of a 1024²
    // cut (1,533 of them) was prepared and refused in one frame, 5 GB of RAM.
    if (!ram_.count(n) && !fits(known_size(n))) {
      g.budget_full = true;
      continue;
    }
    bool fresh = false, swapped = false;
    const PreparedNodeCells& p = get(n, field, fresh, swapped);
    if (fresh) ++g.prepared;
    if (swapped) ++g.swapped;
    if (!fits({p.ints.size(), p.floats.size()})) {
      g.budget_full = true;
      continue;
    }
    ram_.at(n).last_used = tick_;
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
      node_words.insert(node_words.end(), {ib + p.grid_begin, fb + p.grid_float_begin,
                                           p.grid_size[0] | p.grid_size[1] << 10 | p.grid_size[2] << 20, 0u});
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
  drop_from_ram(2 * budget_);
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
