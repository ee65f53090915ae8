// Time-critical level of detail (Leven et al. 2002 §5.1-5.2) with progressive refinement when the view rests
// (Callahan et al. 2006): one object per interactive session that, frame after frame, keeps an active cut
// (active_cut.h), keeps its bricks coming through the RAM cache (brick_cache.h, background reads) into the GPU atlas
// (lod_engine.h), and sizes the work of each frame from measured frame times.
//
// A moving frame:
//  1. the frame controller (frame_controller.h) gives a budget of ray samples from the measured seconds per sample,
//     and the quality policy (quality_policy.h) turns it into the two levers: the cut's node budget (capped by the
//     atlas) and the image scale (< 1 only when the coarsest cut is still too slow at full size);
//  2. the active cut merges and splits (§5.1) for the image at that scale: splits only into bricks already in RAM or
//     in the atlas, at most `uploads_per_frame` new bricks a frame; what it would split next goes to the RAM cache as
//     read requests (`reads_per_frame`, by error), together with the bricks the cut itself must keep;
//  3. the engine draws the visible cut nodes at the scaled size, uploading new bricks from the cache (the session's
//     BrickResidency, brick_residency.h, says where each brick is); a scaled frame is magnified to the output size
//     (bilinear);
//  4. the frame's wall time (to the image in host memory) and its sample count go back to the controller.
// Once the view rests the budget is lifted and the scale returns to 1: the cut refines until it converges, then one
// frame at `resting_step_voxels` (instead of `moving_step_voxels`) is full quality, and stays so while the view rests.
// A single image with no target (`target_fps` 0) renders at full quality: the cut is refined to convergence (waiting
// for bricks) before the one frame is drawn.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>

#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/brick_cache.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

struct TimeCriticalOptions {
  double target_fps = 0;                          // 0: no target: every frame at full quality
  uint64_t ram_budget_bytes = uint64_t(1) << 30;  // RAM cache of decoded bricks
  uint64_t uploads_per_frame = 64;                // bricks RAM -> GPU per frame
  uint64_t reads_per_frame = 256;                 // brick read requests (disk -> RAM) per frame
  // The same once the view rests: no frame rate to hold then, so refinement takes bigger steps (fewer, slower frames
  // to full quality; on llvmpipe a resting frame of a large view costs seconds whatever it uploads).
  uint64_t resting_uploads_per_frame = 512;
  uint64_t resting_reads_per_frame = 1024;
  double pixels = 1;                 // split threshold: texels per pixel
  double error_weight = 0;           // texel size × (node error / range)^w (active_cut.h)
  double moving_step_voxels = 1.0;   // sample step while the view moves
  double resting_step_voxels = 0.5;  // and once it rests and the cut has converged
  int loader_threads = 0;            // RAM cache workers (0: hardware concurrency)
  double min_scale = 0.25;           // smallest image scale while moving (quality_policy.h)
  // Hybrid engines (LodOptions::hybrid; docs/hybrid.md): once the view rests and the cut has converged, more nodes
  // turn exact each frame, in priority order (progressive refinement, Callahan 2006); none while it moves. The first
  // resting frame turns exact_batch; each later one max(exact_batch, (exact_growth - 1) × the nodes already exact),
  // so the exact set grows geometrically: N candidates take about log(N / exact_batch) / log(exact_growth) frames
  // instead of N / exact_batch, each costing at most about exact_growth times the exact work of the frame before
  // (every resting frame draws all of its exact nodes again, so fixed batches made the wait quadratic in N).
  // exact_growth 1: fixed batches of exact_batch.
  uint64_t exact_batch = 64;  // >= 1
  double exact_growth = 2;    // >= 1
};

struct TimeCriticalFrame {
  double seconds = 0;           // wall time of the frame (cut update + draw + read back)
  bool resting = false;         // camera, transfer function and settings as in the previous frame
  bool converged = false;       // the cut cannot improve and the step is the resting one: full quality (hybrid:
                                // and every candidate is exact, or the cell budget is full)
  bool memory_limited = false;  // ... because the RAM cache cannot hold the bricks a finer cut needs
  uint64_t budget_samples = 0;  // the controller's sample budget for this frame (max = unlimited)
  uint64_t budget_nodes = 0;    // the cut size the policy allowed (max = unlimited)
  double scale = 1;             // the image was ray cast at scale × the output size
  uint64_t cut_nodes = 0;       // active cut, culled nodes included
  uint64_t visible_nodes = 0;   // drawn
  uint64_t splits = 0, merges = 0;
  double max_error = 0, mean_error = 0;  // screen size of the visible nodes' texels, in output pixels
  uint64_t uploads = 0;                  // bricks uploaded to the atlas
  uint64_t sync_reads = 0;               // of those, read on the render thread (the cache did not have them)
  uint64_t requested = 0;                // read requests sent to the RAM cache
  BrickCacheStats cache;                 // counters of this frame (gauges: now)
  LodRenderStats render;                 // the engine's figures for the draw
  double cut_seconds = 0;                // updating the active cut (and choosing the requests)
  // Playing a time store (prefetch_time_step after the previous frame): this frame's cache loads nothing for its own
  // step (it is shown once); what the cut wants is read for the next step instead.
  bool playing = false;
  // The first frame of a new time step (switch_time_step): the bricks of the new step the prefetch had ready, and the
  // cut's size before and after it was coarsened to them (what the frame can draw without a read on this thread).
  bool switched = false;
  uint64_t prefetched = 0, switch_cut_before = 0, switch_cut_after = 0;
};

class TimeCriticalRenderer {
 public:
  // The engine (its field bound) must outlive this object.
  TimeCriticalRenderer(LodEngine& engine, TimeCriticalOptions options);
  ~TimeCriticalRenderer();

  Image frame(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
              TimeCriticalFrame* report = nullptr);
  // Full quality for one view: refines (waiting for bricks) until the cut converges, then draws at the resting step.
  Image full_quality(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                     TimeCriticalFrame* report = nullptr);
  // A new frame-rate target (0: none) from the next frame on; the cut, the caches and the cost estimate stay.
  void set_target_fps(double fps);

  // Playing a time store (docs/time-series.md). The octree is the same for every step, so a step change keeps the
  // session: its cut, frame-rate controller and camera; only the bricks change.
  // prefetch_time_step: reads the bricks of `step` for the nodes the last frame drew, coarse before fine (their brick
  // ancestors first, level by level, so that a prefetch cut short still holds a coarser cover of the view), then
  // those it wanted, into a cache of their own, in the background, within what this session's RAM budget leaves free
  // (at least one brick). A new call for the same step renews the list; for another step it starts over. The next
  // frame is a playing one (TimeCriticalFrame::playing): it reads nothing more for its own step.
  void prefetch_time_step(uint32_t step);
  // After LodEngine::set_time_step: takes the prefetched bricks if they are of the engine's new step (else a new,
  // empty cache), drops the old step's, and, when the prefetch read anything, coarsens the cut to the finest cover of
  // the view whose bricks the new cache holds (merging nodes whose bricks were not read in time into ancestors that
  // were), so that the step's first frame reads nothing on the render thread (without a prefetch the cut is kept and
  // its bricks are read in that frame); that frame is a moving one (within the frame budget: each step of a playback
  // is drawn once, at the interactive quality).
  void switch_time_step();
  // Waits until the prefetch has every brick it asked for, or timeout_seconds pass; false when there is none or it
  // is incomplete. For tests and batch callers.
  bool wait_prefetch(double timeout_seconds);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ugvr
