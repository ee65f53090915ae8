// Errors: every failure a user can cause (bad input, bad arguments) is reported as ugvr::Error with a message that
// names the file and the byte offset or line, and what was expected there. Programming errors stay assertions.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

namespace ugvr {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "FILE: byte OFFSET: MESSAGE"
[[noreturn]] void fail_at_offset(std::string_view file, uint64_t offset, std::string_view message);
// "FILE:LINE: MESSAGE"
[[noreturn]] void fail_at_line(std::string_view file, uint64_t line, std::string_view message);
// "FILE: MESSAGE"
[[noreturn]] void fail_in(std::string_view file, std::string_view message);

// Guards an allocation whose size comes from the input: `count` items of at least `min_bytes_each` bytes of input each
// must fit in the `bytes_left` the input still has, otherwise the count is absurd and we fail before allocating.
void check_count_fits(std::string_view file, uint64_t offset, std::string_view what, uint64_t count,
                      uint64_t min_bytes_each, uint64_t bytes_left);

}  // namespace ugvr
