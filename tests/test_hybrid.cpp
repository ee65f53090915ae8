// Hybrid rendering (the [hybrid] issue, part 2; docs/hybrid.md): the LOD engine draws the cut nodes that keep their
// cells in the store (`ugvr build --cells`, format version 5) by walking those cells (shaders/cell_walk.glsl, the exact
// engine's walk) in the same ray-casting pass as the resampled nodes, the ray's stretch clamped to each node's box.
//
// The mesh: `ugvr generate --kind mixed` at 3,000 cells (tetrahedra, pyramids, wedges and hexahedra around a wing on
// a floor), built to a store of 8³ bricks with its leaves' cells. At convergence (every visible leaf with cells
// exact) the image is the exact engine's up to float arithmetic and the integration of the transfer function; the
// voxel image of the same store is further away.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>

#include "column_mesh.h"
#include "gl_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/cell_cache.h"
#include "ugvr/render/lod/hybrid_select.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"
#include "ugvr/render/renderer.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::CommandResult;
using test::run_ugvr;

struct Fixture {
  std::filesystem::path dir;
  Dataset dataset;
  std::string store;
  std::unique_ptr<GlContext> gl;
  std::string gl_error;
};

Fixture& fixture() {
  static Fixture f = [] {
    Fixture r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-hybrid-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    GenerateOptions g;
    g.cells = 3000;
    g.kind = GenCellKind::Mixed;
    r.dataset = generate_in_memory(g);
    const std::vector<std::string> fields = {"pressure"};
    OctreeBuildOptions o;
    o.resolution = 8;
    o.max_depth = 3;
    o.error = 0.02;
    o.leaf_cells = true;
    r.store = (r.dir / "cells.ugvr").string();
    build_octree(prepare_octree_input(r.dataset, fields), o, r.store);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return f;
}

#define REQUIRE_GL() UGVR_REQUIRE_GL_CONTEXT(fixture().gl, fixture().gl_error)

// A transfer function whose opacity rises steeply over a band of the range (where voxels and cells differ most), with
// colour varying over the whole range; translucent enough that rays cross many nodes and cells.
TransferFunction test_tf(const Fixture& f) {
  const BrickStoreReader probe(f.store);
  const BrickStoreField& fd = probe.layout().fields[0];
  const auto at = [&](double u) { return fd.min + u * (fd.max - fd.min); };
  TransferFunction tf;
  tf.color_points = {{at(0), {0.1, 0.2, 0.9}}, {at(0.5), {0.2, 0.9, 0.3}}, {at(1), {0.95, 0.2, 0.1}}};
  tf.opacity_points = {{at(0), 0.0}, {at(0.45), 0.0}, {at(0.55), 0.9}, {at(1), 0.9}};
  tf.opacity_unit_distance = 0.05 * probe.layout().data.size().x;
  return tf;
}

RenderSettings test_settings() {
  RenderSettings rs;
  rs.width = rs.height = 96;
  rs.background = {0, 0, 0, 1};
  return rs;
}

// Every leaf's cells become a walk mesh of their own whose entry triangles bound them: a closed surface (every edge
// of the entry triangles is shared by two of them), as the walk's re-entries need.
TEST(Hybrid, PreparedNodeCellsAreClosed) {
  const Fixture& f = fixture();
  const BrickStoreReader store(f.store);
  ASSERT_TRUE(store.has_cells());
  uint64_t nodes = 0;
  for (uint64_t n = 0; n < store.node_count(); ++n) {
    if (store.cell_block(n).offset == 0) continue;
    const PreparedNodeCells p = prepare_node_cells(store, n, 0);
    const NodeCells nc = store.read_cells(n);
    EXPECT_EQ(p.cells, nc.cell_count());
    EXPECT_EQ(p.points, nc.points.size());
    EXPECT_GE(p.entry_count, 4u);
    // Normalised positions: within the root cell (the cells of a leaf reach at most one cell beyond it).
    for (uint32_t i = 0; i < 3 * p.points; ++i) {
      EXPECT_GE(p.floats[i], -1e-6f);
      EXPECT_LE(p.floats[i], 1.0f + 1e-6f);
    }
    // The field's values, within its range.
    const BrickStoreField& fd = store.layout().fields[0];
    EXPECT_EQ(p.floats.size(), 3 * p.points + p.points + 6);  // pressure is a vertex field; the entry grid's box
    EXPECT_EQ(p.grid_float_begin, 4 * p.points);
    for (size_t i = 3 * p.points; i < 4 * p.points; ++i) {
      EXPECT_GE(p.floats[i], float(fd.min) - 1e-6f);
      EXPECT_LE(p.floats[i], float(fd.max) + 1e-6f);
    }
    ++nodes;
  }
  EXPECT_GT(nodes, 4u);
}

// An entry triangle's positions as the shader reads them (normalised, float).
std::array<Vec3d, 3> entry_triangle(const PreparedNodeCells& p, uint32_t i) {
  const uint32_t b0 = p.ints[p.entry_begin + 2 * i], b1 = p.ints[p.entry_begin + 2 * i + 1];
  const uint32_t c = b0 >> 3;
  int k = 3;
  while (k > 0 && c < p.type_begin[size_t(k)]) --k;
  const CellType type = kAllCellTypes[size_t(k)];
  const CellFace face = cell_info(type).faces[b0 & 7];
  const uint32_t* vid =
      p.ints.data() + p.conn_begin[size_t(k)] + (c - p.type_begin[size_t(k)]) * cell_vertex_count(type);
  std::array<Vec3d, 3> out;
  for (int j = 0; j < 3; ++j) {
    const uint32_t v = vid[face.v[(b1 >> (2 * j)) & 3]];
    out[size_t(j)] = {p.floats[3 * v], p.floats[3 * v + 1], p.floats[3 * v + 2]};
  }
  return out;
}

// The entry grid (cell_cache.h): every point of every entry triangle lies in a grid cell that lists the triangle (so
// the shader's walk along the ray meets the triangle where the ray crosses it), lists are ascending, and the grid
// prunes: a grid cell lists a few triangles, not all. Without the grid (UGVR_HYBRID_ENTRY_GRID=0) one cell lists all.
TEST(Hybrid, EntryGridListsEachTriangleWhereItLies) {
  const Fixture& f = fixture();
  const BrickStoreReader store(f.store);
  uint64_t nodes = 0, listed = 0, triangles = 0;
  uint32_t seed = 12345;
  const auto rnd = [&] {
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  for (uint64_t n = 0; n < store.node_count(); ++n) {
    if (store.cell_block(n).offset == 0) continue;
    const PreparedNodeCells p = prepare_node_cells(store, n, 0);
    const std::array<uint32_t, 3> size = p.grid_size;
    const uint64_t grid_cells = uint64_t(size[0]) * size[1] * size[2];
    EXPECT_LE(grid_cells, uint64_t(p.entry_count) + 8);
    if (p.entry_count > 64) {
      EXPECT_GT(grid_cells, 8u);  // a grid, not one cell
    }
    const Vec3d lo{p.floats[p.grid_float_begin], p.floats[p.grid_float_begin + 1], p.floats[p.grid_float_begin + 2]};
    const Vec3d step{p.floats[p.grid_float_begin + 3], p.floats[p.grid_float_begin + 4],
                     p.floats[p.grid_float_begin + 5]};
    for (uint32_t z = 0; z < size[2]; ++z)
      for (uint32_t y = 0; y < size[1]; ++y)
        for (uint32_t x = 0; x < size[0]; ++x) {
          const std::vector<uint32_t> l = p.grid_cell(x, y, z);
          EXPECT_TRUE(std::is_sorted(l.begin(), l.end()));
          for (uint32_t i : l) EXPECT_LT(i, p.entry_count);
          listed += l.size();
        }
    for (uint32_t i = 0; i < p.entry_count; ++i) {
      const std::array<Vec3d, 3> t = entry_triangle(p, i);
      // The corners and random points inside: the grid cell they fall in (as the shader computes it) lists i.
      for (int s = 0; s < 12; ++s) {
        double a = s < 3 ? double(s == 0) : rnd(), b = s < 3 ? double(s == 1) : rnd();
        if (s >= 3 && a + b > 1) a = 1 - a, b = 1 - b;
        const Vec3d q = t[0] * a + t[1] * b + t[2] * (1 - a - b);
        std::array<uint32_t, 3> c{};
        for (size_t d = 0; d < 3; ++d) {
          const double x = (q[int(d)] - lo[int(d)]) / step[int(d)];
          ASSERT_GE(x, 0.0) << "node " << n << " triangle " << i << " outside the grid";
          ASSERT_LE(x, double(size[d]) + 1e-6) << "node " << n << " triangle " << i << " outside the grid";
          c[d] = std::min(uint32_t(x), size[d] - 1);
        }
        const std::vector<uint32_t> l = p.grid_cell(c[0], c[1], c[2]);
        EXPECT_TRUE(std::binary_search(l.begin(), l.end(), i)) << "node " << n << " triangle " << i;
      }
    }
    triangles += p.entry_count;
    const PreparedNodeCells one = prepare_node_cells(store, n, 0, false);
    ASSERT_EQ(one.grid_size, (std::array<uint32_t, 3>{1, 1, 1}));
    const std::vector<uint32_t> all = one.grid_cell(0, 0, 0);
    ASSERT_EQ(all.size(), one.entry_count);
    for (uint32_t i = 0; i < one.entry_count; ++i) EXPECT_EQ(all[i], i);
    ++nodes;
  }
  ASSERT_GT(nodes, 4u);
  // Pruning: a triangle is listed in a few grid cells, so the lists together are a small multiple of the triangles.
  std::printf("%llu nodes, %llu entry triangles, %.2f listed per triangle\n", (unsigned long long)nodes,
              (unsigned long long)triangles, double(listed) / double(triangles));
  EXPECT_LT(double(listed), 8.0 * double(triangles));
}

// The entry grid finds the linear scan's crossings: the converged hybrid image with it is the image without it
// (UGVR_HYBRID_ENTRY_GRID=0: one grid cell per node, every entry triangle tested), bit for bit, from views where rays
// enter, leave and re-enter the nodes' cells (the axes, along node faces, and an oblique one).
TEST(Hybrid, EntryGridDrawsTheLinearScansImage) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader probe(f.store);
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  LodOptions ho;
  ho.hybrid = true;
  LodEngine grid(f.store, *f.gl, ho);
  grid.set_field("pressure");
  ::setenv("UGVR_HYBRID_ENTRY_GRID", "0", 1);
  LodEngine scan(f.store, *f.gl, ho);
  scan.set_field("pressure");
  for (const char* view : {"iso", "+x", "-y", "+z"}) {
    const Camera cam = camera_preset(view, probe.layout().data);
    LodRenderStats sg, ss;
    const Image a = grid.render(cam, tf, rs, leaves, &sg);
    const Image b = scan.render(cam, tf, rs, leaves, &ss);
    ASSERT_GT(sg.exact_nodes, 4u) << view;
    EXPECT_EQ(sg.exact_nodes, ss.exact_nodes) << view;
    EXPECT_EQ(sg.cell_steps, ss.cell_steps) << view;
    EXPECT_EQ(compare_images(a, b).max_abs, 0.0) << view;
  }
  ::unsetenv("UGVR_HYBRID_ENTRY_GRID");
}

// The converged hybrid image equals the exact engine's within 45 dB at 96² and is closer to it than the voxel image of
// the same store; a node budget of zero gives the voxel image bit for bit.
TEST(Hybrid, ConvergesToTheExactEngine) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader probe(f.store);
  const Camera cam = camera_preset("iso", probe.layout().data);
  ExactEngine exact(f.dataset);
  exact.set_field(f.dataset, "pressure");
  const Image reference = exact.render(cam, tf, rs);

  LodEngine voxels(f.store, *f.gl);
  voxels.set_field("pressure");
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  const Image voxel_image = voxels.render(cam, tf, rs, leaves);

  LodOptions ho;
  ho.hybrid = true;
  LodEngine hybrid(f.store, *f.gl, ho);
  hybrid.set_field("pressure");
  LodRenderStats st;
  const Image hybrid_image = hybrid.render(cam, tf, rs, leaves, &st);
  EXPECT_TRUE(st.hybrid);
  EXPECT_EQ(st.hybrid_off, "");
  EXPECT_GT(st.exact_nodes, 4u);
  EXPECT_EQ(st.exact_nodes, st.exact_candidates);  // converged: every candidate exact
  EXPECT_FALSE(st.cell_budget_full);
  EXPECT_GT(st.cell_steps, 0u);

  const double p_hybrid = compare_images(hybrid_image, reference).psnr_db;
  const double p_voxels = compare_images(voxel_image, reference).psnr_db;
  std::printf("hybrid vs exact %.2f dB, voxels vs exact %.2f dB (%llu of %llu cut nodes exact, %llu cells)\n", p_hybrid,
              p_voxels, (unsigned long long)st.exact_nodes, (unsigned long long)st.cut_nodes,
              (unsigned long long)st.exact_cells);
  // Measured on llvmpipe: 94.9 dB hybrid, 58.9 dB voxels.
  EXPECT_GE(p_hybrid, 45.0);
  EXPECT_GT(p_hybrid, p_voxels + 3.0);

  // No exact node: the voxel image, bit for bit.
  hybrid.set_max_exact_nodes(0);
  LodRenderStats st0;
  const Image none = hybrid.render(cam, tf, rs, leaves, &st0);
  EXPECT_EQ(st0.exact_nodes, 0u);
  EXPECT_EQ(compare_images(none, voxel_image).max_abs, 0.0);

  // Part of the budget: in between (each exact node brings its part of the image to the exact one).
  hybrid.set_max_exact_nodes(st.exact_nodes / 2);
  LodRenderStats sth;
  const Image half = hybrid.render(cam, tf, rs, leaves, &sth);
  EXPECT_EQ(sth.exact_nodes, st.exact_nodes / 2);
  const double p_half = compare_images(half, reference).psnr_db;
  std::printf("half the nodes exact: %.2f dB\n", p_half);
  EXPECT_GT(p_half, p_voxels);
  EXPECT_LT(p_half, p_hybrid);
}

// MIP and isosurfaces: an exact node's maximum is its pieces' larger ends, and its surfaces where the linear pieces
// cross the values, shaded by the cell's gradient (the exact engine's rules), on values normalised to the field's range
// as the voxel nodes' samples are: one maximum and one set of surfaces per ray. Tricubic isosurfaces, those of a cell
// field, and volume lighting fall back to the bricks.
TEST(Hybrid, MipAndIsosurfacesConvergeToTheExactEngine) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const BrickStoreReader probe(f.store);
  const BrickStoreField& fd = probe.layout().fields[0];
  const Camera cam = camera_preset("iso", probe.layout().data);
  ExactEngine exact(f.dataset);
  exact.set_field(f.dataset, "pressure");
  LodEngine voxels(f.store, *f.gl);
  voxels.set_field("pressure");
  LodOptions ho;
  ho.hybrid = true;
  LodEngine hybrid(f.store, *f.gl, ho);
  hybrid.set_field("pressure");
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};

  RenderSettings mip = test_settings();
  mip.mode = RenderMode::Mip;
  RenderSettings iso = test_settings();
  iso.mode = RenderMode::Isosurface;
  iso.iso_values = {fd.min + 0.5 * (fd.max - fd.min), fd.min + 0.68 * (fd.max - fd.min)};
  for (const RenderSettings& rs : {mip, iso}) {
    const Image reference = exact.render(cam, tf, rs);
    const Image voxel_image = voxels.render(cam, tf, rs, leaves);
    LodRenderStats st;
    const Image hybrid_image = hybrid.render(cam, tf, rs, leaves, &st);
    EXPECT_EQ(st.hybrid_off, "");
    EXPECT_GT(st.exact_nodes, 4u);
    EXPECT_EQ(st.exact_nodes, st.exact_candidates);
    EXPECT_GT(st.cell_steps, 0u);
    const double p_hybrid = compare_images(hybrid_image, reference).psnr_db;
    const double p_voxels = compare_images(voxel_image, reference).psnr_db;
    std::printf("%s: hybrid vs exact %.2f dB, voxels vs exact %.2f dB\n", rs.mode == RenderMode::Mip ? "MIP" : "iso",
                p_hybrid, p_voxels);
    // Measured on llvmpipe (ASan build): MIP 121.5 dB hybrid, 47.5 dB voxels; isosurfaces 113.5 dB and 43.2 dB.
    EXPECT_GE(p_hybrid, 60.0);
    EXPECT_GT(p_hybrid, p_voxels + 10.0);
  }

  iso.interpolation = Interpolation::Tricubic;
  LodRenderStats sti;
  hybrid.render(cam, tf, iso, leaves, &sti);
  EXPECT_EQ(sti.exact_nodes, 0u);
  EXPECT_EQ(sti.hybrid_off, "exact cells draw isosurfaces with trilinear interpolation only");
  // Lit exact pieces would sit unshaded among lit voxels: the frame is the bricks'.
  RenderSettings lit = test_settings();
  lit.width = lit.height = 16;
  lit.volume_lighting = true;
  LodRenderStats stl;
  hybrid.render(cam, tf, lit, leaves, &stl);
  EXPECT_EQ(stl.exact_nodes, 0u);
  EXPECT_EQ(stl.hybrid_off, "exact cells are drawn without volume lighting only");
}

// The viewer's resting frames can be cut short (FrameRequest::keep_going): the engines ask between bands of rows (GPU)
// or tiles (CPU). Drawn in bands the image is the one-dispatch image bit for bit; a frame stopped part-way throws
// FrameInterrupted, and the engine's next frame is as if it had never begun.
TEST(Hybrid, AFrameIsInterruptedBetweenBandsAndTheNextIsUnchanged) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();  // 96 x 96: 12 rows of 8 x 8 work groups, a band each
  const BrickStoreReader probe(f.store);
  const Camera cam = camera_preset("iso", probe.layout().data);
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  LodOptions ho;
  ho.hybrid = true;
  LodEngine hybrid(f.store, *f.gl, ho);
  hybrid.set_field("pressure");
  LodRenderStats whole_st;
  const Image whole = hybrid.render(cam, tf, rs, leaves, &whole_st);
  ASSERT_GT(whole_st.exact_nodes, 0u);

  int asked = 0;
  hybrid.set_keep_going([&] { return ++asked > 0; });
  LodRenderStats banded_st;
  const Image banded = hybrid.render(cam, tf, rs, leaves, &banded_st);
  EXPECT_EQ(asked, 12) << "one question a band";
  EXPECT_EQ(compare_images(banded, whole).max_abs, 0.0);
  EXPECT_EQ(banded_st.exact_nodes, whole_st.exact_nodes);
  EXPECT_EQ(banded_st.cell_steps, whole_st.cell_steps);

  asked = 0;
  hybrid.set_keep_going([&] { return ++asked < 4; });  // stops before the fourth band
  EXPECT_THROW(hybrid.render(cam, tf, rs, leaves), FrameInterrupted);
  EXPECT_EQ(asked, 4);
  hybrid.set_keep_going({});
  LodRenderStats after_st;
  const Image after = hybrid.render(cam, tf, rs, leaves, &after_st);
  EXPECT_EQ(compare_images(after, whole).max_abs, 0.0);
  EXPECT_EQ(after_st.exact_nodes, whole_st.exact_nodes);

  // The exact engine (CPU) asks per tile, and likewise.
  ExactEngine exact(f.dataset);
  exact.set_field(f.dataset, "pressure");
  const Image reference = exact.render(cam, tf, rs);
  std::atomic<int> tiles{0};
  exact.set_keep_going([&] { return ++tiles > 0; });
  EXPECT_EQ(compare_images(exact.render(cam, tf, rs), reference).max_abs, 0.0);
  EXPECT_GT(tiles.load(), 1);
  exact.set_keep_going([] { return false; });
  EXPECT_THROW(exact.render(cam, tf, rs), FrameInterrupted);
  exact.set_keep_going({});
  EXPECT_EQ(compare_images(exact.render(cam, tf, rs), reference).max_abs, 0.0);
}

// A node whose cells cannot fit what is left of the cell budget is sized from its block's header and never read or
// prepared (a 250M-cell store's largest leaves took minutes and gigabytes to prepare before the budget refused them).
// The bound from the header is below the prepared size, so what fits is still granted.
// llvmpipe ends a shader invocation's loops after 65,535 back edges in all (shaders/loop_limit_probe.glsl). Down a
// column of 3,000 hexahedra every ray walks all of them and is cut short: each is flagged and drawn from the voxels of
// the same cut, so the frame is the voxel frame, not rays stopped part-way. On a hardware GPU nothing is cut.
TEST(Hybrid, RaysCutByTheDevicesLoopLimitAreDrawnFromTheVoxels) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const Dataset ds = test::column_mesh();
  OctreeBuildOptions o;
  o.leaf_cells = true;
  const std::string store = (f.dir / "column.ugvr").string();
  const std::vector<std::string> fields = {"s"};
  build_octree(prepare_octree_input(ds, fields), o, store);

  const Camera cam = test::column_camera();  // parallel rays: each crosses all 3,000 cells
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(-1.0, 1.6);
  tf.opacity_unit_distance = 3000;
  RenderSettings rs;
  rs.width = rs.height = 16;
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  LodOptions ho;
  ho.hybrid = true;
  LodEngine hybrid(store, *f.gl, ho);
  hybrid.set_field("s");
  LodRenderStats st;
  const Image h = hybrid.render(cam, tf, rs, leaves, &st);
  ASSERT_GT(st.exact_nodes, 0u);
  LodEngine voxels(store, *f.gl);
  voxels.set_field("s");
  const Image v = voxels.render(cam, tf, rs, leaves);
  if (f.gl->software()) {
    EXPECT_EQ(st.loop_limit_rays, 256u) << "every ray walks 3,000 cells: llvmpipe cuts it";
    EXPECT_EQ(st.loop_limit_voxel_rays, st.loop_limit_rays);
    EXPECT_EQ(compare_images(h, v).max_abs, 0.0) << "every ray drawn from the voxels";
  } else {
    EXPECT_EQ(st.loop_limit_rays, 0u);
  }
}

TEST(Hybrid, ANodeTooLargeForTheCellBudgetIsNeverPrepared) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader store(f.store);
  const Camera cam = camera_preset("iso", store.layout().data);
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  uint64_t smallest = UINT64_MAX, with_cells = 0;
  for (uint64_t n = 0; n < store.node_count(); ++n) {
    if (store.cell_block(n).offset == 0) continue;
    ++with_cells;
    const uint64_t bound = prepared_bytes_at_least(store.cell_block_header(n));
    const uint64_t prepared = prepare_node_cells(store, n, 0).bytes();
    EXPECT_LE(bound, prepared) << "node " << n;
    EXPECT_GT(bound, prepared / 4) << "node " << n << ": a bound that says little";
    smallest = std::min(smallest, bound);
  }
  ASSERT_GT(with_cells, 4u);

  LodOptions ho;
  ho.hybrid = true;
  ho.cell_budget_bytes = smallest - 1;  // no node fits
  LodEngine tight(f.store, *f.gl, ho);
  tight.set_field("pressure");
  LodRenderStats st;
  tight.render(cam, tf, rs, leaves, &st);
  EXPECT_GT(st.exact_candidates, 0u);
  EXPECT_EQ(st.exact_nodes, 0u);
  EXPECT_TRUE(st.cell_budget_full);
  EXPECT_EQ(st.cells_prepared, 0u) << "nodes that could not fit were read and prepared";
}

// The GPU buffers have a cap of their own (the driver's largest storage block: 128 MiB on llvmpipe, below the default
// cell budget). Once they are full, the remaining candidates are sized from their headers and not prepared: a 1024²
// view of the 250M-cell store prepared all 1,533 candidates in one frame to refuse 1,492 of them (5 GB of RAM).
TEST(Hybrid, FullCellBuffersPrepareNoMoreNodes) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader store(f.store);
  const Camera cam = camera_preset("iso", store.layout().data);
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  uint64_t largest_ints = 0;
  for (uint64_t n = 0; n < store.node_count(); ++n)
    if (store.cell_block(n).offset != 0)
      largest_ints = std::max<uint64_t>(largest_ints, prepare_node_cells(store, n, 0).ints.size());
  // Room for the largest node and a little more: some nodes are granted, most are not.
  ::setenv("UGVR_CELL_BUFFER_MAX_BYTES", std::to_string(largest_ints * 4 * 3 / 2).c_str(), 1);
  LodOptions ho;
  ho.hybrid = true;
  ho.cell_budget_bytes = uint64_t(1) << 30;  // the budget never binds: the buffers' cap does
  LodEngine capped(f.store, *f.gl, ho);
  capped.set_field("pressure");
  LodRenderStats st;
  capped.render(cam, tf, rs, leaves, &st);  // the cell cache is made (and reads the cap) at the first hybrid frame
  ::unsetenv("UGVR_CELL_BUFFER_MAX_BYTES");
  ASSERT_GT(st.exact_candidates, 4u);
  EXPECT_GE(st.exact_nodes, 1u);
  EXPECT_LT(st.exact_nodes + 2, st.exact_candidates);
  EXPECT_TRUE(st.cell_budget_full);
  EXPECT_LT(st.cells_prepared + 2, st.exact_candidates) << "candidates that could not fit the buffers were prepared";
  // The next frame knows every size it learnt: nothing is prepared again, the same nodes are granted.
  LodRenderStats again;
  capped.render(cam, tf, rs, leaves, &again);
  EXPECT_EQ(again.cells_prepared, 0u);
  EXPECT_EQ(again.exact_nodes, st.exact_nodes);
  EXPECT_EQ(again.exact_cells, st.exact_cells);
}

// Nodes meet without a seam (Muigg's F18): from views along the axes, where rays run along and across node faces, the
// converged image stays at the exact engine's; a stretch of a ray counted in two nodes, or in none, would show as a
// line of pixels far off.
TEST(Hybrid, NoSeamsAtNodeBorders) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader probe(f.store);
  ExactEngine exact(f.dataset);
  exact.set_field(f.dataset, "pressure");
  LodOptions ho;
  ho.hybrid = true;
  LodEngine hybrid(f.store, *f.gl, ho);
  hybrid.set_field("pressure");
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  for (const char* view : {"+x", "-y", "+z"}) {
    const Camera cam = camera_preset(view, probe.layout().data);
    const Image reference = exact.render(cam, tf, rs);
    LodRenderStats st;
    const Image im = hybrid.render(cam, tf, rs, leaves, &st);
    const ImageDifference d = compare_images(im, reference);
    std::printf("%s: %.2f dB, max %.4f\n", view, d.psnr_db, d.max_abs);
    // An axis-aligned view puts rays along node faces: a seam (a stretch counted twice or skipped) would show as a
    // line of pixels far off the reference.
    // Measured on llvmpipe: 84.8, 79.5 and 121.6 dB, max 0.005 (rays grazing the floor's cell faces in float).
    EXPECT_GE(d.psnr_db, 60.0) << view;
    EXPECT_LT(d.max_abs, 0.02) << view;
  }
}

// The fixture's store drawn at its leaves (field pressure) with `options`: the engine, for what it read, and the
// frame's figures.
struct DrawnLeaves {
  std::unique_ptr<LodEngine> engine;
  LodRenderStats stats;
};
DrawnLeaves draw_leaves(const Fixture& f, const LodOptions& options, const Camera& cam, const TransferFunction& tf,
                        const RenderSettings& rs) {
  DrawnLeaves d{std::make_unique<LodEngine>(f.store, *f.gl, options), {}};
  d.engine->set_field("pressure");
  d.engine->render(cam, tf, rs, CutSpec{CutSpec::Kind::Leaves, 0}, &d.stats);
  return d;
}

// Degree of interest: with a focus range only nodes whose values meet it get exact cells, and nodes of zero interest
// load no cells at all (none is read from the store); the rest of the image stays the voxels'.
TEST(Hybrid, FocusLoadsNoCellsOutside) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader store(f.store);
  const Camera cam = camera_preset("iso", store.layout().data);
  LodOptions ho;
  ho.hybrid = true;
  // Without focus: every candidate exact. The focus range then reaches from the lowest of their minima to below the
  // median: the candidates whose values all lie above it are left out.
  const DrawnLeaves all = draw_leaves(f, ho, cam, tf, rs);
  const LodRenderStats& sa = all.stats;
  std::vector<float> mins;
  for (uint64_t n : all.engine->cell_nodes_in_ram()) mins.push_back(store.stats(n, 0).min);
  ASSERT_GE(mins.size(), 4u);
  std::sort(mins.begin(), mins.end());
  const double lo = mins.front(), hi = 0.5 * (double(mins[mins.size() / 2 - 1]) + double(mins[mins.size() / 2]));
  ASSERT_LT(lo, hi);

  ho.focus = parse_focus("pressure:" + std::to_string(lo) + ":" + std::to_string(hi));
  const DrawnLeaves focused = draw_leaves(f, ho, cam, tf, rs);
  const LodRenderStats& st = focused.stats;
  EXPECT_GT(st.exact_nodes, 0u);
  EXPECT_GT(st.focus_excluded, 0u);
  EXPECT_EQ(sa.exact_nodes, st.exact_nodes + st.focus_excluded);
  // Zero-interest nodes load no cells: every node read from the store meets the range.
  const std::vector<uint64_t> loaded = focused.engine->cell_nodes_in_ram();
  EXPECT_EQ(loaded.size(), st.exact_nodes);
  for (uint64_t n : loaded) {
    const FieldStats& s = store.stats(n, 0);
    EXPECT_TRUE(double(s.min) <= hi && double(s.max) >= lo) << "node " << n << " [" << s.min << ", " << s.max << "]";
  }
}

// A region of interest (LaMar) and an AND of focus ranges: only nodes of interest 1 get exact cells, and nodes of zero
// interest read no cells from the store.
TEST(Hybrid, RegionOfInterestAndFocusAndLoadNoCellsOutside) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader store(f.store);
  const Camera cam = camera_preset("iso", store.layout().data);
  LodOptions ho;
  ho.hybrid = true;
  const LodRenderStats sa = draw_leaves(f, ho, cam, tf, rs).stats;
  ASSERT_GT(sa.exact_nodes, 4u);

  // The lower half in x of the root cell.
  const Bounds& root = store.layout().root;
  const double mid = 0.5 * (root.lo.x + root.hi.x);
  RegionOfInterest roi;
  roi.lo = root.lo - Vec3d{1, 1, 1};
  roi.hi = Vec3d{mid - 1e-9 * (root.hi.x - root.lo.x), root.hi.y + 1, root.hi.z + 1};
  ho.roi = roi;
  const DrawnLeaves in_box = draw_leaves(f, ho, cam, tf, rs);
  const LodRenderStats& sb = in_box.stats;
  EXPECT_GT(sb.exact_nodes, 0u);
  EXPECT_LT(sb.exact_nodes, sa.exact_nodes);
  EXPECT_GT(sb.focus_excluded, 0u);
  const std::vector<uint64_t> loaded = in_box.engine->cell_nodes_in_ram();
  EXPECT_EQ(loaded.size(), sb.exact_nodes);
  for (uint64_t n : loaded) EXPECT_LT(store.bounds(n).lo.x, mid) << "node " << n << " outside the region read cells";

  // AND: the region and a focus range that no node meets: nothing exact, no cell read.
  const FieldStats& whole = store.stats(0, 0);
  ho.focus =
      parse_focus("pressure:" + std::to_string(double(whole.min)) + ":" + std::to_string(double(whole.max)) +
                  "+pressure:" + std::to_string(double(whole.max) + 1) + ":" + std::to_string(double(whole.max) + 2));
  const DrawnLeaves none = draw_leaves(f, ho, cam, tf, rs);
  EXPECT_EQ(none.stats.exact_nodes, 0u);
  EXPECT_TRUE(none.engine->cell_nodes_in_ram().empty());
  // OR of the same two: the first holds everywhere, so the region alone decides.
  ho.focus = parse_focus(focus_text(ho.focus).replace(focus_text(ho.focus).find('+'), 1, ","));
  EXPECT_EQ(draw_leaves(f, ho, cam, tf, rs).stats.exact_nodes, sb.exact_nodes);
}

// Focus+context (Muigg eq. 3.15): with a region of interest, the nodes outside it are drawn desaturated and faint; the
// rays that cross only nodes of interest are the image without focus, bit for bit. Seen along -z in parallel
// projection, the region is the lower half in x of the root cell: columns left of its middle cross focus nodes only,
// those right of it context nodes only.
TEST(Hybrid, ContextIsDrawnDesaturatedAndFaint) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  // The same opacity in white: the context's colour cannot change (white is its own luminance), only its opacity.
  // It is also fainter than the test's, so that rays do not saturate: where they do, fainter context would still
  // reach an opacity of 1 and show no change.
  TransferFunction white = tf;
  for (ColorPoint& p : white.color_points) p.rgb = {1, 1, 1};
  for (OpacityPoint& p : white.opacity_points) p.opacity *= 0.1;
  RenderSettings rs = test_settings();
  rs.width = rs.height = 64;
  const BrickStoreReader store(f.store);
  const Bounds& root = store.layout().root;
  const Vec3d centre = 0.5 * (root.lo + root.hi), size = root.hi - root.lo;
  Camera cam;
  cam.focal_point = centre;
  cam.position = centre + Vec3d{0, 0, 3 * size.z};
  cam.view_up = {0, 1, 0};
  cam.parallel_projection = true;
  cam.parallel_scale = 0.5 * std::max(size.x, size.y);  // the root cell's x range spans the image's width
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  LodEngine plain(f.store, *f.gl);
  plain.set_field("pressure");
  const Image full = plain.render(cam, tf, rs, leaves), full_white = plain.render(cam, white, rs, leaves);

  LodOptions o;
  RegionOfInterest roi;
  roi.lo = root.lo - size;
  roi.hi = Vec3d{centre.x - 1e-9 * size.x, root.hi.y + size.y, root.hi.z + size.z};
  o.roi = roi;
  LodEngine faint(f.store, *f.gl, o);  // the defaults: saturation 0.2, opacity 0.3
  faint.set_field("pressure");
  const Image fc = faint.render(cam, tf, rs, leaves), fc_white = faint.render(cam, white, rs, leaves);
  // Grey context (saturation 0) at full opacity: the context's colour alone changes.
  o.context_saturation = 0, o.context_opacity = 1;
  LodEngine grey(f.store, *f.gl, o);
  grey.set_field("pressure");
  const Image gc = grey.render(cam, tf, rs, leaves);

  const int w = rs.width, margin = 3;
  int focus_px = 0, context_px = 0, fainter = 0, grey_px = 0, coloured_px = 0;
  for (int y = 0; y < rs.height; ++y)
    for (int x = 0; x < w; ++x) {
      const float *a = full.pixel(x, y), *b = fc.pixel(x, y), *g = gc.pixel(x, y);
      if (x < w / 2 - margin) {
        ++focus_px;
        for (int c = 0; c < 4; ++c) {
          ASSERT_EQ(a[c], b[c]) << "focus pixel " << x << "," << y << " changed";
          ASSERT_EQ(a[c], g[c]) << "focus pixel " << x << "," << y << " changed";
          ASSERT_EQ(full_white.pixel(x, y)[c], fc_white.pixel(x, y)[c]);
        }
      } else if (x >= w / 2 + margin && full_white.pixel(x, y)[0] > 0.05) {  // the background is black
        ++context_px;
        fainter += fc_white.pixel(x, y)[0] < full_white.pixel(x, y)[0];
        const auto spread = [](const float* p) { return std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}); };
        grey_px += spread(g) < 1e-4f;
        coloured_px += spread(a) > 0.01f;
      }
    }
  std::printf("focus pixels %d, visible context pixels %d: fainter %d, grey at saturation 0 %d (coloured without %d)\n",
              focus_px, context_px, fainter, grey_px, coloured_px);
  ASSERT_GT(context_px, 50) << "too little data on the context side to judge";
  EXPECT_GE(fainter, context_px * 9 / 10);
  EXPECT_EQ(grey_px, context_px);
  EXPECT_GT(coloured_px, context_px / 2) << "the test's colours would not show a desaturation";
  EXPECT_GT(compare_images(full, fc).max_abs, 0.05);
}

// `ugvr render --roi / --focus / --context-*`: bad values are errors naming the flag, before anything is drawn; the
// exact engine has no degree of interest.
TEST(Hybrid, InterestFlagsAreChecked) {
  const Fixture& f = fixture();
  const std::string out = (f.dir / "interest.png").string();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--engine lod --roi sphere:0,0,0,0", "--roi sphere:0,0,0,0: the radius must be > 0"},
      {"--engine hybrid --roi box:1,2", "--roi box:1,2: a box takes 6 numbers, found 2"},
      {"--engine lod --focus pressure:1:0", "MIN above MAX"},
      {"--engine lod --focus nope:0:1", "--focus: no field \"nope\" in the store"},
      {"--engine lod --roi box:0,0,0,1,1,1 --context-saturation 1.5", "--context-saturation: must be in [0, 1]"},
      {"--engine hybrid --focus pressure:0:1 --context-opacity -1", "--context-opacity: must be in [0, 1]"},
      {"--engine exact --roi box:0,0,0,1,1,1", "--roi: the degree of interest is the lod and hybrid engines'"},
  };
  for (const auto& [flags, message] : cases) {
    const CommandResult r = run_ugvr("render " + f.store + " " + flags + " --size 16 -o " + out);
    EXPECT_EQ(r.status, 1) << flags << "\n" << r.out;
    EXPECT_NE(r.out.find(message), std::string::npos) << flags << "\n" << r.out;
  }
}

// Progressive refinement (Callahan 2006) in the time-critical session: while the view moves no node is exact; once it
// rests and the cut has converged, more nodes turn exact per frame in priority order, every frame shown, and the
// session reports convergence only when every candidate is exact; a move starts again with none. With exact_growth 1
// each resting frame adds exact_batch nodes; with the default 2 the exact set doubles (4, 8, 16, ... may be exact), so
// it converges in fewer frames.
TEST(Hybrid, ProgressiveRefinementAtRest) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const TransferFunction tf = test_tf(f);
  const RenderSettings rs = test_settings();
  const BrickStoreReader store(f.store);
  std::vector<uint64_t> frames_to_exact;
  for (const double growth : {1.0, 2.0}) {
    SCOPED_TRACE("exact_growth " + std::to_string(growth));
    LodOptions ho;
    ho.hybrid = true;
    LodEngine engine(f.store, *f.gl, ho);
    engine.set_field("pressure");
    TimeCriticalOptions tco;
    tco.target_fps = 1000;  // a budget while moving
    tco.exact_batch = 4;
    tco.exact_growth = growth;
    tco.pixels = 0.05;  // the converged cut: the leaves, as the still image's
    TimeCriticalRenderer session(engine, tco);
    Camera cam = camera_preset("iso", store.layout().data);
    std::vector<uint64_t> exact;
    bool converged = false;
    TimeCriticalFrame fr;
    for (int i = 0; i < 60 && !converged; ++i) {
      session.frame(cam, tf, rs, &fr);
      exact.push_back(fr.render.exact_nodes);
      converged = fr.converged;
    }
    ASSERT_TRUE(converged);
    EXPECT_EQ(exact.front(), 0u);  // the first frame is not at rest
    const uint64_t candidates = fr.render.exact_candidates;
    EXPECT_EQ(fr.render.exact_nodes, candidates);
    EXPECT_GT(candidates, 16u);  // enough for the two schedules to differ
    // Frame by frame: never fewer exact nodes than before; at most 4 more (fixed batches), or at most the doubling
    // limit 4, 8, 16, ... and, while candidates remain, as many as it allows (the cell budget is not full here).
    size_t grew = 0, first_exact = 0;
    for (size_t i = 1; i < exact.size(); ++i) {
      EXPECT_GE(exact[i], exact[i - 1]);
      grew += exact[i] > exact[i - 1];
      if (exact[i] > 0 && first_exact == 0) first_exact = i;
      if (growth == 1) {
        EXPECT_LE(exact[i], exact[i - 1] + 4);
      } else if (first_exact > 0) {
        const uint64_t limit = uint64_t(4) << (i - first_exact);
        EXPECT_LE(exact[i], limit) << "frame " << i;
        EXPECT_EQ(exact[i], std::min(limit, candidates)) << "frame " << i;
      }
    }
    EXPECT_GE(grew, 3u);
    frames_to_exact.push_back(exact.size() - first_exact);
    // A move: no exact node in the moving frame.
    cam.position = cam.position + Vec3d{0.01, 0, 0};
    session.frame(cam, tf, rs, &fr);
    EXPECT_EQ(fr.render.exact_nodes, 0u);
    EXPECT_FALSE(fr.converged);
  }
  ASSERT_EQ(frames_to_exact.size(), 2u);
  EXPECT_LT(frames_to_exact[1], frames_to_exact[0]);
  std::printf("resting frames from the first exact node to all exact: fixed batches %zu, doubling %zu\n",
              size_t(frames_to_exact[0]), size_t(frames_to_exact[1]));
  // Out-of-range options are refused.
  LodOptions ho;
  ho.hybrid = true;
  LodEngine engine(f.store, *f.gl, ho);
  TimeCriticalOptions bad;
  bad.exact_growth = 0.5;
  EXPECT_THROW(TimeCriticalRenderer(engine, bad), Error);
  bad = {};
  bad.exact_batch = 0;
  EXPECT_THROW(TimeCriticalRenderer(engine, bad), Error);
}

TEST(Hybrid, ParseFocus) {
  const std::vector<FocusRange> f = parse_focus("pressure:-1:2.5,velocity:magnitude:0:1e3");
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f[0], (FocusRange{"pressure", -1, 2.5}));
  EXPECT_EQ(f[1], (FocusRange{"velocity:magnitude", 0, 1000, 1}));  // "," starts another group (OR)
  for (const char* bad : {"", "pressure", "pressure:1", "pressure:2:1", ":1:2", "p:a:2", "p:1:2,", "p:1:inf"})
    EXPECT_THROW(parse_focus(bad), Error) << bad;
}

// Smooth brush edges at the node level: a node whose values come within a range's edge has an interest between 0 and
// 1 (the window at the gap between the ranges), so it stays a candidate, its priority scaled by that interest. A range
// above every value: without an edge no node is a candidate; with an edge of four times the field's range all are.
TEST(Hybrid, NodesWithinTheEdgeAreCandidatesByTheirInterest) {
  const Fixture& f = fixture();
  const BrickStoreReader store(f.store);
  const BrickStoreField& fd = store.layout().fields[0];
  const double w = fd.max - fd.min;
  std::vector<uint64_t> all(store.node_count());
  for (uint64_t n = 0; n < all.size(); ++n) all[n] = n;
  const Camera cam = camera_preset("iso", store.layout().data);
  const TfNodeErrors no_errors(store, 0);
  const std::vector<ExactCandidate> base = exact_candidates(store, all, cam, 96, 96, no_errors);
  ASSERT_GT(base.size(), 4u);
  const std::string above = "pressure:" + std::to_string(fd.max + 0.5 * w) + ":" + std::to_string(fd.max + w);
  NodeInterest hard{resolve_focus(store, parse_focus(above)), std::nullopt};
  uint64_t excluded = 0;
  EXPECT_TRUE(exact_candidates(store, all, cam, 96, 96, no_errors, hard, &excluded).empty());
  EXPECT_EQ(excluded, base.size());
  NodeInterest soft{resolve_focus(store, parse_focus(above + "~" + std::to_string(4 * w))), std::nullopt};
  const std::vector<ExactCandidate> edged = exact_candidates(store, all, cam, 96, 96, no_errors, soft, &excluded);
  EXPECT_EQ(excluded, 0u);
  ASSERT_EQ(edged.size(), base.size());
  for (const ExactCandidate& c : edged) {
    const auto b = std::find_if(base.begin(), base.end(), [&](const ExactCandidate& x) { return x.node == c.node; });
    ASSERT_NE(b, base.end()) << c.node;
    const double doi = node_interest(store, c.node, soft);
    EXPECT_GT(doi, 0.0) << c.node;
    EXPECT_LT(doi, 1.0) << c.node;
    EXPECT_DOUBLE_EQ(c.priority, b->priority * doi) << c.node;
  }
}

// Smooth brush edges in exact nodes: with every focus range on the drawn field, the cells' pieces are mixed with their
// context colour by their values' interest as the bricks' samples are, so the hybrid image with an edge stays as close
// to the voxels' image with the same edge as it is without one. The range lies above every value with an edge of
// four times the field's range: every value's interest is strictly between 0 and 1 (0.16 to 0.84), every node with
// cells a candidate and exact.
TEST(Hybrid, ExactPiecesFollowTheBrushEdge) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  TransferFunction tf = test_tf(f);
  for (OpacityPoint& p : tf.opacity_points) p.opacity *= 0.1;  // unsaturated rays: a fainter context shows
  RenderSettings rs = test_settings();
  rs.width = rs.height = 48;  // every leaf exact, twice: the walk's cost on llvmpipe
  const BrickStoreReader store(f.store);
  const BrickStoreField& fd = store.layout().fields[0];
  const double w = fd.max - fd.min;
  const Camera cam = camera_preset("iso", store.layout().data);
  LodOptions edged;
  edged.focus = parse_focus("pressure:" + std::to_string(fd.max + 0.5 * w) + ":" + std::to_string(fd.max + w) + "~" +
                            std::to_string(4 * w));
  const auto draw = [&](LodOptions o, bool hybrid, LodRenderStats* st = nullptr) {
    o.hybrid = hybrid;
    LodEngine e(f.store, *f.gl, o);
    e.set_field("pressure");
    return e.render(cam, tf, rs, CutSpec{CutSpec::Kind::Leaves, 0}, st);
  };
  LodRenderStats st;
  const Image h0 = draw({}, true), l0 = draw({}, false), he = draw(edged, true, &st), le = draw(edged, false);
  EXPECT_GT(st.exact_nodes, 0u);
  EXPECT_EQ(st.focus_excluded, 0u);
  const double plain = compare_images(h0, l0).psnr_db, with_edge = compare_images(he, le).psnr_db;
  const double moved = compare_images(he, h0).psnr_db;
  std::printf(
      "hybrid vs voxels: %.2f dB plain, %.2f dB with the edge; hybrid with the edge vs plain %.2f dB "
      "(max %.3f)\n",
      plain, with_edge, moved, compare_images(he, h0).max_abs);
  EXPECT_GT(compare_images(he, h0).max_abs, 0.005) << "the edge must change the image to judge";
  EXPECT_GE(with_edge, plain - 3.0) << "the exact nodes are windowed as the voxels are";
  EXPECT_GT(with_edge, moved + 10.0);
}

// `ugvr render STORE --engine hybrid`: the cut is the leaves, the stats say how much is exact; a store without cells
// renders its voxels and says why.
TEST(Hybrid, CommandLine) {
  REQUIRE_GL();
  const Fixture& f = fixture();
  const std::string stats = (f.dir / "hybrid-stats.json").string(), png = (f.dir / "hybrid.png").string();
  const CommandResult r =
      run_ugvr("render " + f.store + " --engine hybrid --size 48x48 --stats " + stats + " -o " + png);
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(stats);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["engine"], "hybrid");
  EXPECT_EQ(j["cut"], "leaves");
  ASSERT_TRUE(j.contains("hybrid")) << j.dump();
  EXPECT_TRUE(j["hybrid"]["off"].is_null());
  EXPECT_GT(j["hybrid"]["exact_nodes"].get<uint64_t>(), 0u);
  EXPECT_EQ(j["hybrid"]["exact_nodes"], j["hybrid"]["candidates"]);
  EXPECT_GT(j["hybrid"]["cell_budget_bytes"].get<uint64_t>(), 0u);

  // A tiny cell budget: fewer nodes exact, and the stats say the budget is full.
  const CommandResult small = run_ugvr("render " + f.store + " --engine hybrid --gpu-cell-memory 4KiB --size 48x48 " +
                                       "--stats " + stats + " -o " + png);
  ASSERT_EQ(small.status, 0) << small.out;
  std::ifstream in2(stats);
  const nlohmann::json k = nlohmann::json::parse(in2);
  EXPECT_TRUE(k["hybrid"]["cell_budget_full"].get<bool>());
  EXPECT_LT(k["hybrid"]["exact_nodes"].get<uint64_t>(), j["hybrid"]["exact_nodes"].get<uint64_t>());
  EXPECT_LE(k["hybrid"]["cell_bytes"].get<uint64_t>(), uint64_t(4096));

  // Not a store: refused with the engine's name.
  const std::string vtu = (f.dir / "small.vtu").string();
  ASSERT_EQ(run_ugvr("generate --cells 1000 -o " + vtu).status, 0);
  const CommandResult mesh = run_ugvr("render " + vtu + " --engine hybrid -o " + png);
  EXPECT_NE(mesh.status, 0);
  EXPECT_NE(mesh.out.find("hybrid engine renders one brick store"), std::string::npos) << mesh.out;
}

}  // namespace
}  // namespace ugvr
