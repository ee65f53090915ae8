#include "ugvr/view/frame_scheduler.h"

#include <algorithm>

namespace ugvr::view {
namespace {

// The tab's last frame shows its current view: it was taken after the last message that changed anything.
bool drawn(const TabState& t) { return t.rendered_generation != kNotDrawn && t.rendered_generation >= t.view.changed; }

bool wants_more(const TabState& t) {
  const bool drawn = view::drawn(t);
  // A tab playing a time series is not refined: its next request (the next step) comes as soon as this step's frame
  // is shown, and a refinement frame drawn meanwhile would only delay it. Pausing (playing false) refines as usual.
  if (drawn && t.view.request.playing && !t.view.full_quality) return false;
  return !(drawn && t.converged && !t.view.full_quality);
}

}  // namespace

bool wants_frame(const TabState& tab) { return tab.view.ready && !tab.closed && !tab.in_flight && wants_more(tab); }

bool is_streaming(const TabState& tab) { return tab.view.ready && !tab.closed && wants_more(tab); }

void FrameScheduler::add(TabState tab) { tabs_.push_back(std::move(tab)); }

TabState* FrameScheduler::find(uint64_t id) {
  for (TabState& t : tabs_)
    if (t.id == id) return &t;
  return nullptr;
}

void FrameScheduler::close(uint64_t id) {
  if (TabState* t = find(id)) t->closed = true;
}

std::vector<uint64_t> FrameScheduler::remove_closed() {
  std::vector<uint64_t> gone;
  std::erase_if(tabs_, [&](const TabState& t) {
    if (t.closed) gone.push_back(t.id);
    return t.closed;
  });
  return gone;
}

std::optional<FrameJob> FrameScheduler::next(std::chrono::steady_clock::time_point now) {
  due_.reset();
  size_t streaming = 0;
  for (const TabState& t : tabs_) streaming += is_streaming(t) ? 1 : 0;
  for (size_t k = 0; k < tabs_.size(); ++k) {
    const size_t i = (next_ + k) % tabs_.size();
    TabState& t = tabs_[i];
    if (!wants_frame(t)) continue;
    if (rest_delay_.count() > 0 && drawn(t) && !t.converged && !t.view.full_quality) {
      const auto due = t.rendered_at + std::chrono::duration_cast<std::chrono::steady_clock::duration>(rest_delay_);
      if (now < due) {
        if (!due_ || due < *due_) due_ = due;
        continue;
      }
    }
    next_ = i + 1;  // round-robin: the next turn starts after this tab
    FrameJob job;
    job.tab = t.id;
    job.request = t.view.request;
    job.ram_budget = t.ram_budget;
    job.generation = t.view.generation;
    job.full_quality = t.view.full_quality;
    job.resting = drawn(t);
    job.streaming = std::max<size_t>(streaming, 1);
    // Frame budgets are shared: while N tabs stream, each tab's controller targets N x its rate, so that every tab
    // gets about the rate it asked for instead of each measuring only its own frames and all falling behind.
    job.target_fps = job.request.fps * double(job.streaming);
    t.view.full_quality = false;
    t.in_flight = true;
    return job;
  }
  return std::nullopt;
}

void FrameScheduler::rendered(const FrameJob& job, bool converged, bool failed,
                              std::chrono::steady_clock::time_point now) {
  TabState* t = find(job.tab);
  if (!t) return;
  t->rendered_generation = job.generation;
  t->rendered_at = now;
  // A failed view is not retried until the client changes it.
  t->converged = converged || failed;
  if (failed) t->in_flight = false;
}

std::optional<uint64_t> FrameScheduler::take_ack(uint64_t id) {
  TabState* t = find(id);
  if (!t || !t->view.ready || t->closed || !drawn(*t) || t->rendered_generation >= t->view.generation || wants_more(*t))
    return std::nullopt;
  // The frame the client has (or the one on its way) shows this generation too.
  t->rendered_generation = t->view.generation;
  return t->view.generation;
}

void FrameScheduler::interrupted(const FrameJob& job) {
  if (TabState* t = find(job.tab)) t->in_flight = false;
}

void FrameScheduler::delivered(uint64_t id) {
  if (TabState* t = find(id)) t->in_flight = false;
}

void FrameScheduler::redraw_all() {
  for (TabState& t : tabs_) {
    t.rendered_generation = kNotDrawn;
    t.converged = false;
  }
}

}  // namespace ugvr::view
