// A collective frame that rank 0 may cut short (FrameRequest::keep_going under MPI, docs/mpi.md): the viewer's resting
// frame takes seconds on big data, and a move during it should not wait for it. Every rank draws its part and the
// compositing needs all of them, so no rank may drop the frame alone: the ranks agree, and either all composite or
// all throw FrameInterrupted, none left inside a collective that another skipped.
//
// The agreement, on a communicator of its own (so that nothing else can match its messages):
//   - at the frame's start each rank > 0 posts a receive of rank 0's word (Done or Stop), which it tests, without
//     blocking, whenever its engine asks keep_going on the thread that runs render();
//   - rank 0 asks the real question (its request's keep_going) between the parts of its own image, as in one process;
//   - when its part is drawn, or stopped, every rank posts MPI_Ibarrier ("my part is over");
//   - rank 0 then goes on asking its question until that barrier completes: Stop as soon as the question says stop
//     (its own part stopped, or the others still drawing), Done once every part is drawn and the question says go on.
//     It sends the word to every rank and waits for the barrier;
//   - every rank > 0, its part over, waits for the word and the barrier; with Stop every rank throws FrameInterrupted.
// Rank 0 sends exactly one word per frame, and only after its part is over, so a rank never hears Done while it
// draws. A rank stops its part only on rank 0's Stop (ranks > 0) or on the question that makes rank 0 say Stop, so a
// rank that stopped always hears Stop. The barrier is posted once by every rank, in the same order among the
// collectives, whichever rank finishes first.
//
// Threads: the library is initialised MPI_THREAD_SERIALIZED (mpi_session.h), so only one thread may be inside MPI at a
// time, and the engines ask keep_going from their worker threads too (the CPU exact engine asks per tile from its
// pool). Only the thread that made the FrameStop (the one running render(), which makes the frame's other MPI calls)
// tests the receive; the others read the atomic it sets.
#pragma once
#include <mpi.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <thread>

namespace ugvr::mpi {

class FrameStop {
 public:
  // Collective over `comm` (every rank makes one for the same frame). `question`: on rank 0 the request's keep_going,
  // thread-safe; ignored on the other ranks, which follow rank 0's answer.
  FrameStop(MPI_Comm comm, std::function<bool()> question);
  FrameStop(const FrameStop&) = delete;
  FrameStop& operator=(const FrameStop&) = delete;

  // The keep_going the rank's engine asks between parts of its image; any thread.
  bool keep_going();
  // After the rank's part is over (drawn or stopped), on the thread that made this: true when every rank drops the
  // frame. Blocks until rank 0 has decided and every rank's part is over.
  bool agree_to_stop();

 private:
  enum Word : int { kUndecided = 0, kDone = 1, kStop = 2 };
  bool leader() const { return rank_ == 0; }
  void hear_word();  // ranks > 0, the owner thread: tests the receive of rank 0's word

  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  std::function<bool()> question_;
  std::thread::id owner_;
  std::atomic<bool> stop_{false};
  int word_ = kUndecided;  // ranks > 0: the receive's buffer
  MPI_Request word_request_ = MPI_REQUEST_NULL;
  bool heard_ = false;
  std::chrono::steady_clock::time_point last_test_;  // hear_word's latest MPI_Test
};

}  // namespace ugvr::mpi
