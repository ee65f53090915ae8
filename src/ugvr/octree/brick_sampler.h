// The leaf sampler of the voxelizer (Leven et al. 2002, section 4.3): the R³ samples of one octree node's brick,
// from the cells that overlap the node, for one or more scalars of the mesh.
//
// Sample positions follow store/brick_store.h: node (i, j, k) of level L covers root.lo + (i, j, k) · root.size() / 2^L
// plus one such step, and its sample (x, y, z) lies at the fraction x / (R - 1) of the way across, border samples on
// the node's faces. They are computed from integer lattice lines, never from the node's own box: along each axis,
// line m = i · (R - 1) + x of level L sits at
//   root.lo + root.size() · (m / ((R - 1) · 2^L))
// evaluated in that order in double. A point shared by two bricks (a common face, or a coarser and a finer level,
// where m and the divisor both double) gets the same m / divisor quotient, exactly, hence the same bits.
//
// Method: a row of samples (x fastest) at a time. First each sample of the row is tried in the cell that holds its
// neighbour at y - 1 (else z - 1), starting from that neighbour's first-order prediction rst + J^-1 (p - p_neighbour),
// off by O(spacing² x the cell's nonlinearity): one Newton step with a second-order correction then puts it within
// 1e-12 (cell_interpolation.h's inverse_map_step). These tests depend on the previous row or plane only, not on each
// other, so they run two at a time in SIMD lanes. Then, in order along the row, a sample not found that way is tried
// in the cells of the previous sample and of the neighbours at y - 1 and z - 1 (the paper's one-cell cache, extended
// to the other two axes), then in its bucket of a coarse uniform grid over the node (octree/cell_box_overlap.h), where
// a bound on the cell's affine approximation rules out most cells without Newton. Point in cell: the closed-form
// inverse where the map is affine (tetrahedra, parallelepipeds), corrected Newton steps on the monomial form
// otherwise, then the parametric margin (cell_interpolation.h). Vertex scalars are interpolated with the cell's shape
// functions (in monomial form), cell scalars are constant over the cell.
//
// Points on or near faces. A sample on a face shared by two cells, or on the mesh boundary, must get a value and the
// same one from every brick that holds it. So a point counts as inside a cell when it is within `tolerance` of the
// cell's parametric domain. A cell whose margin at the point is at least `interior_margin` is the only cell that can
// hold it (in a mesh whose cells do not overlap) and is taken at once; otherwise every cell of the bucket is tried,
// each started from the point's image under the affine map of the cell's centre, and the lowest cell id holding the
// point wins. Both outcomes depend only on the point and the mesh, never on the brick or the visiting order, so
// shared samples are bit-identical: predictions warm-start Newton only away from brick borders, where no other brick
// reads the result, and a sample's steps round the same in a SIMD lane as alone.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/field.h"
#include "ugvr/grid/unstructured_mesh.h"
#include "ugvr/octree/cell_box_overlap.h"

namespace ugvr {

// The sample lattice of an octree of bricks of R samples per axis over `root`.
struct BrickLattice {
  Bounds root;
  uint32_t resolution = 0;  // R >= 2

  // Coordinate along `axis` of lattice line m of `level` (see above).
  double coordinate(int axis, int level, uint64_t m) const {
    const double divisor = double(uint64_t(resolution - 1) << level);
    return root.lo[axis] + (root.hi[axis] - root.lo[axis]) * (double(m) / divisor);
  }
  // The box whose corners are the node's first and last samples.
  Bounds node_box(int level, std::array<uint32_t, 3> node) const;
};

struct BrickSamplerOptions {
  // Parametric distance outside a cell that still counts as inside: absorbs the rounding of inverse maps for points
  // on faces (about 1e-15 times the cell's condition number).
  double tolerance = 1e-8;
  // Parametric depth inside a cell beyond which no other cell is looked for. Another cell can only reach it if it
  // is over interior_margin / tolerance = 1000 times larger than this one across their common face.
  double interior_margin = 1e-5;
  // Newton stops once its error bound (cell_interpolation.h's inverse_map_step) is below this: parametric
  // coordinates within 1e-12 of the cell's size put a sample within 1e-12 of the cell's value range of the exact
  // value, far below float32's rounding.
  double newton_accuracy = 1e-12;
  // Axes of the overlap test that buckets the cells (any subset is conservative; fewer axes, more bucket entries).
  // Bounding boxes alone win here: the separating-axis test cost more than the entries it saved (bench_brick_sampler,
  // oxygen post as 5 tets: 21.3 M samples per CPU second with BoxNormals, 18.3 with FaceNormals).
  OverlapAxes bucket_axes = OverlapAxes::BoxNormals;
  // Target number of cells per bucket of the coarse grid (the grid has at most 16³ buckets).
  double cells_per_bucket = 8.0;
};

// One node's samples. Layout: values holds field_count bricks of R³ float32 back to back (field 0 first), each in
// sample order s = x + R · (y + R · z); mask holds R³ bytes, 1 where the sample lies in a cell, 0 where it lies in no
// cell (outside the mesh, or in an IBLANK hole), and the values there are 0.
struct BrickSamples {
  uint32_t resolution = 0;
  uint32_t field_count = 0;
  std::vector<float> values;
  std::vector<uint8_t> mask;
  uint64_t valid = 0;  // samples with mask 1

  std::span<const float> field(uint32_t f) const {
    const size_t n = size_t(resolution) * resolution * resolution;
    return {values.data() + f * n, n};
  }
};

// How the samples were found (for benchmarks and tuning).
struct BrickSamplerStats {
  uint64_t samples = 0;
  uint64_t predicted = 0;       // tried first in the cell of the neighbour at y - 1 or z - 1, a row at a time
  uint64_t predicted_hits = 0;  // ... and found there
  uint64_t cache_hits = 0;      // found in a neighbour's cell (these included)
  uint64_t searches = 0;        // bucket searches
  uint64_t cell_tests = 0;      // point-in-cell tests (inverse maps) in all
  uint64_t candidates = 0;      // cells prepared
  uint64_t bucket_entries = 0;

  BrickSamplerStats& operator+=(const BrickSamplerStats& o) {
    samples += o.samples, predicted += o.predicted, predicted_hits += o.predicted_hits, cache_hits += o.cache_hits;
    searches += o.searches, cell_tests += o.cell_tests, candidates += o.candidates, bucket_entries += o.bucket_entries;
    return *this;
  }
};

// Per-thread working memory of the sampler (prepared cells, buckets); reusing one across bricks avoids allocating.
class BrickScratch {
 public:
  BrickScratch();
  ~BrickScratch();
  BrickScratch(BrickScratch&&) noexcept;
  BrickScratch& operator=(BrickScratch&&) noexcept;

 private:
  friend class BrickSampler;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class BrickSampler {
 public:
  // The scalars must belong to the mesh (one tuple per vertex or per cell), else ugvr::Error. The mesh and the fields
  // must outlive the sampler. The sampler is immutable: any number of threads may call sample() at once, each with
  // its own scratch.
  BrickSampler(const UnstructuredMesh& mesh, std::vector<ScalarRef> scalars, BrickSamplerOptions options = {});

  // Samples node `node` of `level` into `out` (resized as needed). `candidates` must include every cell that
  // overlaps the node's box widened by kOverlapMargin x the cell's diagonal, as cells_overlapping_boxes lists them:
  // a cell just outside the box may still hold a border sample within `tolerance`. Extra cells only cost time.
  void sample(const BrickLattice& lattice, int level, std::array<uint32_t, 3> node,
              std::span<const uint64_t> candidates, BrickScratch& scratch, BrickSamples& out,
              BrickSamplerStats* stats = nullptr) const;

  const BrickSamplerOptions& options() const { return options_; }
  size_t scalar_count() const { return scalars_.size(); }

 private:
  const UnstructuredMesh& mesh_;
  std::vector<ScalarRef> scalars_;
  BrickSamplerOptions options_;
};

}  // namespace ugvr
