// JSON settings files (camera, render settings, later session state): read with a size bound and an error naming the
// file, written atomically (temporary file + rename) so an interrupted save never leaves half a file.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace ugvr {

// Parses the file; throws ugvr::Error "NAME: invalid JSON: ..." or for files over 16 MiB.
nlohmann::json read_json_file(const std::string& path);
// Writes `j` indented by 2 with a final newline.
void write_json_file(const std::string& path, const nlohmann::json& j);

}  // namespace ugvr
