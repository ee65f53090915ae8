// libFuzzer target for the small JSON files a user hands the command line and the viewer: cameras (--camera),
// render settings (--settings) and ParaView colour-map presets (--tf). The first byte picks the parser; the rest is
// the file's text, parsed as the CLI parses a file (core/json_file.h). Only ugvr::Error may escape.
#include <nlohmann/json.hpp>
#include <string_view>

#include "ugvr/core/error.h"
#include "ugvr/core/json_file.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    switch (data[0] % 3) {
      case 0: {
        const ugvr::Camera c = ugvr::camera_from_json(ugvr::parse_json_text(text, "camera.json"), "camera.json");
        volatile double sink = c.position.x;
        (void)sink;
        break;
      }
      case 1: {
        const ugvr::RenderSettings s =
            ugvr::settings_from_json(ugvr::parse_json_text(text, "settings.json"), "settings.json");
        volatile bool sink = s.volume_lighting;
        (void)sink;
        break;
      }
      default: {
        const auto presets = ugvr::parse_paraview_presets(text, "preset.json");
        volatile size_t sink = presets.size();
        (void)sink;
      }
    }
  } catch (const ugvr::Error&) {
    // Refused with a message naming the file and the field.
  }
  // Any other exception (an nlohmann type or range error inside a parser) escapes: a finding. The campaign of
  // 2026-11-26 found one: a number overflowing a double ("1E3333333") threw nlohmann's out_of_range 406, which the
  // file readers did not catch (fuzz/regression/fuzz_settings_files/).
  return 0;
}
