#include "ugvr/mpi/mpi_session.h"

#include <mpi.h>

#include <cstdio>
#include <cstdlib>

namespace ugvr::mpi {
namespace {
bool g_initialised = false;
}

bool launched_under_mpi() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALNRANKS"})
    if (std::getenv(var)) return true;
  return false;
}

void init(int* argc, char*** argv) {
  if (g_initialised || !launched_under_mpi()) return;
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
  g_initialised = true;
}

void finalize() {
  if (!active()) return;
  MPI_Finalize();
}

bool active() {
  if (!g_initialised) return false;
  int finalized = 0;
  MPI_Finalized(&finalized);
  return !finalized;
}

int rank() {
  if (!active()) return 0;
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int size() {
  if (!active()) return 1;
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

void barrier() {
  if (active()) MPI_Barrier(MPI_COMM_WORLD);
}

void abort_job(const std::string& message, int code) {
  std::fprintf(stderr, "ugvr: rank %d of %d: %s\n", rank(), size(), message.c_str());
  std::fflush(stderr);
  if (active()) MPI_Abort(MPI_COMM_WORLD, code == 0 ? 1 : code);
  std::exit(code == 0 ? 1 : code);
}

}  // namespace ugvr::mpi
