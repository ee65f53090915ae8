// The coarse preview of an out-of-core build (octree/coarse_preview.h): every node of the preview that the final
// store also has (same level and place) holds the same mask and the same valid samples, bit for bit, on small
// generated meshes of tetrahedra and of mixed cells (prisms, pyramids, hexahedra), both with a hole (the wing) and an
// outside (beyond the far field) in their root's cube, streamed in many chunks; the final store is byte for byte the
// one built without a preview; a cancelled build leaves no file; a soup out of id order is refused.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/coarse_preview.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/octree/soup.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string generated(const ScratchDir& dir, GenCellKind kind, uint64_t cells) {
  GenerateOptions g;
  g.cells = cells;
  g.kind = kind;
  const std::string path = dir.file(std::string(gen_cell_kind_name(kind)) + ".vtu");
  generate_dataset(g, path);
  return path;
}

OctreeBuildOptions options(int preview_depth) {
  OctreeBuildOptions o;
  o.resolution = 9;
  o.max_depth = 4;
  o.error = 0.02;
  o.encoding.samples = SampleEncoding::Float32;  // lossless: samples compare bit for bit
  o.boundary_faces_per_node = 0;
  o.preview_depth = preview_depth;
  return o;
}

const std::vector<std::string> kFields = {"pressure", "wall_distance"};  // a vertex and a cell scalar

struct Compared {
  uint64_t nodes = 0, valid = 0, invalid = 0, differing = 0;
};

// Every preview node against the final store's node at its place: the same mask, the same valid samples bit for bit
// (padding under mask 0 is filler and may differ). Every final node of the preview's levels that holds data must be
// in the preview.
Compared compare(const BrickStoreReader& preview, const BrickStoreReader& final_store, int depth) {
  Compared c;
  const auto p = test::nodes_by_place(preview), f = test::nodes_by_place(final_store);
  const size_t n = size_t(preview.resolution()) * preview.resolution() * preview.resolution();
  std::vector<float> va(n), vb(n);
  std::vector<uint8_t> ma(n), mb(n);
  for (const auto& [place, ib] : f) {
    if (int(place[0]) > depth || !final_store.node(ib).has_brick()) continue;
    EXPECT_TRUE(p.count(place)) << "level " << place[0] << " node " << place[1] << " " << place[2] << " " << place[3]
                                << " holds data in the final store but is not in the preview";
  }
  for (const auto& [place, ia] : p) {
    EXPECT_LE(int(place[0]), depth);
    const auto it = f.find(place);
    if (it == f.end()) continue;  // below a leaf of the final tree
    const uint64_t ib = it->second;
    EXPECT_EQ(preview.node(ia).has_brick(), final_store.node(ib).has_brick()) << "level " << place[0];
    if (!preview.node(ia).has_brick() || !final_store.node(ib).has_brick()) continue;
    ++c.nodes;
    for (uint32_t fi = 0; fi < preview.field_count(); ++fi) {
      preview.read_brick(ia, fi, va.data(), ma.data());
      final_store.read_brick(ib, fi, vb.data(), mb.data());
      EXPECT_EQ(ma, mb) << "level " << place[0] << " node " << place[1] << " " << place[2] << " " << place[3];
      for (size_t s = 0; s < n; ++s) {
        if (!ma[s] || !mb[s]) {
          c.invalid += fi == 0;
          continue;
        }
        c.valid += fi == 0;
        if (std::memcmp(&va[s], &vb[s], 4) != 0) ++c.differing;
      }
      // A node's range covers its subtree's samples: the preview's subtree stops at its level K, so its range lies
      // inside the final node's.
      EXPECT_GE(preview.stats(ia, fi).min, final_store.stats(ib, fi).min);
      EXPECT_LE(preview.stats(ia, fi).max, final_store.stats(ib, fi).max);
    }
  }
  return c;
}

void check_kind(GenCellKind kind) {
  ScratchDir dir;
  const std::string vtu = generated(dir, kind, 20000);
  OctreeBuildOptions o = options(3);
  o.preview_path = dir.file("preview.ugvr");
  // A budget of 1 byte: chunks of 64 KiB, so the soup (about 2 MB) is streamed in dozens of chunks.
  build_octree_out_of_core(vtu, kFields, o, 1, dir.file("final.ugvr"));
  const BrickStoreReader preview(o.preview_path), final_store(dir.file("final.ugvr"));
  EXPECT_EQ(preview.layout().fields.size(), 2u);
  EXPECT_FALSE(preview.has_boundary());
  EXPECT_FALSE(preview.has_tf_errors());
  // A preview node claims no exactness: its error is the field's range.
  const BrickStoreField& pressure = preview.layout().fields[0];
  EXPECT_EQ(preview.stats(0, 0).error_max, float(pressure.max - pressure.min));
  const Compared c = compare(preview, final_store, 3);
  std::printf("%s: %llu nodes compared, %llu valid and %llu invalid samples, %llu differing\n",
              std::string(gen_cell_kind_name(kind)).c_str(), (unsigned long long)c.nodes, (unsigned long long)c.valid,
              (unsigned long long)c.invalid, (unsigned long long)c.differing);
  EXPECT_GE(c.nodes, 9u);      // the root and at least 8 more
  EXPECT_GT(c.valid, 1000u);   // data
  EXPECT_GT(c.invalid, 100u);  // and the hole and the outside, where the masks must agree too
  EXPECT_EQ(c.differing, 0u);  // bit for bit
}

TEST(CoarsePreview, TetrahedraEqualTheFinalStoresNodes) { check_kind(GenCellKind::Tet); }

TEST(CoarsePreview, MixedCellsEqualTheFinalStoresNodes) { check_kind(GenCellKind::Mixed); }

TEST(CoarsePreview, FinalStoreIsTheSameByteForByteAndTheTemporaryPreviewGoes) {
  ScratchDir dir;
  const std::string vtu = generated(dir, GenCellKind::Tet, 5000);
  OctreeBuildOptions without = options(0);
  without.threads = 1;  // node ids follow the schedule: one thread makes the file repeatable
  build_octree_out_of_core(vtu, kFields, without, uint64_t(64) << 20, dir.file("a.ugvr"));
  OctreeBuildOptions with = options(3);
  with.threads = 1;
  std::string seen;
  uint64_t preview_nodes = 0;
  with.on_preview = [&](const std::string& path) {
    seen = path;
    preview_nodes = BrickStoreReader(path).node_count();  // complete and valid when announced
  };
  const OctreeBuildStats st = build_octree_out_of_core(vtu, kFields, with, uint64_t(64) << 20, dir.file("b.ugvr"));
  EXPECT_EQ(seen, dir.file("b.ugvr") + ".preview");
  EXPECT_GT(preview_nodes, 9u);
  EXPECT_EQ(st.preview_nodes, preview_nodes);
  EXPECT_GT(st.preview_seconds, 0);
  EXPECT_FALSE(std::filesystem::exists(seen));                                // removed when the build ended
  EXPECT_TRUE(bytes_of(dir.file("a.ugvr")) == bytes_of(dir.file("b.ugvr")));  // (not printed: megabytes)
}

TEST(CoarsePreview, CancelledDuringThePreviewLeavesNoFiles) {
  ScratchDir dir;
  const std::string vtu = generated(dir, GenCellKind::Tet, 5000);
  OctreeBuildOptions o = options(2);
  bool stopped = false;
  o.progress = [&](const std::string& label, double fraction) {
    if (label == "coarse preview" && fraction > 0 && fraction < 1) {
      stopped = true;
      throw Error("cancelled");
    }
  };
  EXPECT_THROW(build_octree_out_of_core(vtu, kFields, o, 1, dir.file("c.ugvr")), Error);
  EXPECT_TRUE(stopped);
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(vtu).parent_path()))
    left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"tet.vtu"});
}

TEST(CoarsePreview, RefusesASoupOutOfIdOrderAndABadDepth) {
  ScratchDir dir;
  const SoupLayout layout{1, 0};
  const std::string soup = dir.file("cells");
  {
    SoupWriter w(soup, layout);
    const uint32_t v[4] = {0, 1, 2, 3};
    const Vec3f p[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const float values[4] = {1, 2, 3, 4};
    w.add(5, CellType::Tetra, 4, v, p, values, nullptr);
    w.add(3, CellType::Tetra, 4, v, p, values, nullptr);
    w.close();
  }
  BrickStoreLayout store;
  store.resolution = 5;
  store.fields = {{"f", Association::Vertex, 1, 4}};
  store.root = Bounds{{0, 0, 0}, {1, 1, 1}};
  store.data = store.root;
  BrickLattice lattice{store.root, 5};
  const std::vector<VtuCellSource::Slot> slots = {{Association::Vertex, 0}};
  CoarsePreviewOptions po;
  po.depth = 1;
  const std::string out = dir.file("p.ugvr");
  const std::string message =
      test::error_of([&] { write_coarse_preview(soup, layout, slots, lattice, store, po, out); });
  EXPECT_NE(message.find(soup), std::string::npos) << message;
  EXPECT_NE(message.find("id order"), std::string::npos) << message;
  EXPECT_FALSE(std::filesystem::exists(out));
  po.depth = kMaxPreviewDepth + 1;
  EXPECT_NE(test::error_of([&] { write_coarse_preview(soup, layout, slots, lattice, store, po, out); }).find("depth"),
            std::string::npos);
  OctreeBuildOptions o = options(-1);
  EXPECT_NE(test::error_of([&] { build_octree_out_of_core(soup, {}, o, 1 << 30, dir.file("x.ugvr")); }).find("preview"),
            std::string::npos);
}

// `ugvr build --out-of-core --preview PATH` keeps the preview there and reports it; --preview needs out of core.
TEST(CoarsePreview, CliBuildWritesThePreviewWhereAsked) {
  ScratchDir dir;
  const std::string vtu = generated(dir, GenCellKind::Tet, 3000);
  const std::string preview = dir.file("p.ugvr");
  const test::CommandResult r =
      test::run_ugvr("build " + vtu + " -o " + dir.file("s.ugvr") +
                     " --fields pressure --max-depth 4 --brick 8 --out-of-core --memory 256MiB"
                     " --preview " +
                     preview + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("\"preview_depth\":3"), std::string::npos) << r.out;  // 256 MiB, R = 8: bricks of 2.5 MiB
  const BrickStoreReader p(preview);
  EXPECT_GT(p.node_count(), 9u);
  EXPECT_EQ(p.node(0).level, 0);
  const test::CommandResult in_core =
      test::run_ugvr("build " + vtu + " -o " + dir.file("t.ugvr") + " --preview " + dir.file("q.ugvr"));
  EXPECT_NE(in_core.status, 0);
  EXPECT_NE(in_core.out.find("out-of-core builds only"), std::string::npos) << in_core.out;
}

// The weld, both ways of numbering the vertices: a table over a dense id range, and sorting when the ids are sparse;
// the cells come out in id order whatever the records' order, each vertex with its position and value.
TEST(CoarsePreview, WeldOrdersCellsByIdAndNumbersVerticesAscending) {
  const SoupLayout layout{1, 1};
  for (const uint32_t stride : {1u, 1000u}) {  // vertex ids 0..4 (dense) or 0..4000 (sparse: sorted)
    SCOPED_TRACE("stride " + std::to_string(stride));
    ScratchDir dir;
    const std::string soup = dir.file("cells");
    {
      SoupWriter w(soup, layout);
      const uint32_t a[4] = {3 * stride, 1 * stride, 0, 2 * stride},
                     b[4] = {4 * stride, 1 * stride, 2 * stride, 3 * stride};
      const Vec3f pa[4] = {{3, 0, 0}, {1, 0, 0}, {0, 0, 0}, {2, 0, 0}},
                  pb[4] = {{4, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
      const float va[4] = {30, 10, 0, 20}, vb[4] = {40, 10, 20, 30};
      const float ca = 7, cb = 8;
      w.add(9, CellType::Tetra, 4, b, pb, vb, &cb);  // the higher id first
      w.add(2, CellType::Tetra, 4, a, pa, va, &ca);
      w.close();
    }
    std::vector<std::byte> records;
    {
      SoupReader r(soup, layout);
      const std::byte* rec = nullptr;
      while (r.next(rec)) records.insert(records.end(), rec, rec + SoupCell(rec, layout).bytes());
    }
    const std::vector<VtuCellSource::Slot> slots = {{Association::Vertex, 0}, {Association::Cell, 0}};
    const std::vector<BrickStoreField> fields = {{"v", Association::Vertex, 0, 40}, {"c", Association::Cell, 7, 8}};
    const std::unique_ptr<WeldedSoup> w = weld_soup_records(records, layout, slots, fields);
    EXPECT_EQ(w->ids, (std::vector<uint64_t>{2, 9}));
    ASSERT_EQ(w->mesh.points.size(), 5u);
    for (uint32_t v = 0; v < 5; ++v) {  // vertex k (id k x stride) sits at x = k with value 10 k
      EXPECT_EQ(w->mesh.points[v].x, float(v));
      EXPECT_EQ(w->fields[0].data().values<float>()[v], 10.0f * float(v));
    }
    const auto c0 = w->mesh.cell(0), c1 = w->mesh.cell(1);
    EXPECT_EQ(std::vector<uint32_t>(c0.begin(), c0.end()), (std::vector<uint32_t>{3, 1, 0, 2}));
    EXPECT_EQ(std::vector<uint32_t>(c1.begin(), c1.end()), (std::vector<uint32_t>{4, 1, 2, 3}));
    EXPECT_EQ(w->fields[1].data().values<float>()[0], 7.0f);
    EXPECT_EQ(w->fields[1].data().values<float>()[1], 8.0f);
  }
}

}  // namespace
}  // namespace ugvr
