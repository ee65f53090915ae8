// Test support for stores built two ways and compared node by node (in core and out of core, a coarse preview and
// its final store), and the generated mesh those tests share.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
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

// Two builds of one mesh, node by node (matched by place): the same child masks, each field's node min/max equal,
// every brick (mask and float32 samples) bit for bit; at a leaf the same error_max and `leaf(ia, ib, f)` for what a
// caller also compares there; at an interior node an error no higher in `other` (out of core an interior node's
// error is measured at its children's samples alone). A store with time compares its current step (set_step).
template <class LeafCheck>
void expect_same_nodes_and_bricks(const BrickStoreReader& reference, const BrickStoreReader& other, LeafCheck&& leaf) {
  const auto a = nodes_by_place(reference), b = nodes_by_place(other);
  const size_t n = size_t(reference.resolution()) * reference.resolution() * reference.resolution();
  std::vector<float> va(n), vb(n);
  std::vector<uint8_t> ma(n), mb(n);
  for (const auto& [place, ia] : a) {
    const auto it = b.find(place);
    ASSERT_NE(it, b.end()) << "level " << place[0] << " node " << place[1] << " " << place[2] << " " << place[3];
    const uint64_t ib = it->second;
    EXPECT_EQ(reference.node(ia).child_mask, other.node(ib).child_mask);
    ASSERT_EQ(reference.node(ia).has_brick(), other.node(ib).has_brick());
    for (uint32_t f = 0; f < reference.field_count(); ++f) {
      const FieldStats &sa = reference.stats(ia, f), &sb = other.stats(ib, f);
      EXPECT_EQ(sa.min, sb.min);
      EXPECT_EQ(sa.max, sb.max);
      if (reference.node(ia).is_leaf()) {
        EXPECT_EQ(sa.error_max, sb.error_max) << "node " << ia;
        leaf(ia, ib, f);
      } else {
        EXPECT_LE(sb.error_max, sa.error_max);
      }
      if (!reference.node(ia).has_brick()) continue;
      reference.read_brick(ia, f, va.data(), ma.data());
      other.read_brick(ib, f, vb.data(), mb.data());
      ASSERT_EQ(ma, mb) << "node " << ia << " field " << f;
      ASSERT_EQ(std::memcmp(va.data(), vb.data(), 4 * n), 0) << "node " << ia << " field " << f;
    }
  }
}

// Two out-of-core builds of one mesh at different memory budgets (octree/out_of_core.h): the same nodes and bricks as
// above, and every node's errors (max and rms) and transfer-function error entries equal, interior nodes too. Their
// boundary sections are not compared: a budget too small for the boundary's triangles leaves the section out.
inline void expect_same_store_at_any_budget(const BrickStoreReader& a, const BrickStoreReader& b) {
  ASSERT_EQ(a.node_count(), b.node_count());
  ASSERT_EQ(a.has_tf_errors(), b.has_tf_errors());
  expect_same_nodes_and_bricks(a, b, [](uint64_t, uint64_t, uint32_t) {});
  const auto pa = nodes_by_place(a), pb = nodes_by_place(b);
  for (const auto& [place, ia] : pa) {
    const uint64_t ib = pb.at(place);
    for (uint32_t f = 0; f < a.field_count(); ++f) {
      EXPECT_EQ(a.stats(ia, f).error_max, b.stats(ib, f).error_max) << "node " << ia << " field " << f;
      EXPECT_EQ(a.stats(ia, f).error_rms, b.stats(ib, f).error_rms) << "node " << ia << " field " << f;
      if (!a.has_tf_errors()) continue;
      const store_format::TfErrorEntry &ta = a.tf_errors()[ia * a.field_count() + f],
                                       &tb = b.tf_errors()[ib * b.field_count() + f];
      EXPECT_EQ(std::memcmp(&ta, &tb, sizeof ta), 0) << "node " << ia << " field " << f;
    }
  }
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
