// The GPU exact engine (exact_gpu_engine.h, shaders/exact_walk.comp) against the CPU engine, its reference: every
// dataset family and mode within RMS 1e-3 and PSNR >= 60 dB, no lost rays, the same rays hitting. On llvmpipe in CI
// (small images); on a GPU machine the same tests run on the GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "column_mesh.h"
#include "gl_test_support.h"
#include "renumber_mesh.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/exact/exact_gpu_engine.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/renderer.h"

namespace ugvr {
namespace {

#define REQUIRE_GL(gl) UGVR_REQUIRE_FILE_GL(gl)

struct Scene {
  Camera camera;
  TransferFunction tf;
  RenderSettings settings;
};

Scene default_scene(const ExactEngine& engine, const std::string& view = "iso", int size = 96) {
  Scene s;
  s.camera = camera_preset(view, engine.bounds());
  s.tf = builtin_preset("viridis");
  s.tf.rescale(engine.field_min(), engine.field_max());
  s.tf.opacity_unit_distance = length(engine.bounds().size()) / 15;
  s.settings.width = s.settings.height = size;
  return s;
}

struct Compared {
  ImageDifference diff;
  ExactRenderStats cpu, gpu;
  int visible = 0;  // pixels the CPU image shows away from the background
};

Compared compare_engines(ExactEngine& engine, const std::shared_ptr<const GlContext>& gl, const Scene& s,
                         ExactGpuOptions options = {}) {
  Compared c;
  const Image cpu = engine.render(s.camera, s.tf, s.settings, &c.cpu);
  ExactGpuEngine gpu(engine.walk_mesh(), gl, options);
  gpu.set_values(engine.bound_values(), engine.per_cell());
  const Image g = gpu.render(s.camera, s.tf, s.settings, engine.tolerance_abs(s.tf), &c.gpu);
  c.diff = compare_images(cpu, g);
  if (c.diff.psnr_db < 60)  // say where, for whoever debugs it
    for (int y = 0; y < cpu.height; ++y)
      for (int x = 0; x < cpu.width; ++x)
        if (std::abs(cpu.pixel(x, y)[0] - g.pixel(x, y)[0]) > 1e-3)
          std::printf("pixel %d %d: cpu %g gpu %g\n", x, y, cpu.pixel(x, y)[0], g.pixel(x, y)[0]);
  for (int y = 0; y < cpu.height; ++y)
    for (int x = 0; x < cpu.width; ++x)
      for (int ch = 0; ch < 3; ++ch)
        if (std::abs(cpu.pixel(x, y)[ch] - float(s.settings.background[size_t(ch)])) > 0.02f) {
          ++c.visible;
          break;
        }
  return c;
}

// The figures every comparison must meet.
void expect_match(const Compared& c, const std::string& what) {
  SCOPED_TRACE(what);
  std::printf("%s: PSNR %.1f dB, RMS %.2g, max %.3g, cpu steps %llu gpu %llu, reentries %llu/%llu\n", what.c_str(),
              c.diff.psnr_db, c.diff.rms, c.diff.max_abs, (unsigned long long)c.cpu.cell_steps,
              (unsigned long long)c.gpu.cell_steps, (unsigned long long)c.cpu.reentries,
              (unsigned long long)c.gpu.reentries);
  EXPECT_LE(c.diff.rms, 1e-3);
  EXPECT_GE(c.diff.psnr_db, 60.0);
  EXPECT_EQ(c.gpu.lost_rays, 0u);
  EXPECT_EQ(c.cpu.lost_rays, 0u);
  EXPECT_EQ(c.gpu.rays_hit, c.cpu.rays_hit);
  EXPECT_GT(c.visible, 100) << "an empty picture proves nothing";
  // Each ray crosses the same cells. On llvmpipe, 2 of the oxygen post's 6400 rays at 80x80 take one re-entry fewer
  // than on the CPU (64 dB; a ray moved by 1e-3 pixel agrees again); on an NVIDIA H200 every count is equal.
  EXPECT_NEAR(double(c.gpu.cell_steps), double(c.cpu.cell_steps), 3e-3 * double(c.cpu.cell_steps) + 4);
  EXPECT_NEAR(double(c.gpu.reentries), double(c.cpu.reentries), 0.01 * double(c.cpu.reentries) + 1);
}

const Dataset& mixed_mesh() {
  static const Dataset dataset = [] {
    GenerateOptions options;
    options.cells = 3000;
    options.kind = GenCellKind::Mixed;
    return generate_in_memory(options);
  }();
  return dataset;
}

// llvmpipe ends every loop of a shader invocation after 65,535 back edges in all (shaders/loop_limit_probe.glsl): a ray
// down a column of 3,000 hexahedra (vertex data: each cell's walk and its error-bounded subdivision loop) reaches it,
// and its walk stopped there, drawn as whatever it had gathered. Such rays are now flagged by the shader and traced
// on the CPU, so the image is the CPU's; on a hardware GPU nothing is flagged.
TEST(ExactGpu, RaysCutByTheDevicesLoopLimitAreTracedOnTheCpu) {
  REQUIRE_GL(gl);
  const Dataset ds = test::column_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, "s");
  Scene s = default_scene(engine, "iso", 16);
  s.camera = test::column_camera();   // every ray that hits crosses all 3,000 cells
  s.tf.opacity_unit_distance = 3000;  // faint, so every ray goes all the way
  const Compared c = compare_engines(engine, gl, s);
  expect_match(c, "column of 3,000 hexahedra");
  EXPECT_GT(c.cpu.cell_steps, 1000 * c.cpu.rays_hit) << "each ray walks over a thousand cells";
  if (gl->software()) {
    EXPECT_GT(c.gpu.cpu_traced_rays, 0u) << "llvmpipe's loop limit is reached here: the fallback must have run";
  } else {
    EXPECT_EQ(c.gpu.cpu_traced_rays, 0u);
  }
}

TEST(ExactGpu, MixedMeshVertexData) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, ds.blocks[0].fields[0].name());
  ASSERT_FALSE(engine.per_cell());
  const WalkMesh& m = engine.walk_mesh();
  for (int k = 0; k < 4; ++k) EXPECT_GT(m.type_begin[k + 1], m.type_begin[k]) << "all four cell types, type " << k;
  Scene s = default_scene(engine);
  const Compared c = compare_engines(engine, gl, s);
  expect_match(c, "mixed, vertex data");
  EXPECT_GT(c.gpu.nonlinear_samples, 0u);
}

// The viewer's resting frames are drawn in bands of rows that a move may stop (FrameRequest::keep_going,
// render/banded_dispatch.h): the same image bit for bit, one question a band, and a stopped frame leaves the engine
// drawing the next one as before.
TEST(ExactGpu, BandsDrawTheSameImageAndStopWhenAsked) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, ds.blocks[0].fields[0].name());
  const Scene s = default_scene(engine);  // 96 x 96: 12 rows of 8 x 8 work groups, a band each
  ExactGpuEngine gpu(engine.walk_mesh(), gl);
  gpu.set_values(engine.bound_values(), engine.per_cell());
  const double tol = engine.tolerance_abs(s.tf);
  const Image whole = gpu.render(s.camera, s.tf, s.settings, tol);
  int asked = 0;
  gpu.set_keep_going([&] { return ++asked > 0; });
  EXPECT_EQ(compare_images(gpu.render(s.camera, s.tf, s.settings, tol), whole).max_abs, 0.0);
  EXPECT_EQ(asked, 12);
  asked = 0;
  gpu.set_keep_going([&] { return ++asked < 2; });
  EXPECT_THROW(gpu.render(s.camera, s.tf, s.settings, tol), FrameInterrupted);
  EXPECT_EQ(asked, 2);
  gpu.set_keep_going({});
  EXPECT_EQ(compare_images(gpu.render(s.camera, s.tf, s.settings, tol), whole).max_abs, 0.0);
}

TEST(ExactGpu, MixedMeshCellDataAndReentries) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  std::string cell_field;
  for (const Field& f : ds.blocks[0].fields)
    if (f.association() == Association::Cell) cell_field = f.name();
  ASSERT_FALSE(cell_field.empty());
  engine.set_field(ds, cell_field);
  ASSERT_TRUE(engine.per_cell());
  // Looking along the wing's span: rays leave the mesh at the wing and enter it again.
  Scene s = default_scene(engine, "+y");
  const Compared c = compare_engines(engine, gl, s);
  expect_match(c, "mixed, cell data");
  EXPECT_GT(c.gpu.reentries, 0u);
  EXPECT_EQ(c.gpu.reentries, c.cpu.reentries);
}

TEST(ExactGpu, ModesOnTheMixedMesh) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, ds.blocks[0].fields[0].name());
  {
    Scene s = default_scene(engine);
    s.settings.mode = RenderMode::Mip;
    expect_match(compare_engines(engine, gl, s), "MIP");
  }
  {
    Scene s = default_scene(engine);
    s.settings.mode = RenderMode::Isosurface;
    // Isovalues at quantiles of the data, so that the surfaces cover the picture whatever the field's distribution.
    std::vector<float> sorted = engine.bound_values();
    std::sort(sorted.begin(), sorted.end());
    s.settings.iso_values = {sorted[sorted.size() / 4], sorted[sorted.size() / 2], sorted[sorted.size() * 3 / 4]};
    s.settings.iso_opacity = 0.6;
    expect_match(compare_engines(engine, gl, s), "isosurfaces");
  }
  {
    Scene s = default_scene(engine);
    const Bounds b = engine.bounds();
    s.settings.clip_plane = ClipPlane{(b.lo + b.hi) * 0.5, normalized(Vec3d{1, 0.3, 0.2})};
    s.settings.boundary_overlay_opacity = 0.2;
    s.settings.volume_lighting = true;
    expect_match(compare_engines(engine, gl, s), "clip, overlay, volume lighting");
  }
}

// Slices (docs/slices.md) as the CPU engine draws them: two planes through the mixed mesh (the field at each by the
// cell's own interpolant, here in every cell type), one with its own colour map and range, with the volume hidden in
// front of them. One frame, small: llvmpipe compiles and runs this shader slowly (MIP, isosurfaces and the other
// hide_volume cases share the code, and the CPU engine's own tests cover them).
TEST(ExactGpu, SlicesOnTheMixedMesh) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, ds.blocks[0].fields[0].name());
  const Bounds b = engine.bounds();
  const Vec3d c = (b.lo + b.hi) * 0.5;
  Scene s = default_scene(engine, "iso", 64);
  s.settings.slices = {
      Slice{c, {0.2, 0.3, 1}, 0.8, "", std::nullopt},
      Slice{c + Vec3d{0.1 * (b.hi.x - b.lo.x), 0, 0},
            {1, 0.1, 0},
            0.6,
            "cool-warm",
            std::array<double, 2>{engine.field_min(), 0.5 * (engine.field_min() + engine.field_max())}}};
  s.settings.hide_volume = HideVolume::Front;
  expect_match(compare_engines(engine, gl, s), "slices, volume hidden in front");
}

TEST(ExactGpu, CameraInsideTheMesh) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, ds.blocks[0].fields[0].name());
  Scene s = default_scene(engine);
  const Bounds b = engine.bounds();
  s.camera.position = b.lo + (b.hi - b.lo) * 0.15;
  s.camera.focal_point = b.hi;
  s.camera.view_up = {0, 0, 1};
  s.camera.view_angle = 60;
  expect_match(compare_engines(engine, gl, s), "camera inside");
}

TEST(ExactGpu, SplitBuffersAndFloatArithmetic) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  ExactEngine engine(ds);
  engine.set_field(ds, ds.blocks[0].fields[0].name());
  Scene s = default_scene(engine);
  ExactGpuOptions split;
  // Connectivity and neighbours over several buffers (the mesh's 3000 cells need ~20K words of each).
  split.max_buffer_bytes = 32 * 1024;
  expect_match(compare_engines(engine, gl, s, split), "split buffers");
  ExactGpuOptions single;
  single.double_precision = false;
  const Compared f = compare_engines(engine, gl, s, single);
  EXPECT_GE(f.diff.psnr_db, 50.0) << "float arithmetic";
  EXPECT_EQ(f.gpu.lost_rays, 0u);
  // Too small for the mesh: a clear error naming the way out.
  ExactGpuOptions tiny;
  tiny.max_buffer_bytes = 1024;
  try {
    ExactGpuEngine g(engine.walk_mesh(), gl, tiny);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ugvr build"), std::string::npos) << e.what();
  }
}

TEST(ExactGpu, RenumberingChangesNothing) {
  REQUIRE_GL(gl);
  const Dataset& ds = mixed_mesh();
  const Dataset shuffled = test::renumbered(ds, 777);
  ExactEngine a(ds), b(shuffled);
  const std::string field = ds.blocks[0].fields[0].name();
  a.set_field(ds, field), b.set_field(shuffled, field);
  Scene s = default_scene(a);
  ExactGpuEngine ga(a.walk_mesh(), gl), gb(b.walk_mesh(), gl);
  ga.set_values(a.bound_values(), false), gb.set_values(b.bound_values(), false);
  const Image ia = ga.render(s.camera, s.tf, s.settings, a.tolerance_abs(s.tf));
  const Image ib = gb.render(s.camera, s.tf, s.settings, b.tolerance_abs(s.tf));
  EXPECT_LE(compare_images(ia, ib).max_abs, 1e-6);
}

TEST(ExactGpu, BluntFinAsHexahedraAndAsTetrahedra) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  REQUIRE_GL(gl);
  const Dataset hexes =
      read_plot3d(test::data_path("blunt-fin/bluntfinxyz.bin"), test::data_path("blunt-fin/bluntfinq.bin"));
  Dataset tets;
  tets.sources = hexes.sources;
  tets.blocks.push_back(to_unstructured_block(hexes.blocks[0], StructuredCellShape::SixTetrahedra));
  for (const Dataset* ds : std::vector<const Dataset*>{&hexes, &tets}) {
    ExactEngine engine(*ds);
    engine.set_field(*ds, "Density");
    Scene s = default_scene(engine, "iso", 80);
    expect_match(compare_engines(engine, gl, s), ds == &hexes ? "blunt fin, hexahedra" : "blunt fin, tetrahedra");
  }
}

TEST(ExactGpu, OxygenPost) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  REQUIRE_GL(gl);
  const std::vector<std::string> files = {test::data_path("lox-post/postxyz.bin"),
                                          test::data_path("lox-post/postq.bin")};
  const Dataset ds = read_dataset(files);
  ExactEngine engine(ds);
  engine.set_field(ds, "StagnationEnergy");
  Scene s = default_scene(engine, "iso", 80);
  expect_match(compare_engines(engine, gl, s), "oxygen post");
}

TEST(ExactGpu, KieferBracketCellData) {
  UGVR_REQUIRE_DATA("fea-kiefer-bracket/dataset.vtu");
  REQUIRE_GL(gl);
  const std::vector<std::string> files = {test::data_path("fea-kiefer-bracket/dataset.vtu")};
  const Dataset ds = read_dataset(files);
  std::string cell_field;
  for (const Field& f : ds.blocks[0].fields)
    if (f.association() == Association::Cell && cell_field.empty()) cell_field = f.name();
  if (cell_field.empty()) GTEST_SKIP() << "no cell field in the kiefer bracket";
  ExactEngine engine(ds);
  engine.set_field(ds, cell_field);
  ASSERT_TRUE(engine.per_cell());
  Scene s = default_scene(engine, "iso", 80);
  expect_match(compare_engines(engine, gl, s), "kiefer bracket, cell data");
}

TEST(ExactGpu, NotchHexahedraAndWedges) {
  UGVR_REQUIRE_DATA("notch-stress/notch_stress.vtk");
  REQUIRE_GL(gl);
  const std::vector<std::string> files = {test::data_path("notch-stress/notch_stress.vtk")};
  const Dataset ds = read_dataset(files);
  ExactEngine engine(ds);
  engine.set_field(ds, "");
  const WalkMesh& m = engine.walk_mesh();
  EXPECT_GT(m.type_begin[3] - m.type_begin[2], 0u) << "wedges";
  EXPECT_GT(m.type_begin[4] - m.type_begin[3], 0u) << "hexahedra";
  Scene s = default_scene(engine, "iso", 80);
  s.tf.opacity_unit_distance = length(engine.bounds().size()) / 200;
  expect_match(compare_engines(engine, gl, s), "notch");
}

}  // namespace
}  // namespace ugvr
