// The level-of-detail GPU engine against the exact engine on the same mesh, camera, transfer function and settings.
// Runs wherever EGL gives an OpenGL 4.5 context: Mesa's llvmpipe in CI (small images), an NVIDIA GPU elsewhere.
//
// The mesh is a box of tetrahedra with a field that makes the builder refine unevenly ("wave") and two fields that
// trilinear bricks represent exactly ("one" = 1 and "lin" linear), so that for those two any difference from the
// exact engine comes from the renderer itself: seams where bricks or levels meet, gaps or double counting along the
// ray, wrong sample positions.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "gl_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/gpu/gl_program.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/structured_grid.h"
#include "ugvr/octree/builder.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/brick_cache.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

// Box [0, 1] x [0, 0.75] x [0, 0.5] (the octree root is the unit cube, so every face lies on lattice planes), with
// points 1/8 apart except for x in [0.75, 0.875], where they are 1/64 apart: the builder refines there (no two data
// points may share a voxel) and stays coarse elsewhere, so the cut mixes levels.
Dataset box_dataset() {
  std::vector<float> xs;
  for (int i = 0; i < 6; ++i) xs.push_back(float(i) / 8.0f);
  for (int i = 0; i < 8; ++i) xs.push_back(0.75f + float(i) / 64.0f);
  for (float x : {0.875f, 1.0f}) xs.push_back(x);
  StructuredGrid g;
  const uint32_t nx = uint32_t(xs.size()), ny = 7, nz = 5;
  g.dims = GridDims{{nx, ny, nz}};
  std::vector<float> wave, one, lin;
  for (uint32_t k = 0; k < nz; ++k)
    for (uint32_t j = 0; j < ny; ++j)
      for (uint32_t i = 0; i < nx; ++i) {
        const Vec3f p{xs[i], float(j) / 8.0f, float(k) / 8.0f};
        g.points.push_back(p);
        wave.push_back(float(std::tanh(12.0 * (p.x - 0.8)) + 0.2 * std::sin(3.0 * p.y)));
        one.push_back(1.0f);
        lin.push_back(float(p.x + 2.0 * p.y - p.z));
      }
  Block b;
  b.name = "box";
  b.grid = std::move(g);
  b.fields.add(Field("wave", Association::Vertex, DataArray::from(std::move(wave), 1)));
  b.fields.add(Field("one", Association::Vertex, DataArray::from(std::move(one), 1)));
  b.fields.add(Field("lin", Association::Vertex, DataArray::from(std::move(lin), 1)));
  Dataset ds;
  ds.sources = {"box"};
  ds.blocks.push_back(to_unstructured_block(b, StructuredCellShape::SixTetrahedra));
  return ds;
}

struct Shared {
  std::filesystem::path dir;
  std::string store;
  Dataset dataset;
  std::unique_ptr<GlContext> gl;
  std::string gl_error;
};

Shared& shared() {
  static Shared s = [] {
    Shared r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-lod-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    r.store = (r.dir / "box.ugvr").string();
    r.dataset = box_dataset();
    const std::vector<std::string> fields = {"wave", "one", "lin"};
    OctreeBuildOptions o;
    o.resolution = 8;
    o.max_depth = 4;
    o.error = 0;
    build_octree(prepare_octree_input(r.dataset, fields), o, r.store);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return s;
}

#define REQUIRE_GL() UGVR_REQUIRE_GL_CONTEXT(shared().gl, shared().gl_error)

TransferFunction linear_tf(double lo, double hi, double opacity) {
  TransferFunction tf;
  tf.color_points = {{lo, {0.1, 0.2, 0.9}}, {hi, {0.9, 0.6, 0.1}}};
  tf.opacity_points = {{lo, opacity}, {hi, opacity}};
  tf.opacity_unit_distance = 0.25;
  return tf;
}

Image render_exact(const std::string& field, const Camera& cam, const TransferFunction& tf, const RenderSettings& s) {
  ExactEngine e(shared().dataset);
  e.set_field(shared().dataset, field);
  return e.render(cam, tf, s);
}

// Largest difference between horizontally or vertically adjacent pixels (RGB), over pixels where `mask` holds.
double max_neighbour_jump(const Image& im) {
  double m = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c) {
        if (x + 1 < im.width) m = std::max(m, double(std::abs(im.pixel(x + 1, y)[c] - im.pixel(x, y)[c])));
        if (y + 1 < im.height) m = std::max(m, double(std::abs(im.pixel(x, y + 1)[c] - im.pixel(x, y)[c])));
      }
  return m;
}

// A view from inside the box with a clip plane in front of its back face: every ray starts and ends inside the
// data, so its length does not depend on where the bricks' stencils put the boundary and the image of a field
// the bricks hold exactly must match the exact engine everywhere.
struct InsideView {
  Camera camera;
  RenderSettings settings;
};
InsideView inside_view(bool parallel) {
  InsideView v;
  v.camera.position = {0.5, 0.37, 0.47};
  v.camera.focal_point = {0.52, 0.38, 0.0};
  v.camera.view_up = {0, 1, 0};
  v.camera.view_angle = 70;
  v.camera.parallel_projection = parallel;
  v.camera.parallel_scale = 0.3;
  v.settings.width = v.settings.height = 64;
  v.settings.background = {0, 0, 0, 1};
  v.settings.clip_plane = ClipPlane{{0, 0, 0.06}, {0, 0, 1}};
  v.settings.early_termination_opacity = 1;
  return v;
}

TEST(LodEngine, StoreHasSeveralLevelsInView) {
  const Shared& s = shared();
  const BrickStoreReader store(s.store);
  const InsideView v = inside_view(false);
  const Cut cut =
      select_cut(store, CutSpec{CutSpec::Kind::Leaves, 0}, v.camera, 64, 64, linear_tf(0, 1, 0.5), CutOptions{});
  int lo = 99, hi = 0;
  for (uint64_t n : cut.nodes) lo = std::min(lo, int(store.node(n).level)), hi = std::max(hi, int(store.node(n).level));
  // The seam tests below are only meaningful if the rays cross level borders.
  EXPECT_LT(lo, hi) << cut.nodes.size() << " nodes";
}

class LodSeams : public ::testing::TestWithParam<std::tuple<std::string, bool>> {};

TEST_P(LodSeams, FieldsHeldExactlyMatchTheExactEngine) {
  REQUIRE_GL();
  const auto& [field, parallel] = GetParam();
  const Shared& s = shared();
  const InsideView v = inside_view(parallel);
  const TransferFunction tf = field == "one" ? linear_tf(0, 2, 0.6) : linear_tf(-0.5, 2.5, 0.6);
  LodOptions options;
  options.step_voxels = 0.25;
  LodEngine lod(s.store, *s.gl, options);
  lod.set_field(field);
  LodRenderStats st;
  const Image a = lod.render(v.camera, tf, v.settings, CutSpec{CutSpec::Kind::Leaves, 0}, &st);
  const Image b = render_exact(field, v.camera, tf, v.settings);
  EXPECT_LT(st.mean_level, double(st.max_level)) << "the cut must mix levels";
  const ImageDifference d = compare_images(a, b);
  // Bricks hold these fields exactly (up to 16-bit quantization); the integration differs from the exact one by the
  // midpoint rule over quarter-voxel steps: well under one 8-bit level.
  EXPECT_LT(d.max_abs, 2e-3) << field << (parallel ? " parallel" : " perspective") << ": PSNR " << d.psnr_db;
  // And nothing jumps between neighbouring pixels more than in the exact image (the smooth reference) plus noise.
  EXPECT_LT(max_neighbour_jump(a), max_neighbour_jump(b) + 1e-3);
}

INSTANTIATE_TEST_SUITE_P(ConstantAndLinear, LodSeams,
                         ::testing::Combine(::testing::Values("one", "lin"), ::testing::Bool()));

// Pre-integration: the value is linear between consecutive samples and each segment is integrated over the transfer
// function with its integrals' table, so for a field the bricks hold exactly the image hardly depends on the step,
// even under a transfer function whose opacity and colour change over a small part of the range (the midpoint rule
// it replaced aliased there: 0.29 away from the exact engine at some pixel of this view at 1 voxel per step, 0.095 at
// 0.5, 0.041 at 0.25). What is left, 0.017 at 1 voxel per step and 0.006 at 0.5, is the colour's attenuation inside
// a segment, which the table leaves out (second order in the segment's optical depth; these are up to 0.25).
TEST(LodPreintegration, SteepTransferFunctionIndependentOfTheStep) {
  REQUIRE_GL();
  const Shared& s = shared();
  const InsideView v = inside_view(false);
  TransferFunction tf;
  tf.color_points = {{0.8, {0.1, 0.2, 0.9}}, {0.9, {0.9, 0.6, 0.1}}, {1.0, {0.2, 0.9, 0.3}}};
  tf.opacity_points = {{0.8, 0.0}, {0.9, 0.0}, {0.95, 0.7}, {1.0, 0.0}};
  tf.opacity_unit_distance = 0.05;
  const Image exact = render_exact("lin", v.camera, tf, v.settings);
  std::vector<Image> images;
  for (double step : {1.0, 0.5, 0.25}) {
    LodOptions options;
    options.step_voxels = step;
    LodEngine lod(s.store, *s.gl, options);
    lod.set_field("lin");
    images.push_back(lod.render(v.camera, tf, v.settings, CutSpec{CutSpec::Kind::Leaves, 0}));
    const ImageDifference d = compare_images(images.back(), exact);
    EXPECT_LT(d.max_abs, 0.02) << "step " << step << " voxels: PSNR " << d.psnr_db;
    EXPECT_GE(d.psnr_db, 45.0) << "step " << step;
  }
  EXPECT_LT(compare_images(images[0], images[2]).max_abs, 0.02);
  // The view is not blank: the band of opacity crosses it.
  double lo = 1, hi = 0;
  for (int y = 0; y < exact.height; ++y)
    for (int x = 0; x < exact.width; ++x)
      lo = std::min(lo, double(exact.pixel(x, y)[1])), hi = std::max(hi, double(exact.pixel(x, y)[1]));
  EXPECT_GT(hi - lo, 0.1);
}

// From outside, with the boundary in view: within PSNR 35 dB of the exact engine (the bar, at small size).
TEST(LodEngine, OutsideViewCloseToExact) {
  REQUIRE_GL();
  const Shared& s = shared();
  for (const std::string field : {"wave", "lin"}) {
    const ExactEngine probe(s.dataset);
    Camera cam = camera_preset("iso", probe.bounds());
    RenderSettings rs;
    rs.width = rs.height = 96;
    const TransferFunction tf = field == "wave" ? linear_tf(-1.2, 1.2, 0.4) : linear_tf(-0.5, 2.5, 0.4);
    LodOptions options;
    options.step_voxels = 0.25;
    LodEngine lod(s.store, *s.gl, options);
    lod.set_field(field);
    const Image a = lod.render(cam, tf, rs, CutSpec{CutSpec::Kind::Leaves, 0});
    const Image b = render_exact(field, cam, tf, rs);
    const ImageDifference d = compare_images(a, b);
    EXPECT_GE(d.psnr_db, 35.0) << field;
    EXPECT_GE(ssim(a, b), 0.97) << field;
  }
}

TEST(LodEngine, MipAndIsosurfaceCloseToExact) {
  REQUIRE_GL();
  const Shared& s = shared();
  const ExactEngine probe(s.dataset);
  const Camera cam = camera_preset("iso", probe.bounds());
  const TransferFunction tf = linear_tf(-0.5, 2.5, 0.4);
  LodEngine lod(s.store, *s.gl);
  lod.set_field("lin");
  RenderSettings mip;
  mip.width = mip.height = 96;
  mip.mode = RenderMode::Mip;
  EXPECT_GE(
      compare_images(lod.render(cam, tf, mip, CutSpec{CutSpec::Kind::Leaves, 0}), render_exact("lin", cam, tf, mip))
          .psnr_db,
      35.0);
  RenderSettings iso = mip;
  iso.mode = RenderMode::Isosurface;
  iso.iso_values = {0.6, 1.4};
  const ImageDifference d =
      compare_images(lod.render(cam, tf, iso, CutSpec{CutSpec::Kind::Leaves, 0}), render_exact("lin", cam, tf, iso));
  EXPECT_GE(d.psnr_db, 30.0);
}

TEST(LodEngine, TransferFunctionEditLoadsNoBricks) {
  REQUIRE_GL();
  const Shared& s = shared();
  LodEngine lod(s.store, *s.gl);
  lod.set_field("wave");
  const InsideView v = inside_view(false);
  LodRenderStats st;
  const Image a = lod.render(v.camera, linear_tf(-1, 1, 0.3), v.settings, CutSpec{CutSpec::Kind::Leaves, 0}, &st);
  EXPECT_GT(st.bricks_loaded, 0u);
  const Image b = lod.render(v.camera, linear_tf(-1, 1, 0.8), v.settings, CutSpec{CutSpec::Kind::Leaves, 0}, &st);
  EXPECT_EQ(st.bricks_loaded, 0u);
  EXPECT_GT(compare_images(a, b).max_abs, 0.01);  // and the edit did change the image
}

// In an odd-sized image looking down an axis, the middle column's and row's rays have direction components that are
// exactly 0. Those rays must march like their neighbours (a wrong exit face once made them creep by the nudge
// distance: thousands of samples each, cut off by the loop guard): the samples per pixel match the even size's, and
// the image matches the exact engine.
TEST(LodEngine, AxisAlignedRaysMarchLikeTheirNeighbours) {
  REQUIRE_GL();
  const Shared& s = shared();
  const ExactEngine probe(s.dataset);
  const Camera cam = camera_preset("+z", probe.bounds());
  const TransferFunction tf = linear_tf(-1.2, 1.2, 0.4);
  LodEngine lod(s.store, *s.gl);
  lod.set_field("wave");
  double per_pixel[2] = {0, 0};
  for (int size : {64, 65}) {
    RenderSettings rs;
    rs.width = rs.height = size;
    LodRenderStats st;
    const Image a = lod.render(cam, tf, rs, CutSpec{CutSpec::Kind::Leaves, 0}, &st);
    per_pixel[size % 2] = double(st.samples) / double(size * size);
    EXPECT_GE(compare_images(a, render_exact("wave", cam, tf, rs)).psnr_db, 35.0) << size;
  }
  EXPECT_GT(per_pixel[0], 1.0);
  EXPECT_NEAR(per_pixel[1] / per_pixel[0], 1.0, 0.05) << per_pixel[0] << " " << per_pixel[1];
}

TEST(LodEngine, CoarserCutsUseFewerNodesAndStayClose) {
  REQUIRE_GL();
  const Shared& s = shared();
  const ExactEngine probe(s.dataset);
  const Camera cam = camera_preset("iso", probe.bounds());
  RenderSettings rs;
  rs.width = rs.height = 64;
  const TransferFunction tf = linear_tf(-1.2, 1.2, 0.4);
  LodEngine lod(s.store, *s.gl);
  lod.set_field("wave");
  LodRenderStats leaves, coarse;
  const Image a = lod.render(cam, tf, rs, CutSpec{CutSpec::Kind::Leaves, 0}, &leaves);
  const Image b = lod.render(cam, tf, rs, CutSpec{CutSpec::Kind::Pixels, 8}, &coarse);
  EXPECT_LT(coarse.cut_nodes, leaves.cut_nodes);
  EXPECT_GE(compare_images(a, b).psnr_db, 25.0);
}

TEST(LodEngine, CorruptBrickIsAnErrorNotAnImage) {
  REQUIRE_GL();
  const Shared& s = shared();
  test::ScratchDir dir;
  const std::string path = dir.file("corrupt.ugvr");
  std::filesystem::copy_file(s.store, path);
  const InsideView v = inside_view(false);
  const CutSpec spec{CutSpec::Kind::Pixels, 1000};
  {
    const BrickStoreReader reader(path);
    const int field = reader.field_index("one");
    const Cut cut = select_cut(reader, spec, v.camera, v.settings.width, v.settings.height, linear_tf(0, 2, 0.5),
                               CutOptions{uint32_t(field)});
    ASSERT_FALSE(cut.nodes.empty());
    const BlockRef block = reader.block(cut.nodes[0], uint32_t(field));
    ASSERT_GT(block.size, 30u);
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(block.offset + block.size - 5));
    char c = 0;
    f.read(&c, 1);
    c = char(c ^ 0x5a);
    f.seekp(std::streamoff(block.offset + block.size - 5));
    f.write(&c, 1);
  }
  LodEngine lod(path, *s.gl);
  lod.set_field("one");
  try {
    lod.render(v.camera, linear_tf(0, 2, 0.5), v.settings, spec);
    FAIL() << "a corrupt brick was rendered";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt.ugvr"), std::string::npos) << e.what();
  }
}

// The time-critical path: the caller's cut, bricks from the RAM cache (background loads), the same image as the
// engine's own cut with bricks read synchronously.
TEST(LodEngine, CallersCutWithCachedBricksMatchesItsOwnCut) {
  REQUIRE_GL();
  const Shared& s = shared();
  const InsideView v = inside_view(false);
  const TransferFunction tf = linear_tf(-1, 1, 0.4);
  LodEngine a(s.store, *s.gl);
  a.set_field("wave");
  LodRenderStats st;
  const Image own = a.render(v.camera, tf, v.settings, CutSpec{CutSpec::Kind::Leaves, 0}, &st);

  const BrickStoreReader store(s.store);
  const uint32_t field = uint32_t(store.field_index("wave"));
  const Cut cut = select_cut(store, CutSpec{CutSpec::Kind::Leaves, 0}, v.camera, v.settings.width, v.settings.height,
                             tf, CutOptions{field});
  BrickCache cache(store, field, uint64_t(64) << 20, 2);
  std::vector<std::pair<uint64_t, float>> wanted;
  for (uint64_t n : cut.nodes) wanted.push_back({n, 1.0f});
  cache.request(wanted);
  ASSERT_TRUE(cache.wait_all(30));
  LodEngine b(s.store, *s.gl);
  b.set_field("wave");
  BrickResidency with_cache(b.store(), b.gpu_slots(), &cache);
  EXPECT_TRUE(with_cache.resident(cut.nodes[0]));
  EXPECT_FALSE(with_cache.on_gpu(cut.nodes[0]));
  LodRenderStats sb;
  const Image theirs = b.render_nodes(v.camera, tf, v.settings, cut.nodes, with_cache, &sb);
  EXPECT_EQ(compare_images(own, theirs).max_abs, 0.0);
  EXPECT_TRUE(with_cache.on_gpu(cut.nodes[0]));
  EXPECT_EQ(sb.bricks_read_sync, 0u);
  // A brick the RAM tier does not have is read by the engine itself: late, never a hole in the image.
  LodEngine c(s.store, *s.gl);
  c.set_field("wave");
  BrickCache empty(store, field, uint64_t(64) << 20, 1);
  BrickResidency with_empty(c.store(), c.gpu_slots(), &empty);
  LodRenderStats sc;
  const Image late = c.render_nodes(v.camera, tf, v.settings, cut.nodes, with_empty, &sc);
  EXPECT_EQ(compare_images(own, late).max_abs, 0.0);
  EXPECT_EQ(sc.bricks_read_sync, cut.nodes.size());
}

// The boundary overlay (RenderSettings::boundary_overlay_opacity). The LOD engine draws the boundary of the valid
// region of the bricks' stencils; on this box every face lies on a lattice plane of the octree (a node face or the
// root's face), so that boundary is the mesh's own and both engines must draw it in the same place and shade it alike.
struct OverlayCase {
  const char* name;
  Camera camera;
  RenderSettings settings;
  TransferFunction tf;
  std::string field;
};

std::vector<OverlayCase> overlay_cases() {
  const ExactEngine probe(shared().dataset);
  std::vector<OverlayCase> cases;
  RenderSettings rs;
  rs.width = rs.height = 96;
  rs.boundary_overlay_opacity = 0.3;
  cases.push_back({"iso", camera_preset("iso", probe.bounds()), rs, linear_tf(-1.2, 1.2, 0.4), "wave"});
  // From below and behind: the other three faces, and the ray's exit from the box on the root's faces.
  Camera back = camera_preset("iso", probe.bounds());
  back.position = back.focal_point + (back.focal_point - back.position);
  cases.push_back({"back", back, rs, linear_tf(-0.5, 2.5, 0.4), "lin"});
  // A clip plane through the box: its cut is no boundary (neither engine draws it) and faces behind it stay drawn.
  RenderSettings clipped = rs;
  clipped.clip_plane = ClipPlane{{0.4, 0.4, 0.25}, {1, 0.2, -0.4}};
  cases.push_back({"clip", camera_preset("iso", probe.bounds()), clipped, linear_tf(-1.2, 1.2, 0.4), "wave"});
  // The other half: the cut faces the camera, rays start on it inside the data.
  clipped.clip_plane->normal = clipped.clip_plane->normal * -1.0;
  cases.push_back({"clip facing", camera_preset("iso", probe.bounds()), clipped, linear_tf(-1.2, 1.2, 0.4), "wave"});
  // Isosurfaces between the entry and the exit.
  RenderSettings iso = rs;
  iso.mode = RenderMode::Isosurface;
  iso.iso_values = {0.6, 1.4};
  iso.iso_opacity = 0.6;
  cases.push_back({"isosurface", camera_preset("iso", probe.bounds()), iso, linear_tf(-0.5, 2.5, 0.4), "lin"});
  // Opacity zero below 0: most of the box is transparent and the cut would drop its nodes (transfer-function
  // culling), which must not put a boundary around the opaque part.
  TransferFunction half = linear_tf(-1.2, 1.2, 0.5);
  half.opacity_points = {{-1.2, 0}, {0, 0}, {1.2, 0.5}};
  cases.push_back({"transparent part", camera_preset("iso", probe.bounds()), rs, half, "wave"});
  return cases;
}

TEST(LodOverlay, ZeroOpacityChangesNothing) {
  REQUIRE_GL();
  const Shared& s = shared();
  LodEngine lod(s.store, *s.gl);
  for (const OverlayCase& c : overlay_cases()) {
    lod.set_field(c.field);
    RenderSettings off = c.settings;
    off.boundary_overlay_opacity = 0;
    RenderSettings plain = off;
    plain.boundary_overlay_opacity = RenderSettings{}.boundary_overlay_opacity;
    EXPECT_EQ(compare_images(lod.render(c.camera, c.tf, off, CutSpec{CutSpec::Kind::Leaves, 0}),
                             lod.render(c.camera, c.tf, plain, CutSpec{CutSpec::Kind::Leaves, 0}))
                  .max_abs,
              0.0)
        << c.name;
  }
  // With the overlay on, rays that cross no boundary (they start at the eye inside the box and end at the clip
  // plane) are untouched bit for bit: the overlay's code leaves the volume integration alone, and neither the eye
  // nor the clip plane's cut counts as a boundary.
  for (bool parallel : {false, true}) {
    const InsideView v = inside_view(parallel);
    lod.set_field("wave");
    RenderSettings on = v.settings;
    on.boundary_overlay_opacity = 0.5;
    const TransferFunction tf = linear_tf(-1.2, 1.2, 0.4);
    EXPECT_EQ(compare_images(lod.render(v.camera, tf, on, CutSpec{CutSpec::Kind::Leaves, 0}),
                             lod.render(v.camera, tf, v.settings, CutSpec{CutSpec::Kind::Leaves, 0}))
                  .max_abs,
              0.0)
        << (parallel ? "parallel" : "perspective");
  }
}

TEST(LodOverlay, MatchesTheExactEngine) {
  REQUIRE_GL();
  const Shared& s = shared();
  LodOptions options;
  options.step_voxels = 0.25;
  LodEngine lod(s.store, *s.gl, options);
  for (const OverlayCase& c : overlay_cases()) {
    lod.set_field(c.field);
    RenderSettings off = c.settings;
    off.boundary_overlay_opacity = 0;
    const Image lod_on = lod.render(c.camera, c.tf, c.settings, CutSpec{CutSpec::Kind::Leaves, 0});
    const Image lod_off = lod.render(c.camera, c.tf, off, CutSpec{CutSpec::Kind::Leaves, 0});
    const Image exact_on = render_exact(c.field, c.camera, c.tf, c.settings);
    const Image exact_off = render_exact(c.field, c.camera, c.tf, off);
    const ImageDifference agree = compare_images(lod_on, exact_on);
    const ImageDifference without = compare_images(lod_off, exact_on);
    const ImageDifference one_sided = compare_images(lod_on, exact_off);
    const ImageDifference changed = compare_images(lod_on, lod_off);
    const ImageDifference reference = compare_images(lod_off, exact_off);
    std::printf(
        "%-16s on/on %.2f dB rms %.4f | off/off %.2f dB | lod off/exact on %.2f dB | lod on/exact off %.2f dB"
        " | lod on/off rms %.4f\n",
        c.name, agree.psnr_db, agree.rms, reference.psnr_db, without.psnr_db, one_sided.psnr_db, changed.rms);
    // Measured on llvmpipe (96², step 0.25 voxel): the engines agree within 42.9-60.0 dB with the overlay (42.5-119
    // dB without it), since the store keeps the boundary faces and the overlay is drawn on them with their normals
    // (with the stencil's boundary alone, before: 35.1-40.0 and 38-52 dB), while an image with the overlay on one
    // side only is at most 30.2 dB from the other, and the overlay changes the image by 0.032-0.066 rms. Planted
    // faults each failed here (measured with the stencil's boundary, before the faces): no exit crossings (29.3-34.5
    // dB), the clip plane's cut drawn (25.7 dB facing, 32.2 dB behind), the view direction as normal (16-22 dB), nodes
    // dropped by transfer-function culling (26.0 dB, "transparent part").
    EXPECT_GE(agree.psnr_db, 40.0) << c.name;
    EXPECT_GE(agree.psnr_db, std::max(without.psnr_db, one_sided.psnr_db) + 4.0) << c.name;
    EXPECT_GT(changed.rms, 0.02) << c.name;
  }
}

TEST(LodOverlay, NoEffectInMip) {
  REQUIRE_GL();
  const Shared& s = shared();
  const ExactEngine probe(s.dataset);
  const Camera cam = camera_preset("iso", probe.bounds());
  const TransferFunction tf = linear_tf(-0.5, 2.5, 0.4);
  LodEngine lod(s.store, *s.gl);
  lod.set_field("lin");
  RenderSettings mip;
  mip.width = mip.height = 96;
  mip.mode = RenderMode::Mip;
  RenderSettings on = mip;
  on.boundary_overlay_opacity = 0.8;
  EXPECT_EQ(compare_images(lod.render(cam, tf, on, CutSpec{CutSpec::Kind::Leaves, 0}),
                           lod.render(cam, tf, mip, CutSpec{CutSpec::Kind::Leaves, 0}))
                .max_abs,
            0.0);
}

TEST(GlPrograms, DriverLogsNameTheFileAndLine) {
  const std::vector<std::string> files = {"shaders/a.comp", "shaders/common.glsl"};
  EXPECT_EQ(map_shader_log("0:12(5): error: `x' undeclared\n", files), "shaders/a.comp:12:5: error: `x' undeclared\n");
  EXPECT_EQ(map_shader_log("1(7) : error C1008: undefined variable\n", files),
            "shaders/common.glsl:7 : error C1008: undefined variable\n");
  EXPECT_EQ(map_shader_log("no location here\n", files), "no location here\n");
}

TEST(GlPrograms, IncludesAndDefinesKeepLineNumbers) {
  test::ScratchDir dir;
  const std::string d = dir.file("");
  std::ofstream(dir.file("main.comp")) << "#version 450\n// one\n#include \"inc.glsl\"\nvoid main() {}\n";
  std::ofstream(dir.file("inc.glsl")) << "float f() { return 1.0; }\n";
  setenv("UGVR_SHADER_DIR", d.c_str(), 1);
  std::vector<std::string> files;
  const std::string src = preprocess_shader("main.comp", {{"MODE", "2"}}, files);
  unsetenv("UGVR_SHADER_DIR");
  ASSERT_EQ(files.size(), 2u);
  EXPECT_NE(src.find("#define MODE 2\n#line 2 0\n// one\n"), std::string::npos) << src;
  EXPECT_NE(src.find("#line 100001 1\nfloat f()"), std::string::npos) << src;  // file 1's lines: 100000 + n
  EXPECT_NE(src.find("#line 4 0\nvoid main()"), std::string::npos) << src;
}

TEST(GlPrograms, CompileErrorsNameTheShaderFile) {
  REQUIRE_GL();
  test::ScratchDir dir;
  std::ofstream(dir.file("bad.comp"))
      << "#version 450\nlayout(local_size_x = 1) in;\nvoid main() { undeclared = 1; }\n";
  const std::string d = dir.file("");
  setenv("UGVR_SHADER_DIR", d.c_str(), 1);
  try {
    ComputeProgram p("bad.comp");
    unsetenv("UGVR_SHADER_DIR");
    FAIL() << "compiled";
  } catch (const Error& e) {
    unsetenv("UGVR_SHADER_DIR");
    EXPECT_NE(std::string(e.what()).find("bad.comp:3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ugvr
