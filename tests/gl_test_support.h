// OpenGL in the tests: how a test file opens its EGL context, and what a test does when there is none. No OpenGL 4.5
// is a failure, not a skip: CI has llvmpipe, and a silent skip would hide a broken GPU path. UGVR_NO_GL_TESTS=1 skips
// on a machine known to lack EGL.
#pragma once

#include <cstdlib>
#include <memory>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"

namespace ugvr::test {

// A context on the first GPU, else llvmpipe; null with the reason in `error` when EGL or OpenGL 4.5 is missing.
inline std::unique_ptr<GlContext> open_gl_context(std::string& error) {
  try {
    return std::make_unique<GlContext>("auto");
  } catch (const Error& e) {
    error = e.what();
    return nullptr;
  }
}

// The context of this test file, opened at its first use and shared by the file's tests; null with the reason in
// `error` when there is none. Internal linkage on purpose: each test file keeps its own context (sharing one across
// files would carry GL state from one file's tests into another's).
namespace {
[[maybe_unused]] std::shared_ptr<const GlContext> file_gl_context(std::string* error) {
  static std::shared_ptr<const GlContext> gl;
  static std::string message;
  static bool tried = false;
  if (!tried) {
    tried = true;
    gl = open_gl_context(message);
  }
  *error = message;
  return gl;
}
}  // namespace

}  // namespace ugvr::test

// Ends the test when `context` (a pointer from open_gl_context) is null: skipped under UGVR_NO_GL_TESTS, else failed
// with `error`.
#define UGVR_REQUIRE_GL_CONTEXT(context, error)                     \
  do {                                                              \
    if (!(context)) {                                               \
      if (std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << (error); \
      FAIL() << "no OpenGL 4.5 context: " << (error);               \
    }                                                               \
  } while (0)

// Declares `gl`, this file's context (file_gl_context), and ends the test as UGVR_REQUIRE_GL_CONTEXT does without one.
#define UGVR_REQUIRE_FILE_GL(gl)                        \
  std::string gl##_error;                               \
  auto gl = ::ugvr::test::file_gl_context(&gl##_error); \
  UGVR_REQUIRE_GL_CONTEXT(gl, gl##_error)
