// Fields-only step reads of CGNS files (io/step_fields.h). A file whose steps are FlowSolutionPointers (one zone's
// grid, a solution per step) has one mesh for all steps unless a zone's grid moves: more than one GridCoordinates_t,
// a RigidGridMotion_t or ArbitraryGridMotion_t, or GridCoordinatesPointers in its ZoneIterativeData. What a step's
// solutions need of the mesh (each zone's location, the shape its solutions are read with, the polyhedra
// decomposition's CellExpansion, the notes of the mesh's read and where the solutions' notes go among them) is a
// CgnsLayout, kept from a whole read; a later step's solutions are then read through the whole read's own code
// (read_solutions, the same expansion), no coordinates nor element sections read.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

struct CgnsLayout;

// The stored identity of a CGNS file's mesh: a hash of its path, size and modification time; nullopt when a zone's
// grid moves (as above: read every step whole). Opens the file and reads its zones' node lists, no arrays. Throws
// ugvr::Error naming the file when it cannot be read.
std::optional<uint64_t> cgns_mesh_key(const std::string& path);
// read_cgns (io/reader.h), and where `kept` is given, the layout of its mesh for read_cgns_fields.
Dataset read_cgns(const std::string& path, int64_t time_step, std::shared_ptr<const CgnsLayout>* kept);
// The mesh key the layout was read with (cgns_mesh_key, taken before the mesh was read).
const std::optional<uint64_t>& cgns_layout_mesh_key(const CgnsLayout& layout);
// Step `time_step`'s solutions on the layout's mesh: bit for bit the blocks' fields read_cgns gives for that step, in
// its block order; `format`, `sources` and `warnings` as it sets the dataset's. The caller has checked that the file's
// mesh key is the layout's. Throws ugvr::Error naming the file as the whole read does.
std::vector<FieldSet> read_cgns_fields(const CgnsLayout& layout, const std::string& path, int64_t time_step,
                                       std::string& format, std::vector<std::string>& sources,
                                       std::vector<std::string>& warnings);

}  // namespace ugvr
