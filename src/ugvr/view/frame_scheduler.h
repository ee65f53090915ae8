// Which browser tab the viewer's render thread draws next (view_server.h, "Scheduling"). Pure bookkeeping: no
// sockets, no GL, no threads; the server keeps one FrameScheduler under its lock, the I/O thread updates the tabs'
// views and the render thread asks next().
//
// Latest wins: a tab holds only its latest requested view (view_request.h), so stale requests are dropped, never
// queued. Turns go round-robin, one frame per turn, to a tab that has said hello, has no frame still on its way to
// the client, and wants one (wants_frame). The frame on the wire is the back-pressure: a slow client gets fewer
// frames, never a queue, and cannot hold up the others.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "ugvr/view/view_request.h"

namespace ugvr::view {

// TabState::rendered_generation of a tab that must draw again whatever its view (redraw_all).
inline constexpr uint64_t kNotDrawn = ~uint64_t(0);

// One tab as the scheduler sees it.
struct TabState {
  uint64_t id = 0;
  ViewState view;                    // the latest request (ready: said hello; generation: messages accepted)
  bool in_flight = false;            // a frame of this tab is on its way to the client
  bool converged = false;            // its last frame was converged (or failed: not retried until the view changes)
  uint64_t rendered_generation = 0;  // view.generation its last frame (or ack) showed; kNotDrawn: draw again
  bool closed = false;               // its socket has gone; remove_closed() drops it
  uint64_t ram_budget = 0;           // its RAM brick cache's budget (tab_memory.h); 0: the engine host's default
  std::chrono::steady_clock::time_point rendered_at;  // when its last frame was drawn (FrameScheduler::rest_delay)
};

// A tab wants a frame: it said hello, has none on the wire, and its view changed (view.changed, not a message that
// changed nothing), or is still refining (not while it
// plays a time series: each step is drawn once, at the interactive quality), or it asked for full quality.
bool wants_frame(const TabState& tab);
// A tab streams frames: as wants_frame, a frame on the wire or not. These tabs share the frame budget.
bool is_streaming(const TabState& tab);

// One frame to draw: a copy of the tab's request, taken under the lock.
struct FrameJob {
  uint64_t tab = 0;
  ViewRequest request;
  uint64_t generation = 0;    // the request's view.generation (FrameStatus.request)
  bool full_quality = false;  // the tab asked for a converged frame now
  bool resting = false;       // the view is the one the tab's previous frame showed (no change since)
  size_t streaming = 1;       // tabs streaming now (at least 1, this one)
  double target_fps = 0;      // the frame-rate target of the tab's controller: request.fps x streaming
  uint64_t ram_budget = 0;    // TabState::ram_budget
};

class FrameScheduler {
 public:
  // A tab whose socket is open joins the round (at its end).
  void add(TabState tab);
  // The tab `id`, or null when it has been removed.
  TabState* find(uint64_t id);
  const TabState* find(uint64_t id) const { return const_cast<FrameScheduler*>(this)->find(id); }
  // Every tab, in round order (closed ones not yet removed included).
  std::vector<TabState>& tabs() { return tabs_; }
  const std::vector<TabState>& tabs() const { return tabs_; }
  size_t size() const { return tabs_.size(); }

  // Its socket has gone: it gets no more frames; remove_closed() drops it.
  void close(uint64_t id);
  // Drops the closed tabs and returns their ids (their renderers go too).
  std::vector<uint64_t> remove_closed();

  // The next frame: for the first tab after the previous turn's that wants one. Marks the tab in flight and takes its
  // full-quality request. nullopt: no tab wants a frame.
  // With a rest delay, a resting frame after one that did not converge waits (see set_rest_delay).
  std::optional<FrameJob> next(std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now());
  // `job`'s frame was drawn: `converged`, or `failed` (then nothing goes on the wire, and the view is not drawn again
  // until the client changes it).
  void rendered(const FrameJob& job, bool converged, bool failed,
                std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now());
  // For a renderer whose resting frame cannot be cut short (a collective one that does not take keep_going: both of
  // ugvr's, a partitioned store's pieces and MPI ranks, now do; 5.5 s at full quality for a billion cells): a tab's
  // resting frame after one that did not converge is drawn only `seconds` after that frame, so that a move arriving
  // meanwhile (the next step of a drag, sent once the moving frame was shown) is drawn first instead of waiting for the
  // whole full-quality frame. A full-quality request goes at once. 0 (the default): no wait.
  void set_rest_delay(double seconds) { rest_delay_ = std::chrono::duration<double>(seconds); }
  // When the earliest resting frame held back by the last next() becomes due; nullopt: none is held back.
  std::optional<std::chrono::steady_clock::time_point> next_due() const { return due_; }
  // The tab's messages since its last frame changed nothing drawn and no frame is coming (converged, or playing):
  // the request count to acknowledge (view_protocol.h "ack"), and from now on it counts as shown. nullopt: no ack
  // is owed (a frame that will carry the count is wanted, or nothing is new).
  std::optional<uint64_t> take_ack(uint64_t id);
  // `job`'s frame was abandoned because the tab's view changed while it was drawn (FrameRequest::keep_going): nothing
  // goes on the wire, and the tab, no longer in flight, wants its new view drawn.
  void interrupted(const FrameJob& job);
  // The last message of the tab's frame has been written: it may get the next one.
  void delivered(uint64_t id);
  // Every tab draws again, as if its view had changed (the engine has changed).
  void redraw_all();

 private:
  std::vector<TabState> tabs_;
  size_t next_ = 0;  // where the next turn starts looking
  std::chrono::duration<double> rest_delay_{0};
  std::optional<std::chrono::steady_clock::time_point> due_;
};

}  // namespace ugvr::view
