#include "ugvr/grid/cell_type.h"

#include <array>

namespace ugvr {

namespace {

VtkCellMapping compute_mapping(int vtk_type) {
  using K = VtkCellMapping::Kind;
  auto keep = [](CellType t, int corners, int points, std::string_view name, bool voxel = false) {
    return VtkCellMapping{K::Keep, t, uint8_t(corners), int16_t(points), voxel, name};
  };
  auto drop = [](int points, std::string_view name) {
    return VtkCellMapping{K::DropLowerDimension, {}, 0, int16_t(points), false, name};
  };
  auto unsupported = [](std::string_view name) { return VtkCellMapping{K::Unsupported, {}, 0, -1, false, name}; };
  switch (vtk_type) {
    case 1: return drop(1, "VTK_VERTEX");
    case 2: return drop(-1, "VTK_POLY_VERTEX");
    case 3: return drop(2, "VTK_LINE");
    case 4: return drop(-1, "VTK_POLY_LINE");
    case 5: return drop(3, "VTK_TRIANGLE");
    case 6: return drop(-1, "VTK_TRIANGLE_STRIP");
    case 7: return drop(-1, "VTK_POLYGON");
    case 8: return drop(4, "VTK_PIXEL");
    case 9: return drop(4, "VTK_QUAD");
    case 10: return keep(CellType::Tetra, 4, 4, "VTK_TETRA");
    case 11: return keep(CellType::Hexahedron, 8, 8, "VTK_VOXEL", true);
    case 12: return keep(CellType::Hexahedron, 8, 8, "VTK_HEXAHEDRON");
    case 13: return keep(CellType::Wedge, 6, 6, "VTK_WEDGE");
    case 14: return keep(CellType::Pyramid, 5, 5, "VTK_PYRAMID");
    case 15: return unsupported("VTK_PENTAGONAL_PRISM");
    case 16: return unsupported("VTK_HEXAGONAL_PRISM");
    case 21: return drop(3, "VTK_QUADRATIC_EDGE");
    case 22: return drop(6, "VTK_QUADRATIC_TRIANGLE");
    case 23: return drop(8, "VTK_QUADRATIC_QUAD");
    case 24: return keep(CellType::Tetra, 4, 10, "VTK_QUADRATIC_TETRA");
    case 25: return keep(CellType::Hexahedron, 8, 20, "VTK_QUADRATIC_HEXAHEDRON");
    case 26: return keep(CellType::Wedge, 6, 15, "VTK_QUADRATIC_WEDGE");
    case 27: return keep(CellType::Pyramid, 5, 13, "VTK_QUADRATIC_PYRAMID");
    case 28: return drop(9, "VTK_BIQUADRATIC_QUAD");
    case 29: return keep(CellType::Hexahedron, 8, 27, "VTK_TRIQUADRATIC_HEXAHEDRON");
    case 30: return drop(8, "VTK_QUADRATIC_LINEAR_QUAD");
    case 31: return keep(CellType::Wedge, 6, 12, "VTK_QUADRATIC_LINEAR_WEDGE");
    case 32: return keep(CellType::Wedge, 6, 18, "VTK_BIQUADRATIC_QUADRATIC_WEDGE");
    case 33: return keep(CellType::Hexahedron, 8, 24, "VTK_BIQUADRATIC_QUADRATIC_HEXAHEDRON");
    case 34: return drop(7, "VTK_BIQUADRATIC_TRIANGLE");
    case 35: return drop(4, "VTK_CUBIC_LINE");
    case 36: return drop(-1, "VTK_QUADRATIC_POLYGON");
    case 37: return keep(CellType::Pyramid, 5, 19, "VTK_TRIQUADRATIC_PYRAMID");
    case 41: return unsupported("VTK_CONVEX_POINT_SET");
    case 42: return unsupported("VTK_POLYHEDRON");
    default: break;
  }
  // The arbitrary-order families, Lagrange (68..74) then Bezier (75..81), list the same shapes in the same order:
  // their curves and surfaces are dropped like the other lower-dimensional cells, their volumes are not supported.
  constexpr int kFirstHighOrder = 68, kHighOrderShapes = 7;
  constexpr std::array<std::string_view, 2 * kHighOrderShapes> kHighOrderNames = {
      "VTK_LAGRANGE_CURVE",      "VTK_LAGRANGE_TRIANGLE",    "VTK_LAGRANGE_QUADRILATERAL", "VTK_LAGRANGE_TETRAHEDRON",
      "VTK_LAGRANGE_HEXAHEDRON", "VTK_LAGRANGE_WEDGE",       "VTK_LAGRANGE_PYRAMID",       "VTK_BEZIER_CURVE",
      "VTK_BEZIER_TRIANGLE",     "VTK_BEZIER_QUADRILATERAL", "VTK_BEZIER_TETRAHEDRON",     "VTK_BEZIER_HEXAHEDRON",
      "VTK_BEZIER_WEDGE",        "VTK_BEZIER_PYRAMID"};
  const int h = vtk_type - kFirstHighOrder;
  if (h >= 0 && h < int(kHighOrderNames.size())) {
    const std::string_view name = kHighOrderNames[size_t(h)];
    return h % kHighOrderShapes < 3 ? drop(-1, name) : unsupported(name);
  }
  return unsupported("unknown cell type");
}

}  // namespace

// Readers call this once per cell of the file, so the switch above is evaluated once per id into a table.
VtkCellMapping map_vtk_cell_type(int vtk_type) {
  static const auto table = [] {
    std::array<VtkCellMapping, 128> t{};
    for (int i = 0; i < 128; ++i) t[size_t(i)] = compute_mapping(i);
    return t;
  }();
  if (vtk_type < 0 || vtk_type >= 128) return compute_mapping(-1);
  return table[size_t(vtk_type)];
}

}  // namespace ugvr
