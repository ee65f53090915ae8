// The octree builder's split criterion (Leven et al. 2002, section 4.2): a node splits while its brick is too coarse
// for the data inside it, that is while two data points (octree/data_points.h) inside the node whose values differ by
// more than the error threshold fall into the same voxel of the node's lattice. A voxel is the set of points nearest
// to one sample, so a node that does not split gives every such point a sample of its own, within half a voxel.
//
// The threshold is `error` times each field's range (max - min over the dataset); a node splits when any field asks.
// error = 0 is the paper's geometric extreme: no two data points (of cells that are not flat) may share a voxel,
// whatever their values; and, so that the voxel field follows the mesh's own interpolant inside each cell rather than
// only at its vertices, every edge of a cell that is not flat and has an end in the node spans at least two voxels
// (length >= 2 h, h = node size / (R - 1): LaMar's "double sampled" rule, Nyquist for the cell's linear pieces).
// Without it a coarse grid stops at about one voxel per cell, and the trilinear voxel field between the vertices
// differs from the cells' interpolant (rings on a coarse curvilinear grid). Zero-length (collapsed) edges never count.
// Points at the very same position never count as two (duplicated vertices cannot be separated by any resolution); with
// error > 0 a voxel triggers when it holds two positions and its value spread exceeds the threshold, which also fires,
// conservatively, when the spread comes from coincident points with different values (a discontinuity no resolution can
// resolve: the max depth ends it).
//
// Cost: one pass over the node's cells and their points with a dense voxel table, stopping at the first voxel that
// triggers, so nodes that must split (most of the coarse ones) decide after a few points.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/data_points.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// The test's voxel table, fed one data point at a time: SplitTest feeds it from a mesh, the out-of-core builder from
// the cells it streams. Per-thread working memory, reused from node to node.
class VoxelSpread {
 public:
  // Starts a node: its lattice box, R, and per field the threshold; geometric: error 0 (any two positions split).
  void begin(const Bounds& box, uint32_t resolution, std::span<const double> thresholds, bool geometric);
  // Adds a data point and its value per field (NaN: the point carries none); true once the node must split.
  bool add(Vec3d position, const float* values);
  // The double-sampling rule (see the header comment) for one cell that is not flat, its vertices in VTK order:
  // true when the node is geometric (error 0) and an edge of the cell with an end in the node is shorter than two
  // voxels.
  bool add_cell_edges(CellType type, const Vec3d* vertices) const;

 private:
  Bounds box_;
  Vec3d scale_;
  uint32_t R_ = 0;
  double min_edge_ = 0;  // 2 voxels: shorter edges split (geometric only)
  std::span<const double> thresholds_;
  bool geometric_ = false;
  std::vector<uint32_t> stamp_;  // per voxel: the node that last touched it
  std::vector<Vec3d> first_;     // position of the first point seen in the voxel
  std::vector<uint8_t> distinct_;
  std::vector<float> lo_, hi_;  // field-major: F x R³
  uint32_t call_ = 0;
};

// The second half of the criterion for error > 0 (a node the voxel rule above would keep as a leaf): the node's brick
// is sampled, padded and read trilinearly at every vertex, edge midpoint and centre of the cells that reach into it
// (node_error.h, cell_interpolant_exceeds), and the node splits where that departs from the mesh's own interpolant by
// more than the threshold. The voxel rule bounds the error only at the data points; between them, where a cell's
// interpolant bends (a curvilinear cell's trilinear map, the kink between two tetrahedra), a coarse lattice can miss
// it by far more. Costs one extra sampling of each leaf (and of each node it splits).
class InterpolantCheck {
 public:
  // All must outlive this. thresholds: per field, as SplitTest's.
  InterpolantCheck(const OctreeDataPoints& points, const BrickSampler& sampler, const BrickLattice& lattice,
                   std::span<const double> thresholds);
  // Whether the node at (level, ijk) with candidate cells `cells` departs by more than the threshold.
  bool exceeds(int level, std::array<uint32_t, 3> ijk, std::span<const uint64_t> cells, BrickScratch& scratch) const;

 private:
  const OctreeDataPoints& points_;
  const BrickSampler& sampler_;
  const BrickLattice& lattice_;
  std::span<const double> thresholds_;
};

class SplitTest {
 public:
  // `fields` gives each scalar's range; error >= 0; resolution R >= 2.
  SplitTest(const OctreeDataPoints& points, std::span<const BrickStoreField> fields, double error, uint32_t resolution);

  // Whether the node with lattice box `box` (its first to its last sample, BrickLattice::node_box) and overlapping
  // cells `cells` must split.
  bool needs_split(const Bounds& box, std::span<const uint64_t> cells, VoxelSpread& scratch) const;

  std::span<const double> thresholds() const { return thresholds_; }
  bool geometric() const { return geometric_; }

 private:
  const OctreeDataPoints& points_;
  std::vector<double> thresholds_;
  bool geometric_;
  uint32_t resolution_;
};

}  // namespace ugvr
