// The active cut: the set of brick-store octree nodes the LOD renderer draws, kept from frame to frame and adapted
// by a bounded number of splits and merges per frame (Leven et al. 2002, section 5.1, "time-critical LOD"), instead
// of being chosen from scratch every frame as select_cut (lod_cut.h) does. Keeping the cut makes the per-frame work
// proportional to the cut, lets a split wait over several frames for its children's bricks to load, and bounds how
// much the cut (hence the bricks to read and upload) changes in one frame.
//
// The tree the cut lives in. Only nodes with a brick can be drawn, so the cut lives in the *brick tree*: the store's
// nodes with a brick, where the brick children of a node are its existing children that have a brick, plus, through
// any child without brick but with children, that child's brick children, recursively (leaves without brick hold no
// data and are dropped). The roots of the brick tree (the root, or its brick children when it has no brick) form the
// coarsest cut. Splitting a node replaces it by its brick children; merging a node replaces its brick children (all
// of them on the cut) by it. Both are O(children).
//
// Invariants (after construction and after every public call):
//  - every cut node has a brick; no cut node is an ancestor of another;
//  - every data unit of the store (a node with a brick and no descendant with one: normally a leaf) has exactly one
//    ancestor-or-self on the cut: the cut covers the data exactly once. Culled nodes (outside the frustum, or
//    transparent under the transfer function) stay on the cut, undrawn, so the cut can be drawn at once whatever the
//    next view (paper, section 5.2);
//  - a node is a *merge candidate* iff it has brick children and all of them are on the cut; a *split candidate* iff
//    it is on the cut and has brick children.
//
// Error (per node, per view): the largest screen size of the node's texels in pixels (ViewMetrics::texel_pixels,
// perspective-correct: at the nearest depth of the node's box), times (error_max / field range)^w with w =
// ActiveCutOptions::error_weight (w = 0: the paper's pure texel size; w = 1: texel size times the relative data error,
// so a node that represents its data exactly is never split), times, with ActiveCutOptions::tf_error, the node's
// transfer-function weight (tf_error.h; the same factor select_cut applies). Culled nodes have error 0. The error is
// clamped to its brick parent's, so it never increases down the tree (the texel size alone already halves per level).
// Hence merging a node removes no error larger than its own, and a merge of lower error than a split truly lowers the
// maximum. No sequence of moves at a fixed view and budget can repeat: the highest-error node split in a would-be cycle
// would have to be merged back, which only a free merge (its error <= threshold: it would not have been split) or a
// merge for a split of higher error (contradicting "highest") could do.
//
// One update (a frame). The errors of the cut nodes and merge candidates are computed for the new view; the split
// queue holds the split candidates by decreasing error, the merge queue the merge candidates by increasing error
// (ties by node id: everything is deterministic). Then:
//  1. capacity: while the cut has more than max_nodes nodes, merge the lowest-error merge candidate whose brick is
//     resident (mandatory: these count as uploads but ignore the upload budget);
//  2. splits, highest error first, while the error is > the threshold (ActiveCutOptions::pixels):
//     - a split needs the bricks of all the node's brick children resident; otherwise the missing ones go to
//       `wanted` with the node's error as priority and the split is *pending*: it completes in the first update that
//       finds them resident, unless a candidate with a higher error comes first (pre-emption, paper 5.1: the loader
//       reads `wanted` in order, so a node that becomes more important takes the reads). A pending split reserves
//       its room in max_nodes so that lower-error splits do not take it meanwhile;
//     - if the split would take the cut past max_nodes, lower-error merge candidates (each with error < the
//       splitting node's) are merged first to make room; if that is impossible the update stops splitting
//       (budget_limited): a split beyond the budget only after merges that lower the error;
//     - the nodes entering the cut (children, and parents merged for room) count against max_new_nodes_per_frame;
//       a split that does not fit waits for a later frame (upload_limited), except that the first move of an update
//       may exceed the budget on its own (else a budget below 8 would forbid every split). Once the uploads are
//       spent, the scan goes on only to find reads, and stops when the reads, or the next update's uploads, are
//       spoken for. This bounds the queue work by the budgets; what remains grows with the cut (an error per cut node
//       and merge candidate, one heapify, one sort): about 2 ms per update, on one core, for a cut of 20,000 nodes of
//       a 120,000-node store with 512 uploads per frame;
//  3. free merges: merge candidates with error <= the threshold (culled ones, error 0, first) are merged while the
//     upload budget allows: they lose nothing at this view and free atlas slots and frame time.
// A node moved in an update is not moved back in the same update. Merges also need the parent's brick resident;
// a missing one goes to `wanted` (priority +inf for capacity merges, 0 for free ones). Cut nodes whose bricks are
// not resident are wanted with priority +inf (drawn nodes) or 0 (culled ones).
//
// With unlimited budgets and everything resident, repeated updates reach the fixed point where every strict
// brick-tree ancestor of a cut node has error > threshold and every non-leaf cut node has error <= threshold: with
// error_weight 0 its non-culled nodes are exactly select_cut's "pixels:threshold" cut for the same view.
//
// Residency is the caller's: is_resident(node) says that the node's brick can be put on the GPU this frame (host
// cache or atlas). The caller reads `wanted` (at most max_reads_per_frame of them, most important first), uploads
// the cut's new nodes, and draws `visible`. Not thread-safe: one thread updates and reads the cut.
//
// Data layout: per store node (indexed by node id): brick parent, first brick child (CSR into one array of brick
// children), on-cut flag and position in an unsorted cut array (O(1) insert and remove), brick children on the cut,
// and per-update stamps for the error cache, moves and wanted marks (no clearing between updates). About 80 bytes
// per node.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/lod/tf_error.h"
#include "ugvr/render/lod/view_metrics.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct ActiveCutOptions {
  uint32_t field = 0;        // whose value range (culling) and error_max (weighting) are used
  double pixels = 1;         // split threshold on the error (> 0): texels per pixel when error_weight is 0
  double error_weight = 0;   // w >= 0 (see the header comment)
  bool frustum_cull = true;  // culled nodes count as error 0 (and are not drawn)
  bool tf_cull = true;
  // Multiply the error by the node's transfer-function weight (render/lod/tf_error.h: 0 when transparent or uniform
  // under the transfer function, so never split; 1 to 2 by how far its image is from its finest data's, so those
  // are split first). Recomputed when the transfer function changes, not per update.
  bool tf_error = true;
};

struct CutBudget {
  static constexpr uint64_t kUnlimited = std::numeric_limits<uint64_t>::max();
  uint64_t max_nodes = kUnlimited;                // cut nodes: atlas capacity, or the frame controller's budget; >= 1
  uint64_t max_new_nodes_per_frame = kUnlimited;  // nodes entering the cut in one update (brick uploads)
  uint64_t max_reads_per_frame = kUnlimited;      // length of CutUpdate::wanted (brick reads)
};

struct NodeError {
  double texel_pixels = 0;  // screen size of one texel, in pixels
  double weighted = 0;      // the error the queues use: 0 when culled, clamped to the brick parent's
  bool culled = false;
};

struct CutUpdate {
  // Nodes whose bricks the cut wants resident and lacks, most important first (priority descending, then id):
  // priority = the error the pending split would remove; +inf for drawn cut nodes and capacity merges; 0 for culled
  // cut nodes and free merges. At most max_reads_per_frame.
  std::vector<uint64_t> wanted;
  std::vector<double> wanted_priority;
  std::vector<uint64_t> pending;  // split candidates waiting for children's bricks, by decreasing error
  std::vector<uint64_t> visible;  // cut nodes not culled, ascending: what to draw this frame
  uint64_t splits = 0, merges = 0;
  uint64_t new_nodes = 0;  // nodes that entered the cut (uploads)
  // Some split above the threshold was refused because max_nodes left no room and no merge of lower error could
  // make it; also set when the coarsest cut alone exceeds max_nodes.
  bool budget_limited = false;
  bool upload_limited = false;  // some possible split waits for the next update's upload budget
  // Nothing moved and nothing is wanted: the cut is final for this view, budget and residency.
  bool converged = false;
  double max_error = 0, mean_error = 0;  // weighted errors of the visible nodes (0 when none)
};

struct QueueEntry {
  uint64_t node = 0;
  double error = 0;
  bool operator==(const QueueEntry&) const = default;
};

class ActiveCut {
 public:
  // Starts as the coarsest cut. The store must outlive the cut (it is read on every update). Throws ugvr::Error for a
  // field out of range, pixels <= 0 or not finite, or a negative or non-finite error weight.
  explicit ActiveCut(const BrickStoreReader& store, ActiveCutOptions options = {});

  // One frame (see the header comment). `width` × `height` is the image the camera renders. Throws ugvr::Error for
  // max_nodes 0, an image size < 1 or a degenerate camera (ViewMetrics).
  CutUpdate update(const Camera& camera, int width, int height, const TransferFunction& tf, const CutBudget& budget,
                   const std::function<bool(uint64_t)>& is_resident);

  std::span<const uint64_t> nodes() const;  // ascending ids
  uint64_t size() const { return cut_.size(); }
  // Size of the coarsest cut (the brick tree's roots): no merge can take the cut below it.
  uint64_t coarsest_size() const { return roots_.size(); }
  bool contains(uint64_t node) const { return node < on_cut_.size() && on_cut_[node]; }
  void reset();  // back to the coarsest cut

  const ActiveCutOptions& options() const { return options_; }
  // Takes effect at the next update.
  void set_options(const ActiveCutOptions& options);

  // The brick tree (see the header comment): brick children, and the nearest ancestor with a brick (kNoNode for
  // the coarsest cut's nodes). Empty for nodes without brick.
  std::span<const uint64_t> brick_children(uint64_t node) const;
  uint64_t brick_parent(uint64_t node) const;

  // For the view of the last update (ugvr::Error before the first): a node's error; the queues as they stand now
  // (all split candidates by decreasing error, all merge candidates by increasing error, ties by id).
  NodeError error(uint64_t node) const;
  std::vector<QueueEntry> split_queue() const;
  std::vector<QueueEntry> merge_queue() const;

  // One move, regardless of view, residency and budget (for tests and tools). Throws ugvr::Error unless the node
  // is on the cut with brick children (split) or is a merge candidate (merge).
  void split(uint64_t node);
  void merge(uint64_t node);

 private:
  struct Frame;

  bool mergeable(uint64_t node) const {
    const uint64_t k = kid_begin_[node + 1] - kid_begin_[node];
    return k > 0 && kids_on_cut_[node] == k;
  }
  uint64_t kid_count(uint64_t node) const { return kid_begin_[node + 1] - kid_begin_[node]; }
  void add(uint64_t node);
  void remove(uint64_t node);
  void do_split(uint64_t node);
  void do_merge(uint64_t node);
  const NodeError& eval(uint64_t node) const;
  void check_node(uint64_t node, const char* what) const;

  const BrickStoreReader& store_;
  ActiveCutOptions options_;
  double range_ = 0;  // field max - field min, for the error weight

  std::vector<uint64_t> parent_;     // brick parent
  std::vector<uint64_t> kid_begin_;  // node_count + 1 offsets into kids_
  std::vector<uint64_t> kids_;       // brick children, ascending per node
  std::vector<uint64_t> roots_;      // the coarsest cut

  std::vector<uint64_t> cut_;          // unsorted
  std::vector<uint64_t> pos_;          // index in cut_ of an on-cut node
  std::vector<uint8_t> on_cut_;        // per node
  std::vector<uint64_t> kids_on_cut_;  // per node: brick children on the cut
  mutable std::vector<uint64_t> sorted_;
  mutable bool sorted_valid_ = false;

  // Per-update state, stamped with frame_ so nothing needs clearing.
  uint32_t frame_ = 0;
  std::vector<uint32_t> moved_;   // split or merged in update frame_
  std::vector<uint32_t> marked_;  // wanted, or listed as a merge candidate, in update frame_ (by mark_)
  uint32_t mark_ = 0;             // separate stamp sequence for marked_
  std::optional<ViewMetrics> view_;
  TransferFunction tf_;
  TfNodeErrors tf_errors_;   // for tf_ and options_.field
  uint32_t view_stamp_ = 0;  // the errors cached with this stamp belong to view_
  mutable std::vector<uint32_t> eval_stamp_;
  mutable std::vector<NodeError> errors_;
};

}  // namespace ugvr
