// A point sketch of an out-of-core build (the [first-image] issue 24): an approximate store of levels 0 .. K made from
// the mesh's points and vertex values alone, in one pass over the points before any cell is read, so that a viewer of
// a mesh far larger than memory shows a volume within seconds. The coarse preview (octree/coarse_preview.h), exact at
// its lattice points, needs every cell first (a lattice point's value is final only once the last cell that may hold
// it has been seen: 50 s at 100M tetrahedra here); the sketch does not wait for the cells.
//
// How (Callahan et al. 2006 draw a subset of the geometry first; here the subset is the vertices): each point's values
// go to the level-K lattice point nearest to it (lattice lines of the final store: octree/brick_sampler.h), and a
// lattice point holds the mean of the points it received. A lattice point that received none is a hole: along each
// axis in turn, a run of at most kSketchGapFill holes between two filled points is filled linearly (a graded mesh's
// coarse cells leave such runs; the mesh's outside, a long run, stays empty: no data, drawn transparent). So the
// sketch is the field smoothed over about one lattice spacing, its boundary within a spacing or two of the mesh's:
// good enough to see where things are, never taken for exact (each node's error is the field's whole range, as the
// preview's) and replaced by the preview, then by the store.
//
// K: the deepest level (<= the caller's maximum) whose lattice, ((R - 1) 2^K + 1)³ points, has at most a quarter as
// many points as the mesh (about four points per lattice point where the mesh fills its box); 0 when even level 1 is
// too fine (a mesh under about a million points: its preview and store come quickly anyway). Vertex fields only: a
// cell field has no value at the points (no sketch then).
//
// Cost: one pass over the points and vertex scalars (a sixth of a tetrahedral .vtu), the lattice's sums and counts
// ((8F + 4) bytes per lattice point: 23 MiB at K = 2, R = 32, F = 1) and the level-K bricks; the writing of levels
// 0 .. K is the preview's (write_level_store).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/vtu_cells.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

inline constexpr uint32_t kSketchGapFill = 4;  // the longest run of empty lattice points filled along an axis

struct PointSketchStats {
  int depth = 0;
  uint64_t points = 0;
  uint64_t lattice_points = 0, hit = 0, filled = 0;  // the level-K lattice; those that got points; holes filled
  uint64_t nodes = 0, store_bytes = 0;
  double seconds = 0;
};

// K for `points` points at brick resolution R, at most `max_depth` (see above); 0: no sketch.
int point_sketch_depth(uint64_t points, uint32_t resolution, int max_depth);

// Whether every selected field is a vertex field (the sketch needs values at the points).
bool point_sketch_possible(std::span<const VtuCellSource::Slot> slots);

// Writes the sketch of `source`'s points at depth K over `lattice` to `path` as a store of `layout` (atomically), its
// fields those of `source` (vertex fields). Points are read in slices of at most `slice_bytes`. Throws ugvr::Error for
// a depth out of 1 .. kMaxPreviewDepth, a cell field, or a failed write.
PointSketchStats write_point_sketch(const VtuCellSource& source, const BrickLattice& lattice,
                                    const BrickStoreLayout& layout, int K, uint64_t slice_bytes,
                                    const std::string& path);

}  // namespace ugvr
