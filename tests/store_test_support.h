// Test support for stores built two ways and compared node by node (in core and out of core, a coarse preview and
// its final store), and the generated mesh those tests share.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <utility>
#include <variant>
#include <vector>

#include "ugvr/gen/generator.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/store/brick_store.h"

namespace ugvr::test {

// A store's nodes by place (level, i, j, k): two builds of one mesh may number them differently.
inline std::map<std::array<uint32_t, 4>, uint64_t> nodes_by_place(const BrickStoreReader& s) {
  std::map<std::array<uint32_t, 4>, uint64_t> m;
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    const BrickNode& n = s.node(id);
    m[{uint32_t(n.level), n.i, n.j, n.k}] = id;
  }
  return m;
}

// `ugvr generate`'s mesh of `kind` in memory, with a cell field of its own ("cell97": the cell id modulo 97) beside
// its vertex fields.
inline Dataset generated_with_cell_field(GenCellKind kind, uint64_t cells) {
  GenerateOptions g;
  g.cells = cells;
  g.kind = kind;
  Dataset ds = generate_in_memory(g);
  Block& b = ds.blocks.at(0);
  const uint64_t n = std::get<UnstructuredMesh>(b.grid).cell_count();
  std::vector<float> id(n);
  for (uint64_t c = 0; c < n; ++c) id[c] = float(c % 97);
  b.fields.add(Field("cell97", Association::Cell, DataArray::from(std::move(id), 1)));
  return ds;
}

}  // namespace ugvr::test
