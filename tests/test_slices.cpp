// Cutting planes (RenderSettings::slices, docs/slices.md): the settings' JSON form and its errors, the exact engine's
// slice against closed forms (a linear field's slice reads the colour map at the plane; a constant volume split at an
// opaque or translucent plane, with the volume hidden on either side), and the LOD engine's slice against the exact
// one, on a box whose field the bricks hold exactly and on blunt fin and oxygen post (../shared/data).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "gl_test_support.h"
#include "oracle/reference_renderer.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/octree/builder.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_request.h"

namespace ugvr {
namespace {

using test::error_of;

// ---- Settings ----

TEST(SliceSettings, JsonRoundTrip) {
  RenderSettings s;
  s.slices.push_back(Slice{{0.5, 0, 1}, {1, 0, 0}, 1, "", std::nullopt});
  s.slices.push_back(Slice{{0, 0.25, 0}, {0.3, -1, 0.2}, 0.4, "cool-warm", std::array<double, 2>{-1, 3}});
  s.hide_volume = HideVolume::Front;
  const nlohmann::json j = settings_to_json(s);
  EXPECT_EQ(j["slices"].size(), 2u);
  EXPECT_EQ(j["hide_volume"], "front");
  EXPECT_TRUE(j["slices"][0]["range"].is_null());
  EXPECT_EQ(j["slices"][1]["color_map"], "cool-warm");
  EXPECT_EQ(settings_from_json(j, "t"), s);
  // Through text too, and the defaults: no slices, nothing hidden.
  EXPECT_EQ(settings_from_json(nlohmann::json::parse(j.dump()), "t"), s);
  EXPECT_EQ(settings_from_json(nlohmann::json::object(), "t").slices.size(), 0u);
  EXPECT_EQ(settings_to_json(RenderSettings{})["hide_volume"], "none");
  // Optional keys of a slice take their defaults.
  const RenderSettings m =
      settings_from_json(nlohmann::json::parse(R"({"slices": [{"point": [1, 2, 3], "normal": [0, 0, 2]}]})"), "t");
  ASSERT_EQ(m.slices.size(), 1u);
  EXPECT_EQ(m.slices[0].opacity, 1);
  EXPECT_EQ(m.slices[0].color_map, "");
  EXPECT_FALSE(m.slices[0].range.has_value());
}

TEST(SliceSettings, BadInputNamesTheSliceAndKey) {
  const auto err = [](const std::string& text) {
    return error_of([&] { settings_from_json(nlohmann::json::parse(text), "s.json"); });
  };
  EXPECT_NE(err(R"({"slices": {}})").find("s.json: key \"slices\": expected an array"), std::string::npos);
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0, 0]}]})").find("key \"slices[0]\""), std::string::npos);
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0, 0], "normal": [0, 0, 0]}]})").find("slices[0].normal"),
            std::string::npos);
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0], "normal": [1, 0, 0]}]})").find("slices[0].point"), std::string::npos);
  const std::string ok = R"({"point": [0, 0, 0], "normal": [1, 0, 0]})";
  EXPECT_NE(err(R"({"slices": [)" + ok + R"(, {"point": [0, 0, 0], "normal": [1, 0, 0], "opacity": 0}]})")
                .find("slices[1].opacity\": must be in (0, 1]"),
            std::string::npos);
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0, 0], "normal": [1, 0, 0], "opacity": 1.5}]})").find("slices[0].opacity"),
            std::string::npos);
  const std::string bad_map = err(R"({"slices": [{"point": [0, 0, 0], "normal": [1, 0, 0], "color_map": "jet2"}]})");
  EXPECT_NE(bad_map.find("slices[0].color_map\": unknown colour map \"jet2\""), std::string::npos) << bad_map;
  EXPECT_NE(bad_map.find("viridis"), std::string::npos) << bad_map;
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0, 0], "normal": [1, 0, 0], "range": [2, 1]}]})").find("slices[0].range"),
            std::string::npos);
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0, 0], "normal": [1, 0, 0], "range": [1]}]})").find("slices[0].range"),
            std::string::npos);
  EXPECT_NE(err(R"({"slices": [{"point": [0, 0, 0], "normal": [1, 0, 0], "colour": 1}]})")
                .find("slices[0].colour\": unknown slice key"),
            std::string::npos);
  EXPECT_NE(err(R"({"hide_volume": "left"})").find("hide_volume"), std::string::npos);
  EXPECT_NE(err(R"({"hide_volume": 1})").find("hide_volume"), std::string::npos);
  std::string nine = R"({"slices": [)";
  for (int i = 0; i < 9; ++i) nine += (i ? ", " : "") + ok;
  EXPECT_NE(err(nine + "]}").find("at most 8 slices"), std::string::npos);
}

TEST(SliceSettings, CommandLineFlags) {
  test::ScratchDir dir;
  const std::string data = dir.file("mixed.vtu");
  ASSERT_EQ(test::run_ugvr("generate --cells 1000 --kind mixed -o " + data).status, 0);
  const std::string base = "render " + data + " -o " + dir.file("a.png") + " --size 16 ";
  const test::CommandResult r =
      test::run_ugvr(base +
                     "--slice 0.1,0.2,0.3,0,0,1 --slice=0,0,0,1,1,0,0.5 --slice-map cool-warm --slice-range "
                     "-1:2 --hide-volume back --stats " +
                     dir.file("s.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(dir.file("s.json"));
  const nlohmann::json s = nlohmann::json::parse(in)["settings"];
  ASSERT_EQ(s["slices"].size(), 2u);
  EXPECT_EQ(s["slices"][0]["point"], nlohmann::json({0.1, 0.2, 0.3}));
  EXPECT_EQ(s["slices"][0]["opacity"], 1.0);
  EXPECT_EQ(s["slices"][1]["normal"], nlohmann::json({1, 1, 0}));
  EXPECT_EQ(s["slices"][1]["opacity"], 0.5);
  EXPECT_EQ(s["slices"][1]["color_map"], "cool-warm");
  EXPECT_EQ(s["slices"][1]["range"], nlohmann::json({-1, 2}));
  EXPECT_EQ(s["hide_volume"], "back");
  const auto fails = [&](const std::string& args, const std::string& expected) {
    const test::CommandResult b = test::run_ugvr(base + args);
    EXPECT_EQ(b.status, 1) << args << "\n" << b.out;
    EXPECT_NE(b.out.find(expected), std::string::npos) << args << "\n" << b.out;
  };
  fails("--slice 0,0,0,0,0,0", "--slice: the normal");
  fails("--slice 0,0,0,1,0", "--slice: expected PX,PY,PZ,NX,NY,NZ[,OPACITY]");
  fails("--slice 0,0,0,1,0,0,0", "--slice: OPACITY must be in (0, 1]");
  fails("--slice 0,0,0,1,0,0 --slice-map jet2", "--slice-map: unknown colour map");
  fails("--slice 0,0,0,1,0,0 --slice-range 2:1", "--slice-range: expected A < B");
  fails("--slice 0,0,0,1,0,0 --slice-range 2", "--slice-range: expected A:B");
  fails("--hide-volume left", "--hide-volume: expected none, front, back or all");
}

// The viewer's settings message carries the whole list of planes (web/slices.js) and where the volume hides: applied
// to the tab's request, replaced by the next list, removed by []; bad planes are rejected naming the key.
TEST(SliceSettings, ViewerMessages) {
  view::SceneInfo scene;
  scene.fields = {{"pressure", 0, 10, {}}};
  scene.field = "pressure";
  scene.bounds = {{0, 0, 0}, {1, 1, 1}};
  view::ViewState state = view::initial_view(scene);
  const auto apply = [&](const std::string& text) {
    view::apply_message(state, view::parse_client_message(text), scene);
  };
  apply(R"({"type": "settings", "slices": [{"point": [0.5, 0.5, 0.5], "normal": [0, 0, 1]},
            {"point": [0.2, 0, 0], "normal": [1, 0, 0], "opacity": 0.5, "color_map": "grayscale", "range": [0, 5]}],
            "hide_volume": "front"})");
  const RenderSettings& rs = state.request.settings;
  ASSERT_EQ(rs.slices.size(), 2u);
  EXPECT_EQ(rs.slices[1], (Slice{{0.2, 0, 0}, {1, 0, 0}, 0.5, "grayscale", std::array<double, 2>{0, 5}}));
  EXPECT_EQ(rs.hide_volume, HideVolume::Front);
  // Dragging the plane: the page sends the list again with the moved point.
  apply(R"({"type": "settings", "slices": [{"point": [0.5, 0.5, 0.7], "normal": [0, 0.1, 1]}]})");
  ASSERT_EQ(state.request.settings.slices.size(), 1u);
  EXPECT_EQ(state.request.settings.slices[0].point, (Vec3d{0.5, 0.5, 0.7}));
  EXPECT_EQ(state.request.settings.hide_volume, HideVolume::Front) << "a key not sent is kept";
  apply(R"({"type": "settings", "slices": [], "hide_volume": "none"})");
  EXPECT_TRUE(state.request.settings.slices.empty());
  const auto rejected = [](const std::string& text) { return error_of([&] { view::parse_client_message(text); }); };
  EXPECT_EQ(
      rejected(R"({"type": "settings", "slices": [{"point": [0, 0, 0], "normal": [0, 0, 0]}]})").rfind("slices:", 0),
      0u);
  EXPECT_NE(rejected(R"({"type": "settings", "slices": [{"point": [0, 0, 0], "normal": [0, 0, 0]}]})")
                .find("slices[0].normal"),
            std::string::npos);
  EXPECT_EQ(rejected(R"({"type": "settings", "slices": 3})").rfind("slices:", 0), 0u);
  EXPECT_EQ(rejected(R"({"type": "settings", "hide_volume": "left"})").rfind("hide_volume:", 0), 0u);
  EXPECT_EQ(rejected(R"({"type": "settings", "hide_volume": 2})").rfind("hide_volume:", 0), 0u);
}

// ---- The exact engine against closed forms ----

// The unit box of 4³ cells, split into tetrahedra or kept as hexahedra, with "f" = field(x).
std::shared_ptr<const Dataset> unit_box(StructuredCellShape shape, const std::function<double(Vec3d)>& field) {
  return std::make_shared<const Dataset>(oracle::box_dataset({0, 0, 0}, {1, 1, 1}, {4, 4, 4}, shape, field));
}

Camera oblique_camera() {
  Camera c;
  c.position = {2.2, -1.6, 1.9};
  c.focal_point = {0.5, 0.5, 0.5};
  c.view_up = {0, 0, 1};
  c.view_angle = 35;
  return c;
}

// A volume that shows nothing (opacity 0) with colours over [lo, hi].
TransferFunction invisible_tf(double lo, double hi) {
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(lo, hi);
  for (OpacityPoint& p : tf.opacity_points) p.opacity = 0;
  return tf;
}

bool inside_unit_box(Vec3d p, double margin) {
  return p.x > margin && p.y > margin && p.z > margin && p.x < 1 - margin && p.y < 1 - margin && p.z < 1 - margin;
}

// Each pixel whose ray meets the plane inside the box shows the colour map at the field's value there, composited at
// the slice's opacity over the background (the volume is invisible); other pixels show the background. Pixels whose
// plane point lies within 1e-3 of the box's faces are left out (the plane's edge).
void check_slice_reads_the_map(StructuredCellShape shape, const std::function<double(Vec3d)>& f, const Slice& slice,
                               const TransferFunction& tf, HideVolume hide) {
  const std::shared_ptr<const Dataset> ds = unit_box(shape, f);
  ExactEngine engine(*ds);
  engine.set_field(*ds, "f");
  RenderSettings s;
  s.width = s.height = 48;
  s.background = {0.1, 0.2, 0.3, 1};
  s.slices = {slice};
  s.hide_volume = hide;
  const Camera cam = oblique_camera();
  const Image image = engine.render(cam, tf, s);
  TransferFunction colors = slice.color_map.empty() ? tf : builtin_preset(slice.color_map);
  if (slice.range) colors.rescale((*slice.range)[0], (*slice.range)[1]);
  const CameraRays rays(cam, s.width, s.height);
  const Vec3d n = slice.normal;
  int on_slice = 0, checked = 0;
  double worst = 0;
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const Ray ray = rays.pixel(x, y);
      const double t = dot(n, slice.point - ray.origin) / dot(n, ray.direction);
      const Vec3d p = ray.origin + ray.direction * t;
      const bool hit = t > 0 && inside_unit_box(p, 0);
      if (hit != inside_unit_box(p, 1e-3) && t > 0) continue;  // the plane's edge
      ++checked;
      Vec3d expected{s.background[0], s.background[1], s.background[2]};
      if (hit) {
        ++on_slice;
        expected = colors.color(f(p)) * slice.opacity + expected * (1 - slice.opacity);
      }
      const float* px = image.pixel(x, y);
      worst =
          std::max({worst, std::abs(px[0] - expected.x), std::abs(px[1] - expected.y), std::abs(px[2] - expected.z)});
      EXPECT_NEAR(px[0], expected.x, 2e-5) << x << "," << y << (hit ? " on the slice" : " off it");
      EXPECT_NEAR(px[1], expected.y, 2e-5) << x << "," << y;
      EXPECT_NEAR(px[2], expected.z, 2e-5) << x << "," << y;
    }
  EXPECT_GT(on_slice, checked / 10) << "the slice must cover a good part of the image";
  EXPECT_LT(on_slice, checked) << "and not all of it";
  std::printf("slice of %s: %d pixels on the slice, %d checked, worst %.2g\n",
              shape == StructuredCellShape::Hexahedra ? "hexahedra" : "tetrahedra", on_slice, checked, worst);
}

// f = x on tetrahedra: the slice at each pixel is the transfer function's colour at the plane point's x.
TEST(ExactSlice, LinearFieldOnTetrahedraReadsTheColourMap) {
  const Slice slice{{0.37, 0.5, 0.5}, {1, 0.2, 0.1}, 1, "", std::nullopt};
  check_slice_reads_the_map(
      StructuredCellShape::FiveTetrahedra, [](Vec3d p) { return p.x; }, slice, invisible_tf(0, 1), HideVolume::None);
}

// On hexahedra with a field the trilinear interpolant holds exactly but that is not linear (x·y + z: the slice cuts
// cells obliquely, so this exercises the inverse isoparametric map), its own colour map and range, half opaque, and
// the volume (now opaque) hidden everywhere.
TEST(ExactSlice, BilinearFieldOnHexahedraWithItsOwnMap) {
  const Slice slice{{0.5, 0.45, 0.5}, {0.3, 1, -0.4}, 0.5, "cool-warm", std::array<double, 2>{0.2, 1.8}};
  TransferFunction opaque = builtin_preset("inferno");
  opaque.rescale(0, 2);
  for (OpacityPoint& p : opaque.opacity_points) p.opacity = 0.8;
  check_slice_reads_the_map(
      StructuredCellShape::Hexahedra, [](Vec3d p) { return p.x * p.y + p.z; }, slice, opaque, HideVolume::All);
}

// A constant field, constant colour and extinction: along each ray the volume in front of the plane, the slice, the
// volume behind it, each part shown or hidden by hide_volume, in closed form.
TEST(ExactSlice, CompositedInDepthOrderWithTheVolume) {
  const std::shared_ptr<const Dataset> ds = unit_box(StructuredCellShape::SixTetrahedra, [](Vec3d) { return 0.5; });
  ExactEngine engine(*ds);
  engine.set_field(*ds, "f");
  TransferFunction tf;
  const Vec3d vol_color{0.9, 0.5, 0.1};
  tf.color_points = {{0, vol_color}, {1, vol_color}};
  tf.opacity_points = {{0, 0.3}, {1, 0.3}};
  tf.opacity_unit_distance = 0.5;
  const double tau = -std::log(1 - 0.3) / 0.5;
  const Camera cam = oblique_camera();
  RenderSettings s;
  s.width = s.height = 40;
  s.background = {0, 0, 0, 1};
  s.early_termination_opacity = 1;
  s.lighting = false;
  // The slice's own map over [0, 1]: grey levels, so its colour at 0.5 is 0.5 grey.
  const Slice slice{{0.5, 0.5, 0.55}, {0.2, -0.3, 1}, 0.7, "grayscale", std::array<double, 2>{0, 1}};
  s.slices = {slice};
  const Vec3d slice_color = builtin_preset("grayscale").color(0.5);
  const CameraRays rays(cam, s.width, s.height);
  for (HideVolume hide : {HideVolume::None, HideVolume::Front, HideVolume::Back, HideVolume::All}) {
    s.hide_volume = hide;
    const Image image = engine.render(cam, tf, s);
    int split = 0;
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x) {
        const Ray ray = rays.pixel(x, y);
        double t0 = 0, t1 = 0;
        Vec3d radiance{0, 0, 0};
        double transmittance = 1;
        if (oracle::segment_in_box(ray, {0, 0, 0}, {1, 1, 1}, std::nullopt, t0, t1)) {
          const double tp = dot(slice.normal, slice.point - ray.origin) / dot(slice.normal, ray.direction);
          const bool crosses = tp > t0 && tp < t1;
          // Which side of the plane the ray starts on: its positive (front) side where dot(p - point, n) > 0.
          const bool starts_front = dot(ray.origin + ray.direction * t0 - slice.point, slice.normal) > 0;
          const auto volume = [&](double length, bool front_side) {
            const bool shown = hide == HideVolume::None || (hide == HideVolume::Front && !front_side) ||
                               (hide == HideVolume::Back && front_side);
            if (!shown || !(length > 0)) return;
            const double e = std::exp(-tau * length);
            radiance = radiance + vol_color * (transmittance * (1 - e));
            transmittance *= e;
          };
          if (crosses) {
            // Skip rays passing within 1e-3 of where the plane meets the box (either side is right there).
            if (tp - t0 < 1e-3 || t1 - tp < 1e-3) continue;
            ++split;
            volume(tp - t0, starts_front);
            radiance = radiance + slice_color * (transmittance * slice.opacity);
            transmittance *= 1 - slice.opacity;
            volume(t1 - tp, !starts_front);
          } else {
            volume(t1 - t0, starts_front);
          }
        }
        const float* px = image.pixel(x, y);
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(px[c], radiance[c], 1e-4) << "hide " << hide_volume_name(hide) << " pixel " << x << "," << y;
      }
    EXPECT_GT(split, 200) << "rays that cross the slice inside the box";
  }
}

// ---- The LOD engine against the exact one ----

struct GlShared {
  std::unique_ptr<GlContext> gl;
  std::string error;
};
GlShared& gl_shared() {
  static GlShared s = [] {
    GlShared r;
    r.gl = test::open_gl_context(r.error);
    return r;
  }();
  return s;
}

#define REQUIRE_GL() UGVR_REQUIRE_GL_CONTEXT(gl_shared().gl, gl_shared().error)

// The same slice by both engines: the slice alone (volume hidden) and with the volume, PSNR of each.
struct SlicePair {
  double slice_only_db = 0, with_volume_db = 0, slice_only_max = 0;
  int max_level = 0;
  double mean_level = 0;
};
SlicePair compare_engines(const Dataset& ds, const std::string& store, const std::string& field, const Camera& cam,
                          TransferFunction tf, RenderSettings s) {
  ExactEngine exact(ds);
  exact.set_field(ds, field);
  LodEngine lod(store, *gl_shared().gl);
  lod.set_field(field);
  SlicePair r;
  s.hide_volume = HideVolume::All;
  LodRenderStats st;
  const Image a = lod.render(cam, tf, s, CutSpec{CutSpec::Kind::Pixels, 1}, &st);
  const ImageDifference d = compare_images(a, exact.render(cam, tf, s));
  r.slice_only_db = d.psnr_db, r.slice_only_max = d.max_abs;
  r.max_level = st.max_level, r.mean_level = st.mean_level;
  s.hide_volume = HideVolume::None;
  r.with_volume_db =
      compare_images(lod.render(cam, tf, s, CutSpec{CutSpec::Kind::Pixels, 1}), exact.render(cam, tf, s)).psnr_db;
  return r;
}

// A box whose linear field trilinear bricks hold exactly, refined unevenly (points 1/64 apart in a band of x, 1/8
// elsewhere), so that the slice crosses nodes of several levels: LOD and exact slices agree to the bricks' 16-bit
// quantisation, with no seam where the levels meet.
TEST(LodSlice, ExactFieldMatchesTheExactSliceAcrossLevels) {
  REQUIRE_GL();
  test::ScratchDir dir;
  std::vector<float> xs;
  for (int i = 0; i < 6; ++i) xs.push_back(float(i) / 8.0f);
  for (int i = 0; i < 8; ++i) xs.push_back(0.75f + float(i) / 64.0f);
  for (float x : {0.875f, 1.0f}) xs.push_back(x);
  StructuredGrid g;
  const uint32_t nx = uint32_t(xs.size()), ny = 9, nz = 9;
  g.dims = GridDims{{nx, ny, nz}};
  std::vector<float> lin;
  for (uint32_t k = 0; k < nz; ++k)
    for (uint32_t j = 0; j < ny; ++j)
      for (uint32_t i = 0; i < nx; ++i) {
        const Vec3f p{xs[i], float(j) / 8.0f, float(k) / 8.0f};
        g.points.push_back(p);
        lin.push_back(float(p.x + 2.0 * p.y - p.z));
      }
  Block b;
  b.name = "box";
  b.grid = std::move(g);
  b.fields.add(Field("lin", Association::Vertex, DataArray::from(std::move(lin), 1)));
  Dataset ds;
  ds.sources = {"box"};
  ds.blocks.push_back(to_unstructured_block(b, StructuredCellShape::SixTetrahedra));
  OctreeBuildOptions o;
  o.resolution = 8;
  o.max_depth = 4;
  o.error = 0;
  const std::vector<std::string> fields = {"lin"};
  build_octree(prepare_octree_input(ds, fields), o, dir.file("box.ugvr"));
  Camera cam;
  cam.position = {1.9, -1.2, 1.7};
  cam.focal_point = {0.55, 0.5, 0.5};
  cam.view_up = {0, 0, 1};
  cam.view_angle = 40;
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(-1, 3);
  tf.opacity_unit_distance = 0.5;
  RenderSettings s;
  s.width = s.height = 64;
  s.background = {0, 0, 0, 1};
  // Through the refined band and the coarse part, obliquely.
  s.slices = {Slice{{0.7, 0.5, 0.5}, {1, 0.3, 0.5}, 1, "", std::nullopt}};
  const SlicePair r = compare_engines(ds, dir.file("box.ugvr"), "lin", cam, tf, s);
  std::printf("box: slice alone %.1f dB (max %.2g), with the volume %.1f dB; cut levels mean %.2f max %d\n",
              r.slice_only_db, r.slice_only_max, r.with_volume_db, r.mean_level, r.max_level);
  EXPECT_LT(r.mean_level, double(r.max_level)) << "the cut must mix levels";
  EXPECT_LT(r.slice_only_max, 2e-3);  // where the plane's edge falls is the same too
  EXPECT_GE(r.slice_only_db, 60.0);
  EXPECT_GE(r.with_volume_db, 45.0);
}

// Blunt fin (Density) and oxygen post (StagnationEnergy): a slice through the flow, LOD at the default cut
// (pixels:1) against the exact slice. The bound (45 dB, the issue's target) holds with margin for the slice alone;
// with the volume the image also carries the volume's own LOD error.
void real_data_slice(const std::string& xyz, const std::string& q, const std::string& field, Vec3d point, Vec3d normal,
                     double min_db) {
  UGVR_REQUIRE_DATA(xyz);
  test::ScratchDir dir;
  const Dataset ds = read_dataset(std::vector<std::string>{test::data_path(xyz), test::data_path(q)});
  const std::vector<std::string> fields = {field};
  // Default bricks, but no deeper than the 128² view's cut goes (level 3 at most): a few seconds to build.
  OctreeBuildOptions o;
  o.max_depth = 4;
  build_octree(prepare_octree_input(ds, fields), o, dir.file("s.ugvr"));
  const Bounds b = ds.bounds();
  const Camera cam = camera_preset("iso", b);
  ExactEngine probe(ds);
  probe.set_field(ds, field);
  TransferFunction tf = default_transfer_function(probe.field_min(), probe.field_max(), b);
  RenderSettings s;
  s.width = s.height = 128;
  const Vec3d size = b.size();
  s.slices = {Slice{b.lo + Vec3d{size.x * point.x, size.y * point.y, size.z * point.z}, normal, 1, "", std::nullopt}};
  const SlicePair r = compare_engines(ds, dir.file("s.ugvr"), field, cam, tf, s);
  std::printf("%s: slice alone %.1f dB (max %.3f), with the volume %.1f dB; cut levels mean %.2f max %d\n", xyz.c_str(),
              r.slice_only_db, r.slice_only_max, r.with_volume_db, r.mean_level, r.max_level);
  EXPECT_GE(r.slice_only_db, min_db);
}

TEST(LodSlice, BluntFinCloseToExact) {
  REQUIRE_GL();
  real_data_slice("blunt-fin/bluntfinxyz.bin", "blunt-fin/bluntfinq.bin", "Density", {0.5, 0.45, 0.5}, {0.2, 1, 0.1},
                  45);
}

TEST(LodSlice, OxygenPostCloseToExact) {
  REQUIRE_GL();
  real_data_slice("lox-post/postxyz.bin", "lox-post/postq.bin", "StagnationEnergy", {0.5, 0.5, 0.4}, {0.1, 0.2, 1}, 45);
}

}  // namespace
}  // namespace ugvr
