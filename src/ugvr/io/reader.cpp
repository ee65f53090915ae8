#include "ugvr/io/reader.h"

#include <cstring>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/openfoam_reader.h"
#include "ugvr/io/time_series.h"

namespace ugvr {

namespace {

bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

std::optional<InputFormat> detect_by_content(std::string_view h, const std::string& path) {
  // CGNS: ADF files carry "ADF Database Version" after a 4-byte tag; HDF5 ones are told from Exodus by the name.
  if (h.size() >= 24 && h.substr(4, 20) == "ADF Database Version") return InputFormat::Cgns;
  if (h.starts_with("\x89HDF\r\n\x1a\n") && extension_lower(path) == ".cgns") return InputFormat::Cgns;
  if (h.starts_with("CDF\x01") || h.starts_with("CDF\x02") || h.starts_with("CDF\x05") ||
      h.starts_with("\x89HDF\r\n\x1a\n")) {
    return InputFormat::Exodus;
  }
  if (h.starts_with("NRRD0")) return InputFormat::Nrrd;
  if (h.starts_with("\xEF\xBB\xBF")) h.remove_prefix(3);
  while (!h.empty() && is_space(h.front())) h.remove_prefix(1);
  if (h.starts_with("<?xml") || h.starts_with("<VTKFile")) return InputFormat::VtkXml;
  if (h.starts_with("# vtk DataFile")) return InputFormat::VtkLegacy;
  if (h.starts_with("$MeshFormat")) return InputFormat::Gmsh;
  return std::nullopt;
}

std::optional<InputFormat> detect_by_extension(const std::string& path) {
  const std::string ext = extension_lower(path);
  if (ext == ".vtu" || ext == ".pvtu" || ext == ".vts" || ext == ".vti" || ext == ".vtr" || ext == ".pvts" ||
      ext == ".pvti" || ext == ".pvtr")
    return InputFormat::VtkXml;
  if (ext == ".vtk") return InputFormat::VtkLegacy;
  if (ext == ".inp") return InputFormat::AvsUcd;
  if (ext == ".off") return InputFormat::OffTets;
  if (ext == ".ugrid") return InputFormat::Ugrid;
  if (ext == ".msh") return InputFormat::Gmsh;
  if (ext == ".node" || ext == ".ele") return InputFormat::TetGen;
  if (ext == ".e" || ext == ".ex2" || ext == ".exo" || ext == ".exii") return InputFormat::Exodus;
  if (ext == ".nas" || ext == ".bdf" || ext == ".nastran") return InputFormat::Nastran;
  if (ext == ".raw") return InputFormat::RawVolume;
  if (ext == ".cgns") return InputFormat::Cgns;
  if (ext == ".nrrd" || ext == ".nhdr") return InputFormat::Nrrd;
  if (ext == ".case" || ext == ".sos") return InputFormat::EnSight;
  if (ext == ".bin" || ext == ".xyz" || ext == ".x" || ext == ".g" || ext == ".grid" || ext == ".p3d")
    return InputFormat::Plot3d;
  return std::nullopt;
}

}  // namespace

InputFormat detect_format(std::span<const std::string> paths) {
  if (paths.empty()) throw Error("no input file given");
  if (paths.size() > 2) throw Error("too many input files: give one file, or a PLOT3D grid file and solution file");
  if (paths.size() == 2) return InputFormat::Plot3d;
  if (openfoam::is_openfoam_path(paths[0])) return InputFormat::OpenFoam;  // a directory: before InputFile opens it
  InputFile f(paths[0]);
  char head[64] = {};
  const size_t n = f.read_some_at(0, head, sizeof head);
  if (auto by_content = detect_by_content(std::string_view(head, n), paths[0])) return *by_content;
  if (auto by_extension = detect_by_extension(paths[0])) return *by_extension;
  fail_in(paths[0], "unrecognised format: no known signature, and the extension '" + extension_lower(paths[0]) +
                        "' is none of .vtu .pvtu .vts .vti .vtr .vtk .inp .off .ugrid .msh .node .ele .e .ex2 .exo "
                        ".nas .bdf .raw .nrrd .nhdr .cgns .case .sos or a PLOT3D grid (.bin .xyz .x .g .grid .p3d)");
}

Dataset read_dataset(std::span<const std::string> paths, const ReadOptions& options) {
  if (is_series_input(paths)) {
    const TimeSeries series = list_time_steps(paths, options);
    return read_time_step(series, options.time_step < 0 ? series.size() - 1 : size_t(options.time_step));
  }
  const InputFormat format = detect_format(paths);
  if (format != InputFormat::Plot3d && paths.size() > 1) {
    throw Error("two input files are only for PLOT3D (grid file, then solution file)");
  }
  switch (format) {
    case InputFormat::VtkXml: return read_vtk_xml(paths[0]);
    case InputFormat::VtkLegacy: return read_vtk_legacy(paths[0]);
    case InputFormat::Plot3d: return read_plot3d(paths[0], paths.size() > 1 ? paths[1] : std::string());
    case InputFormat::AvsUcd: return read_avs_ucd(paths[0]);
    case InputFormat::OffTets: return read_off_tets(paths[0]);
    case InputFormat::Ugrid: return read_ugrid(paths[0]);
    case InputFormat::Gmsh: return read_gmsh(paths[0]);
    case InputFormat::TetGen: return read_tetgen(paths[0]);
    case InputFormat::Exodus: return read_exodus(paths[0], options.time_step);
    case InputFormat::Nastran: return read_nastran(paths[0]);
    case InputFormat::RawVolume: return read_raw_volume(paths[0], options.raw);
    case InputFormat::Nrrd: return read_nrrd(paths[0]);
    case InputFormat::Cgns: return read_cgns(paths[0], options.time_step);
    case InputFormat::EnSight: return read_ensight(paths[0], options.time_step);
    case InputFormat::OpenFoam: return read_openfoam(paths[0], options.time_step);
  }
  throw Error("unreachable");
}

}  // namespace ugvr
