// JSON text from users (camera, settings and preset files, the Python API's strings): anything nlohmann refuses is a
// ugvr::Error naming the file (core/json_file.h). Found by the settings-files fuzz campaign (issue 23): a number that
// overflows a double threw nlohmann's out_of_range 406, which is not a parse_error, past the readers.
#include <gtest/gtest.h>

#include <fstream>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/json_file.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

std::string error_of_parse(std::string_view text) {
  try {
    parse_json_text(text, "cam.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(JsonFile, NumbersOverflowingADoubleAreRefusedNamingTheFile) {
  EXPECT_NE(error_of_parse(R"({"position": [1E3333333, 0, 0]})").find("cam.json: invalid JSON"), std::string::npos);
  EXPECT_NE(error_of_parse("{\"a\": -1e999}").find("cam.json"), std::string::npos);
  EXPECT_NE(error_of_parse("{\"a\": ").find("cam.json: invalid JSON"), std::string::npos);
  EXPECT_EQ(parse_json_text(R"({"a": 1e300})", "x")["a"].get<double>(), 1e300);
}

TEST(JsonFile, FileReadersAndPresetsRefuseTheOverflowToo) {
  test::ScratchDir dir;
  const std::string path = dir.file("camera.json");
  std::ofstream(path) << R"({"position": [3333.33333333E3333333, 0, 0], "focal_point": [0, 0, 0]})";
  try {
    camera_from_json(read_json_file(path), path);
    ADD_FAILURE() << "read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera.json: invalid JSON"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_paraview_presets(R"([{"Name": "x", "RGBPoints": [0, 1E400, 0, 0]}])", "preset.json"), Error);
}

}  // namespace
}  // namespace ugvr
