// The browser viewer's client messages (src/ugvr/view/view_protocol.h): what is accepted, and that every rejection
// names the field at fault.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "ugvr/core/error.h"
#include "ugvr/view/jpeg.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_request.h"

namespace ugvr::view {
namespace {

TEST(ViewProtocol, GoodMessages) {
  const ClientMessage hello = parse_client_message(R"({"type":"hello","width":64,"height":4096})");
  ASSERT_TRUE(std::holds_alternative<SizeMessage>(hello));
  EXPECT_TRUE(std::get<SizeMessage>(hello).hello);
  EXPECT_EQ(std::get<SizeMessage>(hello).width, 64);
  EXPECT_EQ(std::get<SizeMessage>(hello).height, 4096);
  const ClientMessage resize = parse_client_message(R"({"type":"resize","width":16,"height":17})");
  EXPECT_FALSE(std::get<SizeMessage>(resize).hello);

  const ClientMessage cam = parse_client_message(
      R"({"type":"camera","position":[0,0,5],"focal_point":[0,0,0],"view_up":[0,1,0],"view_angle":40})");
  ASSERT_TRUE(std::holds_alternative<CameraMessage>(cam));
  EXPECT_EQ(std::get<CameraMessage>(cam).camera.position.z, 5);
  EXPECT_EQ(std::get<CameraMessage>(cam).camera.view_angle, 40);

  const ClientMessage tf = parse_client_message(
      R"({"type":"tf","preset":"inferno","opacity":0.5,"rgb_points":[0,0,0,0,1,1,1,1],"opacity_points":[0,0,2,1]})");
  ASSERT_TRUE(std::holds_alternative<TfMessage>(tf));
  const TfMessage& t = std::get<TfMessage>(tf);
  EXPECT_EQ(t.preset, "inferno");
  EXPECT_EQ(t.opacity, 0.5);
  ASSERT_EQ(t.color_points.size(), 2u);
  EXPECT_EQ(t.color_points[1].rgb.y, 1);
  ASSERT_EQ(t.opacity_points.size(), 2u);
  EXPECT_EQ(t.opacity_points[1].x, 2);

  const ClientMessage set = parse_client_message(
      R"({"type":"settings","mode":"iso","iso_value":0.25,"step_voxels":0.5,"fps":0,"full_quality":true})");
  ASSERT_TRUE(std::holds_alternative<SettingsMessage>(set));
  const SettingsMessage& s = std::get<SettingsMessage>(set);
  EXPECT_EQ(s.mode, RenderMode::Isosurface);
  EXPECT_EQ(s.iso_value, 0.25);
  EXPECT_EQ(s.step_voxels, 0.5);
  EXPECT_EQ(s.fps, 0);
  EXPECT_TRUE(s.full_quality);
  const SettingsMessage s2 = std::get<SettingsMessage>(parse_client_message(
      R"({"type":"settings","field":"velocity","boundary_opacity":0.25,"clip":{"point":[1,2,3],"normal":[0,0,-2]}})"));
  EXPECT_EQ(s2.field, "velocity");
  EXPECT_EQ(s2.boundary_opacity, 0.25);
  ASSERT_TRUE(s2.clip && *s2.clip);
  EXPECT_EQ((**s2.clip).point.y, 2);
  EXPECT_EQ((**s2.clip).normal.z, -2);
  // "clip": null turns clipping off; no "clip" leaves it as it is.
  const SettingsMessage off = std::get<SettingsMessage>(parse_client_message(R"({"type":"settings","clip":null})"));
  ASSERT_TRUE(off.clip);
  EXPECT_FALSE(*off.clip);
  EXPECT_FALSE(s.clip);
  EXPECT_FALSE(s.field);
  EXPECT_FALSE(s.boundary_opacity);
  for (const std::string_view name : {kExactEngine, kLodEngine}) {
    const ClientMessage engine = parse_client_message(R"({"type":"engine","engine":")" + std::string(name) + "\"}");
    ASSERT_TRUE(std::holds_alternative<EngineMessage>(engine));
    EXPECT_EQ(std::get<EngineMessage>(engine).engine, name);
  }
  // Every key of tf and settings is optional.
  EXPECT_TRUE(std::holds_alternative<TfMessage>(parse_client_message(R"({"type":"tf"})")));
  EXPECT_FALSE(std::get<SettingsMessage>(parse_client_message(R"({"type":"settings"})")).mode);
}

TEST(ViewProtocol, MalformedMessagesNameTheField) {
  const std::string cam = R"("focal_point":[0,0,0],"view_up":[0,1,0])";
  const std::pair<std::string, std::string> cases[] = {
      {"", "message"},
      {"not json", "message"},
      {"[1,2]", "message"},
      {R"({"type":"hello","width":64,"height":64)", "message"},                   // truncated
      {"{\"type\":\"camera\",\"position\":[0,0,1e999]," + cam + "}", "message"},  // not finite: not JSON either
      {R"({"width":64,"height":64})", "type"},
      {R"({"type":7})", "type"},
      {R"({"type":"frobnicate"})", "type"},
      {R"({"type":"hello","height":64})", "width"},
      {R"({"type":"hello","width":64})", "height"},
      {R"({"type":"hello","width":15,"height":64})", "width"},
      {R"({"type":"hello","width":64,"height":4097})", "height"},
      {R"({"type":"hello","width":"64","height":64})", "width"},
      {R"({"type":"hello","width":64.5,"height":64})", "width"},
      {R"({"type":"resize","width":-64,"height":64})", "width"},
      {R"({"type":"hello","width":64,"height":64,"depth":3})", "depth"},
      {"{\"type\":\"camera\",\"position\":[0,0]," + cam + "}", "position"},
      {"{\"type\":\"camera\",\"position\":[0,0,\"x\"]," + cam + "}", "position"},
      {"{\"type\":\"camera\",\"position\":[0,0,1]," + cam + ",\"view_angle\":200}", "view_angle"},
      {"{\"type\":\"camera\",\"position\":[0,0,1]," + cam + ",\"zoom\":2}", "zoom"},
      {R"({"type":"camera","position":[0,0,1],"focal_point":[0,0,0]})", "view_up"},
      {R"({"type":"tf","preset":"nope"})", "preset"},
      {R"({"type":"tf","preset":3})", "preset"},
      {R"({"type":"tf","opacity":1.5})", "opacity"},
      {R"({"type":"tf","opacity":"half"})", "opacity"},
      {R"({"type":"tf","rgb_points":[0,1,1]})", "rgb_points"},
      {R"({"type":"tf","rgb_points":[0,1,1,2]})", "rgb_points"},
      {R"({"type":"tf","rgb_points":[1,1,1,1,0,0,0,0]})", "rgb_points"},
      {R"({"type":"tf","opacity_points":[0,0.5,0,1]})", "opacity_points"},
      {R"({"type":"tf","opacity_points":{"x":1}})", "opacity_points"},
      {R"({"type":"tf","colour":"red"})", "colour"},
      {R"({"type":"settings","mode":"xray"})", "mode"},
      {R"({"type":"settings","iso_value":null})", "iso_value"},
      {R"({"type":"settings","step_voxels":0})", "step_voxels"},
      {R"({"type":"settings","step_voxels":9})", "step_voxels"},
      {R"({"type":"settings","fps":-1})", "fps"},
      {R"({"type":"settings","fps":1000})", "fps"},
      {R"({"type":"settings","full_quality":"yes"})", "full_quality"},
      {R"({"type":"settings","field":""})", "field"},
      {R"({"type":"settings","field":3})", "field"},
      {R"({"type":"settings","field":null})", "field"},
      {R"({"type":"settings","field":")" + std::string(kMaxFieldName + 1, 'f') + "\"}", "field"},
      {R"({"type":"settings","boundary_opacity":1.5})", "boundary_opacity"},
      {R"({"type":"settings","boundary_opacity":"on"})", "boundary_opacity"},
      {R"({"type":"settings","boundary_opacity":-0.1})", "boundary_opacity"},
      {R"({"type":"settings","clip":true})", "clip"},
      {R"({"type":"settings","clip":{"point":[0,0,0]}})", "clip"},
      {R"({"type":"settings","clip":{"point":[0,0,0],"normal":[0,0,0]}})", "clip.normal"},
      {R"({"type":"settings","clip":{"point":[0,0],"normal":[0,0,1]}})", "clip.point"},
      {R"({"type":"settings","clip":{"point":[0,0,"x"],"normal":[0,0,1]}})", "clip.point"},
      {R"({"type":"settings","clip":{"point":[0,0,0],"normal":[0,1e400,1]}})", "message"},  // not finite: not JSON
      {R"({"type":"settings","clip":{"point":[0,0,0],"normal":[0,0,1],"side":1}})", "clip"},
      {R"({"type":"settings","clipping":null})", "clipping"},
      {R"({"type":"engine"})", "engine: missing"},
      {R"({"type":"engine","engine":"fast"})", R"(engine: expected "exact", "lod" or "hybrid", found "fast")"},
      {R"({"type":"engine","engine":"LOD"})", "engine"},
      {R"({"type":"engine","engine":1})", "engine: expected"},
      {R"({"type":"engine","engine":null})", "engine: expected"},
      {R"({"type":"engine","engine":"lod","tab":2})", "tab"},
      {R"({"type":"interest","focus":3})", "focus: expected a non-empty string or null"},
      {R"({"type":"interest","focus":""})", "focus: expected"},
      {R"({"type":"interest","focus":"p:2:1"})", "focus: p:2:1: MIN above MAX"},
      {R"({"type":"interest","focus":"p:0:1+"})", "focus"},
      {R"({"type":"interest","roi":"cube:0,0,0,1,1,1"})", "roi cube:0,0,0,1,1,1: expected box:... or sphere:..."},
      {R"({"type":"interest","roi":"sphere:0,0,0,-1"})", "roi sphere:0,0,0,-1: the radius must be > 0"},
      {R"({"type":"interest","roi":[0,0,0,1,1,1]})", "roi: expected a non-empty string or null"},
      {R"({"type":"interest","context_opacity":1.5})", "context_opacity: must be in"},
      {R"({"type":"interest","context_saturation":"grey"})", "context_saturation"},
      {R"({"type":"interest","brush":"p:0:1"})", "brush"},
  };
  for (const auto& [text, field] : cases) {
    try {
      parse_client_message(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos)
          << text << "\n  message: " << e.what() << "\n  should name: " << field;
    }
  }
}

TEST(ViewProtocol, SizeAndPointLimits) {
  // Over 64 KiB is rejected before parsing, whatever it holds.
  const std::string big = R"({"type":"tf","rgb_points":[)" + std::string(70000, ' ') + "0,0,0,0]}";
  try {
    parse_client_message(big);
    ADD_FAILURE() << "accepted a message of " << big.size() << " bytes";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("too large"), std::string::npos) << e.what();
  }
  std::string points;
  for (size_t i = 0; i <= kMaxTfPoints; ++i) points += (i ? "," : "") + std::to_string(i) + ",0.5";
  EXPECT_THROW(parse_client_message(R"({"type":"tf","opacity_points":[)" + points + "]}"), Error);
}

TEST(ViewProtocol, ServerMessages) {
  const nlohmann::json e = nlohmann::json::parse(error_message("width: must be in [16, 4096]"));
  EXPECT_EQ(e["type"], "error");
  EXPECT_EQ(e["message"], "width: must be in [16, 4096]");
  // Invalid UTF-8 quoted back from a client is replaced, not thrown.
  nlohmann::json quoted;
  EXPECT_NO_THROW(quoted = nlohmann::json::parse(error_message("type: \xff\xfe")));
  EXPECT_EQ(quoted["type"], "error");
  FrameStatus s;
  s.seq = 3, s.png = true, s.width = 64, s.height = 32, s.cut_nodes = 12, s.converged = true, s.texel_error = 0.5;
  const nlohmann::json j = nlohmann::json::parse(status_message(s));
  EXPECT_EQ(j["type"], "status");
  EXPECT_EQ(j["format"], "png");
  EXPECT_EQ(j["seq"], 3);
  EXPECT_EQ(j["width"], 64);
  EXPECT_EQ(j["cut_nodes"], 12);
  EXPECT_EQ(j["texel_error"], 0.5);
  EXPECT_EQ(j["converged"], true);
}

TEST(ViewProtocol, SceneMessageCarriesFieldsAndPresetColours) {
  SceneInfo scene;
  scene.fields = {{"pressure", -1, 2, {1, 2, 3}}, {"velocity", 0, 5, {}}};
  scene.field = "pressure";
  const nlohmann::json j = nlohmann::json::parse(scene_message(scene));
  EXPECT_EQ(j["type"], "scene");
  EXPECT_EQ(j["range"], nlohmann::json({-1.0, 2.0}));
  ASSERT_EQ(j["fields"].size(), 2u);
  EXPECT_EQ(j["fields"][0]["histogram"], nlohmann::json({1, 2, 3}));
  EXPECT_EQ(j["fields"][1]["name"], "velocity");
  for (const std::string& name : builtin_preset_names()) {
    const nlohmann::json& p = j["preset_points"][name];
    const TransferFunction tf = builtin_preset(name);
    ASSERT_EQ(p.size(), 4 * tf.color_points.size()) << name;
    EXPECT_EQ(p[0], 0.0) << name;
    EXPECT_EQ(p[p.size() - 4], 1.0) << name;
    EXPECT_EQ(p[1], tf.color_points[0].rgb.x) << name;
  }
  EXPECT_EQ(j["engines"], nlohmann::json::array()) << "none given";

  scene.engine = "lod";
  scene.renderer = "NVIDIA H100/PCIe/SSE2";
  scene.engines = {{"exact", "exact engine (GPU: NVIDIA H100/PCIe/SSE2)"}, {"lod", "NVIDIA H100/PCIe/SSE2"}};
  const nlohmann::json k = nlohmann::json::parse(scene_message(scene));
  EXPECT_EQ(k["engine"], "lod");
  EXPECT_EQ(k["renderer"], "NVIDIA H100/PCIe/SSE2");
  EXPECT_EQ(k["engines"], nlohmann::json({"exact", "lod"}));
  EXPECT_EQ(k["renderers"]["exact"], "exact engine (GPU: NVIDIA H100/PCIe/SSE2)");
  EXPECT_EQ(k["renderers"]["lod"], "NVIDIA H100/PCIe/SSE2");
}

SceneInfo two_field_scene() {
  SceneInfo scene;
  scene.fields = {{"pressure", 0, 10, {}}, {"velocity", 100, 200, {}}};
  scene.field = "pressure";
  scene.bounds = {{0, 0, 0}, {1, 1, 1}};
  return scene;
}

// `ugvr view` without --tf (ViewServerOptions::auto_tf): tabs start from each field's auto points and unit distance,
// also after a field switch or a preset pick, and the scene message gives the page the same points.
TEST(ViewRequest, TabsStartFromEachFieldsAutoPoints) {
  SceneInfo scene = two_field_scene();
  const std::vector<OpacityPoint> p{{0, 1}, {4, 0}, {6, 0}, {10, 1}}, v{{100, 0}, {200, 1}};
  scene.auto_opacity["pressure"] = {p, 0.01};
  scene.auto_opacity["velocity"] = {v, 0.1};
  ViewState s = initial_view(scene);
  EXPECT_EQ(s.request.tf.opacity_points, p);
  EXPECT_EQ(s.request.tf.opacity_unit_distance, 0.01);
  apply_message(s, parse_client_message(R"({"type":"settings","field":"velocity"})"), scene);
  EXPECT_EQ(s.request.tf.opacity_points, v);
  EXPECT_EQ(s.request.tf.opacity_unit_distance, 0.1);
  apply_message(s, parse_client_message(R"({"type":"settings","field":"pressure"})"), scene);
  apply_message(s, parse_client_message(R"({"type":"tf","preset":"inferno"})"), scene);
  EXPECT_EQ(s.request.tf.opacity_points, p) << "a preset recolours; the opacity stays auto's";
  EXPECT_EQ(s.request.tf.opacity_unit_distance, 0.01);
  EXPECT_EQ(s.request.tf.color_points, [] {
    TransferFunction t = builtin_preset("inferno");
    t.rescale(0, 10);
    return t.color_points;
  }());

  const nlohmann::json j = nlohmann::json::parse(scene_message(scene));
  EXPECT_EQ(j["fields"][0]["auto_opacity"], nlohmann::json::parse("[0, 1, 4, 0, 6, 0, 10, 1]"));
  EXPECT_EQ(j["fields"][1]["auto_opacity"], nlohmann::json::parse("[100, 0, 200, 1]"));
  // Without them (a named --tf): the preset's ramp, no auto_opacity in the message.
  const nlohmann::json k = nlohmann::json::parse(scene_message(two_field_scene()));
  EXPECT_FALSE(k["fields"][0].contains("auto_opacity"));
}

TEST(ViewRequest, FieldSwitchResetsTfPointsAndIsoValue) {
  const SceneInfo scene = two_field_scene();
  ViewState s = initial_view(scene);
  EXPECT_EQ(s.request.settings.field, "pressure");
  EXPECT_EQ(s.request.tf.range_min(), 0);
  EXPECT_EQ(s.request.tf.range_max(), 10);
  apply_message(s, parse_client_message(R"({"type":"tf","opacity_points":[0,0,5,0.5,10,0]})"), scene);
  apply_message(s, parse_client_message(R"({"type":"settings","mode":"iso","iso_value":3})"), scene);
  ASSERT_EQ(s.request.tf.opacity_points.size(), 3u);
  const uint64_t generation = s.generation;

  apply_message(s, parse_client_message(R"({"type":"settings","field":"velocity"})"), scene);
  EXPECT_EQ(s.request.settings.field, "velocity");
  EXPECT_TRUE(s.tf_opacities.empty());
  EXPECT_TRUE(s.tf_colors.empty());
  // The preset over the new range, its linear opacity ramp back.
  EXPECT_EQ(s.request.tf.range_min(), 100);
  EXPECT_EQ(s.request.tf.range_max(), 200);
  ASSERT_EQ(s.request.tf.opacity_points.size(), 2u);
  EXPECT_EQ(s.request.tf.opacity_points[1].x, 200);
  EXPECT_EQ(s.request.settings.iso_values, std::vector<double>{150}) << "3 is outside [100, 200]: the middle";
  EXPECT_EQ(s.generation, generation + 1);

  // An iso value sent with the field is kept; switching to the field already shown changes nothing.
  apply_message(s, parse_client_message(R"({"type":"settings","field":"pressure","iso_value":9})"), scene);
  EXPECT_EQ(s.request.settings.iso_values, std::vector<double>{9});
  apply_message(s, parse_client_message(R"({"type":"tf","opacity_points":[0,1,10,1]})"), scene);
  apply_message(s, parse_client_message(R"({"type":"settings","field":"pressure"})"), scene);
  EXPECT_EQ(s.tf_opacities.size(), 2u);
  // ... so it counts (generation) without changing what is drawn (changed: no frame, an ack).
  EXPECT_EQ(s.generation, generation + 4);
  EXPECT_EQ(s.changed, generation + 3);
}

TEST(ViewRequest, OnlyMessagesThatChangeTheViewMarkItChanged) {
  const SceneInfo scene = two_field_scene();
  ViewState s = initial_view(scene);
  apply_message(s, parse_client_message(R"({"type":"hello","width":64,"height":64})"), scene);
  EXPECT_EQ(s.changed, 1u) << "hello draws the first frame";
  const std::string camera =
      R"({"type":"camera","position":[0,0,5],"focal_point":[0,0,0],"view_up":[0,1,0],"view_angle":30})";
  apply_message(s, parse_client_message(camera), scene);
  EXPECT_EQ(s.changed, 2u);
  for (const std::string& repeat : {camera, std::string(R"({"type":"resize","width":64,"height":64})"),
                                    std::string(R"({"type":"settings","fps":10})")}) {
    apply_message(s, parse_client_message(repeat), scene);
    EXPECT_EQ(s.changed, 2u) << repeat << " changed nothing";
  }
  EXPECT_EQ(s.generation, 5u);
  apply_message(s, parse_client_message(R"({"type":"settings","full_quality":true})"), scene);
  EXPECT_EQ(s.changed, 6u) << "a full-quality frame is asked for";
  apply_message(s, parse_client_message(R"({"type":"settings","fps":3})"), scene);
  EXPECT_EQ(s.changed, 7u);
}

TEST(ViewRequest, UnknownFieldIsRejectedAndStateUnchanged) {
  const SceneInfo scene = two_field_scene();
  ViewState s = initial_view(scene);
  apply_message(s, parse_client_message(R"({"type":"tf","opacity_points":[0,0,10,1]})"), scene);
  const ViewState before = s;
  try {
    apply_message(s, parse_client_message(R"({"type":"settings","field":"temperature","fps":3})"), scene);
    ADD_FAILURE() << "accepted an unknown field";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("field: no field \"temperature\" (fields: pressure, velocity)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(s.request.settings, before.request.settings);
  EXPECT_EQ(s.request.tf, before.request.tf);
  EXPECT_EQ(s.request.fps, before.request.fps);
  EXPECT_EQ(s.generation, before.generation);
}

// A vector's name alone selects its magnitude, as on a mesh and in `ugvr render` of a store; the scene's own names
// win, and the state names the field as the store does.
TEST(ViewRequest, VectorNameSelectsItsMagnitude) {
  SceneInfo scene = two_field_scene();
  scene.fields = {{"pressure", 0, 10, {}}, {"velocity:magnitude", 0, 2, {}}, {"heat", 1, 3, {}}};
  ASSERT_NE(scene.find_field("velocity"), nullptr);
  EXPECT_EQ(scene.find_field("velocity")->name, "velocity:magnitude");
  EXPECT_EQ(scene.find_field("heat")->name, "heat");
  EXPECT_EQ(scene.find_field("heat:magnitude"), nullptr) << "only a name alone is widened";
  EXPECT_EQ(scene.find_field("pres"), nullptr);
  ViewState s = initial_view(scene);
  apply_message(s, parse_client_message(R"({"type":"settings","field":"velocity"})"), scene);
  EXPECT_EQ(s.request.settings.field, "velocity:magnitude");
  EXPECT_EQ(s.request.tf.range_max(), 2);
}

// New tabs start from the scene's background when it has one (the demo's dark one), else RenderSettings' default;
// the opacity unit distance defaults to the bounds' diagonal / 10, as `ugvr render`'s.
TEST(ViewRequest, InitialBackgroundAndUnitDistance) {
  SceneInfo scene = two_field_scene();
  scene.bounds = {{0, 0, 0}, {3, 4, 12}};  // diagonal 13
  ViewState plain = initial_view(scene);
  EXPECT_EQ(plain.request.settings.background, RenderSettings{}.background);
  EXPECT_DOUBLE_EQ(plain.request.tf.opacity_unit_distance, 1.3);
  scene.background = std::array<double, 4>{0.02, 0.02, 0.04, 1};
  const ViewState dark = initial_view(scene);
  EXPECT_EQ(dark.request.settings.background, *scene.background);
  apply_message(plain, parse_client_message(R"({"type":"settings","background":[1,1,1]})"), scene);
  EXPECT_EQ(plain.request.settings.background[0], 1.0) << "a page's pick still wins";
}

TEST(ViewRequest, ClipAndBoundaryOverlay) {
  const SceneInfo scene = two_field_scene();
  ViewState s = initial_view(scene);
  EXPECT_FALSE(s.request.settings.clip_plane);
  apply_message(
      s,
      parse_client_message(R"({"type":"settings","boundary_opacity":0.4,"clip":{"point":[0.5,0,0],"normal":[1,0,0]}})"),
      scene);
  EXPECT_EQ(s.request.settings.boundary_overlay_opacity, 0.4);
  ASSERT_TRUE(s.request.settings.clip_plane);
  EXPECT_EQ(s.request.settings.clip_plane->point.x, 0.5);
  apply_message(s, parse_client_message(R"({"type":"settings","fps":5})"), scene);
  EXPECT_TRUE(s.request.settings.clip_plane) << "absent: unchanged";
  apply_message(s, parse_client_message(R"({"type":"settings","clip":null})"), scene);
  EXPECT_FALSE(s.request.settings.clip_plane);
  EXPECT_EQ(s.request.settings.boundary_overlay_opacity, 0.4);
}

// A tab picks one of the scene's engines; another is refused with the engines there are, and the state is unchanged.
TEST(ViewRequest, EngineMustBeOneTheSceneOffers) {
  SceneInfo scene = two_field_scene();
  scene.engine = "exact";
  scene.engines = {{"exact", "exact engine (CPU)"}};  // a grid whose store is still being built
  ViewState s = initial_view(scene);
  EXPECT_EQ(s.request.engine, "") << "a new tab: the scene's engine";
  const ViewState before = s;
  try {
    apply_message(s, parse_client_message(R"({"type":"engine","engine":"lod"})"), scene);
    ADD_FAILURE() << "accepted an engine the scene does not offer";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "engine: \"lod\" is not available: the brick store is not ready yet (engines: exact)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(s.request.engine, before.request.engine);
  EXPECT_EQ(s.generation, before.generation);
  apply_message(s, parse_client_message(R"({"type":"engine","engine":"exact"})"), scene);
  EXPECT_EQ(s.request.engine, "exact");
  EXPECT_EQ(s.generation, before.generation + 1) << "an accepted message is counted (a new frame follows)";

  scene.engines = {{"exact", "exact engine (CPU)"}, {"lod", "llvmpipe"}};  // the store is shown, the grid kept
  apply_message(s, parse_client_message(R"({"type":"engine","engine":"lod"})"), scene);
  EXPECT_EQ(s.request.engine, "lod");
  apply_message(s, parse_client_message(R"({"type":"engine","engine":"exact"})"), scene);
  EXPECT_EQ(s.request.engine, "exact");

  scene.engines = {{"lod", "llvmpipe"}};  // a viewer of a store
  EXPECT_THROW(apply_message(s, parse_client_message(R"({"type":"engine","engine":"exact"})"), scene), Error);
  EXPECT_EQ(s.request.engine, "exact") << "unchanged";
}

// The interest message (focus + context, docs/hybrid.md): the texts of `ugvr render --focus / --roi`, each key
// optional, null removing it; a focus field must be one of the scene's (a vector's name alone is its magnitude). The
// status of a hybrid frame says how much is exact.
TEST(ViewRequest, InterestSetsFocusRegionAndContext) {
  SceneInfo scene = two_field_scene();
  scene.fields.push_back({"wind:magnitude", 0, 5, {}});
  ViewState s = initial_view(scene);
  EXPECT_TRUE(s.request.focus.empty());
  EXPECT_FALSE(s.request.roi);
  apply_message(s,
                parse_client_message(R"({"type":"interest","focus":"pressure:1:2+wind:0:1,velocity:150:160",)"
                                     R"("roi":"sphere:0.5,0.5,0.5,0.25","context_saturation":0,"context_opacity":1})"),
                scene);
  ASSERT_EQ(s.request.focus.size(), 3u);
  EXPECT_EQ(s.request.focus[0], (FocusRange{"pressure", 1, 2, 0}));
  EXPECT_EQ(s.request.focus[1], (FocusRange{"wind:magnitude", 0, 1, 0}));
  EXPECT_EQ(s.request.focus[2], (FocusRange{"velocity", 150, 160, 1}));
  ASSERT_TRUE(s.request.roi);
  EXPECT_EQ(s.request.roi->shape, RegionOfInterest::Shape::Sphere);
  EXPECT_EQ(s.request.context_saturation, 0);
  EXPECT_EQ(s.request.context_opacity, 1);
  // Absent keys stay; null removes.
  apply_message(s, parse_client_message(R"({"type":"interest","roi":null})"), scene);
  EXPECT_FALSE(s.request.roi);
  EXPECT_EQ(s.request.focus.size(), 3u);
  const ViewState before = s;
  EXPECT_THROW(apply_message(s, parse_client_message(R"({"type":"interest","focus":"density:0:1"})"), scene), Error);
  EXPECT_EQ(s.request.focus, before.request.focus) << "unchanged";
  apply_message(s, parse_client_message(R"({"type":"interest","focus":null})"), scene);
  EXPECT_TRUE(s.request.focus.empty());

  FrameStatus st;
  st.engine = "hybrid", st.hybrid = true, st.exact_nodes = 5, st.exact_candidates = 7, st.exact_fraction = 0.25;
  st.cell_budget_full = true;
  const nlohmann::json j = nlohmann::json::parse(status_message(st));
  EXPECT_EQ(j["exact"]["nodes"], 5);
  EXPECT_EQ(j["exact"]["candidates"], 7);
  EXPECT_EQ(j["exact"]["fraction"], 0.25);
  EXPECT_EQ(j["exact"]["budget_full"], true);
  EXPECT_TRUE(j["exact"]["off"].is_null());
  EXPECT_FALSE(nlohmann::json::parse(status_message(FrameStatus{})).contains("exact")) << "not a hybrid frame";
}

// The time message (a series' step, web/time_panel.js): parsed strictly, then checked against the scene's steps;
// a scene without a time axis rejects it. The scene and status messages carry the steps and the step shown.
TEST(ViewProtocol, TimeMessage) {
  const ClientMessage m = parse_client_message(R"({"type":"time","step":3,"playing":true})");
  ASSERT_TRUE(std::holds_alternative<TimeMessage>(m));
  EXPECT_EQ(std::get<TimeMessage>(m).step, 3u);
  EXPECT_TRUE(std::get<TimeMessage>(m).playing);
  EXPECT_FALSE(std::get<TimeMessage>(parse_client_message(R"({"type":"time","step":0})")).playing);
  const std::pair<std::string, std::string> bad[] = {
      {R"({"type":"time"})", "step"},
      {R"({"type":"time","step":-1})", "step"},
      {R"({"type":"time","step":1.5})", "step"},
      {R"({"type":"time","step":"2"})", "step"},
      {R"({"type":"time","step":4294967296})", "step"},
      {R"({"type":"time","step":1,"playing":1})", "playing"},
      {R"({"type":"time","step":1,"time":0.5})", "time"},
  };
  for (const auto& [text, field] : bad) {
    try {
      parse_client_message(text);
      ADD_FAILURE() << "accepted " << text;
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(field + ":", 0), 0u) << text << " -> " << e.what();
    }
  }

  SceneInfo scene = two_field_scene();
  ViewState one = initial_view(scene);
  EXPECT_FALSE(one.request.time_step.has_value()) << "no time axis: no step asked for";
  try {
    apply_message(one, parse_client_message(R"({"type":"time","step":0})"), scene);
    ADD_FAILURE() << "a scene of one step accepted a time step";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("step: this viewer shows one step (the input is not a time series)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(nlohmann::json::parse(scene_message(scene)).count("time"), 0u);

  scene.times = {0, 0.5, 1.0};
  scene.time_step = 1;
  const nlohmann::json sj = nlohmann::json::parse(scene_message(scene));
  EXPECT_EQ(sj["time"]["count"], 3);
  EXPECT_EQ(sj["time"]["times"], nlohmann::json({0, 0.5, 1.0}));
  EXPECT_EQ(sj["time"]["step"], 1);
  EXPECT_EQ(sj["time"].count("play"), 0u) << "paused unless --play";
  scene.play_rate = 12;
  EXPECT_EQ(nlohmann::json::parse(scene_message(scene))["time"]["play"], 12.0);
  scene.play_rate = 0;
  ViewState s = initial_view(scene);
  EXPECT_EQ(s.request.time_step, 1u) << "a new tab asks for the scene's step";
  const ViewState before = s;
  try {
    apply_message(s, parse_client_message(R"({"type":"time","step":3})"), scene);
    ADD_FAILURE() << "accepted a step past the end";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("step: step 3 is out of range (the series has 3 steps: 0 to 2)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(s.request.time_step, before.request.time_step);
  EXPECT_EQ(s.generation, before.generation);
  apply_message(s, parse_client_message(R"({"type":"time","step":2,"playing":true})"), scene);
  EXPECT_EQ(s.request.time_step, 2u);
  EXPECT_TRUE(s.request.playing);
  EXPECT_EQ(s.generation, before.generation + 1);

  FrameStatus st;
  EXPECT_EQ(nlohmann::json::parse(status_message(st)).count("time_step"), 0u) << "no time axis: not said";
  st.time_step = 2, st.time = 1.0;
  const nlohmann::json j = nlohmann::json::parse(status_message(st));
  EXPECT_EQ(j["time_step"], 2);
  EXPECT_EQ(j["time"], 1.0);
}

TEST(ViewJpeg, EncodesAnyImageSize) {
  Image im(17, 5);  // odd sizes: chroma subsampling pads internally
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      float* p = im.pixel(x, y);
      p[0] = float(x) / 16, p[1] = float(y) / 4, p[2] = 2.0f, p[3] = 1;  // 2: clamped
    }
  const std::vector<unsigned char> j = jpeg_bytes(im);
  ASSERT_GT(j.size(), 100u);
  EXPECT_EQ(j[0], 0xFF);
  EXPECT_EQ(j[1], 0xD8);
  EXPECT_EQ(j[j.size() - 2], 0xFF);
  EXPECT_EQ(j[j.size() - 1], 0xD9);
  EXPECT_LT(jpeg_bytes(im, 20).size(), jpeg_bytes(im, 95).size());
  EXPECT_THROW(jpeg_bytes(Image{}), Error);
}

}  // namespace
}  // namespace ugvr::view
