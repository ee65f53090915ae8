// Blocks of unit hexahedra for tests that need a small, exactly known mesh (step reading, time ranges, visible
// bounds). Layout: point (i, j, k) of an n^3 block is index i + (n+1) * (j + (n+1) * k) at (i, j, k); cell (i, j, k)
// is index i + n * (j + n * k), its corners in VTK hexahedron order.
#pragma once

#include <cstdint>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr::test {

// n x n x n unit hexahedra from the origin.
inline UnstructuredMesh unit_hex_mesh(int n) {
  UnstructuredMesh m;
  const int p = n + 1;
  for (int k = 0; k < p; ++k)
    for (int j = 0; j < p; ++j)
      for (int i = 0; i < p; ++i) m.points.push_back({float(i), float(j), float(k)});
  auto id = [&](int i, int j, int k) { return uint32_t(i + p * (j + p * k)); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const uint32_t v[8] = {id(i, j, k),     id(i + 1, j, k),     id(i + 1, j + 1, k),     id(i, j + 1, k),
                               id(i, j, k + 1), id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        m.add_cell(CellType::Hexahedron, v);
      }
  return m;
}

// The step-reading tests' block: unit_hex_mesh(n) with vertex fields f = x + y + z + offset and g = (x, y, offset),
// and cell field c = cell index / 2 + offset; `moved` shifts point 0 by 0.25 in x (another mesh, the same counts).
inline Block step_cube_block(int n, double offset, bool moved = false) {
  UnstructuredMesh m = unit_hex_mesh(n);
  if (moved) m.points[0].x += 0.25f;
  std::vector<float> f, g, c;
  for (const Vec3f& q : m.points) {
    f.push_back(float(q.x + q.y + q.z + offset));
    for (float x : {q.x, q.y, float(offset)}) g.push_back(x);
  }
  for (uint64_t i = 0; i < m.cell_count(); ++i) c.push_back(float(double(i) * 0.5 + offset));
  Block b;
  b.grid = std::move(m);
  b.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(f), 1)));
  b.fields.add(Field("g", Association::Vertex, DataArray::from(std::move(g), 3)));
  b.fields.add(Field("c", Association::Cell, DataArray::from(std::move(c), 1)));
  return b;
}

}  // namespace ugvr::test
