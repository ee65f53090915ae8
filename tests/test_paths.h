// Where the tests find the source tree and the `ugvr` binary. The paths are compiled into test_paths.cpp alone
// (tests/CMakeLists.txt gives that one file their definitions): a test file's compile line then names neither the
// checkout nor the build folder, so ccache shares the test objects between checkouts and build folders.
#pragma once

namespace ugvr::test {
const char* source_dir();   // the repository root
const char* ugvr_binary();  // the `ugvr` executable of this build
}  // namespace ugvr::test

#define UGVR_SOURCE_DIR (::ugvr::test::source_dir())
#define UGVR_BINARY (::ugvr::test::ugvr_binary())
