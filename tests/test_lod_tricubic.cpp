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
//
// The second field is a product of sines, sin(3πx) sin(3πy) sin(3πz) on the same 33³ lattice, whose blobs f = 0.25
// are about 3 voxels in radius: curved enough per voxel that trilinear normals degrade (issue 22's must-show). Its
// isosurface is found along each pixel's ray analytically (bisection on the analytic function), and the surface
// position error along the rays is measured on the CPU evaluation of the same two reconstructions (trilinear, and the
// B-spline of the lattice samples, clamped at the lattice's border as one brick's apron clamps): the renderer returns
// no depth. The rendered normals are checked against the CPU spline's too, which ties the shader to that spline.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>

#include "gl_test_support.h"
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/structured_grid.h"
#include "ugvr/octree/builder.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/brick_atlas.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/render_settings.h"

namespace ugvr {
namespace {

constexpr int kPoints = 33;  // per axis, spacing 1/32
const Vec3d kCentre{0.5, 0.5, 0.5};
constexpr double kRadius = 0.3;

constexpr double kSinesK = 3.0 * M_PI;  // sin(kx) sin(ky) sin(kz): 1.5 periods over the cube, 21 voxels a period
constexpr double kSinesIso = 0.25;

double sphere_value(const Vec3d& p) { return length(p - kCentre); }
// The squared distance: quadratic, so every level's interpolating spline reproduces it (the coarse samples are the
// fine lattice's every other one, and the prefilter reproduces cubics): levels must agree.
double sphere_squared_value(const Vec3d& p) { return dot(p - kCentre, p - kCentre); }
double sines_value(const Vec3d& p) {
  return std::sin(kSinesK * p.x) * std::sin(kSinesK * p.y) * std::sin(kSinesK * p.z);
}
Vec3d sines_gradient(const Vec3d& p) {
  const double sx = std::sin(kSinesK * p.x), sy = std::sin(kSinesK * p.y), sz = std::sin(kSinesK * p.z);
  const double cx = std::cos(kSinesK * p.x), cy = std::cos(kSinesK * p.y), cz = std::cos(kSinesK * p.z);
  return Vec3d{cx * sy * sz, sx * cy * sz, sx * sy * cz} * kSinesK;
}

Vec3d lattice_point(int i, int j, int k) {
  return Vec3d{double(i), double(j), double(k)} * (1.0 / double(kPoints - 1));
}

// The field "d" sampled on the kPoints³ lattice over the unit cube.
Dataset lattice_dataset(const std::function<double(const Vec3d&)>& f) {
  StructuredGrid g;
  g.dims = GridDims{{kPoints, kPoints, kPoints}};
  std::vector<float> d;
  for (int k = 0; k < kPoints; ++k)
    for (int j = 0; j < kPoints; ++j)
      for (int i = 0; i < kPoints; ++i) {
        const Vec3d p = lattice_point(i, j, k);
        g.points.push_back(Vec3f{float(p.x), float(p.y), float(p.z)});
        d.push_back(float(f(p)));
      }
  Block b;
  b.name = "lattice";
  b.grid = std::move(g);
  b.fields.add(Field("d", Association::Vertex, DataArray::from(std::move(d), 1)));
  Dataset ds;
  ds.sources = {"lattice"};
  ds.blocks.push_back(to_unstructured_block(b, StructuredCellShape::Hexahedra));
  return ds;
}

struct Shared {
  std::filesystem::path dir;
  std::map<std::string, std::string> stores;
  std::unique_ptr<GlContext> gl;
  std::string gl_error;
};

Shared& shared() {
  static Shared s = [] {
    Shared r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-tricubic-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return s;
}

enum class Bricks {
  One,
  Many
};  // one brick of 33³ (depth 0), or 64 leaf bricks of 9³ (depth 2): both sample the lattice

// The store of field `name` ("sphere" or "sines") with `bricks`, built on first use.
const std::string& lattice_store(const std::string& name, Bricks bricks) {
  const std::string key = name + (bricks == Bricks::One ? "-1" : "-64");
  auto it = shared().stores.find(key);
  if (it != shared().stores.end()) return it->second;
  const std::string path = (shared().dir / (key + ".ugvr")).string();
  OctreeBuildOptions o;
  o.resolution = bricks == Bricks::One ? kPoints : 9;
  o.max_depth = bricks == Bricks::One ? 0 : 2;
  o.error = 0;
  const Dataset ds = lattice_dataset(name == "sphere"           ? sphere_value
                                     : name == "sphere-squared" ? sphere_squared_value
                                                                : sines_value);
  const std::vector<std::string> fields = {"d"};
  build_octree(prepare_octree_input(ds, fields), o, path);
  return shared().stores[key] = path;
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

// in_loop: with a slice outside the volume (so nothing of it is drawn), which compiles the variant that evaluates the
// spline inside the sample loop (shaders/lod_raycast.comp, TRICUBIC_WALK): the reference for the walk's bracketing.
Image render_iso(const std::string& store, double iso, Interpolation interpolation, bool in_loop = false,
                 const CutSpec& cut = CutSpec{CutSpec::Kind::Leaves, 0}, LodRenderStats* stats = nullptr,
                 const TransferFunction& tf = grey_tf()) {
  LodEngine lod(store, *shared().gl);
  lod.set_field("d");
  RenderSettings s;
  s.width = s.height = 128;
  s.background = {0, 0, 0, 1};
  s.mode = RenderMode::Isosurface;
  s.iso_values = {iso};
  s.interpolation = interpolation;
  if (in_loop) {
    Slice outside;
    outside.point = {0.5, 0.5, 3.0};
    outside.normal = {0, 0, 1};
    s.slices = {outside};
  }
  return lod.render(sphere_camera(), tf, s, cut, stats);
}

Image render_sphere(Interpolation interpolation) {
  return render_iso(lattice_store("sphere", Bricks::One), kRadius, interpolation);
}

// The CPU reconstructions of the lattice's samples of f, in the unit cube: trilinear; the uniform cubic B-spline whose
// coefficients are the samples (the approximating spline, clamped at the border as one brick's apron clamps); and the
// interpolating one, whose coefficients cubic_coefficients computes from the lattice as one brick's slot (what the
// one-brick store uploads, up to the store's 16-bit values).
struct Lattice {
  std::vector<double> v, coef;  // coef: (kPoints + 2)³, value units, index + 1
  explicit Lattice(const std::function<double(const Vec3d&)>& f) {
    std::vector<float> samples;
    for (int k = 0; k < kPoints; ++k)
      for (int j = 0; j < kPoints; ++j)
        for (int i = 0; i < kPoints; ++i) samples.push_back(float(f(lattice_point(i, j, k))));
    v.assign(samples.begin(), samples.end());
    const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
    const double l = *lo, h = *hi;
    std::vector<uint8_t> mask(samples.size(), 1);
    std::vector<uint16_t> texels;
    make_atlas_slot(kPoints, samples.data(), mask.data(), l, h, texels);
    if (!cubic_coefficients(kPoints, texels.data(), coef)) std::abort();
    for (double& c : coef) c = l + c * (h - l);
  }
  double at(int i, int j, int k) const {
    const auto c = [](int a) { return std::clamp(a, 0, kPoints - 1); };
    return v[(size_t(c(k)) * kPoints + c(j)) * kPoints + c(i)];
  }
  double coefficient(int i, int j, int k) const {
    constexpr int s = kPoints + 2;
    return coef[(size_t(k + 1) * s + (j + 1)) * s + (i + 1)];
  }
  double trilinear(const Vec3d& p) const {
    const Vec3d u = p * double(kPoints - 1);
    const int i = std::clamp(int(std::floor(u.x)), 0, kPoints - 2),
              j = std::clamp(int(std::floor(u.y)), 0, kPoints - 2),
              k = std::clamp(int(std::floor(u.z)), 0, kPoints - 2);
    const double fx = u.x - i, fy = u.y - j, fz = u.z - k;
    double r = 0;
    for (int c = 0; c < 8; ++c) {
      const int a = c & 1, b = (c >> 1) & 1, d = c >> 2;
      r += (a ? fx : 1 - fx) * (b ? fy : 1 - fy) * (d ? fz : 1 - fz) * at(i + a, j + b, k + d);
    }
    return r;
  }
  // B-spline weights at fraction f (deriv: of d/du) for the 4 samples i-1 .. i+2.
  static void weights(double f, bool deriv, double w[4]) {
    const double r = 1 - f;
    if (deriv) {
      w[0] = -0.5 * r * r, w[1] = 0.5 * f * (3 * f - 4), w[2] = 0.5 * r * (3 * f + 1), w[3] = 0.5 * f * f;
    } else {
      w[0] = r * r * r / 6, w[1] = (3 * f * f * f - 6 * f * f + 4) / 6;
      w[2] = (-3 * f * f * f + 3 * f * f + 3 * f + 1) / 6, w[3] = f * f * f / 6;
    }
  }
  // The spline (interpolating, or the samples' approximating one), or its partial derivative along `axis` (0..2) in
  // world units; -1: the value.
  double spline(const Vec3d& p, int axis = -1, bool interpolating = true) const {
    const Vec3d u = p * double(kPoints - 1);
    const double us[3] = {u.x, u.y, u.z};
    int i[3];
    double w[3][4];
    for (int a = 0; a < 3; ++a) {
      i[a] = std::clamp(int(std::floor(us[a])), 0, kPoints - 2);
      weights(us[a] - i[a], a == axis, w[a]);
    }
    double r = 0;
    for (int c = 0; c < 4; ++c)
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) {
          const int x = i[0] - 1 + a, y = i[1] - 1 + b, z = i[2] - 1 + c;
          r += w[0][a] * w[1][b] * w[2][c] * (interpolating ? coefficient(x, y, z) : at(x, y, z));
        }
    return axis < 0 ? r : r * double(kPoints - 1);
  }
  Vec3d spline_gradient(const Vec3d& p) const { return Vec3d{spline(p, 0), spline(p, 1), spline(p, 2)}; }
};

// The first t along r inside the unit cube where f(r(t)) = iso (a sign change within steps of ds, then bisection), or
// -1.
double first_crossing(const Ray& r, const std::function<double(const Vec3d&)>& f, double iso, double ds) {
  double t0 = 0, t1 = 1e30;
  const double o[3] = {r.origin.x, r.origin.y, r.origin.z}, d[3] = {r.direction.x, r.direction.y, r.direction.z};
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) continue;
    const double ta = (0 - o[a]) / d[a], tb = (1 - o[a]) / d[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  if (!(t0 < t1)) return -1;
  double ta = t0, fa = f(r.origin + r.direction * ta) - iso;
  for (double tb = t0 + ds;; tb += ds) {
    tb = std::min(tb, t1);
    const double fb = f(r.origin + r.direction * tb) - iso;
    if ((fa < 0) != (fb < 0)) {
      for (int i = 0; i < 50; ++i) {
        const double tm = 0.5 * (ta + tb), fm = f(r.origin + r.direction * tm) - iso;
        ((fm < 0) == (fa < 0) ? ta : tb) = tm;
      }
      return 0.5 * (ta + tb);
    }
    if (tb >= t1) return -1;
    ta = tb, fa = fb;
  }
}

// The rendered normal's mean angle error, in the ray's plane, against the analytic gradient at the analytic surface
// of the sines (and, with `cpu`, against the CPU spline's gradient at its own crossing), over pixels whose ray meets
// the analytic surface away from its silhouette (cosine above 0.3) and that the rendering covers too; with `cpu`,
// over the same pixels, the mean position error along the ray of the two CPU reconstructions (voxels; a ray that
// misses counts 1).
struct SinesError {
  double analytic_degrees = 0, spline_degrees = 0;  // against the analytic gradient, the CPU spline's
  // The analytic-gradient error split by where the analytic hit lies: within half a voxel of a plane between the
  // 64-brick store's bricks (x, y or z at 0.25, 0.5, 0.75), and elsewhere (means; pixels counted).
  double border_degrees = 0, inner_degrees = 0;
  int border_pixels = 0;
  double trilinear_voxels = 0, spline_voxels = 0, approximating_voxels = 0;  // |t - t_analytic| / h, mean
  int pixels = 0, uncovered = 0;
};

double angle_error(double c_rendered, const Vec3d& g, const Vec3d& dir) {
  const double c = std::abs(dot(g, dir)) / length(g);
  return std::abs(std::acos(std::min(c_rendered, 1.0)) - std::acos(std::min(c, 1.0))) * 180.0 / M_PI;
}

SinesError sines_error(const Image& im, const Lattice* cpu) {
  const Camera cam = sphere_camera();
  const CameraRays rays(cam, im.width, im.height);
  const double h = 1.0 / (kPoints - 1);
  SinesError e;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const Ray r = rays.pixel(x, y);
      const double t = first_crossing(r, sines_value, kSinesIso, 0.02 * h);
      if (t < 0) continue;
      const Vec3d p = r.origin + r.direction * t;
      const Vec3d g = sines_gradient(p);
      if (std::abs(dot(g, r.direction)) / length(g) < 0.3) continue;
      if (!(im.pixel(x, y)[0] > 0)) {
        ++e.uncovered;
        continue;
      }
      const double c = cosine_of(im.pixel(x, y)[0]);
      const double err = angle_error(c, g, r.direction);
      e.analytic_degrees += err;
      double border = 1;
      for (double q : {p.x, p.y, p.z}) border = std::min(border, std::abs(q * 4 - std::round(q * 4)) / 4);
      if (border < 0.5 * h) {
        e.border_degrees += err;
        ++e.border_pixels;
      } else {
        e.inner_degrees += err;
      }
      if (cpu) {
        const auto lin = [&](const Vec3d& q) { return cpu->trilinear(q); };
        const auto cub = [&](const Vec3d& q) { return cpu->spline(q); };
        const auto approx = [&](const Vec3d& q) { return cpu->spline(q, -1, false); };
        const double tl = first_crossing(r, lin, kSinesIso, 0.25 * h), tc = first_crossing(r, cub, kSinesIso, 0.25 * h);
        const double ta = first_crossing(r, approx, kSinesIso, 0.25 * h);
        e.trilinear_voxels += tl < 0 ? 1.0 : std::abs(tl - t) / h;
        e.spline_voxels += tc < 0 ? 1.0 : std::abs(tc - t) / h;
        e.approximating_voxels += ta < 0 ? 1.0 : std::abs(ta - t) / h;
        if (tc >= 0) e.spline_degrees += angle_error(c, cpu->spline_gradient(r.origin + r.direction * tc), r.direction);
      }
      ++e.pixels;
    }
  if (e.pixels > 0) {
    e.analytic_degrees /= e.pixels, e.spline_degrees /= e.pixels;
    if (e.border_pixels > 0) e.border_degrees /= e.border_pixels;
    if (e.pixels > e.border_pixels) e.inner_degrees /= e.pixels - e.border_pixels;
    e.trilinear_voxels /= e.pixels, e.spline_voxels /= e.pixels, e.approximating_voxels /= e.pixels;
  }
  return e;
}

TEST(LodTricubic, NormalsMatchTheAnalyticSphere) {
  // Measured 2026-11-27 (llvmpipe): trilinear 0.138°, tricubic 0.0072° (0.227° before the prefilter: the
  // approximating spline's shrink moved the surface). A distance field is nearly linear, where central differences are
  // already accurate; the interpolating spline is still far closer. What this asserts: the spline's analytic gradient
  // is a correct normal (a wrong derivative weight or scale would be degrees off), and issue 22's ratio.
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
  EXPECT_LE(3.0 * cub.mean_degrees, lin.mean_degrees);
}

TEST(LodTricubic, SameSilhouetteAsTrilinear) {
  // Both reconstructions pass through the samples: the surfaces differ by far less than a pixel, so both renderings
  // cover the same pixels up to a few along the silhouette.
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

TEST(LodTricubic, SinesNormalsThreeTimesCloserThanTrilinearInOneBrick) {
  REQUIRE_GL();
  const std::string& store = lattice_store("sines", Bricks::One);
  const Lattice cpu(sines_value);
  const SinesError lin = sines_error(render_iso(store, kSinesIso, Interpolation::Trilinear), &cpu);
  const SinesError cub = sines_error(render_iso(store, kSinesIso, Interpolation::Tricubic), &cpu);
  std::printf(
      "sines, one brick: mean normal angle error (degrees, in the ray's plane) trilinear %.4f, tricubic %.4f "
      "(ratio %.1f; tricubic against the CPU spline %.4f) over %d pixels; position error along the rays "
      "(voxels, CPU): trilinear %.4f, interpolating spline %.4f, approximating spline %.4f; uncovered %d / %d\n",
      lin.analytic_degrees, cub.analytic_degrees, lin.analytic_degrees / cub.analytic_degrees, cub.spline_degrees,
      cub.pixels, lin.trilinear_voxels, lin.spline_voxels, lin.approximating_voxels, lin.uncovered, cub.uncovered);
  ASSERT_GT(lin.pixels, 2000);
  EXPECT_LE(lin.uncovered + cub.uncovered, lin.pixels / 100);
  // Issue 22's target (measured 2026-11-27 on llvmpipe: trilinear 0.355°, tricubic 0.0042°; 0.639° without the
  // prefilter).
  EXPECT_LE(3.0 * cub.analytic_degrees, lin.analytic_degrees);
  // The shader draws the spline the CPU evaluates: its normals are the CPU spline's up to the fetches' precision,
  // which a wrong weight, scale or stencil offset would put degrees off.
  EXPECT_LT(cub.spline_degrees, 0.05);
  // The interpolating spline's surface lies on the analytic one (the approximating spline's shrank by 0.085 voxel,
  // trilinear's is off by 0.042).
  EXPECT_LE(3.0 * lin.spline_voxels, lin.trilinear_voxels);
}

TEST(LodTricubic, SinesNormalsAcross64Bricks) {
  // The same lattice in 64 bricks: the brick borders (0.25, 0.5, 0.75) cross the blobs, where each brick's spline is
  // its own (prefiltered per brick; the apron holds its own extrapolated coefficient, not the neighbour's data:
  // docs/tricubic.md). Measured 2026-11-27 (llvmpipe): trilinear 1.08°, tricubic 0.026° (0.013° with the spline in
  // the sample loop, which locates a few crossings at brick entries on the other brick's spline).
  REQUIRE_GL();
  const std::string& store = lattice_store("sines", Bricks::Many);
  const SinesError lin = sines_error(render_iso(store, kSinesIso, Interpolation::Trilinear), nullptr);
  const SinesError cub = sines_error(render_iso(store, kSinesIso, Interpolation::Tricubic), nullptr);
  std::printf(
      "sines, 64 bricks: mean normal angle error (degrees, in the ray's plane) trilinear %.4f, tricubic %.4f "
      "(ratio %.2f) over %d pixels; uncovered %d / %d; within half a voxel of a brick border (%d pixels): "
      "trilinear %.4f, tricubic %.4f; elsewhere: trilinear %.4f, tricubic %.4f\n",
      lin.analytic_degrees, cub.analytic_degrees, lin.analytic_degrees / cub.analytic_degrees, cub.pixels,
      lin.uncovered, cub.uncovered, cub.border_pixels, lin.border_degrees, cub.border_degrees, lin.inner_degrees,
      cub.inner_degrees);
  ASSERT_GT(lin.pixels, 2000);
  EXPECT_LE(lin.uncovered + cub.uncovered, lin.pixels / 100);
  EXPECT_LE(3.0 * cub.analytic_degrees, lin.analytic_degrees);
  // Brick borders (same level; a border between levels is not in this store): trilinear's one-sided differences show
  // them (measured 3.32° there against 0.46° elsewhere), tricubic's per-brick splines hardly (0.030° against 0.025°).
  ASSERT_GT(cub.border_pixels, 500);
  EXPECT_GT(lin.border_degrees, 3.0 * lin.inner_degrees) << "the test sees a seam where there is one";
  EXPECT_LT(cub.border_degrees, 1.5 * cub.inner_degrees) << "no seam beyond the error elsewhere";
}

// Level borders: on a quadratic field (the squared distance to the centre, iso R²) every level's interpolating
// spline is the field itself, so a cut that mixes levels draws the image of the leaves: coarse and fine neighbours
// agree by construction (docs/tricubic.md, "Seams"). Trilinear does not: a coarse level interpolates the parabola
// with a larger error, and the surface and its shading move where the levels change.
TEST(LodTricubic, LevelsAgreeOnAQuadraticField) {
  REQUIRE_GL();
  const std::string& store = lattice_store("sphere-squared", Bricks::Many);
  const double iso = kRadius * kRadius;
  LodRenderStats mixed_stats;
  const CutSpec mixed{CutSpec::Kind::Pixels, 14};  // levels 1 and 2 (measured: 15 nodes)
  const Image cub_leaves = render_iso(store, iso, Interpolation::Tricubic);
  const Image cub_mixed = render_iso(store, iso, Interpolation::Tricubic, false, mixed, &mixed_stats);
  const Image lin_leaves = render_iso(store, iso, Interpolation::Trilinear);
  const Image lin_mixed = render_iso(store, iso, Interpolation::Trilinear, false, mixed);
  const ImageDifference cub = compare_images(cub_mixed, cub_leaves), lin = compare_images(lin_mixed, lin_leaves);
  const NormalError cub_n = normal_error(cub_mixed, sphere_camera()), lin_n = normal_error(lin_mixed, sphere_camera());
  std::printf(
      "squared distance, 64 bricks, cut %s (%llu nodes, levels %.2f mean, %d max) against the leaves: tricubic "
      "max %.4f PSNR %.1f dB, trilinear max %.4f PSNR %.1f dB; mean normal error at that cut: tricubic %.4f deg, "
      "trilinear %.4f deg\n",
      cut_spec_name(mixed).c_str(), (unsigned long long)mixed_stats.cut_nodes, mixed_stats.mean_level,
      mixed_stats.max_level, cub.max_abs, cub.psnr_db, lin.max_abs, lin.psnr_db, cub_n.mean_degrees,
      lin_n.mean_degrees);
  ASSERT_LT(mixed_stats.mean_level, double(mixed_stats.max_level)) << "the cut must mix levels";
  // Measured 2026-11-27 (llvmpipe, 15 nodes of levels 1 and 2): tricubic 55.7 dB from the leaves' image, its normals
  // 0.011° from the analytic sphere's; trilinear 36.8 dB, 2.36°.
  EXPECT_GT(cub.psnr_db, 45.0);
  EXPECT_GT(cub.psnr_db, lin.psnr_db + 10) << "the test sees the levels differ where they do";
  EXPECT_LT(cub_n.mean_degrees, 0.1);
  EXPECT_GT(lin_n.mean_degrees, 10 * cub_n.mean_degrees);
}

// An isosurface's geometry is the field's: the cut must not drop nodes for being transparent under the transfer
// function (an opacity of 0 there drew no surface at all) nor keep them coarse for being uniform under it (a constant
// colour drew the root brick alone). Both transfer functions below draw the same image as the leaves.
TEST(LodEngineIso, TheCutIgnoresTheTransferFunctionsOpacityAndUniformity) {
  REQUIRE_GL();
  const std::string& store = lattice_store("sines", Bricks::Many);
  TransferFunction transparent = grey_tf();
  transparent.opacity_points = {{0.0, 0.0}, {1.0, 0.0}};
  const Image leaves = render_iso(store, kSinesIso, Interpolation::Trilinear);
  for (const TransferFunction& tf : {grey_tf(), transparent}) {
    LodRenderStats st;
    const Image im =
        render_iso(store, kSinesIso, Interpolation::Trilinear, false, CutSpec{CutSpec::Kind::Pixels, 1}, &st, tf);
    EXPECT_EQ(st.cut_nodes, 64u) << "opacity " << tf.opacity_points[0].opacity;
    EXPECT_EQ(compare_images(im, leaves).max_abs, 0.0) << "opacity " << tf.opacity_points[0].opacity;
  }
}

// Pixels covered by a and by b, and the largest difference of a covered pixel's red.
struct Coverage {
  int a = 0, b = 0, differ = 0;
  float max_shade_difference = 0;
  int shade_differs = 0;  // covered by both, red differing by more than 0.01
};
Coverage compare(const Image& a, const Image& b) {
  Coverage c;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const bool ha = a.pixel(x, y)[0] > 0, hb = b.pixel(x, y)[0] > 0;
      c.a += ha, c.b += hb, c.differ += ha != hb;
      if (ha && hb) c.shade_differs += std::abs(a.pixel(x, y)[0] - b.pixel(x, y)[0]) > 0.01f;
      if (ha && hb)
        c.max_shade_difference = std::max(c.max_shade_difference, std::abs(a.pixel(x, y)[0] - b.pixel(x, y)[0]));
    }
  return c;
}

TEST(LodTricubic, BracketingOnTrilinearKeepsEveryCrossingOfTheSpline) {
  // The walk samples the trilinear value only and hands the segments that may hold a crossing of the spline (the
  // slot's cubic margin, brick_atlas.h) to the spline after it: the same crossings as the spline evaluated at every
  // sample inside the loop (the slices variant with UGVR_TRICUBIC_NO_BRACKET, the previous path), so the same pixels.
  // The slices variant bracketing in the loop on the margin gives the very same image.
  REQUIRE_GL();
  for (const auto& [name, iso] : {std::pair<std::string, double>{"sines", kSinesIso}, {"sphere", kRadius}})
    for (Bricks bricks : {Bricks::One, Bricks::Many}) {
      const std::string& store = lattice_store(name, bricks);
      ::setenv("UGVR_TRICUBIC_NO_BRACKET", "1", 1);
      const Image every = render_iso(store, iso, Interpolation::Tricubic, true);
      ::unsetenv("UGVR_TRICUBIC_NO_BRACKET");
      const Image in_loop = render_iso(store, iso, Interpolation::Tricubic, true);
      const Image walk = render_iso(store, iso, Interpolation::Tricubic);
      SCOPED_TRACE(name + (bricks == Bricks::One ? ", one brick" : ", 64 bricks"));
      for (const Image* im : {&in_loop, &walk}) {
        const Coverage c = compare(every, *im);
        EXPECT_GT(c.a, 2000);
        EXPECT_EQ(c.differ, 0) << (im == &walk ? "the walk" : "in the loop");
        std::printf("%s, %s: %d pixels' shade differs by more than 0.01 (at most %.4f)\n", name.c_str(),
                    im == &walk ? "the walk" : "in the loop", c.shade_differs, c.max_shade_difference);
        if (im == &in_loop) {
          EXPECT_LT(c.max_shade_difference, 0.01f) << "in the loop";
        } else {
          // The walk locates a crossing within one brick; the loop may locate it in a zero-length segment at a brick's
          // entry, between the previous brick's spline and this one's (per-brick prefilter: they differ there by the
          // seam). Measured: 19 pixels of the 64-brick sines, at most 0.068; none elsewhere.
          EXPECT_LE(c.shade_differs, c.a / 200) << "the walk";
          EXPECT_LT(c.max_shade_difference, 0.1f) << "the walk";
        }
      }
    }
}

TEST(LodTricubic, CubicMarginBoundsSplineMinusTrilinear) {
  // A brick of 9³ samples, linear, or smooth plus noise, through make_atlas_slot: at random points of its cells the
  // exact spline of the slot's codes differs from their exact trilinear interpolant by at most the margin, which is
  // not much more. In a linear brick both agree wherever the stencil stays inside the brick; in its border cells the
  // clamped apron bends the spline by up to a sixth of a sample step per axis, which the margin then covers.
  constexpr int r = 9, s = r + 2;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (double noise : {0.0, 0.05, 0.5}) {
    std::vector<float> samples;
    std::vector<uint8_t> mask(size_t(r) * r * r, 1);
    for (int z = 0; z < r; ++z)
      for (int y = 0; y < r; ++y)
        for (int x = 0; x < r; ++x)
          samples.push_back(
              float(0.3 * x / 8.0 + (noise > 0 ? std::sin(1.3 * x + 0.7 * y * y) * std::cos(0.4 * z) + noise * unit(rng)
                                               : 0.1 * y / 8.0 + 0.2 * z / 8.0)));
    std::vector<uint16_t> texels;
    make_atlas_slot(r, samples.data(), mask.data(), -1.5, 1.5, texels);
    const double margin = cubic_margin_code(r, texels.data());
    std::vector<double> coefficients;
    ASSERT_TRUE(cubic_coefficients(r, texels.data(), coefficients));
    const double margin_c = cubic_margin_code(r, texels.data(), &coefficients);
    const auto code = [&](int x, int y, int z) {
      const auto c = [](int a) { return std::clamp(a, 0, s - 1); };
      return double(texels[((size_t(c(z)) * s + c(y)) * s + c(x)) * 2]);
    };
    double worst = 0, worst_inside = 0, worst_c = 0;
    for (int n = 0; n < 20000; ++n) {
      const double u[3] = {1 + unit(rng) * (r - 1), 1 + unit(rng) * (r - 1), 1 + unit(rng) * (r - 1)};  // texel index
      int i[3];
      double f[3], w[3][4];
      for (int a = 0; a < 3; ++a) {
        i[a] = std::min(int(std::floor(u[a])), r - 1);
        f[a] = u[a] - i[a];
        Lattice::weights(f[a], false, w[a]);
      }
      double spline = 0, lin = 0, spline_c = 0;
      for (int c = 0; c < 4; ++c)
        for (int b = 0; b < 4; ++b)
          for (int a = 0; a < 4; ++a) {
            const double wt = w[0][a] * w[1][b] * w[2][c];
            spline += wt * code(i[0] - 1 + a, i[1] - 1 + b, i[2] - 1 + c);
            spline_c += wt * 65535.0 * coefficients[(size_t(i[2] - 1 + c) * s + (i[1] - 1 + b)) * s + (i[0] - 1 + a)];
          }
      for (int c = 0; c < 8; ++c) {
        const int a = c & 1, b = (c >> 1) & 1, d = c >> 2;
        lin +=
            (a ? f[0] : 1 - f[0]) * (b ? f[1] : 1 - f[1]) * (d ? f[2] : 1 - f[2]) * code(i[0] + a, i[1] + b, i[2] + d);
      }
      worst = std::max(worst, std::abs(spline - lin));
      worst_c = std::max(worst_c, std::abs(spline_c - lin));
      if (std::min({u[0], u[1], u[2]}) >= 2 && std::max({u[0], u[1], u[2]}) < r - 1)
        worst_inside = std::max(worst_inside, std::abs(spline - lin));
    }
    SCOPED_TRACE("noise " + std::to_string(noise));
    EXPECT_LE(worst, margin);
    EXPECT_LE(worst_c, margin_c) << "the interpolating spline's bound";
    if (noise == 0.0) {
      EXPECT_LT(margin_c, 0.3 * margin) << "no clamp in the interpolating spline's bound (measured 68 against 289)";
    }
    EXPECT_GT(worst, 0.3 * margin) << "the bound is not absurdly loose";
    if (noise == 0.0) {
      // Codes per sample step: 0.3, 0.1, 0.2 of 3 / 8 over 65535; the margin is their sum / 6 + / 128 (+ 2 codes, and
      // the second differences' rounding).
      const double steps = (0.3 + 0.1 + 0.2) / 8.0 / 3.0 * 65535.0;
      EXPECT_LT(worst_inside, 2.0);
      EXPECT_LE(margin, std::ceil(steps / 6.0 + steps / 128.0) + 4.0);
    }
  }
}

TEST(LodTricubic, PrefilteredCoefficientsInterpolateTheSamplesAndReproduceCubics) {
  // A cubic polynomial brick: the not-a-knot spline of its samples is the polynomial itself, everywhere in the brick
  // (apron coefficients included); a brick with a sample without data is left alone.
  constexpr int r = 9, s = r + 2;
  std::vector<float> samples;
  std::vector<uint8_t> mask(size_t(r) * r * r, 1);
  const auto poly = [](double x, double y, double z) {
    return 0.2 + 0.01 * x * x * x - 0.02 * x * y + 0.03 * z * z - 0.001 * y * y * z + 0.004 * x * y * z;
  };
  for (int z = 0; z < r; ++z)
    for (int y = 0; y < r; ++y)
      for (int x = 0; x < r; ++x) samples.push_back(float(poly(x, y, z)));
  std::vector<uint16_t> texels;
  make_atlas_slot(r, samples.data(), mask.data(), -4.0, 8.0, texels);
  std::vector<double> c;
  ASSERT_TRUE(cubic_coefficients(r, texels.data(), c));
  ASSERT_EQ(c.size(), size_t(s) * s * s);
  const auto coef = [&](int x, int y, int z) { return c[(size_t(z) * s + y) * s + x]; };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst = 0;
  for (int n = 0; n < 2000; ++n) {
    const double u[3] = {unit(rng) * (r - 1), unit(rng) * (r - 1), unit(rng) * (r - 1)};  // sample coordinates
    int i[3];
    double w[3][4];
    for (int a = 0; a < 3; ++a) {
      i[a] = std::min(int(std::floor(u[a])), r - 2);
      Lattice::weights(u[a] - i[a], false, w[a]);
    }
    double v = 0;  // texel index = sample index + 1
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) v += w[0][x] * w[1][y] * w[2][z] * coef(i[0] + x, i[1] + y, i[2] + z);
    const double truth = (poly(u[0], u[1], u[2]) + 4.0) / 12.0;
    worst = std::max(worst, std::abs(v - truth));
  }
  EXPECT_LT(worst, 4.0 / 65535.0) << "the spline is the cubic up to the codes' rounding";
  mask[5] = 0;
  make_atlas_slot(r, samples.data(), mask.data(), -4.0, 8.0, texels);
  EXPECT_FALSE(cubic_coefficients(r, texels.data(), c));
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
