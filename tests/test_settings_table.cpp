// Every front end of the render settings against their one table (src/ugvr/render/settings_table.h): the JSON form
// (settings_to_json), `ugvr render`'s flags, the viewer's "settings" message (view_protocol.h, applied by
// view_request.h) and the page's controls (web/index.html, web/app.js). A RenderSettings field without a row, a row
// whose flag, message key or control is missing (and not explained in the row), or a front end that accepts a value
// without applying it, fails here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/settings_table.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_request.h"

namespace ugvr {
namespace {

using nlohmann::json;
using test::CommandResult;
using test::run_ugvr;

std::string read_source(const std::string& relative) {
  const std::string path = std::string(UGVR_SOURCE_DIR) + "/" + relative;
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << "cannot read " << path;
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A value other than the default for each row, per front end, and what settings_to_json then holds for the row's
// key. A new row needs an entry here.
struct Example {
  std::string flag_args;  // after the row's flag (empty for a switch)
  json from_flag;
  json message_value;  // the row's value in a "settings" message
  json from_message;
};

const std::map<std::string, Example>& examples() {
  static const std::map<std::string, Example> m = {
      {"width", {"12x16", 12, nullptr, nullptr}},
      {"height", {"16x12", 12, nullptr, nullptr}},
      {"background", {"1,0,0", {1, 0, 0, 1}, {1, 0.5, 0}, {1, 0.5, 0, 1}}},
      {"mode", {"mip", "mip", "mip", "mip"}},
      {"field", {"velocity:x", "velocity:x", "velocity", "velocity"}},
      // --iso alone also picks isosurface mode; --mode ea keeps the change to this key.
      {"iso_values", {"0.5 --mode ea", {0.5}, 3, {3}}},
      {"iso_opacity", {"0.5", 0.5, 0.5, 0.5}},
      {"clip_plane",
       {"0,0,0,1,0,0",
        {{"point", {0, 0, 0}}, {"normal", {1, 0, 0}}},
        {{"point", {0.5, 0, 0}}, {"normal", {0, 0, -1}}},
        {{"point", {0.5, 0, 0}}, {"normal", {0, 0, -1}}}}},
      {"lighting", {"", false, false, false}},
      {"volume_lighting", {"", true, true, true}},
      {"early_termination_opacity", {"0.5", 0.5, 0.5, 0.5}},
      {"sample_step", {"0.01", 0.01, 0.01, 0.01}},
      {"boundary_overlay_opacity", {"0.5", 0.5, 0.5, 0.5}},
      {"slices",
       {"0,0,0,1,0,0",
        json::array(
            {{{"point", {0, 0, 0}}, {"normal", {1, 0, 0}}, {"opacity", 1}, {"color_map", ""}, {"range", nullptr}}}),
        json::array({{{"point", {0.5, 0, 0}}, {"normal", {0, 0, 1}}}}),
        json::array(
            {{{"point", {0.5, 0, 0}}, {"normal", {0, 0, 1}}, {"opacity", 1}, {"color_map", ""}, {"range", nullptr}}})}},
      {"hide_volume", {"front", "front", "back", "back"}},
      {"interpolation", {"tricubic", "tricubic", "tricubic", "tricubic"}},
  };
  return m;
}

// The keys whose values differ between two settings_to_json objects.
std::vector<std::string> changed_keys(const json& a, const json& b) {
  std::vector<std::string> keys;
  for (const auto& [key, v] : a.items())
    if (!b.contains(key) || b[key] != v) keys.push_back(key);
  for (const auto& [key, v] : b.items())
    if (!a.contains(key)) keys.push_back(key);
  return keys;
}

// settings_to_json writes every key (clip_plane as null when off), so its keys are the fields.
TEST(SettingsTable, HasOneRowPerRenderSetting) {
  std::vector<std::string> json_keys, table_keys;
  // nlohmann::json sorts an object's keys: compare sorted.
  RenderSettings with_clip;
  with_clip.clip_plane = ClipPlane{{0, 0, 0}, {1, 0, 0}};
  for (const RenderSettings& s : {RenderSettings{}, with_clip}) {
    json_keys.clear();
    const json j = settings_to_json(s);
    for (const auto& [key, v] : j.items()) json_keys.push_back(key);
    table_keys.clear();
    for (const RenderSettingInfo& row : render_setting_table()) table_keys.emplace_back(row.key);
    std::sort(table_keys.begin(), table_keys.end());
    EXPECT_EQ(json_keys, table_keys) << "a RenderSettings field needs a row in settings_table.cpp";
  }
  EXPECT_EQ(std::adjacent_find(table_keys.begin(), table_keys.end()), table_keys.end()) << "a key in two rows";
}

TEST(SettingsTable, RowsAreComplete) {
  const json defaults = settings_to_json(RenderSettings{});
  for (const RenderSettingInfo& row : render_setting_table()) {
    const std::string key(row.key);
    EXPECT_FALSE(row.description.empty()) << key;
    EXPECT_FALSE(setting_values_text(row).empty()) << key << ": say what values are valid";
    const bool all_there = !row.flag.empty() && !row.message_key.empty() && !row.element_id.empty();
    EXPECT_EQ(row.absent.empty(), all_there)
        << key << ": a front end may be absent only with the reason in `absent` (and `absent` only then)";
    EXPECT_TRUE(examples().count(key)) << key << ": add an example value to this test";
    EXPECT_EQ(&render_setting(row.key), &row);
    if (!row.message_key.empty()) {
      EXPECT_EQ(render_setting_for_message(row.message_key), &row) << key;
    }
    // The default is valid.
    if (row.interval) {
      const json& d = defaults[key];
      for (const json& v : d.is_array() ? d : json::array({d}))
        EXPECT_TRUE(row.interval->contains(v.get<double>()))
            << key << ": default " << d << " outside " << row.interval->text();
    }
  }
  EXPECT_THROW(render_setting("no_such_setting"), std::out_of_range);
  EXPECT_EQ(render_setting_for_message("fps"), nullptr) << "the viewer's own keys are not render settings";
}

TEST(SettingsTable, IntervalText) {
  EXPECT_EQ((SettingInterval{0, 1}.text()), "[0, 1]");
  EXPECT_EQ((SettingInterval{0, 1, true}.text()), "(0, 1]");
  EXPECT_EQ((SettingInterval{0, INFINITY}.text()), "[0, inf)");
  EXPECT_TRUE((SettingInterval{0, INFINITY}.contains(1e300)));
  EXPECT_FALSE((SettingInterval{0, INFINITY}.contains(INFINITY)));
  EXPECT_FALSE((SettingInterval{0, 1}.contains(NAN)));
  EXPECT_FALSE((SettingInterval{0, 1, true}.contains(0)));
  EXPECT_TRUE((SettingInterval{0, 1, true}.contains(1)));
}

TEST(SettingsTable, EveryFlagIsInRenderHelp) {
  const CommandResult r = run_ugvr("render --help");
  ASSERT_EQ(r.status, 0) << r.out;
  for (const RenderSettingInfo& row : render_setting_table()) {
    if (row.flag.empty()) continue;
    // The flag as a whole word: "--iso" is not found in "--iso-opacity".
    bool found = false;
    for (size_t at = r.out.find(row.flag); at != std::string::npos && !found; at = r.out.find(row.flag, at + 1)) {
      const size_t end = at + row.flag.size();
      found = end == r.out.size() || !(std::isalnum(static_cast<unsigned char>(r.out[end])) || r.out[end] == '-');
    }
    EXPECT_TRUE(found) << row.key << ": " << row.flag << " is not in `ugvr render --help`";
  }
}

// Each flag, given alone on top of a baseline, changes its key in the settings `--stats` records, and only it; a
// number outside the row's interval is an error naming the flag.
TEST(SettingsTable, EveryFlagSetsItsKeyWithinItsRange) {
  test::ScratchDir dir;
  const std::string data = dir.file("mixed.vtu");
  const CommandResult g = run_ugvr("generate --cells 1000 --kind mixed -o " + data);
  ASSERT_EQ(g.status, 0) << g.out;
  const auto settings_of = [&](const std::string& args) {
    const std::string stats = dir.file("s.json");
    std::filesystem::remove(stats);
    const CommandResult r = run_ugvr("render " + data + " -o " + dir.file("a.png") + " --stats " + stats + " " + args);
    EXPECT_EQ(r.status, 0) << args << "\n" << r.out;
    std::ifstream in(stats);
    return r.status == 0 && in ? json::parse(in)["settings"] : json();
  };
  const std::string size = "--size 16";
  const json base = settings_of(size);
  ASSERT_TRUE(base.is_object());
  for (const RenderSettingInfo& row : render_setting_table()) {
    if (row.flag.empty() || !examples().count(std::string(row.key))) continue;
    const Example& e = examples().at(std::string(row.key));
    const std::string args = (row.flag == "--size" ? "" : size + " ") + std::string(row.flag) +
                             (e.flag_args.empty() ? "" : " ") + e.flag_args;
    const json s = settings_of(args);
    if (!s.is_object()) continue;
    EXPECT_EQ(s[std::string(row.key)], e.from_flag) << args;
    EXPECT_EQ(changed_keys(base, s), std::vector<std::string>{std::string(row.key)}) << args;
  }
  const json defaults = settings_to_json(RenderSettings{});
  for (const RenderSettingInfo& row : render_setting_table()) {
    if (row.flag.empty() || !row.interval) continue;
    const SettingInterval& r = *row.interval;
    std::vector<double> bad = {r.lo_open ? r.lo : r.lo - 1};
    if (std::isfinite(r.hi)) bad.push_back(r.hi + 1);
    for (const double v : bad) {
      char buf[32];
      const std::string number(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
      const std::string args = std::string(row.flag) + " " + number +
                               (defaults[std::string(row.key)].is_array() ? ",0,0" : "");  // --background R,G,B
      const CommandResult r2 = run_ugvr("render " + data + " -o " + dir.file("a.png") + " " + args);
      EXPECT_EQ(r2.status, 1) << args << "\n" << r2.out;
      EXPECT_NE(r2.out.find(std::string(row.flag) + ":"), std::string::npos) << args << "\n" << r2.out;
    }
  }
}

view::SceneInfo two_field_scene() {
  view::SceneInfo scene;
  scene.fields = {{"pressure", 0, 10, {}}, {"velocity", 100, 200, {}}};
  scene.field = "pressure";
  scene.bounds = {{0, 0, 0}, {1, 1, 1}};
  return scene;
}

// Each message key is accepted with a valid value, changes its key in the applied request's settings and only it,
// and is documented in view_protocol.h's comment.
TEST(SettingsTable, EveryMessageKeyChangesTheRequest) {
  const view::SceneInfo scene = two_field_scene();
  const std::string doc = read_source("src/ugvr/view/view_protocol.h");
  for (const RenderSettingInfo& row : render_setting_table()) {
    if (row.message_key.empty() || !examples().count(std::string(row.key))) continue;
    const Example& e = examples().at(std::string(row.key));
    const std::string text = json{{"type", "settings"}, {std::string(row.message_key), e.message_value}}.dump();
    view::ViewState state = view::initial_view(scene);
    const json before = settings_to_json(state.request.settings);
    try {
      view::apply_message(state, view::parse_client_message(text), scene);
    } catch (const Error& err) {
      ADD_FAILURE() << text << " rejected: " << err.what();
      continue;
    }
    const json after = settings_to_json(state.request.settings);
    EXPECT_EQ(after[std::string(row.key)], e.from_message) << text;
    EXPECT_EQ(changed_keys(before, after), std::vector<std::string>{std::string(row.key)}) << text;
    EXPECT_NE(doc.find("\"" + std::string(row.message_key) + "\""), std::string::npos)
        << row.message_key << " is not documented in view_protocol.h";
  }
}

// Numbers outside a row's interval are rejected by the message, naming its key.
TEST(SettingsTable, MessagesRejectValuesOutsideTheRange) {
  for (const RenderSettingInfo& row : render_setting_table()) {
    if (row.message_key.empty() || !row.interval) continue;
    const SettingInterval& r = *row.interval;
    std::vector<double> bad = {r.lo_open ? r.lo : r.lo - 1};
    if (std::isfinite(r.hi)) bad.push_back(r.hi + 1);
    for (const double v : bad) {
      const json value = settings_to_json(RenderSettings{})[std::string(row.key)].is_array() ? json{v, 0, 0} : json(v);
      const std::string text = json{{"type", "settings"}, {std::string(row.message_key), value}}.dump();
      try {
        view::parse_client_message(text);
        ADD_FAILURE() << "accepted " << text;
      } catch (const Error& err) {
        EXPECT_EQ(std::string(err.what()).rfind(std::string(row.message_key) + ":", 0), 0u) << err.what();
      }
    }
  }
}

// Each control is on the page, app.js handles it, and app.js sends the row's message key.
TEST(SettingsTable, EveryControlIsOnThePage) {
  const std::string html = read_source("web/index.html");
  const std::string app = read_source("web/app.js");
  for (const RenderSettingInfo& row : render_setting_table()) {
    if (row.element_id.empty()) continue;
    const std::string id(row.element_id);
    EXPECT_NE(html.find("id=\"" + id + "\""), std::string::npos) << row.key << ": no #" << id << " in web/index.html";
    EXPECT_NE(app.find("$(\"" + id + "\")"), std::string::npos) << row.key << ": web/app.js does not use #" << id;
    if (!row.message_key.empty()) {
      EXPECT_NE(app.find(std::string(row.message_key) + ":"), std::string::npos)
          << row.key << ": web/app.js never sends " << row.message_key;
    }
  }
}

}  // namespace
}  // namespace ugvr
