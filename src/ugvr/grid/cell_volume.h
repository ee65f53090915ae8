// The volume of a cell given its corners, for cells not stored in an UnstructuredMesh (a structured grid's
// hexahedra, the exact engine's walk mesh); cell_volume(const UnstructuredMesh&, cell) is the same on a mesh's cell.
#pragma once

#include <span>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"

namespace ugvr {

// Signed volume of a cell of `type` whose corners, in VTK's vertex order, are `corners` (cell_vertex_count(type) of
// them): as cell_volume(const UnstructuredMesh&, uint64_t) (unstructured_mesh.h), positive in VTK's orientation.
double cell_volume(CellType type, std::span<const Vec3d> corners);

}  // namespace ugvr
