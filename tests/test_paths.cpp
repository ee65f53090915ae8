#include "test_paths.h"

namespace ugvr::test {
const char* source_dir() { return UGVR_TEST_SOURCE_DIR; }
const char* ugvr_binary() { return UGVR_TEST_BINARY; }
}  // namespace ugvr::test
