#include "ugvr/core/json_file.h"

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr {

nlohmann::json parse_json_text(std::string_view text, std::string_view name) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail_in(name, std::string("invalid JSON: ") + e.what());
  }
}

nlohmann::json read_json_file(const std::string& path) {
  const InputFile in(path);
  return parse_json_text(in.read_all(uint64_t(1) << 24), in.name());
}

void write_json_file(const std::string& path, const nlohmann::json& j) {
  AtomicOutputFile out(path);
  out.write(j.dump(2) + "\n");
  out.commit();
}

}  // namespace ugvr
