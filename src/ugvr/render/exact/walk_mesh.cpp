#include "ugvr/render/exact/walk_mesh.h"

#include <tbb/parallel_for.h>

#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/topology.h"

namespace ugvr {
namespace {

int type_index_of(CellType t) {
  for (int k = 0; k < 4; ++k)
    if (kAllCellTypes[k] == t) return k;
  return -1;
}

// The block's cells as an unstructured mesh: the mesh itself, or explicit hexahedra for a structured grid.
struct BlockCells {
  const UnstructuredMesh* unstructured = nullptr;
  std::optional<ExplicitCells> explicit_cells;
  const UnstructuredMesh* mesh() const { return unstructured ? unstructured : &explicit_cells->mesh; }
};

BlockCells block_cells(const Block& block) {
  BlockCells bc;
  if (const auto* m = std::get_if<UnstructuredMesh>(&block.grid))
    bc.unstructured = m;
  else
    bc.explicit_cells = make_explicit_cells(block.grid, StructuredCellShape::Hexahedra);
  return bc;
}

bool position_less(Vec3f a, Vec3f b, uint32_t ia, uint32_t ib) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  if (a.z != b.z) return a.z < b.z;
  return ia < ib;
}

// Appends face f of cell c to the boundary as one or two triangles (quadrilaterals split by quad_split).
void append_boundary_face(WalkMesh& w, uint32_t c, uint32_t f) {
  const int k = w.type_index(c);
  const CellFace face = cell_info(kAllCellTypes[k]).faces[f];
  if (face.size == 3) {
    w.boundary.push_back({c, uint8_t(f), {0, 1, 2}});
  } else if (w.quad_split_13(c, int(f))) {
    w.boundary.push_back({c, uint8_t(f), {0, 1, 3}});
    w.boundary.push_back({c, uint8_t(f), {1, 2, 3}});
  } else {
    w.boundary.push_back({c, uint8_t(f), {0, 1, 2}});
    w.boundary.push_back({c, uint8_t(f), {0, 2, 3}});
  }
}

}  // namespace

uint64_t WalkMesh::memory_bytes() const {
  return points.capacity() * sizeof(Vec3f) + point_base.capacity() * sizeof(uint64_t) +
         connectivity.capacity() * sizeof(uint32_t) + neighbors.capacity() * sizeof(uint32_t) + quad_split.capacity() +
         boundary.capacity() * sizeof(BoundaryTriangle) + block_type_begin.capacity() * sizeof(block_type_begin[0]);
}

WalkMesh build_walk_mesh(const Dataset& dataset) {
  if (dataset.blocks.empty()) fail_in("exact engine", "the dataset has no blocks");
  WalkMesh w;
  const size_t nblocks = dataset.blocks.size();

  // Per block and type counts, then the engine numbering: type-major, block-minor.
  std::vector<BlockCells> cells;
  cells.reserve(nblocks);
  std::vector<CellTypeCounts> counts(nblocks);
  uint64_t total_cells = 0, total_points = 0;
  for (size_t b = 0; b < nblocks; ++b) {
    cells.push_back(block_cells(dataset.blocks[b]));
    counts[b] = cells[b].mesh()->cell_type_counts();
    total_cells += counts[b].total();
    total_points += cells[b].mesh()->point_count();
  }
  if (total_cells == 0) fail_in("exact engine", "the dataset has no volume cells");
  if (total_cells > kMaxWalkCells)
    fail_in("exact engine", std::to_string(total_cells) + " cells exceed the exact engine's limit of " +
                                std::to_string(kMaxWalkCells) +
                                "; render this dataset with the level-of-detail engine");
  if (total_points > ~uint32_t(0)) fail_in("exact engine", "more than 2^32 - 1 vertices");

  w.block_type_begin.assign(nblocks, {});
  uint32_t next = 0;
  for (int k = 0; k < 4; ++k) {
    w.type_begin[k] = next;
    for (size_t b = 0; b < nblocks; ++b) {
      w.block_type_begin[b][k] = next;
      next += uint32_t(counts[b][kAllCellTypes[k]]);
    }
  }
  w.type_begin[4] = next;

  // Points of all blocks, concatenated.
  w.points.reserve(total_points);
  for (size_t b = 0; b < nblocks; ++b) {
    w.point_base.push_back(w.points.size());
    w.points.insert(w.points.end(), cells[b].mesh()->points.begin(), cells[b].mesh()->points.end());
  }
  for (const Vec3f& p : w.points) w.bounds.add(to_double(p));

  // The sorted mesh, with global vertex indices, for the topology build.
  UnstructuredMesh sorted;
  uint64_t indices = 0;
  for (int k = 0; k < 4; ++k) {
    w.conn_begin[k] = indices;
    indices += uint64_t(w.type_begin[k + 1] - w.type_begin[k]) * cell_vertex_count(kAllCellTypes[k]);
  }
  sorted.reserve(total_cells, indices);
  for (int k = 0; k < 4; ++k) {
    for (size_t b = 0; b < nblocks; ++b) {
      const UnstructuredMesh& m = *cells[b].mesh();
      const uint32_t base = uint32_t(w.point_base[b]);
      uint32_t v[8];
      for (uint64_t c = 0; c < m.cell_count(); ++c) {
        if (m.cell_types[c] != kAllCellTypes[k]) continue;
        const auto cv = m.cell(c);
        for (size_t i = 0; i < cv.size(); ++i) v[i] = cv[i] + base;
        sorted.add_cell(kAllCellTypes[k], {v, cv.size()});
      }
    }
  }
  cells.clear();  // explicit structured cells are no longer needed

  sorted.points = std::move(w.points);  // the topology buckets faces by vertex
  MeshTopology topo = build_topology(sorted);
  w.points = std::move(sorted.points);
  uint64_t faces = 0;
  for (int k = 0; k < 4; ++k) {
    w.face_begin[k] = faces;
    faces += uint64_t(w.type_begin[k + 1] - w.type_begin[k]) * cell_face_count(kAllCellTypes[k]);
  }
  w.neighbors.resize(faces);
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, faces, 1 << 16), [&](const tbb::blocked_range<uint64_t>& r) {
    for (uint64_t i = r.begin(); i != r.end(); ++i) {
      const uint64_t n = topo.neighbors[i];
      w.neighbors[i] = n == kNoNeighbor ? kWalkBoundary : uint32_t((face_cell(n) << 3) | face_local(n));
    }
  });
  topo.neighbors = {};
  topo.face_offsets = {};
  w.connectivity = std::move(sorted.connectivity);
  sorted = {};

  // Quadrilateral diagonals.
  const uint32_t non_tets = w.type_begin[4] - w.type_begin[1];
  w.quad_split.assign(non_tets, 0);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(w.type_begin[1], w.type_begin[4], 1 << 14),
                    [&](const tbb::blocked_range<uint32_t>& r) {
                      for (uint32_t c = r.begin(); c != r.end(); ++c) {
                        const int k = w.type_index(c);
                        const CellInfo info = cell_info(kAllCellTypes[k]);
                        const uint32_t* v = w.cell_vertices(c, k);
                        uint8_t bits = 0;
                        for (int f = 0; f < info.face_count; ++f) {
                          if (info.faces[f].size != 4) continue;
                          int smallest = 0;
                          for (int i = 1; i < 4; ++i) {
                            const uint32_t a = v[info.faces[f].v[i]], s = v[info.faces[f].v[smallest]];
                            if (position_less(w.points[a], w.points[s], a, s)) smallest = i;
                          }
                          if (smallest == 1 || smallest == 3) bits |= uint8_t(1u << f);
                        }
                        w.quad_split[c - w.type_begin[1]] = bits;
                      }
                    });

  // Boundary triangles, in cell order.
  w.boundary.reserve(topo.boundary.size() * 2);
  for (uint64_t packed : topo.boundary) {
    append_boundary_face(w, uint32_t(face_cell(packed)), face_local(packed));
  }
  w.boundary.shrink_to_fit();
  return w;
}

WalkMeshPart restrict_walk_mesh(const WalkMesh& m, const Bounds& box) {
  WalkMeshPart part;
  WalkMesh& w = part.mesh;
  const uint32_t n = m.cell_count();
  // Closed overlap of the cell's bounding box with the box (whose faces may be infinite): a cell touching the box
  // is kept, so no point of the box is left uncovered.
  std::vector<uint8_t> keep(n, 0);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1 << 14), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t c = r.begin(); c != r.end(); ++c) {
      const int k = m.type_index(c);
      const uint32_t* v = m.cell_vertices(c, k);
      Bounds cb;
      for (int i = 0; i < cell_vertex_count(kAllCellTypes[k]); ++i) cb.add(to_double(m.points[v[i]]));
      keep[c] = cb.lo.x <= box.hi.x && cb.hi.x >= box.lo.x && cb.lo.y <= box.hi.y && cb.hi.y >= box.lo.y &&
                cb.lo.z <= box.hi.z && cb.hi.z >= box.lo.z;
    }
  });
  std::vector<uint32_t> new_of(n, kWalkBoundary);
  for (int k = 0; k < 4; ++k) {
    w.type_begin[k] = uint32_t(part.cell_source.size());
    for (uint32_t c = m.type_begin[k]; c < m.type_begin[k + 1]; ++c)
      if (keep[c]) new_of[c] = uint32_t(part.cell_source.size()), part.cell_source.push_back(c);
  }
  w.type_begin[4] = uint32_t(part.cell_source.size());
  keep = {};

  // The kept cells' vertices, compacted in their old order.
  std::vector<uint32_t> point_new(m.points.size(), kWalkBoundary);
  for (uint32_t c : part.cell_source) {
    const int k = m.type_index(c);
    const uint32_t* v = m.cell_vertices(c, k);
    for (int i = 0; i < cell_vertex_count(kAllCellTypes[k]); ++i) point_new[v[i]] = 0;
  }
  for (uint32_t p = 0; p < uint32_t(m.points.size()); ++p)
    if (point_new[p] == 0) {
      point_new[p] = uint32_t(part.point_source.size());
      part.point_source.push_back(p);
      w.points.push_back(m.points[p]);
    }

  for (int k = 0; k < 4; ++k) {
    const int nv = cell_vertex_count(kAllCellTypes[k]), nf = cell_face_count(kAllCellTypes[k]);
    w.conn_begin[k] = w.connectivity.size();
    w.face_begin[k] = w.neighbors.size();
    for (uint32_t c = w.type_begin[k]; c < w.type_begin[k + 1]; ++c) {
      const uint32_t old = part.cell_source[c];
      const uint32_t* v = m.cell_vertices(old, k);
      for (int i = 0; i < nv; ++i) w.connectivity.push_back(point_new[v[i]]);
      const uint32_t* nb = m.cell_neighbors(old, k);
      for (int f = 0; f < nf; ++f) {
        const uint32_t across = nb[f] == kWalkBoundary ? kWalkBoundary : new_of[nb[f] >> 3];
        w.neighbors.push_back(across == kWalkBoundary ? kWalkBoundary : (across << 3) | (nb[f] & 7));
      }
      if (k > 0) w.quad_split.push_back(m.quad_split[old - m.type_begin[1]]);
    }
  }
  // The part's boundary: the mesh's own faces and the faces where it was cut.
  for (int k = 0; k < 4; ++k)
    for (uint32_t c = w.type_begin[k]; c < w.type_begin[k + 1]; ++c) {
      const uint32_t* nb = w.cell_neighbors(c, k);
      for (int f = 0; f < cell_face_count(kAllCellTypes[k]); ++f)
        if (nb[f] == kWalkBoundary) append_boundary_face(w, c, uint32_t(f));
    }
  // Grown by push_back: give back the slack (the part's memory is what a rank holds).
  w.points.shrink_to_fit(), w.connectivity.shrink_to_fit(), w.neighbors.shrink_to_fit();
  w.quad_split.shrink_to_fit(), w.boundary.shrink_to_fit();
  part.cell_source.shrink_to_fit(), part.point_source.shrink_to_fit();
  w.point_base = m.point_base;
  w.block_type_begin = m.block_type_begin;
  w.bounds = m.bounds;
  return part;
}

std::vector<uint32_t> block_cell_order(const Dataset& dataset, const WalkMesh& mesh, size_t block) {
  const Block& b = dataset.blocks.at(block);
  std::array<uint32_t, 4> next = mesh.block_type_begin.at(block);
  if (const auto* m = std::get_if<UnstructuredMesh>(&b.grid)) {
    std::vector<uint32_t> order(m->cell_count());
    for (uint64_t c = 0; c < m->cell_count(); ++c) order[c] = next[type_index_of(m->cell_types[c])]++;
    return order;
  }
  const ExplicitCells ec = make_explicit_cells(b.grid, StructuredCellShape::Hexahedra);
  std::vector<uint32_t> order(grid_cell_count(b.grid), kWalkBoundary);
  for (uint64_t c = 0; c < ec.source_cell.size(); ++c) order[ec.source_cell[c]] = next[3]++;
  return order;
}

}  // namespace ugvr
