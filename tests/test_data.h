// Test support. Locating the real datasets of ../shared/data (override with UGVR_DATA). Tests that need one call
// UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin"), which reports the test as skipped when the file is absent.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "test_paths.h"
#include "ugvr/core/error.h"

namespace ugvr::test {

// The message of the ugvr::Error that f throws, or "(no error)".
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

inline std::string data_dir() {
  if (const char* env = std::getenv("UGVR_DATA"); env && *env) return env;
  return std::string(UGVR_SOURCE_DIR) + "/../shared/data";
}

inline std::string data_path(const std::string& relative) { return data_dir() + "/" + relative; }

// What a command printed (stderr merged into the output) and its exit status.
struct CommandResult {
  int status;
  std::string out;
};
// Runs a shell command line.
inline CommandResult run_command(const std::string& command) {
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}
// Runs the ugvr binary with `args`.
inline CommandResult run_ugvr(const std::string& args) {
  return run_command(std::string(UGVR_BINARY) + " --quiet " + args);
}

// A fresh scratch directory per test, removed when the test ends.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() / ("ugvr-test-" + std::string(info->test_suite_name()) + "-" +
                                                      info->name() + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() { std::filesystem::remove_all(path_); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Bytes read(2) / pread(2) returned to this process so far (Linux task I/O accounting); 0 where /proc/self/io is
// missing (tests then skip).
inline uint64_t bytes_read_so_far() {
  std::ifstream io("/proc/self/io");
  std::string key;
  uint64_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  return 0;
}

}  // namespace ugvr::test

#define UGVR_REQUIRE_DATA(relative)                                                    \
  const std::string relative_data_path = ::ugvr::test::data_path(relative);            \
  if (!std::filesystem::exists(relative_data_path)) {                                  \
    GTEST_SKIP() << "dataset not found: " << relative_data_path << " (set UGVR_DATA)"; \
  }
