// Which viewer tab gets the next frame (src/ugvr/view/frame_scheduler.h): round-robin fairness, latest request wins,
// back-pressure (a tab with a frame on the wire gets none), closing tabs, full-quality requests, and the number of
// tabs streaming that shares the frame budget. Pure logic: no sockets, GL or threads.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <optional>
#include <vector>

#include "ugvr/view/frame_scheduler.h"

namespace ugvr::view {
namespace {

// A tab that has said hello, asking for `fps` frames a second.
TabState ready_tab(uint64_t id, double fps = 10) {
  TabState t;
  t.id = id;
  t.view.ready = true;
  t.view.generation = t.view.changed = 1;
  t.view.request.fps = fps;
  return t;
}

// A message changed the tab's view (what apply_message does to the scheduling state).
void change_view(FrameScheduler& s, uint64_t id) {
  ViewState& v = s.find(id)->view;
  v.changed = ++v.generation;
}
// A message that changed nothing drawn: it counts, the view stays.
void repeat_view(FrameScheduler& s, uint64_t id) { ++s.find(id)->view.generation; }

// Takes the next frame and completes it at once: drawn (`converged` or not) and delivered.
std::optional<FrameJob> turn(FrameScheduler& s, bool converged = false) {
  std::optional<FrameJob> job = s.next();
  if (job) {
    s.rendered(*job, converged, false);
    s.delivered(job->tab);
  }
  return job;
}

TEST(ViewFrameScheduler, RoundRobinIsFairOverManyTurns) {
  FrameScheduler s;
  for (uint64_t id = 1; id <= 3; ++id) s.add(ready_tab(id));
  std::map<uint64_t, int> frames;
  std::vector<uint64_t> order;
  for (int i = 0; i < 3000; ++i) {
    const std::optional<FrameJob> job = turn(s);  // never converged: every tab always wants more
    ASSERT_TRUE(job);
    ++frames[job->tab];
    if (i < 6) order.push_back(job->tab);
  }
  EXPECT_EQ(order, (std::vector<uint64_t>{1, 2, 3, 1, 2, 3}));
  for (uint64_t id = 1; id <= 3; ++id) EXPECT_EQ(frames[id], 1000) << id;

  // A tab that joins takes its turn at the end of the round (here: next, the round having just ended).
  s.add(ready_tab(4));
  order.clear();
  for (int i = 0; i < 8; ++i) order.push_back(turn(s)->tab);
  EXPECT_EQ(order, (std::vector<uint64_t>{4, 1, 2, 3, 4, 1, 2, 3}));
}

TEST(ViewFrameScheduler, ATabWithAFrameOnTheWireGetsNone) {
  FrameScheduler s;
  s.add(ready_tab(1));
  s.add(ready_tab(2));
  // Tab 1's frame is drawn but never delivered (a slow client): tab 2 gets every turn meanwhile.
  std::optional<FrameJob> slow = s.next();
  ASSERT_TRUE(slow);
  EXPECT_EQ(slow->tab, 1u);
  s.rendered(*slow, false, false);
  EXPECT_TRUE(s.find(1)->in_flight);
  EXPECT_FALSE(wants_frame(*s.find(1)));
  for (int i = 0; i < 20; ++i) EXPECT_EQ(turn(s)->tab, 2u);
  // Its view changes many times meanwhile: still one frame at a time, never a queue.
  for (int i = 0; i < 5; ++i) change_view(s, 1);
  EXPECT_EQ(turn(s)->tab, 2u);
  // Delivered: it is served again, with its latest view.
  s.delivered(1);
  std::optional<FrameJob> next = s.next();
  ASSERT_TRUE(next);
  EXPECT_EQ(next->tab, 1u);
  EXPECT_EQ(next->generation, 6u);

  // With every tab's frame on the wire there is nothing to draw.
  FrameScheduler alone;
  alone.add(ready_tab(7));
  ASSERT_TRUE(alone.next());
  EXPECT_FALSE(alone.next());
}

TEST(ViewFrameScheduler, LatestRequestWinsAndARestingConvergedTabWantsNothing) {
  FrameScheduler s;
  s.add(ready_tab(1));
  TabState& t = *s.find(1);
  for (int i = 0; i < 3; ++i) {
    change_view(s, 1);
    t.view.request.width = 100 + i;
  }
  std::optional<FrameJob> job = turn(s);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->generation, 4u);
  EXPECT_EQ(job->request.width, 102);
  EXPECT_FALSE(job->resting);  // a new view
  // Not converged yet: it goes on refining, now resting on the view it showed.
  job = turn(s, true);
  ASSERT_TRUE(job);
  EXPECT_TRUE(job->resting);
  EXPECT_EQ(job->generation, 4u);
  // Converged at rest: nothing until the view changes.
  EXPECT_FALSE(s.next());
  EXPECT_FALSE(is_streaming(*s.find(1)));
  change_view(s, 1);
  job = turn(s);
  ASSERT_TRUE(job);
  EXPECT_FALSE(job->resting);
  EXPECT_EQ(job->generation, 5u);

  // A tab that has not said hello gets nothing.
  TabState quiet = ready_tab(2);
  quiet.view.ready = false;
  s.add(quiet);
  s.find(1)->converged = true;
  s.find(1)->rendered_generation = s.find(1)->view.generation;
  EXPECT_FALSE(s.next());
}

TEST(ViewFrameScheduler, FullQualityAsksForOneFrameAtRest) {
  FrameScheduler s;
  s.add(ready_tab(1));
  ASSERT_TRUE(turn(s, true));  // converged
  EXPECT_FALSE(s.next());
  s.find(1)->view.full_quality = true;
  EXPECT_TRUE(wants_frame(*s.find(1)));
  std::optional<FrameJob> job = turn(s, true);
  ASSERT_TRUE(job);
  EXPECT_TRUE(job->full_quality);
  EXPECT_TRUE(job->resting);
  EXPECT_FALSE(s.find(1)->view.full_quality);  // taken: one frame
  EXPECT_FALSE(s.next());
}

// Issue 18: while a tab plays a time series, each step gets one frame and no refinement (the next step's request
// follows the frame at once); when it pauses, the step shown is refined as usual.
TEST(ViewFrameScheduler, APlayingTabGetsOneFramePerStep) {
  FrameScheduler s;
  s.add(ready_tab(1));
  s.find(1)->view.request.playing = true;
  ASSERT_TRUE(turn(s, false));  // not converged
  EXPECT_FALSE(s.next()) << "no refinement frame while playing";
  EXPECT_FALSE(is_streaming(*s.find(1)));
  change_view(s, 1);  // the next step
  ASSERT_TRUE(turn(s, false));
  EXPECT_FALSE(s.next());
  s.find(1)->view.request.playing = false;  // paused: a message, so the view changes
  change_view(s, 1);
  ASSERT_TRUE(turn(s, false));
  EXPECT_TRUE(turn(s, true)) << "refined at rest";
  EXPECT_FALSE(s.next());
}

TEST(ViewFrameScheduler, AFailedFrameIsNotRetriedUntilTheViewChanges) {
  FrameScheduler s;
  s.add(ready_tab(1));
  std::optional<FrameJob> job = s.next();
  ASSERT_TRUE(job);
  s.rendered(*job, false, true);  // failed: nothing goes on the wire, so nothing will be delivered
  EXPECT_FALSE(s.find(1)->in_flight);
  EXPECT_FALSE(s.next());
  change_view(s, 1);
  EXPECT_TRUE(s.next());
}

// A resting frame abandoned for a move (FrameRequest::keep_going): the tab is free for the next frame at once, which
// draws its new view (no ack, no retry of the abandoned one).
TEST(ViewFrameScheduler, AnInterruptedFrameFreesTheTabForItsNewView) {
  FrameScheduler s;
  s.add(ready_tab(1));
  ASSERT_TRUE(turn(s));  // the first view, drawn (not converged: resting frames follow)
  const std::optional<FrameJob> resting = s.next();
  ASSERT_TRUE(resting);
  EXPECT_TRUE(resting->resting);
  change_view(s, 1);  // the move arrives while it is drawn
  EXPECT_FALSE(s.next()) << "a tab with a frame under way gets no other";
  s.interrupted(*resting);
  EXPECT_FALSE(s.take_ack(1)) << "the new view is owed a frame, not an ack";
  const std::optional<FrameJob> moved = s.next();
  ASSERT_TRUE(moved) << "the tab stays in flight after an interrupted frame";
  EXPECT_EQ(moved->generation, 2u);
  EXPECT_FALSE(moved->resting);
}

TEST(ViewFrameScheduler, AClosedTabGetsNoFramesAndIsRemoved) {
  FrameScheduler s;
  for (uint64_t id = 1; id <= 3; ++id) s.add(ready_tab(id));
  EXPECT_EQ(turn(s)->tab, 1u);
  s.close(2);
  EXPECT_FALSE(wants_frame(*s.find(2)));
  EXPECT_EQ(s.size(), 3u);  // still counted (the tab limit) until removed
  EXPECT_EQ(s.remove_closed(), std::vector<uint64_t>{2});
  EXPECT_EQ(s.size(), 2u);
  EXPECT_EQ(s.find(2), nullptr);
  EXPECT_TRUE(s.remove_closed().empty());
  // The others go on taking turns; a closed tab's late delivery or result changes nothing.
  std::map<uint64_t, int> frames;
  for (int i = 0; i < 100; ++i) ++frames[turn(s)->tab];
  EXPECT_EQ(frames[1], 50);
  EXPECT_EQ(frames[3], 50);
  s.delivered(2);
  s.close(2);
  EXPECT_EQ(s.size(), 2u);

  // Closed while its frame is drawn: the result is dropped with the tab.
  std::optional<FrameJob> job = s.next();
  ASSERT_TRUE(job);
  s.close(job->tab);
  EXPECT_EQ(s.remove_closed(), std::vector<uint64_t>{job->tab});
  s.rendered(*job, true, false);
  EXPECT_EQ(s.size(), 1u);
  // The last tab closes: nothing to do.
  s.close(s.tabs().front().id);
  EXPECT_FALSE(s.next());
  s.remove_closed();
  EXPECT_FALSE(s.next());
}

TEST(ViewFrameScheduler, TabsStreamingShareTheFrameBudget) {
  FrameScheduler s;
  s.add(ready_tab(1, 10));
  std::optional<FrameJob> job = turn(s);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->streaming, 1u);
  EXPECT_EQ(job->target_fps, 10);

  s.add(ready_tab(2, 20));
  s.add(ready_tab(3, 5));
  job = s.next();  // tab 2
  ASSERT_TRUE(job);
  EXPECT_EQ(job->tab, 2u);
  EXPECT_EQ(job->streaming, 3u);
  EXPECT_EQ(job->target_fps, 60);
  // Tab 2's frame is on the wire: it still streams, and still counts.
  job = turn(s);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->tab, 3u);
  EXPECT_EQ(job->streaming, 3u);
  EXPECT_EQ(job->target_fps, 15);
  s.rendered(*s.next(), true, false);  // tab 1 converges (its frame still on the wire)
  s.delivered(1);
  s.delivered(2);
  // Tab 1 at rest and converged does not count, nor a tab that has not said hello, nor a closed one.
  TabState quiet = ready_tab(4);
  quiet.view.ready = false;
  s.add(quiet);
  s.add(ready_tab(5));
  s.close(5);
  job = s.next();
  ASSERT_TRUE(job);
  EXPECT_EQ(job->tab, 2u);
  EXPECT_EQ(job->streaming, 2u);
  EXPECT_EQ(job->target_fps, 40);
}

TEST(ViewFrameScheduler, RedrawAllAfterAnEngineSwitch) {
  FrameScheduler s;
  s.add(ready_tab(1));
  s.add(ready_tab(2));
  while (turn(s, true)) {
  }
  EXPECT_FALSE(s.next());
  s.redraw_all();
  std::optional<FrameJob> a = turn(s), b = turn(s);
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(a->resting);
  EXPECT_FALSE(b->resting);
  EXPECT_NE(a->tab, b->tab);
}

// A message that changes nothing draws no frame; the tab is told by an ack once no frame that would carry its count
// is coming (the server asked for a full-quality frame again on a repeated message: seconds on a slow machine).
TEST(ViewFrameScheduler, AMessageThatChangesNothingIsAcknowledgedNotDrawn) {
  FrameScheduler s;
  s.add(ready_tab(1));
  EXPECT_FALSE(s.take_ack(1));  // nothing drawn yet: the first frame carries the count
  ASSERT_TRUE(turn(s, true));   // converged
  EXPECT_FALSE(s.take_ack(1));  // nothing new
  repeat_view(s, 1);
  EXPECT_FALSE(s.next()) << "a repeated view must not be drawn again";
  EXPECT_EQ(s.take_ack(1), std::optional<uint64_t>(2));
  EXPECT_FALSE(s.take_ack(1));  // acknowledged once

  // While refining (not converged) the next frame carries the count: no ack.
  change_view(s, 1);
  std::optional<FrameJob> job = turn(s, false);
  ASSERT_TRUE(job);
  repeat_view(s, 1);
  EXPECT_FALSE(s.take_ack(1));
  job = s.next();
  ASSERT_TRUE(job);
  EXPECT_TRUE(job->resting) << "a repeated message must not restart refinement";
  EXPECT_EQ(job->generation, 4u);

  // A repeat that comes while the view's first frame is drawn: acknowledged once that frame is done.
  s.rendered(*job, true, false);
  s.delivered(1);
  change_view(s, 1);  // 5
  job = s.next();
  ASSERT_TRUE(job);
  repeat_view(s, 1);            // 6, during the render
  EXPECT_FALSE(s.take_ack(1));  // the frame being drawn is for 5: not shown yet
  s.rendered(*job, true, false);
  EXPECT_EQ(s.take_ack(1), std::optional<uint64_t>(6));
  s.delivered(1);
  EXPECT_FALSE(s.next());

  // After an engine switch every tab draws again, repeats or not.
  s.redraw_all();
  repeat_view(s, 1);
  EXPECT_FALSE(s.take_ack(1));
  EXPECT_TRUE(s.next());
}

// A collective renderer's full-quality frame cannot be cut short: with a rest delay, the resting frame after a moving
// one waits, and a move arriving meanwhile is drawn first; a full-quality request does not wait.
TEST(ViewFrameScheduler, ARestDelayHoldsTheRestingFrameBackForTheNextMove) {
  using Clock = std::chrono::steady_clock;
  FrameScheduler s;
  s.set_rest_delay(0.5);
  s.add(ready_tab(1));
  const Clock::time_point t0 = Clock::now();
  std::optional<FrameJob> job = s.next(t0);
  ASSERT_TRUE(job);
  EXPECT_FALSE(job->resting);
  s.rendered(*job, false, false, t0);  // a moving frame: not converged
  s.delivered(1);

  EXPECT_FALSE(s.next(t0 + std::chrono::milliseconds(100))) << "the resting frame waits";
  ASSERT_TRUE(s.next_due());
  EXPECT_EQ(*s.next_due(), t0 + std::chrono::milliseconds(500));

  change_view(s, 1);  // the drag's next step, within the delay: drawn at once
  job = s.next(t0 + std::chrono::milliseconds(200));
  ASSERT_TRUE(job);
  EXPECT_FALSE(job->resting);
  s.rendered(*job, false, false, t0 + std::chrono::milliseconds(300));
  s.delivered(1);
  EXPECT_FALSE(s.next(t0 + std::chrono::milliseconds(700))) << "half a second after the last moving frame";
  job = s.next(t0 + std::chrono::milliseconds(800));
  ASSERT_TRUE(job);
  EXPECT_TRUE(job->resting);
  EXPECT_FALSE(s.next_due());
  s.rendered(*job, true, false, t0 + std::chrono::milliseconds(900));
  s.delivered(1);
  EXPECT_FALSE(s.next(t0 + std::chrono::seconds(5))) << "converged: nothing more";

  // A full-quality request (the page's "save PNG") is not held back.
  change_view(s, 1);
  job = s.next(t0 + std::chrono::seconds(6));
  ASSERT_TRUE(job);
  s.rendered(*job, false, false, t0 + std::chrono::seconds(6));
  s.delivered(1);
  s.find(1)->view.full_quality = true;
  job = s.next(t0 + std::chrono::seconds(6));
  ASSERT_TRUE(job);
  EXPECT_TRUE(job->full_quality);

  // Without a delay (every other renderer) the resting frame follows at once.
  FrameScheduler plain;
  plain.add(ready_tab(2));
  job = plain.next(t0);
  ASSERT_TRUE(job);
  plain.rendered(*job, false, false, t0);
  plain.delivered(2);
  job = plain.next(t0);
  ASSERT_TRUE(job);
  EXPECT_TRUE(job->resting);
}

}  // namespace
}  // namespace ugvr::view
