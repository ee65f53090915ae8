#include "ugvr/octree/cell_box_overlap.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "ugvr/grid/cell_interpolation.h"

namespace ugvr {
namespace {

// The edges of a cell type and the diagonals of its quadrilateral faces, as vertex pairs, derived from cell_info's
// faces so they cannot disagree with them.
struct EdgeTable {
  std::array<std::array<uint8_t, 2>, 24> e{};
  int edges = 0;      // e[0 .. edges): the cell's edges
  int diagonals = 0;  // e[edges .. edges + diagonals): quad diagonals
};

constexpr EdgeTable make_edge_table(CellType t) {
  EdgeTable table;
  const CellInfo info = cell_info(t);
  auto has = [&](uint8_t a, uint8_t b) {
    for (int i = 0; i < table.edges; ++i) {
      const auto& p = table.e[size_t(i)];
      if ((p[0] == a && p[1] == b) || (p[0] == b && p[1] == a)) return true;
    }
    return false;
  };
  for (int f = 0; f < info.face_count; ++f) {
    const CellFace& face = info.faces[size_t(f)];
    for (int i = 0; i < face.size; ++i) {
      const uint8_t a = face.v[size_t(i)], b = face.v[size_t((i + 1) % face.size)];
      if (!has(a, b)) table.e[size_t(table.edges++)] = {a, b};
    }
  }
  int n = table.edges;
  for (int f = 0; f < info.face_count; ++f) {
    const CellFace& face = info.faces[size_t(f)];
    if (face.size != 4) continue;
    table.e[size_t(n++)] = {face.v[0], face.v[2]};
    table.e[size_t(n++)] = {face.v[1], face.v[3]};
  }
  table.diagonals = n - table.edges;
  return table;
}

constexpr std::array<EdgeTable, 4> kEdgeTables = {make_edge_table(CellType::Tetra), make_edge_table(CellType::Pyramid),
                                                  make_edge_table(CellType::Wedge),
                                                  make_edge_table(CellType::Hexahedron)};
static_assert(kEdgeTables[0].edges == 6 && kEdgeTables[0].diagonals == 0);
static_assert(kEdgeTables[3].edges == 12 && kEdgeTables[3].diagonals == 12);

const EdgeTable& edge_table(CellType t) {
  switch (t) {
    case CellType::Tetra: return kEdgeTables[0];
    case CellType::Pyramid: return kEdgeTables[1];
    case CellType::Wedge: return kEdgeTables[2];
    case CellType::Hexahedron: break;
  }
  return kEdgeTables[3];
}

}  // namespace

std::span<const std::array<uint8_t, 2>> cell_edges(CellType type) {
  const EdgeTable& t = edge_table(type);
  return std::span<const std::array<uint8_t, 2>>(t.e.data(), size_t(t.edges));
}

bool cell_box_overlap(CellType type, const Vec3d* vertices, const Bounds& box, OverlapAxes axes) {
  const int n = cell_vertex_count(type);
  // Work relative to the box centre: the box is then [-h, h] and projections lose no digits to a far origin.
  const Vec3d c = box.center();
  const Vec3d h = (box.hi - box.lo) * 0.5;
  Vec3d p[kMaxCellVertices];
  Vec3d lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (int i = 0; i < n; ++i) {
    p[i] = vertices[i] - c;
    lo = {std::min(lo.x, p[i].x), std::min(lo.y, p[i].y), std::min(lo.z, p[i].z)};
    hi = {std::max(hi.x, p[i].x), std::max(hi.y, p[i].y), std::max(hi.z, p[i].z)};
  }
  // The 3 box normals: the bounding boxes must overlap.
  if (lo.x > h.x || lo.y > h.y || lo.z > h.z || hi.x < -h.x || hi.y < -h.y || hi.z < -h.z) return false;
  if (axes == OverlapAxes::BoxNormals) return true;
  // Cheap certain overlaps: a vertex inside the box.
  for (int i = 0; i < n; ++i) {
    if (std::abs(p[i].x) <= h.x && std::abs(p[i].y) <= h.y && std::abs(p[i].z) <= h.z) return true;
  }
  auto separates = [&](Vec3d a) {
    const double r = h.x * std::abs(a.x) + h.y * std::abs(a.y) + h.z * std::abs(a.z);
    double mn = dot(p[0], a), mx = mn;
    for (int i = 1; i < n; ++i) {
      const double d = dot(p[i], a);
      mn = std::min(mn, d), mx = std::max(mx, d);
    }
    return mn > r || mx < -r;
  };
  // Face normals (both triangulations of a quadrilateral).
  const CellInfo info = cell_info(type);
  for (int f = 0; f < info.face_count; ++f) {
    const CellFace& face = info.faces[size_t(f)];
    const Vec3d& a = p[face.v[0]];
    const Vec3d& b = p[face.v[1]];
    const Vec3d& d2 = p[face.v[2]];
    if (separates(cross(b - a, d2 - a))) return false;
    if (face.size == 4 && axes == OverlapAxes::Exact) {
      const Vec3d& d3 = p[face.v[3]];
      if (separates(cross(d2 - a, d3 - a))) return false;
      if (separates(cross(d2 - b, d3 - b))) return false;
      if (separates(cross(d3 - b, a - b))) return false;
    }
  }
  if (axes == OverlapAxes::FaceNormals) return true;
  // Cell edges (and quad diagonals) crossed with the box axes: e x X = (0, e.z, -e.y), and so on.
  const EdgeTable& edges = edge_table(type);
  for (int i = 0; i < edges.edges + edges.diagonals; ++i) {
    const Vec3d e = p[edges.e[size_t(i)][1]] - p[edges.e[size_t(i)][0]];
    if (separates({0, e.z, -e.y}) || separates({-e.z, 0, e.x}) || separates({e.y, -e.x, 0})) return false;
  }
  return true;
}

BoxCellLists cells_overlapping_boxes(const UnstructuredMesh& mesh, const Bounds& region, std::array<uint32_t, 3> dims,
                                     std::span<const uint64_t> cells) {
  BoxCellLists out;
  out.dims = dims;
  const uint64_t box_count = uint64_t(dims[0]) * dims[1] * dims[2];
  out.offsets.assign(box_count + 1, 0);
  const uint64_t count = cells.empty() ? mesh.cell_count() : cells.size();
  if (box_count == 0 || count == 0 || region.empty()) return out;
  const Vec3d size = region.size();
  auto box_lo = [&](int axis, uint32_t i) { return region.lo[axis] + size[axis] * (double(i) / double(dims[axis])); };

  // Fixed chunks, each filled by one task and concatenated in order: the result does not depend on the schedule.
  constexpr uint64_t kChunk = 4096;
  const uint64_t chunks = (count + kChunk - 1) / kChunk;
  std::vector<std::vector<std::pair<uint64_t, uint64_t>>> hits(chunks);  // (box, cell)
  tbb::parallel_for(uint64_t(0), chunks, [&](uint64_t chunk) {
    auto& mine = hits[chunk];
    Vec3d v[kMaxCellVertices];
    for (uint64_t k = chunk * kChunk; k < std::min(count, (chunk + 1) * kChunk); ++k) {
      const uint64_t cell = cells.empty() ? k : cells[k];
      const int n = gather_cell_vertices(mesh, cell, v);
      Bounds bb;
      for (int i = 0; i < n; ++i) bb.add(v[i]);
      const double margin = kOverlapMargin * length(bb.size());
      std::array<uint32_t, 3> first{}, last{};
      bool outside = false;
      for (int a = 0; a < 3; ++a) {
        const double cell_size = size[a] / double(dims[a]);
        // Twice the margin: the division rounds differently from the box bounds below, which decide.
        const double f0 = std::floor((bb.lo[a] - 2 * margin - region.lo[a]) / cell_size);
        const double f1 = std::floor((bb.hi[a] + 2 * margin - region.lo[a]) / cell_size);
        if (f1 < 0 || f0 > double(dims[a])) outside = true;
        first[size_t(a)] = uint32_t(std::clamp(f0, 0.0, double(dims[a] - 1)));
        last[size_t(a)] = uint32_t(std::clamp(f1, 0.0, double(dims[a] - 1)));
      }
      if (outside) continue;
      const CellType type = mesh.cell_types[cell];
      for (uint32_t z = first[2]; z <= last[2]; ++z)
        for (uint32_t y = first[1]; y <= last[1]; ++y)
          for (uint32_t x = first[0]; x <= last[0]; ++x) {
            Bounds b;
            b.lo = {box_lo(0, x), box_lo(1, y), box_lo(2, z)};
            b.hi = {box_lo(0, x + 1), box_lo(1, y + 1), box_lo(2, z + 1)};
            if (cell_box_overlap(type, v, expanded(b, margin))) {
              mine.push_back({x + uint64_t(dims[0]) * (y + uint64_t(dims[1]) * z), cell});
            }
          }
    }
  });
  // Counting sort by box, stable: each box lists its cells in input order.
  for (const auto& chunk : hits)
    for (const auto& [b, cell] : chunk) ++out.offsets[b + 1];
  for (uint64_t b = 0; b < box_count; ++b) out.offsets[b + 1] += out.offsets[b];
  out.cells.resize(out.offsets[box_count]);
  std::vector<uint64_t> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (const auto& chunk : hits)
    for (const auto& [b, cell] : chunk) out.cells[fill[b]++] = cell;
  return out;
}

}  // namespace ugvr
