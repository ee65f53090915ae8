// A deliberate layering violation for the ModuleDeps test (tests/CMakeLists.txt): grid may include only core.
#include "ugvr/view/view_server.h"
