// The <Piece>s of a .vtu (VTK XML UnstructuredGrid), for a reader that takes only some of them: under mpirun each rank
// reads the pieces it owns (src/ugvr/mpi/part_source.h, docs/mpi.md). read_vtk_xml concatenates them into one mesh.
#pragma once
#include <cstddef>
#include <string>

#include "ugvr/grid/dataset.h"

namespace ugvr {

// The <Piece>s of the .vtu at `path`, from its markup alone. Throws ugvr::Error naming the file (not an
// UnstructuredGrid, malformed markup).
size_t vtu_piece_count(const std::string& path);

// <Piece> `piece` (< vtu_piece_count) alone, as read_vtk_xml reads it within the whole file: one unstructured block
// with its points, its volume cells in order and the fields every piece has (checked over all pieces, as a whole read
// checks them). Throws ugvr::Error naming the file, and the piece, as read_vtk_xml does.
Dataset read_vtu_piece(const std::string& path, size_t piece);

}  // namespace ugvr
