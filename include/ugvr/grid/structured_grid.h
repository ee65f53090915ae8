// Grids with implicit (i, j, k) connectivity. None is exploded into cells at load; consumers that need cells ask
// tetrahedralize.h or walk the index space.
//
// Point (i, j, k) of a grid with point dimensions (ni, nj, nk) has linear index i + ni * (j + nj * k) (i fastest, as
// in VTK and PLOT3D); cell (i, j, k) spans points i..i+1, j..j+1, k..k+1 and has index i + (ni-1) * (j + (nj-1) * k).
// A dimension of 1 makes the grid 2-D or 1-D; such grids have no volume cells.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "ugvr/core/vec.h"

namespace ugvr {

struct GridDims {
  std::array<uint32_t, 3> points{1, 1, 1};

  uint64_t point_count() const { return uint64_t(points[0]) * points[1] * points[2]; }
  std::array<uint32_t, 3> cells() const {
    return {points[0] > 1 ? points[0] - 1 : 0, points[1] > 1 ? points[1] - 1 : 0, points[2] > 1 ? points[2] - 1 : 0};
  }
  uint64_t cell_count() const {
    const auto c = cells();
    return uint64_t(c[0]) * c[1] * c[2];
  }
  uint64_t point_index(uint64_t i, uint64_t j, uint64_t k) const { return i + points[0] * (j + points[1] * k); }
  uint64_t cell_index(uint64_t i, uint64_t j, uint64_t k) const {
    const auto c = cells();
    return i + c[0] * (j + uint64_t(c[1]) * k);
  }
  bool operator==(const GridDims&) const = default;
};

// Curvilinear grid: every point has its own position. `iblank` is empty or one entry per point: 0 = blanked (no
// data; cells touching it do not exist), anything else = in use (PLOT3D's overset values 1, -n, 2 all count as in use).
struct StructuredGrid {
  GridDims dims;
  std::vector<Vec3f> points;
  std::vector<int32_t> iblank;

  bool has_iblank() const { return !iblank.empty(); }
  Bounds bounds() const;
  uint64_t memory_bytes() const { return points.capacity() * sizeof(Vec3f) + iblank.capacity() * sizeof(int32_t); }
  bool operator==(const StructuredGrid&) const = default;
};

// Uniform voxel grid: point (i, j, k) is at origin + (i, j, k) * spacing (axis-aligned; VTK's image direction
// matrix is not supported and readers reject non-identity directions).
struct ImageGrid {
  GridDims dims;
  Vec3d origin{0, 0, 0};
  Vec3d spacing{1, 1, 1};

  Bounds bounds() const;
  Vec3d point(uint64_t i, uint64_t j, uint64_t k) const {
    return {origin.x + double(i) * spacing.x, origin.y + double(j) * spacing.y, origin.z + double(k) * spacing.z};
  }
  bool operator==(const ImageGrid&) const = default;
};

// Rectilinear grid: axis-aligned with per-axis coordinate lists (sizes = dims.points[axis]).
struct RectilinearGrid {
  GridDims dims;
  std::array<std::vector<double>, 3> coords;

  Bounds bounds() const;
  Vec3d point(uint64_t i, uint64_t j, uint64_t k) const { return {coords[0][i], coords[1][j], coords[2][k]}; }
  bool operator==(const RectilinearGrid&) const = default;
};

}  // namespace ugvr
