// Reading any supported input. A dataset is named by one path, or for PLOT3D by its grid file and then its solution
// file ("ugvr info bluntfinxyz.bin bluntfinq.bin"). The format is recognised from the file contents first (XML
// header, legacy VTK banner) and the extension second; PLOT3D has no signature and is recognised by its sizes.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

enum class InputFormat { VtkXml, VtkLegacy, Plot3d };

InputFormat detect_format(std::span<const std::string> paths);
Dataset read_dataset(std::span<const std::string> paths);

// The per-format entry points (each validates its input fully and throws ugvr::Error with file and offset/line).
Dataset read_vtk_xml(const std::string& path);
Dataset read_vtk_legacy(const std::string& path);
// `q_path` may be empty (geometry only).
Dataset read_plot3d(const std::string& xyz_path, const std::string& q_path);

}  // namespace ugvr
