// PLACEHOLDER: being written; replaced by the real reader.
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
namespace ugvr {
Dataset read_plot3d(const std::string& path, const std::string&) { fail_in(path, "reader not yet implemented"); }
}  // namespace ugvr
