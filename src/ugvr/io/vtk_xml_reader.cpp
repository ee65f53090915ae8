// PLACEHOLDER: being written; replaced by the real reader.
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
namespace ugvr {
Dataset read_vtk_xml(const std::string& path) { fail_in(path, "reader not yet implemented"); }
}  // namespace ugvr
