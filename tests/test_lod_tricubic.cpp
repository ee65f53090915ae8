// Tricubic isosurfaces in the LOD engine (--interpolation tricubic; docs/tricubic.md) against the analytic surface.
//
// The input is a sphere's distance field |p - C| sampled on a coarse 33³ lattice over the unit cube (spacing 1/32),
// built into a store of one brick that samples exactly that lattice (resolution 33, depth 0), so that the bricks hold
// the analytic values at their samples and every difference from the analytic sphere comes from the reconstruction
// between samples. The isosurface |p - C| = R is rendered lit by the headlight with a constant grey transfer function;
// the shade 0.5 (A + D c) + S c^32 (lod_shared.h) is monotonic in c = |n · v|, so each pixel gives back the cosine
// between its rendered normal and the ray, and the analytic sphere the true one. Their angles differ by the normal's
// error in the plane of the ray (its part around the ray does not change the shade): a lower bound on the full angle,
// measured the same way for both interpolations.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "gl_test_support.h"
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/structured_grid.h"
#include "ugvr/octree/builder.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/render_settings.h"

namespace ugvr {
namespace {

constexpr int kPoints = 33;  // per axis, spacing 1/32
const Vec3d kCentre{0.5, 0.5, 0.5};
constexpr double kRadius = 0.3;

Dataset sphere_dataset() {
  StructuredGrid g;
  g.dims = GridDims{{kPoints, kPoints, kPoints}};
  std::vector<float> d;
  for (int k = 0; k < kPoints; ++k)
    for (int j = 0; j < kPoints; ++j)
      for (int i = 0; i < kPoints; ++i) {
        const Vec3f p{float(i) / float(kPoints - 1), float(j) / float(kPoints - 1), float(k) / float(kPoints - 1)};
        g.points.push_back(p);
        d.push_back(float(length(Vec3d{p.x, p.y, p.z} - kCentre)));
      }
  Block b;
  b.name = "sphere";
  b.grid = std::move(g);
  b.fields.add(Field("d", Association::Vertex, DataArray::from(std::move(d), 1)));
  Dataset ds;
  ds.sources = {"sphere"};
  ds.blocks.push_back(to_unstructured_block(b, StructuredCellShape::Hexahedra));
  return ds;
}

struct Shared {
  std::filesystem::path dir;
  std::string store;
  std::unique_ptr<GlContext> gl;
  std::string gl_error;
};

Shared& shared() {
  static Shared s = [] {
    Shared r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-tricubic-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    r.store = (r.dir / "sphere.ugvr").string();
    OctreeBuildOptions o;
    o.resolution = kPoints;
    o.max_depth = 0;
    o.error = 0;
    const Dataset ds = sphere_dataset();
    const std::vector<std::string> fields = {"d"};
    build_octree(prepare_octree_input(ds, fields), o, r.store);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return s;
}

#define REQUIRE_GL() UGVR_REQUIRE_GL_CONTEXT(shared().gl, shared().gl_error)

// An oblique view (no axis-aligned rays: the rings of a trilinear surface follow the lattice).
Camera sphere_camera() {
  Camera c;
  c.position = {1.6, 1.3, 2.0};
  c.focal_point = {0.5, 0.5, 0.5};
  c.view_up = {0, 1, 0};
  c.view_angle = 24;
  return c;
}

TransferFunction grey_tf() {
  TransferFunction tf;
  tf.color_points = {{0.0, {0.5, 0.5, 0.5}}, {1.0, {0.5, 0.5, 0.5}}};
  tf.opacity_points = {{0.0, 1.0}, {1.0, 1.0}};
  return tf;
}

// The shade's red channel for cosine c with the grey 0.5 (lod_shared.h: LOD_AMBIENT, LOD_DIFFUSE, LOD_SPECULAR,
// LOD_SHININESS; below 1, so never clamped).
double shade(double c) { return 0.5 * (0.2 + 0.8 * c) + 0.25 * std::pow(c, 32.0); }

double cosine_of(double red) {
  double lo = 0, hi = 1;
  for (int i = 0; i < 40; ++i) ((shade(0.5 * (lo + hi)) < red) ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

struct NormalError {
  double mean_degrees = 0;
  int pixels = 0;
};

// Mean |angle(rendered n, ray) - angle(analytic n, ray)| over pixels whose ray meets the sphere away from its
// silhouette (the analytic cosine above 0.3: there a pixel's footprint spans little of the surface).
NormalError normal_error(const Image& im, const Camera& cam) {
  const CameraRays rays(cam, im.width, im.height);
  NormalError e;
  double sum = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const Ray r = rays.pixel(x, y);
      const Vec3d oc = r.origin - kCentre;
      const double b = dot(oc, r.direction), q = dot(oc, oc) - kRadius * kRadius, disc = b * b - q;
      if (disc <= 0) continue;
      const Vec3d p = r.origin + r.direction * (-b - std::sqrt(disc));
      const double c_true = std::abs(dot(p - kCentre, r.direction) / kRadius);
      if (c_true < 0.3) continue;
      const double c = cosine_of(im.pixel(x, y)[0]);
      sum += std::abs(std::acos(std::min(c, 1.0)) - std::acos(std::min(c_true, 1.0)));
      ++e.pixels;
    }
  e.mean_degrees = e.pixels > 0 ? sum / e.pixels * 180.0 / M_PI : 0;
  return e;
}

Image render_sphere(Interpolation interpolation) {
  LodEngine lod(shared().store, *shared().gl);
  lod.set_field("d");
  RenderSettings s;
  s.width = s.height = 128;
  s.background = {0, 0, 0, 1};
  s.mode = RenderMode::Isosurface;
  s.iso_values = {kRadius};
  s.interpolation = interpolation;
  return lod.render(sphere_camera(), grey_tf(), s, CutSpec{CutSpec::Kind::Leaves, 0});
}

TEST(LodTricubic, NormalsMatchTheAnalyticSphere) {
  // Measured 2026-11-26 (llvmpipe): trilinear 0.138°, tricubic 0.227°. Issue 22's target (tricubic >= 3x lower) is
  // NOT met on this field: a distance field is nearly linear, where central differences are already accurate
  // (docs/tricubic.md). What this asserts: the spline's analytic gradient is a correct normal (a wrong derivative
  // weight or scale would be degrees off), and both stay within half a degree of the analytic sphere.
  REQUIRE_GL();
  const Camera cam = sphere_camera();
  const NormalError lin = normal_error(render_sphere(Interpolation::Trilinear), cam);
  const NormalError cub = normal_error(render_sphere(Interpolation::Tricubic), cam);
  // The sphere covers about 6000 pixels of the 128² image; both renderings hit it wherever the analytic one does.
  ASSERT_GT(lin.pixels, 4000);
  EXPECT_EQ(cub.pixels, lin.pixels);
  std::printf("mean normal angle error (degrees, in the ray's plane): trilinear %.4f, tricubic %.4f\n",
              lin.mean_degrees, cub.mean_degrees);
  EXPECT_LT(lin.mean_degrees, 0.5);
  EXPECT_LT(cub.mean_degrees, 0.5);
}

TEST(LodTricubic, SameSilhouetteAsTrilinear) {
  // The spline is not interpolating (docs/tricubic.md): the surface moves by about h²/3r (0.03 voxel here) inward,
  // far below a pixel, so both renderings cover the same pixels up to a few along the silhouette.
  REQUIRE_GL();
  const Image a = render_sphere(Interpolation::Trilinear), b = render_sphere(Interpolation::Tricubic);
  int differ = 0, covered = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const bool ha = a.pixel(x, y)[0] > 0, hb = b.pixel(x, y)[0] > 0;
      covered += ha;
      differ += ha != hb;
    }
  EXPECT_GT(covered, 4000);
  EXPECT_LE(differ, covered / 50);
}

TEST(LodTricubic, SettingParsesAndRejectsUnknownNames) {
  const RenderSettings s = settings_from_json(nlohmann::json{{"interpolation", "tricubic"}}, "s.json");
  EXPECT_EQ(s.interpolation, Interpolation::Tricubic);
  EXPECT_EQ(settings_to_json(s)["interpolation"], "tricubic");
  EXPECT_EQ(settings_from_json(nlohmann::json::object(), "s.json").interpolation, Interpolation::Trilinear);
  try {
    settings_from_json(nlohmann::json{{"interpolation", "cubic"}}, "s.json");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("s.json: key \"interpolation\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ugvr
