// Reading any supported input. A dataset is named by one path, or for PLOT3D by its grid file and then its solution
// file ("ugvr info bluntfinxyz.bin bluntfinq.bin"). The format is recognised from the file contents first (XML
// header, legacy VTK banner, netCDF/HDF5 magic, NRRD magic, Gmsh $MeshFormat) and the extension second; PLOT3D and
// raw volumes have no signature and are recognised by extension and sizes. An OpenFOAM case is a directory, found
// before anything is opened.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

enum class InputFormat {
  VtkXml,
  VtkLegacy,
  Plot3d,
  AvsUcd,     // .inp
  OffTets,    // .off (tetrahedral OFF of the HAVS / Bunyk / ZSweep samples)
  Ugrid,      // fun3d .ugrid (.ugrid ASCII, .b8/.lb8/.b4/.lb4/.r8/.lr8 ... binary)
  Gmsh,       // .msh 2.2 / 4.1
  TetGen,     // .node + .ele
  Exodus,     // .e .ex2 .exo (netCDF)
  Nastran,    // .nas .bdf
  RawVolume,  // .raw (layout given in RawVolumeOptions)
  Nrrd,       // .nrrd / .nhdr
  Cgns,       // .cgns (ADF or HDF5)
  EnSight,    // .case (EnSight Gold) / .sos (its server-of-servers file)
  OpenFoam,   // a case directory, its *.foam / *.OpenFOAM file or its system/controlDict
};

// Layout of a headerless raw voxel volume (dims, type and spacing come from the command line).
struct RawVolumeOptions {
  std::array<uint32_t, 3> dims{0, 0, 0};
  std::string type = "float32";  // int8 uint8 int16 uint16 int32 uint32 float32 float64
  std::array<double, 3> spacing{1, 1, 1};
  std::array<double, 3> origin{0, 0, 0};
  bool big_endian = false;
  uint64_t header_bytes = 0;  // bytes to skip at the start of the file
};

struct ReadOptions {
  // Exodus, EnSight, CGNS: the time step read (0-based); -1 = the last one. OpenFOAM: the index of the time
  // directory read, in the time directories sorted by value ("0" included); -1 = the latest.
  int64_t time_step = -1;
  RawVolumeOptions raw;
};

InputFormat detect_format(std::span<const std::string> paths);

// A grid's size as its headers say it, without reading coordinates, cells or fields: for decisions made before a
// read (`ugvr view`'s memory budget). Known for a .vtu (its <Piece> tags in the first 64 KiB), a .pvtu (its pieces'),
// Exodus (dimensions), CGNS (zone sizes) and OpenFOAM (the "nPoints: nCells:" note of polyMesh/owner, summed over
// processor*/ for a decomposed case; polyhedra count once, before their decomposition); nullopt for other inputs or
// headers that do not say. Throws ugvr::Error for a file that cannot be opened or whose header is malformed.
struct GridCounts {
  uint64_t points = 0, cells = 0;
};
std::optional<GridCounts> grid_counts_from_headers(std::span<const std::string> paths);
Dataset read_dataset(std::span<const std::string> paths, const ReadOptions& options = {});

// The per-format entry points (each validates its input fully and throws ugvr::Error with file and offset/line).
Dataset read_vtk_xml(const std::string& path);
Dataset read_vtk_legacy(const std::string& path);
// `q_path` may be empty (geometry only).
Dataset read_plot3d(const std::string& xyz_path, const std::string& q_path);
Dataset read_avs_ucd(const std::string& path);
Dataset read_off_tets(const std::string& path);
Dataset read_ugrid(const std::string& path);
Dataset read_gmsh(const std::string& path);
// Either the .node or the .ele file; the other is found beside it.
Dataset read_tetgen(const std::string& path);
Dataset read_exodus(const std::string& path, int64_t time_step);
Dataset read_nastran(const std::string& path);
Dataset read_raw_volume(const std::string& path, const RawVolumeOptions& options);
Dataset read_nrrd(const std::string& path);
// Every zone of every 3-D base; `time_step` picks a step of the zones' iterative data (-1: the last).
Dataset read_cgns(const std::string& path, int64_t time_step);
// A .case file, or a .sos file whose servers' cases are read and concatenated; one step (time_step, -1 = last).
Dataset read_ensight(const std::string& path, int64_t time_step);
// A case directory (or a *.foam / *.OpenFOAM file or system/controlDict in it); decomposed cases (processor*/) are
// read as pieces concatenated into one mesh. `time_step` indexes the sorted time directories, -1 = the latest.
Dataset read_openfoam(const std::string& path, int64_t time_step);

}  // namespace ugvr
