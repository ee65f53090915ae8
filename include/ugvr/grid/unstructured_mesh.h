// UnstructuredMesh: mixed volume cells (tetra, pyramid, wedge, hexahedron) over float32 vertex positions.
//
// Layout (compressed sparse rows, like vtkCellArray):
//   points        N x Vec3f                      vertex positions, 12 bytes each
//   cell_types    C x CellType (uint8)           VTK type id per cell
//   cell_offsets  (C+1) x uint64                 cell c uses connectivity[cell_offsets[c] .. cell_offsets[c+1])
//   connectivity  cell_offsets[C] x uint32       vertex indices in VTK's vertex order for the cell type
// Offsets are 64-bit so a mesh may hold more than 2^31 (or 2^32) indices in total. Vertex indices are 32-bit: an
// in-memory mesh is capped at 2^32-1 vertices (48 GiB of positions); readers refuse larger ones with a clear message.
// Fields live beside the mesh in a Block, never inside it (values and geometry are separate).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"

namespace ugvr {

struct CellTypeCounts {
  uint64_t tetra = 0, pyramid = 0, wedge = 0, hexahedron = 0;
  uint64_t& operator[](CellType t);
  uint64_t operator[](CellType t) const;
  uint64_t total() const { return tetra + pyramid + wedge + hexahedron; }
};

struct UnstructuredMesh {
  std::vector<Vec3f> points;
  std::vector<CellType> cell_types;
  std::vector<uint64_t> cell_offsets{0};
  std::vector<uint32_t> connectivity;

  uint64_t point_count() const { return points.size(); }
  uint64_t cell_count() const { return cell_types.size(); }
  std::span<const uint32_t> cell(uint64_t c) const {
    return {connectivity.data() + cell_offsets[c], size_t(cell_offsets[c + 1] - cell_offsets[c])};
  }
  void add_cell(CellType type, std::span<const uint32_t> vertices);
  // Pre-sizes for `cells` cells of `indices` connectivity entries in total.
  void reserve(uint64_t cells, uint64_t indices);

  CellTypeCounts cell_type_counts() const;
  Bounds bounds() const;
  // Bytes held by the arrays (capacity, not size: what the process actually pays).
  uint64_t memory_bytes() const;
  // Checks the invariants above (offsets monotone and sized per type, indices < point_count); throws ugvr::Error
  // naming `source` and the first offending cell.
  void validate(std::string_view source) const;
  bool operator==(const UnstructuredMesh&) const = default;
};

// Signed volume of a cell from its faces (divergence theorem; a non-planar quadrilateral counts as the surface
// spanned by its two triangle fans' average). Positive for a cell in VTK's orientation, negative when inverted.
double cell_volume(const UnstructuredMesh& mesh, uint64_t cell);
// Cells of negative volume (computed in parallel).
uint64_t count_inverted_cells(const UnstructuredMesh& mesh);
// For formats whose tetrahedron orientation convention varies between writers (TetGen, OFF): when most tetrahedra
// are inverted, swaps vertices 1 and 2 of every one and sets `flipped`. Returns the tetrahedra still inverted.
uint64_t orient_tetrahedra_by_majority(UnstructuredMesh& mesh, bool& flipped);

}  // namespace ugvr
