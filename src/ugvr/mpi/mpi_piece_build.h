// `mpirun -np R ugvr build ... --pieces N --out-of-core`: each rank counts the cells of the pieces it builds while
// their soups are written (piece_build_ooc.h); rank 0 needs every piece's counts for the index.
#pragma once
#include "ugvr/mpi/piece_build.h"

namespace ugvr::mpi {

// Collective over MPI_COMM_WORLD: every piece's cells and ghost_cells summed over the ranks (a rank holds zeros for
// the pieces it did not build), so every rank ends with every piece's counts. A no-op when MPI is not active.
void sum_piece_counts(PiecePlan& plan);

}  // namespace ugvr::mpi
