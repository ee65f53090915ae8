// The cells each leaf keeps in the store (octree/node_cells.h, store format version 5): checked against the mesh they
// came from, cell by cell, and the store's refusals of damaged blocks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <set>

#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/grid/topology.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/octree/node_cells.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// A mixed mesh (prisms, tetrahedra, pyramids, hexahedra) with a vertex field and a cell field of its own.
Dataset mixed_dataset() { return test::generated_with_cell_field(GenCellKind::Mixed, 3000); }

std::string read_bytes(const std::string& path) { return InputFile(path).read_all(); }
void write_bytes(const std::string& path, const std::string& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
}

TEST(NodeCells, EveryLeafKeepsItsCellsAsInTheMesh) {
  ScratchDir dir;
  const Dataset ds = mixed_dataset();
  const std::vector<std::string> fields = {"pressure", "cell97"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  OctreeBuildOptions o;
  o.resolution = 8;
  o.max_depth = 3;
  o.error = 0.01;
  o.leaf_cells = true;
  const OctreeBuildStats st = build_octree(in, o, dir.file("c.ugvr"));
  const BrickStoreReader store(dir.file("c.ugvr"));
  ASSERT_TRUE(store.has_cells());
  ASSERT_GT(st.leaves, 8u);
  EXPECT_EQ(store.cells_header().block_count, st.cell_blocks);
  EXPECT_EQ(store.cells_header().total_cells, st.leaf_cells);

  const UnstructuredMesh& mesh = *in.mesh;
  const MeshTopology topo = build_topology(mesh);
  std::set<uint64_t> seen;
  uint64_t outside = 0, boundary = 0, inside = 0, total = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    if (!store.node(id).is_leaf()) {
      EXPECT_EQ(store.cell_block(id).offset, 0u) << "interior node " << id;
      continue;
    }
    if (store.cell_block(id).offset == 0) continue;
    const NodeCells c = store.read_cells(id);
    ASSERT_TRUE(std::is_sorted(c.ids.begin(), c.ids.end()));
    total += c.cell_count();
    const Bounds box = store.bounds(id);
    size_t k = 0, s = 0;
    for (size_t i = 0; i < c.cell_count(); ++i) {
      const uint64_t cell = c.ids[i];
      seen.insert(cell);
      ASSERT_EQ(c.types[i], mesh.cell_types[cell]);
      // Its vertices, where the mesh has them; its bounding box meets the node's (with the sampler's margin).
      Bounds cb;
      for (uint32_t v : mesh.cell(cell)) {
        const Vec3f p = c.points[c.connectivity[k++]];
        EXPECT_EQ(std::memcmp(&p, &mesh.points[v], sizeof p), 0) << "cell " << cell;
        cb.add(Vec3d{p.x, p.y, p.z});
      }
      const Vec3d margin = box.size() * 0.01;
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(cb.lo[a], box.hi[a] + margin[a]);
        EXPECT_GE(cb.hi[a], box.lo[a] - margin[a]);
      }
      // What lies across each face: the mesh's neighbour, here or not.
      for (uint32_t f = 0; f < cell_face_count(mesh.cell_types[cell]); ++f) {
        const uint32_t a = c.across[s++];
        const uint64_t n = topo.neighbor(cell, f);
        if (n == kNoNeighbor) {
          EXPECT_EQ(a, store_format::kCellAcrossBoundary);
          ++boundary;
        } else if (a == store_format::kCellAcrossOutside) {
          EXPECT_FALSE(std::binary_search(c.ids.begin(), c.ids.end(), face_cell(n))) << "cell " << cell;
          ++outside;
        } else {
          ASSERT_LT(a, c.cell_count());
          EXPECT_EQ(c.ids[a], face_cell(n));
          ++inside;
        }
      }
    }
    // The fields: pressure at the points, cell97 per cell, as the bricks' scalars.
    ASSERT_EQ(c.values.size(), c.points.size() + c.cell_count());
    for (size_t i = 0; i < c.cell_count(); ++i) EXPECT_EQ(c.values[c.points.size() + i], float(c.ids[i] % 97));
    k = 0;
    for (size_t i = 0; i < c.cell_count(); ++i)
      for (uint32_t v : mesh.cell(c.ids[i]))
        EXPECT_EQ(c.values[c.connectivity[k++]], float(in.scalars[0].field->scalar(v, in.scalars[0].component)));
  }
  EXPECT_EQ(seen.size(), mesh.cell_count());  // no cell is lost
  EXPECT_GT(total, mesh.cell_count());        // cells on node borders are kept by each node they overlap
  EXPECT_GT(outside, 0u);
  EXPECT_GT(boundary, 0u);
  EXPECT_GT(inside, outside);
  std::printf(
      "%llu leaves keep %llu cells (%llu distinct) in %llu bytes; faces: %llu inside, %llu outside, %llu "
      "boundary\n",
      (unsigned long long)st.cell_blocks, (unsigned long long)total, (unsigned long long)mesh.cell_count(),
      (unsigned long long)st.cell_bytes, (unsigned long long)inside, (unsigned long long)outside,
      (unsigned long long)boundary);

  // Without --cells the store keeps none.
  o.leaf_cells = false;
  build_octree(in, o, dir.file("plain.ugvr"));
  const BrickStoreReader plain(dir.file("plain.ugvr"));
  EXPECT_FALSE(plain.has_cells());
  EXPECT_THROW(plain.read_cells(1), Error);
}

TEST(NodeCells, DamagedBlocksAndIndexAreRefused) {
  ScratchDir dir;
  const Dataset ds = mixed_dataset();
  const OctreeInput in = prepare_octree_input(ds, {});
  OctreeBuildOptions o;
  o.resolution = 8;
  o.max_depth = 2;
  o.leaf_cells = true;
  const std::string path = dir.file("c.ugvr");
  build_octree(in, o, path);
  const std::string good = read_bytes(path);
  uint64_t leaf = 0;
  store_format::CellBlockRecord r;
  store_format::CellsHeaderRecord h;
  {
    const BrickStoreReader s(path);
    while (s.cell_block(leaf).offset == 0) ++leaf;
    r = s.cell_block(leaf);
    h = s.cells_header();
    EXPECT_NO_THROW(s.read_cells(leaf));
  }
  // A flipped byte in a block: the store opens, the block is refused with its node and offset.
  std::string f = good;
  f[r.offset + r.size / 2] ^= 0x10;
  const std::string bad = dir.file("bad.ugvr");
  write_bytes(bad, f);
  {
    const BrickStoreReader s(bad);
    try {
      s.read_cells(leaf);
      ADD_FAILURE() << "read a damaged cell block";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("cell block of node " + std::to_string(leaf)), std::string::npos) << what;
      EXPECT_NE(what.find("checksum"), std::string::npos) << what;
      EXPECT_NE(what.find("byte " + std::to_string(r.offset)), std::string::npos) << what;
    }
  }
  // A flipped byte in the index: refused at open.
  f = good;
  f[h.index_offset + leaf * 16 + 9] ^= 0x01;
  write_bytes(bad, f);
  try {
    BrickStoreReader s(bad);
    ADD_FAILURE() << "opened a store with a damaged cell index";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cell index checksum"), std::string::npos) << e.what();
  }
}

TEST(NodeCells, WriterRefusesCellsThatDoNotMatch) {
  ScratchDir dir;
  BrickStoreLayout layout;
  layout.resolution = 4;
  layout.fields = {{"f", Association::Vertex, 0, 1}};
  layout.root.lo = {0, 0, 0};
  layout.root.hi = {1, 1, 1};
  layout.data = layout.root;
  BrickStoreWriter w(dir.file("w.ugvr"), layout);
  NodeCells c;
  c.ids = {7};
  c.types = {CellType::Tetra};
  c.connectivity = {0, 1, 2, 3};
  c.across = {store_format::kCellAcrossBoundary, store_format::kCellAcrossBoundary, store_format::kCellAcrossBoundary,
              store_format::kCellAcrossOutside};
  c.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  c.values = {0, 1, 2, 3};
  EXPECT_NO_THROW(w.encode_cells(c));
  NodeCells bad = c;
  bad.values.pop_back();  // one value short for a vertex field
  EXPECT_THROW(w.encode_cells(bad), Error);
  bad = c;
  bad.across.pop_back();
  EXPECT_THROW(w.encode_cells(bad), Error);
  w.append_cells(0, w.encode_cells(c));
  EXPECT_THROW(w.append_cells(0, w.encode_cells(c)), Error);  // one block a node
  // A single-node tree with it, read back as written.
  OctreeNode root;
  w.add_brick(0, std::vector<const float*>{std::vector<float>(64, 0.5f).data()}, nullptr);
  w.commit(std::span<const OctreeNode>(&root, 1));
  const BrickStoreReader s(dir.file("w.ugvr"));
  EXPECT_EQ(s.read_cells(0), c);
}

}  // namespace
}  // namespace ugvr
