// The exact mesh boundary in voxel nodes (issue 25, part 2; docs/lod-engine.md, "Exact boundary"): the builder keeps
// the boundary faces that cross each node (octree/boundary_faces.h, store format version 4) and the LOD shader clips
// each node's samples at them, so that the domain boundary is the mesh's own at every level.
//
// The mesh is `ugvr generate --kind tet` at 20,000 cells: a curvilinear O-grid of Kuhn tetrahedra around a wing on a
// floor, whose outer boundary (a cylinder) and wall (the wing) are curved and lie off the octree's lattice, so the
// validity stencil puts them within half of each level's voxel and they move with the level. A transfer function of
// one colour and one opacity makes a pixel measure only how far its ray runs inside the mesh; the store built without
// faces (boundary_faces_per_node 0) is the "before".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <set>

#include "gl_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/topology.h"
#include "ugvr/octree/boundary_faces.h"
#include "ugvr/octree/builder.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/store/boundary_planes.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

struct Fixture {
  std::filesystem::path dir;
  Dataset dataset;
  std::string with_faces, without_faces;
  std::unique_ptr<GlContext> gl;
  std::string gl_error;
};

Fixture& fixture() {
  static Fixture f = [] {
    Fixture r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-lod-boundary-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    GenerateOptions g;
    g.cells = 20000;
    g.kind = GenCellKind::Tet;
    r.dataset = generate_in_memory(g);
    const std::vector<std::string> fields = {"pressure"};
    OctreeBuildOptions o;
    o.resolution = 8;
    o.max_depth = 5;
    o.error = 0.02;
    r.with_faces = (r.dir / "faces.ugvr").string();
    build_octree(prepare_octree_input(r.dataset, fields), o, r.with_faces);
    o.boundary_faces_per_node = 0;
    r.without_faces = (r.dir / "stencil.ugvr").string();
    build_octree(prepare_octree_input(r.dataset, fields), o, r.without_faces);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return f;
}

#define REQUIRE_GL() UGVR_REQUIRE_GL_CONTEXT(fixture().gl, fixture().gl_error)

Bounds node_box_normalised(const OctreeNode& n) {
  const double s = std::ldexp(1.0, -int(n.level));
  Bounds b;
  b.lo = Vec3d{n.i * s, n.j * s, n.k * s};
  b.hi = Vec3d{(n.i + 1) * s, (n.j + 1) * s, (n.k + 1) * s};
  return b;
}

Vec3d corner(const store_format::BoundaryTriangleRecord& t, int i) {
  return Vec3d{t.p[3 * i], t.p[3 * i + 1], t.p[3 * i + 2]};
}

TEST(BoundaryFaces, TriangleBoxOverlap) {
  Bounds box;
  box.lo = Vec3d{0, 0, 0};
  box.hi = Vec3d{1, 1, 1};
  // Through the box, touching a face, beyond a corner along the diagonal (only an edge product separates it).
  EXPECT_TRUE(triangle_box_overlap({-1, 0.5, 0.5}, {2, 0.5, 0.5}, {0.5, 0.5, 3}, box));
  EXPECT_TRUE(triangle_box_overlap({1, 0, 0}, {1, 1, 0}, {1, 0, 1}, box));
  EXPECT_FALSE(triangle_box_overlap({1.1, 0, 0}, {1.1, 1, 0}, {1.1, 0, 1}, box));
  EXPECT_FALSE(triangle_box_overlap({2.2, 0, 0}, {0, 2.2, 0}, {0, 0, 2.2}, {Vec3d{2, 2, 2}, Vec3d{3, 3, 3}}));
  EXPECT_FALSE(triangle_box_overlap({1.2, 1.5, -1}, {1.5, 1.2, -1}, {1.35, 1.35, 2}, box));
  EXPECT_TRUE(triangle_box_overlap({0.9, 1.1, -1}, {1.1, 0.9, -1}, {1.0, 1.0, 2}, box));
}

// A face that two unwelded blocks share (each block its own copy of the points, so the topology finds no neighbour)
// comes as two coincident triangles of opposite orientation, with the mesh on both sides: the section leaves both
// out. A coincident pair of the same orientation (two blocks overlapping, or a duplicated cell) is no such face and
// stays, as does a triangle matched by corner set but not by position (a quadrilateral split along the other
// diagonal).
TEST(BoundaryFaces, UnweldedBlocksSharedFacesAreDropped) {
  const Vec3f a{0.5f, 0.1f, 0.1f}, b{0.5f, 0.9f, 0.1f}, c{0.5f, 0.1f, 0.9f}, d{0.5f, 0.9f, 0.9f};
  const Vec3f e{0.2f, 0.2f, 0.3f}, f{0.3f, 0.7f, 0.3f}, g{0.2f, 0.2f, 0.8f};
  std::vector<MeshFaceTriangle> tris = {
      {a, b, c},             // block 1's side of the shared quadrilateral (a, b, d, c), split along b-c
      {b, d, c}, {e, f, g},  // a boundary triangle
      {c, b, a},  // block 2's side: the same corners, the other orientation (rotated: a different first corner)
      {b, c, d}, {e, f, g},  // the same triangle twice in the same orientation: kept
      {a, d, c},             // the quadrilateral split along a-d instead: not coincident with either, kept
  };
  std::vector<OctreeNode> nodes(1);  // the root alone, a leaf
  BoundaryFaceStats st;
  const StoreBoundary out = store_boundary_faces(tris, Bounds{Vec3d{0, 0, 0}, Vec3d{1, 1, 1}}, nodes, 16, &st);
  EXPECT_EQ(st.triangles, 7u);
  EXPECT_EQ(st.inner_pairs, 2u);
  ASSERT_EQ(out.triangles.size(), 3u);
  ASSERT_EQ(out.nodes.size(), 1u);
  EXPECT_EQ(out.nodes[0].count, 3u);
  // What is left: e f g twice and a d c, in the input's order.
  const auto first_corner = [&](size_t t) {
    return Vec3d{out.triangles[t].p[0], out.triangles[t].p[1], out.triangles[t].p[2]};
  };
  EXPECT_EQ(first_corner(0), (Vec3d{e.x, e.y, e.z}));
  EXPECT_EQ(first_corner(1), (Vec3d{e.x, e.y, e.z}));
  EXPECT_EQ(first_corner(2), (Vec3d{a.x, a.y, a.z}));

  // Only pairs: with a third copy of one side, one of the two same-oriented copies stays.
  tris.push_back({a, b, c});
  const StoreBoundary three = store_boundary_faces(tris, Bounds{Vec3d{0, 0, 0}, Vec3d{1, 1, 1}}, nodes, 16, &st);
  EXPECT_EQ(st.inner_pairs, 2u);
  EXPECT_EQ(three.triangles.size(), 4u);
}

// Every node lists exactly the boundary triangles that overlap its cell (or says it has more than the cap), each
// triangle oriented outwards, and the section survives the round trip through the file.
TEST(BoundaryFaces, StoreListsTheFacesCrossingEachNode) {
  const Fixture& f = fixture();
  const BrickStoreReader store(f.with_faces);
  ASSERT_TRUE(store.has_boundary());
  const StoreBoundary& b = store.boundary();
  EXPECT_EQ(b.max_per_node, kBoundaryFacesPerNode);
  // All boundary faces are quadrilaterals split in two or triangles: the tet mesh's boundary is triangles.
  const auto& mesh = std::get<UnstructuredMesh>(f.dataset.blocks[0].grid);
  EXPECT_EQ(b.triangles.size(), build_topology(mesh).boundary.size());
  EXPECT_FALSE(BrickStoreReader(f.without_faces).has_boundary());
  uint64_t listed = 0, overflow = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const Bounds box = node_box_normalised(store.node(id));
    const double grow = (box.hi.x - box.lo.x) * 1e-6;
    Bounds grown = box;
    grown.lo = box.lo - Vec3d{grow, grow, grow};
    grown.hi = box.hi + Vec3d{grow, grow, grow};
    std::set<uint32_t> expected;
    for (uint32_t t = 0; t < b.triangles.size(); ++t)
      if (triangle_box_overlap(corner(b.triangles[t], 0), corner(b.triangles[t], 1), corner(b.triangles[t], 2), grown))
        expected.insert(t);
    const auto& e = b.nodes[id];
    if (e.count == store_format::kBoundaryOverflow) {
      EXPECT_GT(expected.size(), kBoundaryFacesPerNode) << "node " << id;
      ++overflow;
      continue;
    }
    const std::set<uint32_t> got(b.refs.begin() + e.first, b.refs.begin() + e.first + e.count);
    EXPECT_EQ(got, expected) << "node " << id;
    listed += e.count > 0;
  }
  EXPECT_GT(listed, 10u);
  std::printf("%llu nodes, %llu with faces listed, %llu over the cap, %zu triangles, %zu references\n",
              (unsigned long long)store.node_count(), (unsigned long long)listed, (unsigned long long)overflow,
              b.triangles.size(), b.refs.size());
  // Outward: the wall (the wing) is nearest the domain's axis; its faces point towards it, the far field's away.
  const Bounds root = store.layout().root;
  const Vec3d size = root.size();
  const Vec3d axis{(0.0 - root.lo.x) / size.x, (0.0 - root.lo.y) / size.y, 0};
  int far_out = 0, far = 0;
  for (const auto& t : b.triangles) {
    const Vec3d a = corner(t, 0), e1 = corner(t, 1) - a, e2 = corner(t, 2) - a;
    const Vec3d n{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
    const Vec3d r{a.x - axis.x, a.y - axis.y, 0};
    if (std::hypot(r.x, r.y) > 0.4 && std::abs(n.z) < 0.1 * std::hypot(n.x, n.y)) {
      ++far;
      far_out += n.x * r.x + n.y * r.y > 0;
    }
  }
  EXPECT_GT(far, 50);
  EXPECT_EQ(far_out, far);
}

// A node whose faces all lie on one plane, facing one way, and cover the plane's section of its cell is clipped at
// the plane (boundary_face_planes); faces that leave part of the section open, lie on two planes or face both ways
// are not, nor is a cell the plane only touches along an edge.
TEST(BoundaryFaces, PlaneWhereTheFacesLieOnOnePlaneAndCoverTheCell) {
  std::vector<OctreeNode> root(1);  // the root alone, a leaf: the cell [0, 1]³
  auto planes_of = [&](const std::vector<MeshFaceTriangle>& tris) {
    const StoreBoundary b = store_boundary_faces(tris, Bounds{Vec3d{0, 0, 0}, Vec3d{1, 1, 1}}, root);
    return boundary_face_planes(b, root);
  };
  // z = 0.25, outward +z (counter-clockwise seen from above), larger than the cell: covers it.
  const Vec3f a{-1, -1, 0.25f}, b{2, -1, 0.25f}, c{2, 2, 0.25f}, d{-1, 2, 0.25f};
  auto planes = planes_of({{a, b, c}, {a, c, d}});
  ASSERT_EQ(planes.size(), 1u);
  ASSERT_TRUE(planes[0].has_value());
  EXPECT_NEAR(planes[0]->normal.z, 1.0, 1e-12);
  EXPECT_NEAR(planes[0]->offset, 0.25, 1e-12);
  // Outward -z (clockwise): the normal follows the faces.
  planes = planes_of({{a, c, b}, {a, d, c}});
  ASSERT_TRUE(planes[0].has_value());
  EXPECT_NEAR(planes[0]->normal.z, -1.0, 1e-12);
  EXPECT_NEAR(planes[0]->offset, -0.25, 1e-12);
  // One of the two triangles: half of the section open.
  EXPECT_FALSE(planes_of({{a, b, c}})[0].has_value());
  // Two halves that leave a sliver open (x from 0.4 to 0.5 uncovered): 10 % of the section.
  const Vec3f e{0.4f, -1, 0.25f}, f{0.4f, 2, 0.25f}, g{0.5f, -1, 0.25f}, h{0.5f, 2, 0.25f};
  EXPECT_FALSE(planes_of({{a, e, f}, {a, f, d}, {g, b, c}, {g, c, h}})[0].has_value());
  EXPECT_TRUE(planes_of({{a, e, f}, {a, f, d}, {e, b, c}, {e, c, f}})[0].has_value());  // the same, closed
  // The two orientations (a sheet with the mesh on both sides), or a second plane crossing the cell.
  EXPECT_FALSE(planes_of({{a, b, c}, {a, d, c}})[0].has_value());
  const Vec3f p{0.5f, -1, -1}, q{0.5f, 2, -1}, r{0.5f, -1, 2};
  EXPECT_FALSE(planes_of({{a, b, c}, {a, c, d}, {p, q, r}})[0].has_value());
  // The plane x + y = 0 meets the cell at its edge only: nothing to cover, no plane.
  const Vec3f s0{-1, 1, -1}, s1{1, -1, -1}, s2{-1, 1, 2};
  EXPECT_FALSE(planes_of({{s0, s1, s2}})[0].has_value());

  // A leaf over the cap (cap 2, the face in 8 triangles) is divided into virtual nodes: the plane at the leaf and at
  // each virtual node the face crosses, none where it does not.
  std::vector<MeshFaceTriangle> fine;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const float x0 = -1 + 1.5f * i, y0 = -1 + 1.5f * j, x1 = x0 + 1.5f, y1 = y0 + 1.5f;
      fine.push_back({Vec3f{x0, y0, 0.25f}, Vec3f{x1, y0, 0.25f}, Vec3f{x1, y1, 0.25f}});
      fine.push_back({Vec3f{x0, y0, 0.25f}, Vec3f{x1, y1, 0.25f}, Vec3f{x0, y1, 0.25f}});
    }
  const StoreBoundary divided = store_boundary_faces(fine, Bounds{Vec3d{0, 0, 0}, Vec3d{1, 1, 1}}, root, 2);
  ASSERT_EQ(divided.nodes[0].count, store_format::kBoundaryOverflow);
  planes = boundary_face_planes(divided, root);
  ASSERT_EQ(planes.size(), divided.nodes.size());
  EXPECT_TRUE(planes[0].has_value());
  const uint32_t v = divided.nodes[0].first;
  for (uint32_t o = 0; o < 8; ++o) EXPECT_EQ(planes[v + o].has_value(), o < 4) << "virtual node " << o;
}

TEST(BoundaryFaces, CorruptSectionIsNamed) {
  const Fixture& f = fixture();
  const std::string copy = (f.dir / "corrupt.ugvr").string();
  std::filesystem::copy_file(f.with_faces, copy, std::filesystem::copy_options::overwrite_existing);
  const uint64_t at = BrickStoreReader(copy).boundary_header().section_offset + 12;
  {
    std::fstream io(copy, std::ios::in | std::ios::out | std::ios::binary);
    io.seekg(std::streamoff(at));
    char c = 0;
    io.read(&c, 1);
    c = char(c ^ 0x5a);
    io.seekp(std::streamoff(at));
    io.write(&c, 1);
  }
  const std::string message = test::error_of([&] { BrickStoreReader r(copy); });
  EXPECT_NE(message.find("boundary face section checksum mismatch"), std::string::npos) << message;
  EXPECT_NE(message.find("corrupt.ugvr"), std::string::npos) << message;
}

// The nodes of level `level` and the leaves above it that have a brick: a cut forced to that depth.
std::vector<uint64_t> level_cut(const BrickStoreReader& store, int level) {
  std::vector<uint64_t> nodes;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& n = store.node(id);
    if (n.has_brick() && (n.level == level || (n.level < level && n.is_leaf()))) nodes.push_back(id);
  }
  return nodes;
}

// Mean |difference| of the red channel over pixels where either image has data (red above the background's).
double mean_difference(const Image& a, const Image& b) {
  double sum = 0;
  uint64_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const double ra = a.pixel(x, y)[0], rb = b.pixel(x, y)[0];
      if (ra < 1e-3 && rb < 1e-3) continue;
      sum += std::abs(ra - rb);
      ++n;
    }
  return n ? sum / double(n) : 0.0;
}

// The boundary no longer moves with the level: a transfer function of one colour and opacity shows only the length
// of each ray inside the mesh; the LOD images at two forced cut depths, and each against the exact engine, differ far
// less with the faces than with the stencil alone.
TEST(LodBoundary, BoundaryIndependentOfTheLevel) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  TransferFunction tf;
  tf.color_points = {{-10, {1, 1, 1}}, {10, {1, 1, 1}}};
  tf.opacity_points = {{-10, 0.5}, {10, 0.5}};
  // Unit distance: the domain's width, so that no ray saturates.
  const BrickStoreReader probe(f.with_faces);
  tf.opacity_unit_distance = 1.0 * probe.layout().data.size().x;
  RenderSettings rs;
  rs.width = rs.height = 96;
  rs.background = {0, 0, 0, 1};
  rs.early_termination_opacity = 1;
  // Looking down on the domain at an angle: the far-field cylinder's silhouette and top, the wing's top through it.
  Camera cam = camera_preset("iso", probe.layout().data);
  ExactEngine exact(f.dataset);
  exact.set_field(f.dataset, "pressure");
  const Image reference = exact.render(cam, tf, rs);
  double level_change[2] = {}, vs_exact[2][2] = {};
  for (int faces = 0; faces < 2; ++faces) {
    LodEngine lod(faces ? f.with_faces : f.without_faces, *f.gl);
    lod.set_field("pressure");
    Image im[2];
    for (int d = 0; d < 2; ++d) {
      const std::vector<uint64_t> cut = level_cut(lod.store(), d == 0 ? 2 : 4);
      im[d] = lod.render_nodes(cam, tf, rs, cut);
      vs_exact[faces][d] = mean_difference(im[d], reference);
    }
    level_change[faces] = mean_difference(im[0], im[1]);
    std::printf("%-8s level 2 vs 4: %.5f; vs exact: level 2 %.5f, level 4 %.5f\n", faces ? "faces" : "stencil",
                level_change[faces], vs_exact[faces][0], vs_exact[faces][1]);
  }
  // Measured on llvmpipe (96²): the stencil's images differ by 0.0066 between the two depths and by 0.0149 and 0.0089
  // from the exact engine; with the faces, 0.00000, 0.00002 and 0.00002 (only the mesh's own boundary bounds the
  // rays). A shader that ignores the faces, or clips at them with the wrong orientation, fails every line.
  EXPECT_LT(level_change[1], 0.1 * level_change[0]);
  EXPECT_LT(vs_exact[1][0], 0.1 * vs_exact[0][0]);
  EXPECT_LT(vs_exact[1][1], 0.1 * vs_exact[0][1]);
}

// A node whose faces all lie on one plane (here the far field's flat top and floor) is clipped at the plane, one test
// instead of its triangles and of the walk through its descendants (boundary_face_planes): the images are the
// triangles' to float rounding (the two compute the same crossing differently), at two cut depths, with and without
// the boundary overlay (whose normal then comes from the plane), with the same face passes.
TEST(LodBoundary, PlanesDrawWhatTheTrianglesDraw) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const BrickStoreReader store(f.with_faces);
  const std::vector<OctreeNode> tree(store.nodes().begin(), store.nodes().end());
  const std::vector<std::optional<BoundaryPlane>> planes = boundary_face_planes(store.boundary(), tree);
  const auto planar = std::count_if(planes.begin(), planes.end(), [](const auto& p) { return p.has_value(); });
  const auto crossed = std::count_if(store.boundary().nodes.begin(), store.boundary().nodes.end(),
                                     [](const auto& e) { return e.count != 0; });
  std::printf("%lld of %lld entries with faces have them on one plane\n", (long long)planar, (long long)crossed);
  EXPECT_GT(planar, 10);
  EXPECT_LT(planar, crossed);
  TransferFunction tf;
  tf.color_points = {{-10, {1, 1, 1}}, {10, {1, 1, 1}}};
  tf.opacity_points = {{-10, 0.5}, {10, 0.5}};
  tf.opacity_unit_distance = 1.0 * store.layout().data.size().x;
  RenderSettings rs;
  rs.width = rs.height = 96;
  rs.background = {0, 0, 0, 1};
  rs.early_termination_opacity = 1;
  const Camera cam = camera_preset("iso", store.layout().data);
  LodEngine with_planes(f.with_faces, *f.gl);
  ::setenv("UGVR_NO_FACE_PLANES", "1", 1);
  LodEngine without(f.with_faces, *f.gl);
  ::unsetenv("UGVR_NO_FACE_PLANES");
  with_planes.set_field("pressure");
  without.set_field("pressure");
  for (double overlay : {0.0, 0.5}) {
    rs.boundary_overlay_opacity = overlay;
    for (int depth : {2, 4}) {
      const std::vector<uint64_t> cut = level_cut(store, depth);
      LodRenderStats sa, sb;
      const Image a = with_planes.render_nodes(cam, tf, rs, cut, &sa), b = without.render_nodes(cam, tf, rs, cut, &sb);
      // The overlay differs at a few pixels (32 of 9,216 here, up to 0.16), mostly where the triangles' own answer
      // is the odd one out among its neighbours: a ray through a shared edge or corner of the cap's triangulation,
      // whose two float crossings miss or double. Without the overlay the images agree to 1e-6. A plane of the wrong
      // orientation changes about a fifth of the pixels.
      double sum = 0;
      int differing = 0;
      for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
          for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(a.pixel(x, y)[c] - b.pixel(x, y)[c]);
            sum += diff;
            differing += c == 0 && diff > 1e-3;
          }
      const double mean = sum / (3.0 * a.width * a.height);
      std::printf(
          "overlay %.1f, depth %d: mean difference %.3g, %d pixels over 1e-3; face passes %llu (planes) vs %llu\n",
          overlay, depth, mean, differing, (unsigned long long)sa.face_passes, (unsigned long long)sb.face_passes);
      EXPECT_LT(mean, 1e-3) << "overlay " << overlay << ", depth " << depth;
      EXPECT_LE(differing, a.width * a.height / 100) << "overlay " << overlay << ", depth " << depth;
      // The rays that look at the faces (the render's face_passes) are the same with the planes: a plane changes how
      // a pass clips, not which rays take one (up to a ray that the float difference ends a node sooner).
      EXPECT_GT(sa.face_passes, 0u);
      EXPECT_LE(std::abs(double(sa.face_passes) - double(sb.face_passes)), 0.01 * double(sb.face_passes))
          << "overlay " << overlay << ", depth " << depth;
    }
  }
}

}  // namespace
}  // namespace ugvr
