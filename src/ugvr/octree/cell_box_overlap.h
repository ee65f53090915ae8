// Does a cell overlap an axis-aligned box? The octree builder routes cells to the children they touch with this test
// (Leven et al. 2002, section 4.2), and the leaf sampler may bucket a node's cells with it (octree/brick_sampler.h).
//
// Separating-axis test: the cell and the box are disjoint if their projections onto some axis are, and for convex
// polyhedra it is enough to try the face normals of both and the cross products of an edge of each. For a
// tetrahedron that is Leven's 25 axes: 3 box normals, 4 face normals, 3 x 6 edge cross products.
//
// Other cells are tested as the convex hull of their vertices. That hull contains the cell (its shape functions are
// non-negative and sum to 1 inside the parametric domain, so every point of the cell is a convex combination of its
// vertices), and any axis that separates the hull from the box separates the cell too: the answer "no overlap" is
// always right. A non-planar quadrilateral face is replaced by both triangle pairs that span it (4 normals) and both
// its diagonals count as edges; that covers the hull of most warped cells exactly, and where it does not the test
// only errs towards "overlap" (a cell sampled in one extra node, never a hole). Touching counts as overlap: the
// samples on a node's faces belong to it.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

// Which axes to try. Every subset of the axes is conservative (an axis that separates proves disjointness), so a
// caller that only needs a coarse filter may skip the expensive ones:
//  - Exact: box normals, all face normals (4 per quadrilateral), edges and diagonals x box axes (Leven's 25 for a
//    tetrahedron, 99 for a hexahedron).
//  - FaceNormals: box normals and one normal per face (4 + 3 for a tetrahedron, 3 + 6 for a hexahedron); misses only
//    configurations that need an edge cross product to separate (a box just off an edge of the cell).
//  - BoxNormals: the 3 box normals alone, i.e. the cell's bounding box overlaps the box.
enum class OverlapAxes : uint8_t { Exact, FaceNormals, BoxNormals };

bool cell_box_overlap(CellType type, const Vec3d* vertices, const Bounds& box, OverlapAxes axes = OverlapAxes::Exact);

// The edges of a cell type as pairs of local vertex indices (6 for a tetrahedron, 8 for a pyramid, 9 for a wedge, 12
// for a hexahedron), derived from cell_info's faces.
std::span<const std::array<uint8_t, 2>> cell_edges(CellType type);

// The box grown by `margin` on every side.
inline Bounds expanded(const Bounds& b, double margin) {
  Bounds e;
  e.lo = b.lo - Vec3d{margin, margin, margin};
  e.hi = b.hi + Vec3d{margin, margin, margin};
  return e;
}

// How far a cell's box test is widened, relative to the diagonal of the cell's bounding box: far more than the
// parametric tolerance of the samplers reaches in world space (about 3 x tolerance x diagonal) and than the rounding
// of box corners computed in different ways, so a cell that claims a point on a box face is always routed to the box.
inline constexpr double kOverlapMargin = 1e-7;

// The cells overlapping each box of a uniform grid of `dims` boxes over `region` (box (x, y, z) spans
// region.lo + (x, y, z) · region.size() / dims ... + 1), each box widened by kOverlapMargin x the cell's diagonal.
// Layout (compressed rows): box b = x + dims.x · (y + dims.y · z) lists cells[offsets[b] .. offsets[b+1]), in the
// order of `cells`, which restricts the search to those cells (empty: all of the mesh, in cell id order). Parallel
// (oneTBB), and the same for any thread count.
struct BoxCellLists {
  std::array<uint32_t, 3> dims{};
  std::vector<uint64_t> offsets;
  std::vector<uint64_t> cells;

  std::span<const uint64_t> box(uint64_t b) const { return {cells.data() + offsets[b], cells.data() + offsets[b + 1]}; }
};
BoxCellLists cells_overlapping_boxes(const UnstructuredMesh& mesh, const Bounds& region, std::array<uint32_t, 3> dims,
                                     std::span<const uint64_t> cells = {});

}  // namespace ugvr
