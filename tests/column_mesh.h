// A column of 2 x 2 x `length` hexahedra with a smooth vertex field "s", and a parallel camera looking down it: every
// ray crosses all its cells, enough to reach llvmpipe's loop limit (shaders/loop_limit_probe.glsl). Shared by the
// exact GPU engine's and the hybrid's tests; bench/make_column_vtk.py writes the same column as a file.
#pragma once
#include <cmath>
#include <utility>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/render/camera.h"

namespace ugvr::test {

inline Dataset column_mesh(int length = 3000) {
  ImageGrid grid;
  grid.dims.points = {3, 3, uint32_t(length) + 1};
  ExplicitCells cells = make_explicit_cells(Grid(grid), StructuredCellShape::Hexahedra);
  std::vector<double> values;
  for (const Vec3f& p : cells.mesh.points)
    values.push_back(std::sin(0.05 * p.z) + 0.2 * p.x + 0.1 * p.y * p.z / length);
  Block block{"column", std::move(cells.mesh), {}};
  block.fields.add(Field("s", Association::Vertex, DataArray::from(std::move(values), 1)));
  Dataset ds;
  ds.format = "test column";
  ds.blocks.push_back(std::move(block));
  return ds;
}

// Down the column from below it, parallel rays inside its 2 x 2 section.
inline Camera column_camera(int length = 3000) {
  Camera cam;
  cam.position = {1, 1, -4};
  cam.focal_point = {1, 1, 0.5 * length};
  cam.view_up = {0, 1, 0};
  cam.parallel_projection = true;
  cam.parallel_scale = 0.95;
  return cam;
}

}  // namespace ugvr::test
