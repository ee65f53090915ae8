// Explicit cells for structured grids, for consumers that need an unstructured mesh (the .vtu writer, tet-only
// algorithms). The structured grid itself stays implicit; this makes a new mesh.
//
// Every point of the grid is kept (indices unchanged), so vertex fields carry over as they are; each output cell
// records the structured cell it came from so cell fields can be gathered. With IBLANK, a cell any of whose 8 points
// is blanked (iblank == 0) does not exist and produces no output cells.
//
// Tetrahedral splits of the hexahedron (i..i+1, j..j+1, k..k+1):
//  - Six:  Kuhn/Freudenthal split along the diagonal (i,j,k)-(i+1,j+1,k+1): 6 tets, each a monotone path of axis
//          steps. Every face is cut along its diagonal from its lowest to its highest corner, the same choice in both
//          cells sharing it, so the mesh conforms everywhere with no bookkeeping.
//  - Five: one central tet plus four corner tets. Its face diagonals flip with the parity of i+j+k, so cells
//          alternate between the two mirror-image splits and neighbouring faces conform.
#pragma once

#include <cstdint>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

enum class StructuredCellShape { Hexahedra, FiveTetrahedra, SixTetrahedra };

struct ExplicitCells {
  UnstructuredMesh mesh;
  std::vector<uint64_t> source_cell;  // per output cell: the structured cell index it was cut from
};

// `grid` must hold a StructuredGrid, ImageGrid or RectilinearGrid.
ExplicitCells make_explicit_cells(const Grid& grid, StructuredCellShape shape);

// The block as an unstructured block: unstructured grids are copied as they are; structured ones are converted with
// make_explicit_cells, their vertex fields kept and their cell fields gathered to the output cells. IBLANK, when
// present, is kept as an Int32 vertex field named "IBLANK".
Block to_unstructured_block(const Block& block, StructuredCellShape shape);

}  // namespace ugvr
