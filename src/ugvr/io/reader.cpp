#include "ugvr/io/reader.h"

#include <cstring>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr {

InputFormat detect_format(std::span<const std::string> paths) {
  if (paths.empty()) throw Error("no input file given");
  if (paths.size() > 2) throw Error("too many input files: give one file, or a PLOT3D grid file and solution file");
  if (paths.size() == 2) return InputFormat::Plot3d;
  InputFile f(paths[0]);
  char head[64] = {};
  const size_t n = f.read_some_at(0, head, sizeof head - 1);
  std::string_view h(head, n);
  // Skip a UTF-8 byte-order mark and leading whitespace before the XML declaration.
  if (h.starts_with("\xEF\xBB\xBF")) h.remove_prefix(3);
  while (!h.empty() && (h.front() == ' ' || h.front() == '\n' || h.front() == '\r' || h.front() == '\t'))
    h.remove_prefix(1);
  if (h.starts_with("<?xml") || h.starts_with("<VTKFile")) return InputFormat::VtkXml;
  if (h.starts_with("# vtk DataFile")) return InputFormat::VtkLegacy;
  const std::string ext = extension_lower(paths[0]);
  if (ext == ".vtu" || ext == ".pvtu" || ext == ".vts" || ext == ".vti" || ext == ".vtr") return InputFormat::VtkXml;
  if (ext == ".vtk") return InputFormat::VtkLegacy;
  if (ext == ".bin" || ext == ".xyz" || ext == ".x" || ext == ".g" || ext == ".grid" || ext == ".p3d")
    return InputFormat::Plot3d;
  fail_in(paths[0], "unrecognised format: not VTK XML, not legacy VTK, and the extension '" + ext +
                        "' is not a PLOT3D grid (.bin .xyz .x .g .grid .p3d)");
}

Dataset read_dataset(std::span<const std::string> paths) {
  switch (detect_format(paths)) {
    case InputFormat::VtkXml: return read_vtk_xml(paths[0]);
    case InputFormat::VtkLegacy: return read_vtk_legacy(paths[0]);
    case InputFormat::Plot3d: return read_plot3d(paths[0], paths.size() > 1 ? paths[1] : std::string());
  }
  throw Error("unreachable");
}

}  // namespace ugvr
