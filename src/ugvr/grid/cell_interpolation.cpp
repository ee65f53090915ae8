#include "ugvr/grid/cell_interpolation.h"

#include <array>

namespace ugvr {

Vec3d parametric_vertex(CellType type, int i) {
  // VTK's vtkTetra/vtkHexahedron/vtkWedge/vtkPyramid parametric coordinates, in vertex order.
  static constexpr std::array<Vec3d, 4> kTetra = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  static constexpr std::array<Vec3d, 8> kHexahedron = {
      {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};
  static constexpr std::array<Vec3d, 6> kWedge = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}}};
  static constexpr std::array<Vec3d, 5> kPyramid = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}}};
  switch (type) {
    case CellType::Tetra: return kTetra.at(size_t(i));
    case CellType::Hexahedron: return kHexahedron.at(size_t(i));
    case CellType::Wedge: return kWedge.at(size_t(i));
    case CellType::Pyramid: return kPyramid.at(size_t(i));
  }
  return {};
}

}  // namespace ugvr
