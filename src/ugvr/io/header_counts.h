// The sizes of the readers whose headers say them through their own files' structure (netCDF, CGNS, OpenFOAM's case
// layout), for grid_counts_from_headers (reader.h); each in its reader's file, beside the file checks it shares with
// the reader. nullopt where the header does not say; errors as the readers' own (ugvr::Error naming the file).
#pragma once

#include <optional>
#include <string>

#include "ugvr/io/reader.h"

namespace ugvr {

// Exodus II: the dimensions num_nodes and num_elem.
std::optional<GridCounts> exodus_header_counts(const std::string& path);
// CGNS: the vertex and cell counts of every zone of every 3-D base (cg_zone_read).
std::optional<GridCounts> cgns_header_counts(const std::string& path);
// OpenFOAM: polyMesh/owner's "nPoints: nCells:" note, summed over processor*/ when the reader reads those.
std::optional<GridCounts> openfoam_header_counts(const std::string& path);

}  // namespace ugvr
