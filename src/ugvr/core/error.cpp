#include "ugvr/core/error.h"

#include <string>

namespace ugvr {

void fail_at_offset(std::string_view file, uint64_t offset, std::string_view message) {
  throw Error(std::string(file) + ": byte " + std::to_string(offset) + ": " + std::string(message));
}

void fail_at_line(std::string_view file, uint64_t line, std::string_view message) {
  throw Error(std::string(file) + ":" + std::to_string(line) + ": " + std::string(message));
}

void fail_in(std::string_view file, std::string_view message) {
  throw Error(std::string(file) + ": " + std::string(message));
}

void check_count_fits(std::string_view file, uint64_t offset, std::string_view what, uint64_t count,
                      uint64_t min_bytes_each, uint64_t bytes_left) {
  if (min_bytes_each == 0) min_bytes_each = 1;
  if (count > bytes_left / min_bytes_each) {
    fail_at_offset(file, offset,
                   std::string(what) + " count " + std::to_string(count) + " needs at least " +
                       std::to_string(min_bytes_each) + " bytes each but only " + std::to_string(bytes_left) +
                       " bytes remain in the file");
  }
}

}  // namespace ugvr
