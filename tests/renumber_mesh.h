// Test support: a dataset with its cells and vertices renumbered, for invariance tests of the renderers.
#pragma once

#include <algorithm>
#include <numeric>
#include <random>
#include <variant>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr::test {

// The same mesh with cells and vertices renumbered by random permutations (fields permuted to match); each cell
// keeps its own vertex order, so the geometry and the field are unchanged.
inline Dataset renumbered(const Dataset& source, uint64_t seed) {
  const Block& in = source.blocks.at(0);
  const auto& mesh = std::get<UnstructuredMesh>(in.grid);
  std::mt19937_64 rng(seed);
  std::vector<uint64_t> new_of_old_point(mesh.point_count()), old_of_new_cell(mesh.cell_count());
  std::iota(new_of_old_point.begin(), new_of_old_point.end(), 0);
  std::iota(old_of_new_cell.begin(), old_of_new_cell.end(), 0);
  std::shuffle(new_of_old_point.begin(), new_of_old_point.end(), rng);
  std::shuffle(old_of_new_cell.begin(), old_of_new_cell.end(), rng);
  std::vector<uint64_t> old_of_new_point(mesh.point_count());
  for (uint64_t p = 0; p < mesh.point_count(); ++p) old_of_new_point[new_of_old_point[p]] = p;

  UnstructuredMesh out;
  out.points.resize(mesh.point_count());
  for (uint64_t p = 0; p < mesh.point_count(); ++p) out.points[new_of_old_point[p]] = mesh.points[p];
  for (uint64_t old : old_of_new_cell) {
    std::vector<uint32_t> ids;
    for (uint32_t v : mesh.cell(old)) ids.push_back(uint32_t(new_of_old_point[v]));
    out.add_cell(mesh.cell_types[old], ids);
  }
  Block block{in.name, std::move(out), {}};
  for (const Field& f : in.fields) {
    const auto& order = f.association() == Association::Vertex ? old_of_new_point : old_of_new_cell;
    block.fields.add(Field(f.name(), f.association(), f.data().gather(order)));
  }
  Dataset ds;
  ds.format = source.format;
  ds.blocks.push_back(std::move(block));
  return ds;
}

}  // namespace ugvr::test
