// The adaptive octree builder (Leven et al. 2002, sections 3-4): a dataset in, a brick store (store/brick_store.h) out.
// docs/octree-build.md explains the choices and gives the measurements.
//
// Two passes over the tree:
//  1. Shape, top-down (octree/subdivide.h): the root covers a cube around the data; a node splits while two data
//     points that differ by more than the error threshold share one of its voxels, at error 0 while a cell edge in it
//     spans fewer than two voxels, and above 0 while its trilinear voxel field departs from the cells' interpolant by
//     more than the threshold (octree/split.h), up to the maximum depth; children get the cells that overlap them;
//     empty children are not created.
//  2. Bricks, bottom-up and depth first, subtrees in parallel: a leaf samples its cells (octree/brick_sampler.h); an
//     interior node subsamples its children (octree/downsample.h), so every sample of every node is the exact field
//     at its lattice point and borders shared by neighbours are identical; each brick is padded (store/brick_pad.h),
//     its error measured (octree/node_error.h; the same (node value, finest value) pairs make its transfer-function
//     error table entry, store/brick_store_format.h's TfErrorEntry), encoded and appended to the store as soon as it
//     exists. Only the bricks of the nodes whose subtrees are in progress are in memory, never the whole tree's.
// octree/out_of_core.h builds the same store from a .vtu within a memory budget, streaming the cells through files.
// Gradients are not stored: a renderer takes central differences on the brick it has (the paper's gradient pass
// stored them, tripling the store for what costs a renderer a few loads per sample).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/io/time_series.h"
#include "ugvr/octree/boundary_faces.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/input.h"
#include "ugvr/store/brick_codec.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// OctreeBuildOptions::max_leaf_cells' default: 262,144 cells, about 25 MB of out-of-core records (tetrahedra with one
// vertex field) and 14 MB of the hybrid renderer's prepared cells.
inline constexpr uint64_t kDefaultMaxLeafCells = uint64_t(1) << 18;
// How far past max_depth a leaf over max_leaf_cells is split: a cell larger than the node overlaps every child, so
// splitting further would not shrink the leaf's list.
inline constexpr int kLeafCellsExtraDepth = 3;

struct OctreeBuildOptions {
  uint32_t resolution = 32;  // samples per brick axis (the paper's 32)
  int max_depth = 8;         // deepest level (root = 0), at most kMaxOctreeLevel
  // Split threshold relative to each field's range (>= 0); 0: no two data points of one leaf share a voxel.
  double error = 0.01;
  BrickEncoding encoding;                // of the store's blocks
  double tolerance = kQuant16Tolerance;  // quant16 tolerance (store/brick_store.h)
  int threads = 0;                       // worker threads; 0: all
  BrickSamplerOptions sampler;
  // Set from another thread to stop the build early (build_octree then throws ugvr::Error and writes nothing).
  const std::atomic<bool>* cancel = nullptr;
  // The files the mesh came from, as the caller named them: recorded in the store (BrickStoreLayout::provenance).
  std::vector<std::string> inputs;
  // Sees this build's progress (stage label, fraction done), from whichever thread reports (core/progress.h).
  Progress::Observer progress;
  // Write the transfer-function error table (store/brick_store_format.h, TfErrorEntry): 44 bytes per node and field.
  bool tf_errors = true;
  // Keep the mesh's boundary faces with the nodes they cross (octree/boundary_faces.h), up to this many per node; 0:
  // none (the renderer's boundary is then the stencil's alone). Both builders (out of core: octree/soup_boundary.h).
  uint32_t boundary_faces_per_node = kBoundaryFacesPerNode;
  // Keep each leaf's cells in the store (octree/node_cells.h, format version 5), for exact rendering per node (the
  // [hybrid] issue). Both builders (out of core: each leaf from its welded records, the same blocks).
  bool leaf_cells = false;
  // With leaf_cells: a node overlapping more cells than this splits whatever the split test says, past max_depth by up
  // to kLeafCellsExtraDepth levels (deepest_level), so that a leaf's cell block stays small: the out-of-core builder
  // welds a leaf's cells in memory to write its block (a leaf over the worker's share of --memory exceeded the budget
  // by its size), and the hybrid renderer grants a node exact only whole, within its cell budget. Both builders apply
  // it to the same counts (the cells overlapping the node), so their stores stay the same. 0: no cap.
  uint64_t max_leaf_cells = kDefaultMaxLeafCells;
  // Out of core only: a coarse preview of levels 0 .. preview_depth (octree/coarse_preview.h: the final store's
  // samples at those levels, in one pass over the cells) written as a store of its own as soon as the cells are on
  // disk, for a viewer to show while the bricks are built; 0: none.
  int preview_depth = 0;
  // Where the preview goes: empty: "<output>.preview", removed when the build ends however it ends (a viewer that
  // opened it keeps reading its open file); else that path, kept.
  std::string preview_path;
  // Called on the build's thread once the preview is complete at its path.
  std::function<void(const std::string& path)> on_preview;
  // Out of core with a preview: before the cells, an approximate point sketch of levels 0 .. K <= preview_depth
  // (octree/point_sketch.h: each lattice point the mean of the mesh's points nearest to it) when the mesh has enough
  // points and only vertex fields, at `sketch_path` (empty: "<output>.sketch", removed when the build ends), then
  // on_sketch(path, K). For a viewer's first image within seconds of a mesh whose preview takes a minute.
  bool point_sketch = false;
  std::string sketch_path;
  std::function<void(const std::string& path, int depth)> on_sketch;
  // build_octree_steps: read every step whole, as before fields-only step reads (octree/step_loader.h); the store is
  // the same either way (tests compare the two).
  bool whole_step_reads = false;
};

// The deepest level a build may make: max_depth, or past it by kLeafCellsExtraDepth where leaf cells are capped.
int deepest_level(const OctreeBuildOptions& options);

struct OctreeBuildStats {
  uint64_t cells = 0;  // of the mesh voxelized
  uint64_t nodes = 0, leaves = 0;
  uint64_t bricks = 0;                    // nodes with at least one data sample
  int max_level = 0;                      // deepest leaf (root = 0)
  double mean_leaf_level = 0;             // over leaves
  std::vector<uint64_t> nodes_per_level;  // index = level
  uint64_t leaf_samples = 0;              // samples of the leaves' lattices (leaves x R³)
  uint64_t valid_samples = 0;             // of the leaves' samples, in the mesh
  uint64_t leaves_in_pieces = 0;          // out of core: leaves too large for memory, sampled in pieces
  uint64_t point_passes = 0;              // out of core: slices of the points the cells were streamed for
  double sampler_seconds = 0;             // summed over threads
  // Wall clock. Out of core, "subdivide" is the writing of the cells to disk (the tree is shaped as bricks are made).
  double subdivide_seconds = 0, brick_seconds = 0, seconds = 0;
  uint64_t store_bytes = 0;
  uint64_t tf_error_table_bytes = 0;  // of store_bytes: the transfer-function error table (nodes × fields × 44)
  uint64_t boundary_bytes = 0;  // of store_bytes: the boundary faces (nodes × 8 + references × 4 + triangles × 36)
  uint64_t boundary_triangles = 0, boundary_overflow_nodes = 0;
  double boundary_seconds = 0;  // finding them, of `seconds`
  // Out of core with a preview (preview_depth): its wall time (of `seconds`), nodes and bytes.
  double preview_seconds = 0;
  uint64_t preview_nodes = 0, preview_bytes = 0;
  // Out of core with point_sketch: its depth (0: none made), wall time (of `seconds`) and bytes.
  int sketch_depth = 0;
  double sketch_seconds = 0;
  uint64_t sketch_bytes = 0;
  // Why the store has no boundary faces although they were asked for (out of core: over the memory budget); empty
  // otherwise.
  std::string boundary_note;
  // The leaves' cells (leaf_cells): blocks, cells over all blocks (a cell in several leaves counts in each), bytes (a
  // store of several time steps: with the later steps' values blocks);
  // the time writing them (in core: wall clock; out of core, where leaves write theirs as they are sampled: summed
  // over threads).
  uint64_t cell_blocks = 0, leaf_cells = 0, cell_bytes = 0;
  double cell_seconds = 0;
  // A store of several time steps (build_octree_steps): the steps, the wall time spent reading them (every read), and
  // the nodes of the first step's own tree (the union over the steps has `nodes`).
  uint32_t time_steps = 0;
  double read_seconds = 0;
  uint64_t first_step_nodes = 0;
  // Of those reads: steps read fields-only (onto the mesh held) and whole (a step read twice counts twice).
  uint32_t fields_only_reads = 0, whole_reads = 0;
};

// The root cell: a cube with the data's lower corner and its largest extent. A cube keeps voxels isotropic, so a
// split threshold, a gradient and a renderer's texel size mean the same along every axis (the paper's choice, and
// the brick store's documented convention); the empty part of the cube costs nothing, as empty nodes are not created.
Bounds octree_root(const Bounds& data);

// Builds the octree of `input` and writes it to `path` (atomically: nothing is left there on failure). Throws
// ugvr::Error for invalid options or a failed write.
OctreeBuildStats build_octree(const OctreeInput& input, const OctreeBuildOptions& options, const std::string& path);

// Builds one store holding steps `steps` (indices into the series, in order) of a series whose geometry is static
// (format version 6; docs/time-series.md, "Stores with time"): one octree, its boundary faces shared; each step adds
// its bricks, per-node ranges and errors. The tree is the union of the steps' own trees: a node splits where the split
// rule splits it for any step (at --error 0 the rule looks at the geometry alone, so every step's tree is the same and
// one is built). Each step's bricks are quantized over that step's own range, so a step's bricks equal those of a
// store of that step alone wherever the trees agree. Reads: the first step whole, each later step's fields alone where
// its files hold the first's mesh as stored (octree/step_loader.h; a step read whole otherwise). Memory: the mesh and
// one step's fields at a time beside the tree's cell lists; at --error > 0 each step's fields are read twice (for its
// tree, then for its bricks: keeping every step's fields between the passes would hold the whole series' values).
// `fields` as prepare_octree_input takes them (empty: those it picks for the first step, kept for all). Throws
// ugvr::Error when a step read whole has another geometry than the first's (geometry_fingerprint), naming both steps:
// such a series needs one store per step. With options.leaf_cells the leaves' cell blocks (geometry, and the first
// step's values) are shared, and each later step adds its values of them (store_format::kStepsHaveCells).
OctreeBuildStats build_octree_steps(const TimeSeries& series, std::span<const uint32_t> steps,
                                    std::span<const std::string> fields, const OctreeBuildOptions& options,
                                    const std::string& path);

// Checks options for build_octree; throws ugvr::Error naming the bad one.
void validate_build_options(const OctreeBuildOptions& options);

}  // namespace ugvr
