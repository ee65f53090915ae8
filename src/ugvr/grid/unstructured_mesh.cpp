#include "ugvr/grid/unstructured_mesh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <string>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_volume.h"

namespace ugvr {

uint64_t& CellTypeCounts::operator[](CellType t) {
  switch (t) {
    case CellType::Tetra: return tetra;
    case CellType::Pyramid: return pyramid;
    case CellType::Wedge: return wedge;
    case CellType::Hexahedron: return hexahedron;
  }
  return tetra;
}

uint64_t CellTypeCounts::operator[](CellType t) const { return const_cast<CellTypeCounts&>(*this)[t]; }

void UnstructuredMesh::add_cell(CellType type, std::span<const uint32_t> vertices) {
  cell_types.push_back(type);
  connectivity.insert(connectivity.end(), vertices.begin(), vertices.end());
  cell_offsets.push_back(connectivity.size());
}

void UnstructuredMesh::reserve(uint64_t cells, uint64_t indices) {
  cell_types.reserve(cells);
  cell_offsets.reserve(cells + 1);
  connectivity.reserve(indices);
}

CellTypeCounts UnstructuredMesh::cell_type_counts() const {
  CellTypeCounts counts;
  for (CellType t : cell_types) ++counts[t];
  return counts;
}

Bounds UnstructuredMesh::bounds() const {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, points.size(), 1 << 16), Bounds{},
      [&](const tbb::blocked_range<size_t>& r, Bounds b) {
        for (size_t i = r.begin(); i != r.end(); ++i) b.add(to_double(points[i]));
        return b;
      },
      [](Bounds a, const Bounds& b) {
        a.add(b);
        return a;
      });
}

uint64_t UnstructuredMesh::memory_bytes() const {
  return points.capacity() * sizeof(Vec3f) + cell_types.capacity() * sizeof(CellType) +
         cell_offsets.capacity() * sizeof(uint64_t) + connectivity.capacity() * sizeof(uint32_t);
}

double cell_volume(CellType type, std::span<const Vec3d> corners) {
  const CellInfo info = cell_info(type);
  // Relative to the first vertex to keep the rounding small for cells far from the origin.
  const Vec3d o = corners[0];
  double six_volume = 0;
  for (uint32_t f = 0; f < info.face_count; ++f) {
    const CellFace& face = info.faces[f];
    Vec3d area2{}, centroid{};
    for (uint32_t i = 0; i < face.size; ++i) {
      const Vec3d a = corners[face.v[i]] - o;
      const Vec3d b = corners[face.v[(i + 1) % face.size]] - o;
      area2 = area2 + cross(a, b);
      centroid = centroid + a * (1.0 / face.size);
    }
    six_volume += dot(centroid, area2);
  }
  return six_volume / 6.0;
}

double cell_volume(const UnstructuredMesh& mesh, uint64_t cell) {
  const auto v = mesh.cell(cell);
  std::array<Vec3d, 8> corners;
  for (size_t i = 0; i < v.size() && i < corners.size(); ++i) corners[i] = to_double(mesh.points[v[i]]);
  return cell_volume(mesh.cell_types[cell], std::span<const Vec3d>(corners.data(), v.size()));
}

uint64_t count_inverted_cells(const UnstructuredMesh& mesh) {
  return tbb::parallel_reduce(
      tbb::blocked_range<uint64_t>(0, mesh.cell_count(), 1 << 14), uint64_t(0),
      [&](const tbb::blocked_range<uint64_t>& r, uint64_t n) {
        for (uint64_t c = r.begin(); c != r.end(); ++c) n += cell_volume(mesh, c) < 0;
        return n;
      },
      [](uint64_t a, uint64_t b) { return a + b; });
}

uint64_t orient_tetrahedra_by_majority(UnstructuredMesh& mesh, bool& flipped) {
  const uint64_t negative = count_inverted_cells(mesh);
  flipped = negative * 2 > mesh.cell_count();
  if (!flipped) return negative;
  for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
    if (mesh.cell_types[c] == CellType::Tetra) {
      std::swap(mesh.connectivity[mesh.cell_offsets[c] + 1], mesh.connectivity[mesh.cell_offsets[c] + 2]);
    }
  }
  return count_inverted_cells(mesh);
}

void UnstructuredMesh::validate(std::string_view source) const {
  if (cell_offsets.size() != cell_types.size() + 1 || cell_offsets.front() != 0 ||
      cell_offsets.back() != connectivity.size()) {
    fail_in(source, "inconsistent cell arrays: " + std::to_string(cell_types.size()) + " cells, " +
                        std::to_string(cell_offsets.size()) + " offsets, " + std::to_string(connectivity.size()) +
                        " indices");
  }
  const uint64_t n = points.size();
  for (uint64_t c = 0; c < cell_types.size(); ++c) {
    const uint8_t id = uint8_t(cell_types[c]);
    if (!is_valid_cell_type(id))
      fail_in(source, "cell " + std::to_string(c) + " has invalid type " + std::to_string(id));
    if (cell_offsets[c + 1] < cell_offsets[c] ||
        cell_offsets[c + 1] - cell_offsets[c] != cell_vertex_count(cell_types[c])) {
      fail_in(source, "cell " + std::to_string(c) + " (" + std::string(cell_name(cell_types[c])) + ") has " +
                          std::to_string(int64_t(cell_offsets[c + 1] - cell_offsets[c])) + " vertices, expected " +
                          std::to_string(cell_vertex_count(cell_types[c])));
    }
    for (uint32_t v : cell(c)) {
      if (v >= n) {
        fail_in(source, "cell " + std::to_string(c) + " refers to vertex " + std::to_string(v) + " but there are " +
                            std::to_string(n) + " vertices");
      }
    }
  }
}

}  // namespace ugvr
