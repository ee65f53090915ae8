#include "ugvr/grid/structured_cells.h"

#include <array>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

// Corner c (bit 0 = +i, bit 1 = +j, bit 2 = +k) of the cell whose lowest point is p0.
struct CellCorners {
  std::array<uint32_t, 8> id;
};

CellCorners corners(const GridDims& d, uint64_t i, uint64_t j, uint64_t k) {
  CellCorners c;
  for (int b = 0; b < 8; ++b)
    c.id[size_t(b)] = uint32_t(d.point_index(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)));
  return c;
}

// The 6 Kuhn tets: each is the path 0 -> e_a -> e_a+e_b -> 7 for a permutation (a, b, c) of the axes. They share the
// diagonal 0-7, around which the other corners form a ring, each one axis step from the next (1, 3, 2, 6, 4, 5); tet m
// joins the diagonal to ring corners m and m + 1, which in the ring's order gives every tet positive orientation in
// VTK's convention (vertices 0,1,2 counter-clockwise seen from vertex 3).
constexpr std::array<std::array<uint8_t, 4>, 6> kSixTets = [] {
  constexpr std::array<uint8_t, 6> ring = {1, 3, 2, 6, 4, 5};
  std::array<std::array<uint8_t, 4>, 6> tets{};
  for (size_t m = 0; m < ring.size(); ++m) tets[m] = {0, ring[m], ring[(m + 1) % ring.size()], 7};
  return tets;
}();
// Five-tet split, even parity: corner tets at 0, 3, 5, 6 around the central tet (1, 2, 4, 7).
constexpr std::array<std::array<uint8_t, 4>, 5> kFiveTetsEven = {{
    {0, 1, 2, 4},
    {3, 2, 1, 7},
    {5, 4, 7, 1},
    {6, 7, 4, 2},
    {1, 2, 4, 7},
}};
// Odd parity mirrors it across the plane i = 1/2 (corner bit 0 flipped), so that neighbouring cells cut their shared
// face along the same diagonal; the mirror reverses orientation, which swapping the last two vertices restores.
constexpr std::array<std::array<uint8_t, 4>, 5> mirrored_in_i(const std::array<std::array<uint8_t, 4>, 5>& tets) {
  std::array<std::array<uint8_t, 4>, 5> out{};
  for (size_t t = 0; t < tets.size(); ++t) {
    const auto& v = tets[t];
    out[t] = {uint8_t(v[0] ^ 1), uint8_t(v[1] ^ 1), uint8_t(v[3] ^ 1), uint8_t(v[2] ^ 1)};
  }
  return out;
}
constexpr std::array<std::array<uint8_t, 4>, 5> kFiveTetsOdd = mirrored_in_i(kFiveTetsEven);
static_assert(kFiveTetsOdd[0] == std::array<uint8_t, 4>{1, 0, 5, 3} &&
              kFiveTetsOdd[4] == std::array<uint8_t, 4>{0, 3, 6, 5});
// Hexahedron in VTK order from the corner bits.
constexpr std::array<uint8_t, 8> kHexOrder = {0, 1, 3, 2, 4, 5, 7, 6};

const std::vector<int32_t>* iblank_of(const Grid& g) {
  if (const auto* s = std::get_if<StructuredGrid>(&g); s && s->has_iblank()) return &s->iblank;
  return nullptr;
}

template <class PointAt>
std::vector<Vec3f> collect_points(const GridDims& d, PointAt at) {
  std::vector<Vec3f> pts;
  pts.reserve(d.point_count());
  for (uint64_t k = 0; k < d.points[2]; ++k)
    for (uint64_t j = 0; j < d.points[1]; ++j)
      for (uint64_t i = 0; i < d.points[0]; ++i) {
        const Vec3d p = at(i, j, k);
        pts.push_back({float(p.x), float(p.y), float(p.z)});
      }
  return pts;
}

}  // namespace

ExplicitCells make_explicit_cells(const Grid& grid, StructuredCellShape shape) {
  ExplicitCells out;
  GridDims d;
  if (const auto* s = std::get_if<StructuredGrid>(&grid)) {
    d = s->dims;
    out.mesh.points = s->points;
  } else if (const auto* im = std::get_if<ImageGrid>(&grid)) {
    d = im->dims;
    out.mesh.points = collect_points(d, [&](uint64_t i, uint64_t j, uint64_t k) { return im->point(i, j, k); });
  } else if (const auto* r = std::get_if<RectilinearGrid>(&grid)) {
    d = r->dims;
    out.mesh.points = collect_points(d, [&](uint64_t i, uint64_t j, uint64_t k) { return r->point(i, j, k); });
  } else {
    throw Error("make_explicit_cells: the grid is already unstructured");
  }
  if (d.point_count() > uint64_t(UINT32_MAX)) throw Error("structured grid has more than 2^32-1 points");

  const std::vector<int32_t>* blank = iblank_of(grid);
  const auto c = d.cells();
  const uint64_t per_cell =
      shape == StructuredCellShape::Hexahedra ? 1 : (shape == StructuredCellShape::FiveTetrahedra ? 5 : 6);
  out.mesh.reserve(d.cell_count() * per_cell,
                   d.cell_count() * (shape == StructuredCellShape::Hexahedra ? 8 : 4 * per_cell));
  out.source_cell.reserve(d.cell_count() * per_cell);

  std::array<uint32_t, 8> v{};
  for (uint64_t k = 0; k < c[2]; ++k) {
    for (uint64_t j = 0; j < c[1]; ++j) {
      for (uint64_t i = 0; i < c[0]; ++i) {
        const CellCorners cc = corners(d, i, j, k);
        if (blank) {
          bool blanked = false;
          for (uint32_t p : cc.id) blanked |= (*blank)[p] == 0;
          if (blanked) continue;
        }
        const uint64_t cell = d.cell_index(i, j, k);
        auto emit_tets = [&](const auto& tets) {
          for (const auto& t : tets) {
            for (int q = 0; q < 4; ++q) v[size_t(q)] = cc.id[t[size_t(q)]];
            out.mesh.add_cell(CellType::Tetra, std::span<const uint32_t>(v.data(), 4));
            out.source_cell.push_back(cell);
          }
        };
        switch (shape) {
          case StructuredCellShape::Hexahedra:
            for (int q = 0; q < 8; ++q) v[size_t(q)] = cc.id[kHexOrder[size_t(q)]];
            out.mesh.add_cell(CellType::Hexahedron, v);
            out.source_cell.push_back(cell);
            break;
          case StructuredCellShape::FiveTetrahedra:
            if ((i + j + k) % 2 == 0)
              emit_tets(kFiveTetsEven);
            else
              emit_tets(kFiveTetsOdd);
            break;
          case StructuredCellShape::SixTetrahedra: emit_tets(kSixTets); break;
        }
      }
    }
  }
  return out;
}

Block to_unstructured_block(const Block& block, StructuredCellShape shape) {
  if (std::holds_alternative<UnstructuredMesh>(block.grid)) return block;
  ExplicitCells cells = make_explicit_cells(block.grid, shape);
  Block out{block.name, std::move(cells.mesh), {}};
  for (const Field& f : block.fields) {
    if (f.association() == Association::Vertex)
      out.fields.add(f);
    else
      out.fields.add(Field(f.name(), Association::Cell, f.data().gather(cells.source_cell)));
  }
  if (const auto* blank = iblank_of(block.grid)) {
    out.fields.add(Field("IBLANK", Association::Vertex, DataArray::from(*blank, 1)));
  }
  return out;
}

}  // namespace ugvr
