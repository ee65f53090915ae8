#include "ugvr/core/json_file.h"

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr {

nlohmann::json read_json_file(const std::string& path) {
  const InputFile in(path);
  try {
    return nlohmann::json::parse(in.read_all(uint64_t(1) << 24));
  } catch (const nlohmann::json::parse_error& e) {
    fail_in(in.name(), std::string("invalid JSON: ") + e.what());
  }
}

void write_json_file(const std::string& path, const nlohmann::json& j) {
  AtomicOutputFile out(path);
  out.write(j.dump(2) + "\n");
  out.commit();
}

}  // namespace ugvr
