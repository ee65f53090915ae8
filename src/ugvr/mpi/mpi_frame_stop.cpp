#include "ugvr/mpi/mpi_frame_stop.h"

#include <chrono>
#include <utility>

namespace ugvr::mpi {
namespace {

constexpr int kWordTag = 1;

// A rank waiting here may share its core with a rank still drawing (oversubscribed jobs, the viewer's tests): MPI_Wait
// would spin on that core, so the request is tested with a short sleep in between (a millisecond is nothing next to
// a frame that was worth cutting short).
void wait_yielding(MPI_Request& request) {
  for (int done = 0;;) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace

FrameStop::FrameStop(MPI_Comm comm, std::function<bool()> question)
    : comm_(comm), question_(std::move(question)), owner_(std::this_thread::get_id()) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  if (!leader()) MPI_Irecv(&word_, 1, MPI_INT, 0, kWordTag, comm_, &word_request_);
}

bool FrameStop::keep_going() {
  if (stop_.load(std::memory_order_relaxed)) return false;
  if (leader()) {
    if (question_()) return true;
    stop_.store(true, std::memory_order_relaxed);  // sticky: rank 0 will say Stop
    return false;
  }
  if (std::this_thread::get_id() == owner_) hear_word();
  return !stop_.load(std::memory_order_relaxed);
}

void FrameStop::hear_word() {
  if (heard_) return;
  // An engine asks per tile (thousands a frame), and an MPI_Test that finds nothing may give the core away (Open MPI
  // yields when idle in an oversubscribed job): at most one test a millisecond, which delays the stop by nothing that
  // matters next to a frame worth cutting short.
  const auto now = std::chrono::steady_clock::now();
  if (now - last_test_ < std::chrono::milliseconds(1)) return;
  last_test_ = now;
  int arrived = 0;
  MPI_Test(&word_request_, &arrived, MPI_STATUS_IGNORE);
  if (!arrived) return;
  heard_ = true;
  if (word_ == kStop) stop_.store(true, std::memory_order_relaxed);
}

bool FrameStop::agree_to_stop() {
  MPI_Request parts_over = MPI_REQUEST_NULL;
  MPI_Ibarrier(comm_, &parts_over);
  if (!leader()) {
    if (!heard_) wait_yielding(word_request_);
    heard_ = true;
    wait_yielding(parts_over);
    return word_ == kStop;
  }
  // Rank 0 keeps asking while the others draw: a move then stops them too, instead of waiting for the slowest.
  Word word = kUndecided;
  while (word == kUndecided) {
    int all_over = 0;
    MPI_Test(&parts_over, &all_over, MPI_STATUS_IGNORE);
    if (!keep_going())
      word = kStop;
    else if (all_over)
      word = kDone;
    else
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const int sent = word;
  for (int r = 1; r < size_; ++r) MPI_Send(&sent, 1, MPI_INT, r, kWordTag, comm_);
  wait_yielding(parts_over);
  return word == kStop;
}

}  // namespace ugvr::mpi
