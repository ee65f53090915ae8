// The piece files of a `.pvtu` (VTK XML PUnstructuredGrid), for a reader that takes only some of them: under mpirun
// each rank reads the pieces its part of the domain needs (docs/mpi.md). read_vtk_xml reads them all into one mesh.
#pragma once
#include <string>
#include <vector>

namespace ugvr {

// True for a path ending in ".pvtu", in any case (the extension detect_format goes by).
bool is_pvtu_path(const std::string& path);

// The piece files `path` lists, in order, with the checks read_vtk_xml makes before reading any (a sane count, no
// file listed twice, their total size within the memory budget); relative Sources are resolved against the .pvtu's
// folder. Reads only the .pvtu's markup. Throws ugvr::Error naming the file (not a PUnstructuredGrid, no pieces).
std::vector<std::string> pvtu_piece_files(const std::string& path);

}  // namespace ugvr
