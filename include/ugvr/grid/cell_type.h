// Volume cell types and their vertex and face ordering. Ids and orderings are VTK's (vtkCellType.h and
// vtkTetra/vtkHexahedron/vtkWedge/vtkPyramid::GetFaceArray), so connectivity is copied from VTK files unchanged and
// faces list their vertices counter-clockwise seen from outside the cell (outward normals, right-hand rule).
//
/*   Tetra (10)         Hexahedron (12)          Wedge (13)             Pyramid (14)
        3               7-------6                 5                      4
       /|\             /|      /|                /|\                   //|\
      / | \           4-------5 |               3-+-4                 // | \
     0--|--2          | 3-----|-2               | 2 |               3-/--+--2
      \ | /           |/      |/                |/ \|              /  /   /
        1             0-------1                 0---1             0-------1          */
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace ugvr {

enum class CellType : uint8_t {
  Tetra = 10,
  Hexahedron = 12,
  Wedge = 13,
  Pyramid = 14,
};

inline constexpr std::array<CellType, 4> kAllCellTypes = {CellType::Tetra, CellType::Pyramid, CellType::Wedge,
                                                          CellType::Hexahedron};

// A face: up to 4 vertex positions (local indices into the cell); size is 3 or 4.
struct CellFace {
  uint8_t size;
  std::array<uint8_t, 4> v;
};

struct CellInfo {
  std::string_view name;
  uint8_t vertex_count;
  uint8_t face_count;
  std::array<CellFace, 6> faces;
};

constexpr CellInfo cell_info(CellType t) {
  switch (t) {
    case CellType::Tetra: return {"tetra", 4, 4, {{{3, {0, 1, 3}}, {3, {1, 2, 3}}, {3, {2, 0, 3}}, {3, {0, 2, 1}}}}};
    case CellType::Hexahedron:
      return {"hexahedron",
              8,
              6,
              {{{4, {0, 4, 7, 3}},
                {4, {1, 2, 6, 5}},
                {4, {0, 1, 5, 4}},
                {4, {3, 7, 6, 2}},
                {4, {0, 3, 2, 1}},
                {4, {4, 5, 6, 7}}}}};
    case CellType::Wedge:
      return {
          "wedge", 6, 5, {{{3, {0, 1, 2}}, {3, {3, 5, 4}}, {4, {0, 3, 4, 1}}, {4, {1, 4, 5, 2}}, {4, {2, 5, 3, 0}}}}};
    case CellType::Pyramid:
      return {"pyramid", 5, 5, {{{4, {0, 3, 2, 1}}, {3, {0, 1, 4}}, {3, {1, 2, 4}}, {3, {2, 3, 4}}, {3, {3, 0, 4}}}}};
  }
  return {"invalid", 0, 0, {}};
}

constexpr uint8_t cell_vertex_count(CellType t) { return cell_info(t).vertex_count; }
constexpr uint8_t cell_face_count(CellType t) { return cell_info(t).face_count; }
constexpr std::string_view cell_name(CellType t) { return cell_info(t).name; }
constexpr bool is_valid_cell_type(uint8_t id) { return id == 10 || id == 12 || id == 13 || id == 14; }

// How a VTK cell type id found in a file is brought into the model.
//  - Keep: a linear volume cell, or a quadratic / higher-order one linearised to its corner vertices (the first
//    `corner_count` of its point list, which VTK orders corners first). Subdividing instead would multiply the cell
//    count and invent a piecewise-linear field that was never in the data; renderers interpolate the corner values.
//    VTK_VOXEL is kept as a hexahedron with its vertices reordered.
//  - DropLowerDimension: vertices, lines, polygons (0-D..2-D cells). Ignored with a warning when the file also has
//    volume cells; a file with no volume cells at all is an error.
//  - Unsupported: polyhedra, pentagonal/hexagonal prisms, Lagrange/Bezier cells, unknown ids: an error.
struct VtkCellMapping {
  enum class Kind : uint8_t { Keep, DropLowerDimension, Unsupported } kind;
  CellType type{};               // for Keep
  uint8_t corner_count = 0;      // for Keep
  int16_t expected_points = -1;  // points the file must list for this cell, -1 = variable
  bool voxel_order = false;      // VTK_VOXEL: corners 2<->3 and 6<->7 swapped relative to a hexahedron
  std::string_view vtk_name;
};

VtkCellMapping map_vtk_cell_type(int vtk_type);

}  // namespace ugvr
