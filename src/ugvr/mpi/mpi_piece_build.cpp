#include "ugvr/mpi/mpi_piece_build.h"

#include <mpi.h>

#include "ugvr/mpi/mpi_session.h"

namespace ugvr::mpi {

void sum_piece_counts(PiecePlan& plan) {
  if (!active()) return;
  MPI_Allreduce(MPI_IN_PLACE, plan.cells.data(), int(plan.cells.size()), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, plan.ghost_cells.data(), int(plan.ghost_cells.size()), MPI_UINT64_T, MPI_SUM,
                MPI_COMM_WORLD);
}

}  // namespace ugvr::mpi
