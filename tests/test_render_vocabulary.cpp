// Rendering vocabulary: VTK-compatible camera framing, presets, camera JSON, primary rays, transfer functions with
// ParaView preset JSON, and render settings.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

using test::error_of;

Bounds box(Vec3d lo, Vec3d hi) {
  Bounds b;
  b.add(lo);
  b.add(hi);
  return b;
}

void expect_near(Vec3d a, Vec3d b, double tol = 1e-9) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

double angle_between(Vec3d a, Vec3d b) { return std::acos(std::clamp(dot(a, b) / (length(a) * length(b)), -1.0, 1.0)); }

TEST(Camera, ResetMatchesVtk) {
  const Camera c = reset_camera(box({0, 0, 0}, {2, 4, 6}));
  const double radius = 0.5 * std::sqrt(4.0 + 16.0 + 36.0);
  const double distance = radius / std::sin(15 * kDeg);
  expect_near(c.focal_point, {1, 2, 3});
  expect_near(c.position, {1, 2, 3 + distance});  // default direction -z: camera on +z
  expect_near(c.view_up, {0, 1, 0});
  EXPECT_NEAR(c.parallel_scale, radius, 1e-12);
  EXPECT_NEAR(c.distance(), distance, 1e-9);
  EXPECT_DOUBLE_EQ(c.view_angle, 30);
  EXPECT_NE(error_of([] { reset_camera(Bounds{}); }), "(no error)");
}

TEST(Camera, PresetsLookAlongAxes) {
  const Bounds b = box({-1, -1, -1}, {1, 1, 1});
  struct Case {
    const char* name;
    Vec3d dir, up;
  };
  for (const Case& k :
       {Case{"+x", {1, 0, 0}, {0, 0, 1}}, Case{"-x", {-1, 0, 0}, {0, 0, 1}}, Case{"+y", {0, 1, 0}, {0, 0, 1}},
        Case{"-y", {0, -1, 0}, {0, 0, 1}}, Case{"+z", {0, 0, 1}, {0, 1, 0}}, Case{"-z", {0, 0, -1}, {0, 1, 0}}}) {
    SCOPED_TRACE(k.name);
    const Camera c = camera_preset(k.name, b);
    expect_near(c.direction(), k.dir);
    expect_near(c.view_up, k.up);
  }
  const Camera iso = camera_preset("iso", b);
  expect_near(iso.direction(), normalized(Vec3d{-1, -1, -1}));
  EXPECT_NEAR(dot(iso.view_up, iso.direction()), 0, 1e-12);
  EXPECT_GT(iso.view_up.y, 0.8);
  EXPECT_NE(error_of([&] { camera_preset("top", b); }).find("unknown view preset"), std::string::npos);
}

TEST(Camera, JsonRoundTripAndValidation) {
  Camera c = reset_camera(box({0, 0, 0}, {1, 2, 3}), 40, {1, 2, -1}, {0, 0, 1});
  c.parallel_projection = true;
  EXPECT_EQ(camera_from_json(nlohmann::json::parse(camera_to_json(c).dump()), "cam.json"), c);

  auto error_with = [&](const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json j = camera_to_json(c);
    edit(j);
    return error_of([&] { camera_from_json(j, "cam.json"); });
  };
  auto expect_error = [](const std::string& e, const std::string& key) {
    EXPECT_NE(e.find("cam.json"), std::string::npos) << e;
    EXPECT_NE(e.find("\"" + key + "\""), std::string::npos) << e;
  };
  expect_error(error_with([](auto& j) { j["position"] = {0, 0}; }), "position");
  expect_error(error_with([](auto& j) { j["position"][0] = "a"; }), "position");
  expect_error(error_with([](auto& j) { j["view_angle"] = std::nan(""); }), "view_angle");  // NaN becomes null
  expect_error(error_with([](auto& j) { j["view_angle"] = 180; }), "view_angle");
  expect_error(error_with([](auto& j) { j["view_angle"] = 0; }), "view_angle");
  expect_error(error_with([](auto& j) { j["parallel_scale"] = 0; }), "parallel_scale");
  expect_error(error_with([](auto& j) { j["parallel_projection"] = 1; }), "parallel_projection");
  expect_error(error_with([](auto& j) { j["view_up"] = {0, 0, 0}; }), "view_up");
  expect_error(error_with([](auto& j) { j["focal_point"] = j["position"]; }), "focal_point");
  expect_error(error_with([](auto& j) { j.erase("view_up"); }), "view_up");
  expect_error(error_with([](auto& j) { j["zoom"] = 2; }), "zoom");
  // view_up parallel to the view direction
  expect_error(error_with([](auto& j) {
                 j["position"] = {0, 0, 5};
                 j["focal_point"] = {0, 0, 0};
                 j["view_up"] = {0, 0, -2};
               }),
               "view_up");
}

TEST(CameraRays, PerspectiveCentreAndCorners) {
  const Camera c = reset_camera(box({0, 0, 0}, {2, 4, 6}), 30, {1, -0.5, -2}, {0, 1, 0});
  const CameraRays rays(c, 101, 51);  // odd sizes: the centre pixel's centre is the image centre
  const Ray centre = rays.pixel(50, 25);
  expect_near(centre.origin, c.position);
  expect_near(centre.direction, c.direction());
  EXPECT_NEAR(length(centre.direction), 1, 1e-12);
  // Top and bottom edges span exactly the vertical view angle; left/right span the aspect-scaled one.
  const Ray top = rays.at(50.5, 0), bottom = rays.at(50.5, 51);
  EXPECT_NEAR(angle_between(top.direction, bottom.direction), 30 * kDeg, 1e-12);
  EXPECT_GT(dot(top.direction, c.view_up), 0);  // row 0 is the top
  const double half_w = std::atan(std::tan(15 * kDeg) * 101.0 / 51.0);
  EXPECT_NEAR(angle_between(rays.at(0, 25.5).direction, rays.at(101, 25.5).direction), 2 * half_w, 1e-12);
  // Pixel-centre corner rays lie half a pixel inside those edges.
  const double half_h_px = std::tan(15 * kDeg) * (1 - 1.0 / 51);
  EXPECT_NEAR(angle_between(rays.pixel(50, 0).direction, rays.pixel(50, 50).direction), 2 * std::atan(half_h_px),
              1e-12);
}

TEST(CameraRays, ParallelRaysAreParallel) {
  Camera c = reset_camera(box({0, 0, 0}, {2, 4, 6}));
  c.parallel_projection = true;
  const CameraRays rays(c, 64, 32);
  const Ray a = rays.pixel(0, 0), b = rays.pixel(63, 31), top = rays.at(10, 0), bottom = rays.at(10, 32);
  expect_near(a.direction, c.direction());
  expect_near(b.direction, c.direction());
  EXPECT_NEAR(dot(top.origin - bottom.origin, c.view_up), 2 * c.parallel_scale, 1e-9);
  EXPECT_NEAR(length(rays.at(0, 16).origin - rays.at(64, 16).origin), 4 * c.parallel_scale, 1e-9);
  EXPECT_NEAR(dot(a.origin - c.position, c.direction()), 0, 1e-9);  // origins on the plane through the camera
}

TEST(TransferFunction, InterpolationClampAndRescale) {
  TransferFunction tf;
  tf.color_points = {{0, {0, 0, 1}}, {10, {1, 0, 0}}, {20, {1, 1, 1}}};
  tf.opacity_points = {{5, 0}, {15, 0.8}};
  expect_near(tf.color(0), {0, 0, 1});
  expect_near(tf.color(10), {1, 0, 0});
  expect_near(tf.color(5), {0.5, 0, 0.5});
  expect_near(tf.color(17.5), {1, 0.75, 0.75});
  expect_near(tf.color(-3), {0, 0, 1});
  expect_near(tf.color(99), {1, 1, 1});
  expect_near(tf.color(std::nan("")), tf.nan_color);
  EXPECT_DOUBLE_EQ(tf.opacity(0), 0);
  EXPECT_DOUBLE_EQ(tf.opacity(10), 0.4);
  EXPECT_DOUBLE_EQ(tf.opacity(15), 0.8);
  EXPECT_DOUBLE_EQ(tf.opacity(100), 0.8);
  EXPECT_DOUBLE_EQ(tf.opacity(std::nan("")), 0);

  tf.rescale(100, 140);
  EXPECT_DOUBLE_EQ(tf.range_min(), 100);
  EXPECT_DOUBLE_EQ(tf.range_max(), 140);
  expect_near(tf.color(110), {0.5, 0, 0.5});
  EXPECT_DOUBLE_EQ(tf.opacity(120), 0.4);
  tf.rescale(7, 7);
  EXPECT_DOUBLE_EQ(tf.range_min(), 6.5);
  EXPECT_DOUBLE_EQ(tf.range_max(), 7.5);
}

TEST(TransferFunction, UnitDistanceCorrection) {
  TransferFunction tf = builtin_preset("grayscale");
  tf.opacity_unit_distance = 0.25;
  const double a = tf.opacity(0.3);
  EXPECT_DOUBLE_EQ(a, 0.3);
  EXPECT_NEAR(tf.opacity_for_length(0.3, 0.25), a, 1e-15);
  EXPECT_NEAR(tf.opacity_for_length(0.3, 0.5), 1 - (1 - a) * (1 - a), 1e-15);
  EXPECT_NEAR(tf.opacity_for_length(0.3, 0.125), 1 - std::sqrt(1 - a), 1e-15);
  EXPECT_DOUBLE_EQ(corrected_opacity(1, 0.01, 1), 1);
  EXPECT_DOUBLE_EQ(corrected_opacity(0.5, 0, 1), 0);
}

// "Cool to Warm" exactly as ParaView 5.x exports it.
constexpr const char* kCoolToWarm = R"([
  {
    "ColorSpace" : "Diverging",
    "Creator" : "Kenneth Moreland",
    "Name" : "Cool to Warm",
    "NanColor" : [ 1, 1, 0 ],
    "RGBPoints" : [ 0, 0.23137254902, 0.298039215686, 0.752941176471,
                    0.5, 0.865, 0.865, 0.865,
                    1, 0.705882352941, 0.0156862745098, 0.149019607843 ]
  }
])";

TEST(TransferFunction, ParaViewPresetJson) {
  const std::vector<TransferFunction> all = parse_paraview_presets(kCoolToWarm, "cw.json");
  ASSERT_EQ(all.size(), 1u);
  const TransferFunction& tf = all[0];
  EXPECT_EQ(tf.name, "Cool to Warm");
  EXPECT_EQ(tf.color_space, "Diverging");
  ASSERT_EQ(tf.color_points.size(), 3u);
  expect_near(tf.color(0.5), {0.865, 0.865, 0.865});
  expect_near(tf.color(1), {0.705882352941, 0.0156862745098, 0.149019607843});
  EXPECT_DOUBLE_EQ(tf.opacity(0.25), 0.25);  // default ramp without "Points"

  // Our own output reads back identically, with opacity points and a non-default unit distance.
  TransferFunction mine = builtin_preset("viridis");
  mine.opacity_points = {{0, 0}, {0.3, 0.1}, {1, 0.9}};
  mine.opacity_unit_distance = 0.5;
  mine.rescale(-2, 3);
  const std::vector<TransferFunction> back = parse_paraview_presets(paraview_preset_json(mine), "out.json");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0], mine);
  // A single object (not an array) is accepted too, with opacity "Points".
  const TransferFunction single = parse_paraview_presets(
      R"({"Name": "x", "RGBPoints": [0, 0, 0, 0, 2, 1, 1, 1], "Points": [0, 0, 0.5, 0, 2, 0.5, 0.5, 0]})", "s.json")[0];
  EXPECT_DOUBLE_EQ(single.opacity(1), 0.25);

  auto bad = [](const char* text) { return error_of([&] { parse_paraview_presets(text, "bad.json"); }); };
  for (const char* text : {R"({"RGBPoints": [0, 0, 0, 0, 1, 1, 1]})", R"({"RGBPoints": [1, 0, 0, 0, 0, 1, 1, 1]})",
                           R"({"RGBPoints": [0, 0, 0, 0, 0, 1, 1, 1]})", R"({"RGBPoints": [0, 2, 0, 0]})"}) {
    const std::string e = bad(text);
    EXPECT_NE(e.find("bad.json"), std::string::npos) << e;
    EXPECT_NE(e.find("RGBPoints"), std::string::npos) << e;
  }
  EXPECT_NE(bad(R"({"RGBPoints": [0, 0, 0, 0], "Points": [0, 1.5, 0.5, 0]})").find("Points"), std::string::npos);
  EXPECT_NE(bad(R"({"RGBPoints": [0, 0, 0, 0], "Points": [0, 1, 0.5]})").find("Points"), std::string::npos);
  EXPECT_NE(bad(R"({"Name": "x"})").find("RGBPoints"), std::string::npos);
  EXPECT_NE(bad("[1, 2").find("invalid JSON"), std::string::npos);
}

TEST(TransferFunction, BuiltinPresets) {
  for (const std::string& name : builtin_preset_names()) {
    SCOPED_TRACE(name);
    const TransferFunction tf = builtin_preset(name);
    EXPECT_NO_THROW(tf.validate(name));
    EXPECT_DOUBLE_EQ(tf.range_min(), 0);
    EXPECT_DOUBLE_EQ(tf.range_max(), 1);
  }
  EXPECT_GE(builtin_preset("viridis").color_points.size(), 16u);
  EXPECT_GE(builtin_preset("inferno").color_points.size(), 16u);
  // matplotlib viridis: #440154 at 0, #fde725 at 1, and entry 128 (#21918c) close to the middle.
  expect_near(builtin_preset("viridis").color(0), {0.267004, 0.004874, 0.329415});
  expect_near(builtin_preset("viridis").color(1), {0.993248, 0.906157, 0.143936});
  expect_near(builtin_preset("viridis").color(128.0 / 255), {0.128729, 0.563265, 0.551229}, 0.01);
  expect_near(builtin_preset("cool-warm").color(0.5), {0.865003, 0.865003, 0.865003});
  EXPECT_NE(error_of([] { builtin_preset("nope"); }).find("viridis"), std::string::npos);
}

TEST(RenderSettings, JsonRoundTripValidationAndSize) {
  RenderSettings s;
  s.width = 800;
  s.height = 600;
  s.background = {0, 0, 0, 0};
  s.mode = RenderMode::Isosurface;
  s.field = "velocity:magnitude";
  s.iso_values = {0.25, 1.5};
  s.clip_plane = ClipPlane{{1, 2, 3}, {0, 0, 1}};
  s.lighting = false;
  s.early_termination_opacity = 0.95;
  s.sample_step = 0.01;
  s.boundary_overlay_opacity = 0.3;
  EXPECT_EQ(settings_from_json(nlohmann::json::parse(settings_to_json(s).dump()), "s.json"), s);
  EXPECT_EQ(settings_from_json(settings_to_json(RenderSettings{}), "s.json"), RenderSettings{});
  EXPECT_EQ(settings_from_json(nlohmann::json::object(), "s.json"), RenderSettings{});

  auto error_with = [](const char* text) {
    return error_of([&] { settings_from_json(nlohmann::json::parse(text), "s.json"); });
  };
  for (auto [text, key] : std::initializer_list<std::pair<const char*, const char*>>{
           {R"({"width": 0})", "width"},
           {R"({"height": 1.5})", "height"},
           {R"({"background": [2, 0, 0]})", "background"},
           {R"({"mode": "dvr"})", "mode"},
           {R"({"mode": "isosurface"})", "iso_values"},
           {R"({"clip_plane": {"point": [0, 0, 0], "normal": [0, 0, 0]}})", "clip_plane"},
           {R"({"early_termination_opacity": 0})", "early_termination_opacity"},
           {R"({"sample_step": -1})", "sample_step"},
           {R"({"boundary_overlay_opacity": 2})", "boundary_overlay_opacity"},
           {R"({"lightning": true})", "lightning"}}) {
    const std::string e = error_with(text);
    EXPECT_NE(e.find("s.json"), std::string::npos) << e;
    EXPECT_NE(e.find(key), std::string::npos) << e;
  }

  EXPECT_EQ(parse_size("512"), (ImageSize{512, 512}));
  EXPECT_EQ(parse_size("800x600"), (ImageSize{800, 600}));
  for (const char* bad : {"", "0", "x600", "800x", "800x600x2", "-5", "12a", "99999"})
    EXPECT_NE(error_of([&] { parse_size(bad, "--size"); }).find("--size"), std::string::npos) << bad;
}

}  // namespace
}  // namespace ugvr
