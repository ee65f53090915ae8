// The process's MPI session, for `mpirun -np N ugvr ...` (docs/mpi.md). Plain `ugvr` never touches MPI: main()
// initialises it only when a launcher started the process (its environment says so), so the same binary runs with
// and without mpirun. This header does not include <mpi.h>.
#pragma once
#include <string>

namespace ugvr::mpi {

// True when mpirun / mpiexec (Open MPI, MPICH, PMIx or Slurm's PMI) launched this process.
bool launched_under_mpi();

// MPI_Init once, asking for MPI_THREAD_SERIALIZED (one thread at a time may call MPI, not only the main one: the
// viewer's render thread does on rank 0); a no-op when not launched under MPI. finalize() is MPI_Finalize when
// initialised.
void init(int* argc, char*** argv);
// The library granted MPI_THREAD_SERIALIZED or more (`ugvr view` under MPI needs it).
bool threads_serialized();
void finalize();
bool active();  // initialised and not finalised
int rank();     // 0 when not active
int size();     // 1 when not active

// MPI_Barrier on MPI_COMM_WORLD (a no-op when not active): `ugvr build --pieces` waits for every rank's pieces
// before rank 0 writes the index.
void barrier();

// Ends the whole job from one rank: prints "ugvr: rank R of N: message" to stderr and calls MPI_Abort, which
// takes every other rank down (they may be waiting in a collective: a plain exit would leave them hanging).
[[noreturn]] void abort_job(const std::string& message, int code);

}  // namespace ugvr::mpi
