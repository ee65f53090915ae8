// What a moving frame may cost, turned into the two levers of the time-critical LOD renderer (time_critical.h): the
// active cut's node budget (ActiveCut's CutBudget::max_nodes) and the image scale (the frame is ray cast at
// scale × the output size and magnified).
//
// Why two levers, and why the budget is in ray samples. A frame's cost is, to a good approximation, a small fixed part
// plus a cost per ray sample (measured on llvmpipe, oxygen post, 512²: 8-20 ns per sample; the samples are counted
// by the shader). Nodes are a poor unit for it: splitting a node into its 8 children doubles its samples per ray (the
// sample step halves with the voxel size) but does not multiply them by 8, and the coarsest cut, one node covering
// the whole image, already costs its pixels × R / step samples. So the frame controller (frame_controller.h) budgets
// samples, and this policy turns "S samples next frame, S_now this frame" into a node budget by the refinement law
// samples ∝ nodes^(1/3) (a uniform refinement by one level: 8 × the nodes, 2 × the samples):
//   max_nodes = cut_nodes · (S / S_now)^3,  the ratio clamped to [1/2, max_sample_growth] per frame.
// Basing it on the cut's actual size (not the last budget) means a cut that has converged at this view does not let
// the budget run away. When the cut is already at its coarsest and the frame is still too slow (a software
// rasteriser, a full-screen root brick), the image scale is the lever: samples ∝ scale², so
//   scale ← scale · sqrt(S / S_now),  within [min_scale, 1], at most × max_scale_growth per frame.
// With frames between 90 % and 100 % of the target both levers hold (a dead band against timing noise: the cut is
// quantised, and a merge of the root's 7 children into the root is a jump in image quality); a lever that moves aims
// at 95 %. Scale comes back first: while scale < 1
// and there is room, the scale grows and the node budget holds, because a finer cut than the image can show is
// wasted (the cut measures texels in pixels of the scaled image, so it stops splitting where a texel is smaller than
// a rendered pixel).
#pragma once

#include <cstdint>

namespace ugvr {

struct QualityPolicyOptions {
  double min_scale = 0.25;          // smallest linear image scale while moving, in (0, 1]
  double max_sample_growth = 1.26;  // per frame: S / S_now is clamped to this (1.26³ ≈ 2: twice the nodes)
  double max_scale_growth = 1.25;   // per frame, >= 1
  uint64_t initial_nodes = 64;      // the first frame's node budget
};

struct QualityChoice {
  uint64_t max_nodes = 0;  // >= 1
  double scale = 1;        // in [min_scale, 1]
};

class QualityPolicy {
 public:
  // Throws ugvr::Error for options out of range.
  explicit QualityPolicy(QualityPolicyOptions options = {});

  // After a frame: the controller's sample budget for the next frame, the samples this frame took, the cut's size
  // and whether the cut is at its coarsest (no merge can shrink it). Returns the next frame's levers.
  QualityChoice next(uint64_t sample_budget, uint64_t samples, uint64_t cut_nodes, bool coarsest);
  const QualityChoice& current() const { return current_; }
  void reset();

 private:
  QualityPolicyOptions options_;
  QualityChoice current_;
};

}  // namespace ugvr
