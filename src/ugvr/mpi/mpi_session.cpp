#include "ugvr/mpi/mpi_session.h"

#include <mpi.h>
#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>

namespace ugvr::mpi {
namespace {
bool g_initialised = false;
int g_thread_level = MPI_THREAD_SINGLE;
}  // namespace

bool launched_under_mpi() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALNRANKS"})
    if (std::getenv(var)) return true;
  return false;
}

void init(int* argc, char*** argv) {
  if (g_initialised || !launched_under_mpi()) return;
  // Serialized, not funneled: `ugvr view` calls MPI from its render thread on rank 0 (mpi_view.h) and from the main
  // thread before and after it, never at once. Open MPI grants it (and more) at no cost to the other commands.
  // The threads MPI starts here (Open MPI's progress and PMIx threads) must never take the process's SIGINT / SIGTERM:
  // `ugvr view` waits for them with sigwait on its own threads, and a signal the kernel hands to a thread that does
  // not block it ends the process, so rank 0's stop would become an abort. They inherit this mask; the main thread's
  // is restored, so every other command sees the signals as before.
  sigset_t ours, saved;
  sigemptyset(&ours);
  for (int sig : {SIGINT, SIGTERM, SIGUSR1, SIGHUP}) sigaddset(&ours, sig);
  pthread_sigmask(SIG_BLOCK, &ours, &saved);
  MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &g_thread_level);
  pthread_sigmask(SIG_SETMASK, &saved, nullptr);
  g_initialised = true;
}

void finalize() {
  if (!active()) return;
  MPI_Finalize();
}

bool threads_serialized() { return active() && g_thread_level >= MPI_THREAD_SERIALIZED; }

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
