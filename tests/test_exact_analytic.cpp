// The exact engine against closed forms (no oracle): constant and linear fields in boxes of tetrahedra and
// hexahedra, per-cell data, MIP with a clip plane, isosurface positions, and the engine's invariances (renumbering
// the mesh, thread count). The scenes and their expected images come from tests/oracle (closed_form_scenes), which
// test_oracle_selftest.cpp also checks the oracle against.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>

#include "oracle/reference_renderer.h"
#include "renumber_mesh.h"
#include "ugvr/gen/generator.h"
#include "ugvr/render/exact/exact_engine.h"

namespace ugvr {
namespace {

using test::renumbered;

Image render_exact(const Dataset& dataset, std::string_view field, const Camera& camera, const TransferFunction& tf,
                   const RenderSettings& settings) {
  ExactEngine engine(dataset);
  engine.set_field(dataset, field);
  return engine.render(camera, tf, settings);
}

// Every pixel within 1e-4 of the closed form (the engine's transfer-function table linearises the extinction to an
// opacity error of 1e-4 per unit distance; these scenes stay well inside that).
void check_family(std::string_view family) {
  for (const oracle::ClosedFormScene& scene : oracle::closed_form_scenes(family)) {
    const Image image = render_exact(*scene.dataset, scene.field, scene.camera, scene.tf, scene.settings);
    const oracle::SceneError e = oracle::scene_error(scene, image);
    EXPECT_LE(e.max_abs, 1e-4) << scene.name << ": worst pixel (" << e.x << ", " << e.y << ")";
  }
}

// Constant field in a box of tetrahedra (and hexahedra), parallel and perspective views, with and without a clip
// plane: c (1 - e^-tau L) + e^-tau L bg per pixel.
TEST(ExactAnalytic, ConstantBoxMatchesClosedForm) { check_family("constant"); }
// s = z, colour linear in s, constant opacity, viewed from above, below and obliquely.
TEST(ExactAnalytic, LinearFieldSlabMatchesClosedForm) { check_family("linear-slab"); }
// Per-cell data: constant in each cell, jumping at the faces between two layers.
TEST(ExactAnalytic, CellDataLayersMatchClosedForm) { check_family("cell-layers"); }
// MIP of s = z: colour(s_max) exactly, s_max on the near or far face, or on the clip plane.
TEST(ExactAnalytic, MipOfLinearFieldIsItsMaximum) { check_family("mip"); }
// Isosurfaces of s = x: every crossing inside the box, front to back; rays that miss show the background; seen
// edge-on nothing is drawn; the coverage edge of the wide perspective view falls where the rays predict.
TEST(ExactAnalytic, IsosurfacesWhereExpected) { check_family("iso"); }

// ---- Invariances ----

// A small mixed mesh (tetrahedra, pyramids, wedges, hexahedra) with a vertex and a cell field.
const Dataset& mixed_mesh() {
  static const Dataset dataset = [] {
    GenerateOptions options;
    options.cells = 1000;
    options.kind = GenCellKind::Mixed;
    return generate_in_memory(options);
  }();
  return dataset;
}

struct Scene {
  Camera camera;
  TransferFunction tf;
  RenderSettings settings;
};

Scene mixed_scene(const Dataset& ds, std::string_view field) {
  ExactEngine engine(ds);
  engine.set_field(ds, field);
  Scene s;
  s.camera = camera_preset("iso", ds.bounds());
  s.tf = builtin_preset("viridis");
  s.tf.rescale(engine.field_min(), engine.field_max());
  s.tf.opacity_unit_distance = length(ds.bounds().size()) / 20;
  s.settings.width = s.settings.height = 48;
  s.settings.early_termination_opacity = 1;
  s.settings.lighting = false;
  return s;
}

// Pixels whose colour differs visibly from the background: an invariance shown on an empty image proves nothing.
int visible_pixels(const Image& image, const RenderSettings& settings) {
  int n = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c)
        if (std::abs(image.pixel(x, y)[c] - float(settings.background[size_t(c)])) > 0.02f) {
          ++n;
          break;
        }
  return n;
}

TEST(ExactAnalytic, RenumberingDoesNotChangeTheImage) {
  const Dataset& original = mixed_mesh();
  const Dataset shuffled = renumbered(original, 12345);
  for (const char* field : {"pressure", "wall_distance"}) {
    const Scene s = mixed_scene(original, field);
    for (RenderMode mode : {RenderMode::EmissionAbsorption, RenderMode::Mip}) {
      RenderSettings settings = s.settings;
      settings.mode = mode;
      const Image a = render_exact(original, field, s.camera, s.tf, settings);
      const Image b = render_exact(shuffled, field, s.camera, s.tf, settings);
      const oracle::RgbDifference d = oracle::rgb_difference(a, b);
      EXPECT_LE(d.max_abs, 1e-6) << field << " " << render_mode_name(mode);
      EXPECT_GT(visible_pixels(a, settings), settings.width * settings.height / 10) << field;
    }
  }
}

TEST(ExactAnalytic, SameBitsForAnyThreadCount) {
  const Dataset& ds = mixed_mesh();
  for (const char* field : {"pressure", "wall_distance"}) {
    Scene s = mixed_scene(ds, field);
    s.settings.width = s.settings.height = 64;
    s.settings.early_termination_opacity = 0.99;  // the default: termination must not depend on scheduling either
    ExactEngine engine(ds);
    engine.set_field(ds, field);
    Image one, two;
    {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      one = engine.render(s.camera, s.tf, s.settings);
    }
    {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
      two = engine.render(s.camera, s.tf, s.settings);
    }
    ASSERT_EQ(one.rgba.size(), two.rgba.size());
    EXPECT_GT(visible_pixels(one, s.settings), s.settings.width * s.settings.height / 10) << field;
    EXPECT_EQ(std::memcmp(one.rgba.data(), two.rgba.data(), one.rgba.size() * sizeof(float)), 0) << field;
  }
}

}  // namespace
}  // namespace ugvr
