// JSON settings files (camera, render settings, later session state): read with a size bound and an error naming the
// file, written atomically (temporary file + rename) so an interrupted save never leaves half a file.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace ugvr {

// Parses the file; throws ugvr::Error "NAME: invalid JSON: ..." or for files over 16 MiB.
nlohmann::json read_json_file(const std::string& path);
// Parses `text` (the contents of `name`); throws ugvr::Error "NAME: invalid JSON: ..." for anything nlohmann refuses:
// syntax errors, and numbers that overflow a double (nlohmann's out_of_range 406, not a parse_error).
nlohmann::json parse_json_text(std::string_view text, std::string_view name);
// Writes `j` indented by 2 with a final newline.
void write_json_file(const std::string& path, const nlohmann::json& j);

}  // namespace ugvr
