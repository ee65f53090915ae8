// The <Piece>s of a .vtu (VTK XML UnstructuredGrid), for a reader that takes only some of them: under mpirun each rank
// reads the pieces it owns (src/ugvr/mpi/part_source.h, docs/mpi.md). read_vtk_xml concatenates them into one mesh.
#pragma once
#include <cstddef>
#include <cstdint>
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

// Whether the .vtu at `path` can be read by cell ranges, each reading only its own bytes: one <Piece> with cells, every
// array in raw appended data (<AppendedData encoding="raw">), uncompressed. False also for a file the markup of which
// cannot be read (a whole read then says why).
bool vtu_reads_by_cell_ranges(const std::string& path);

// Cells [first, first + count) of the file's one <Piece> (its volume cells among them, in order, as read_vtk_xml keeps
// them), with the points from the least to the greatest id they use and the fields on those points and cells: the
// offsets, types, connectivity, points and field arrays are each read at that range alone (XmlArrayReader::skip seeks
// in raw data; other encodings are decoded through). Throws ugvr::Error naming the file: a range past the cells, an
// offset or point id out of range, an array too short.
// `first_point`, when given, receives the file's id of the block's point 0 (point i is the file's first_point + i).
Dataset read_vtu_cells(const std::string& path, uint64_t first, uint64_t count, uint64_t* first_point = nullptr);

}  // namespace ugvr
