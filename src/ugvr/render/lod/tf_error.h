// The transfer-function-aware error of brick-store nodes (LaMar et al., ch. 7 of ../shared/notes/seed-lamar.md): how
// far a node's image differs from its finest data's under the *current* transfer function, computed from the store's
// transfer-function error table (store/brick_store_format.h, TfErrorEntry) when the transfer function changes, never
// per frame, and used by both cut selections (lod_cut.h, active_cut.h) to weigh a node's texel size.
//
// Why. A node's stored error_max is in field units: it says nothing about what a transfer function makes of it. A
// steep opacity ramp turns a small value error into a large colour error; a node whose values all lie where the
// transfer function is transparent or constant looks exactly like its finest data, however large its value error.
//
// The error of a node. Its table entry has, per group of its (node value c, finest value f) pairs of about equal
// count, the range [f0, f1] of the finest values and the rms s of c - f. Under the transfer function, with
// g(v) = (opacity, opacity · r, opacity · g, opacity · b) (the premultiplied colour a compositing ray sees per unit
// distance), the group's error is estimated as
//   e = min( variation of g over [f0 - s, f1 + s],  s · max slope of g over [f0 - s, f1 + s] )
// (channel by channel, the largest), and the node's per-slab error as the weighted mean of its groups' e. A ray
// crosses about (node edge / unit distance) slabs of the node, so its image error is that many times larger (capped
// at 1). Exactly 0 when the transfer function is transparent or constant over the node's subtree value range
// [min, max] (FieldStats): such a node is never split. Then made monotone up the tree (a parent's error is at least
// its children's), as the stored errors are, so refinement never raises the error.
//
// The weight that multiplies a node's texel size in the cut's priority:
//   0                                 when the error is exactly 0 (transparent or uniform: never split),
//   1 + min(1, error / kTfNoticeable) otherwise,
// so a node whose coarse image differs from its finest data is split first and down to half the texel size of one
// that does not, and no node is split less than by the texel criterion alone. Unknown error (an older store without
// the table, or a node where the builder measured no point): weight 1, the plain texel criterion, except that the
// transparent-or-uniform rule (which needs only the node's value range) still gives 0.
//
// Cost: the transfer function sampled at kTfSamples points over the field's range, range-max tables over them
// (O(1) per query), then a pass over the nodes: about 20 queries per node and field, a few milliseconds for 50,000
// nodes (bench/run_tf_error.sh).
#pragma once

#include <cstdint>
#include <vector>

#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// Image error (mean premultiplied colour and opacity difference) at which a node's weight reaches 2.
inline constexpr double kTfNoticeable = 0.05;
// Samples of the transfer function over the field's range.
inline constexpr int kTfSamples = 1024;

class TfNodeErrors {
 public:
  // The store must outlive this. Nothing is computed before the first update().
  TfNodeErrors(const BrickStoreReader& store, uint32_t field);

  // Recomputes the errors if `tf` (or the field) differs from the last update's; returns whether it did.
  bool update(const TransferFunction& tf);
  void set_field(uint32_t field);

  // Whether the store has the table (else error() is NaN except for transparent-or-uniform nodes, which are 0).
  bool has_table() const { return store_.has_tf_errors(); }
  bool ready() const { return ready_; }
  // For the transfer function of the last update: the node's image error in [0, 1] (NaN: unknown), its weight.
  double error(uint64_t node) const { return errors_[node]; }
  double weight(uint64_t node) const;
  // Wall time of the last recomputation.
  double last_seconds() const { return seconds_; }

 private:
  const BrickStoreReader& store_;
  uint32_t field_ = 0;
  uint32_t step_ = 0;  // the store's time step of the last update
  bool ready_ = false;
  TransferFunction tf_;
  std::vector<double> errors_;  // per node
  double seconds_ = 0;
};

}  // namespace ugvr
