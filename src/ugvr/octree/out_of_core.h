// The out-of-core octree builder (Leven et al. 2002, figure 6): the same tree and bricks as build_octree
// (octree/builder.h) from a .vtu file whose cells never are in memory all at once.
//
//  1. The file's cells become a cell soup (octree/soup.h), the root's cell file, streamed from the .vtu
//     (octree/vtu_cells.h), which holds the points and vertex scalars a slice at a time within the budget.
//  2. process(node, file), depth first, subtrees in parallel: the node streams its file once through the split
//     test (VoxelSpread), keeping the records in memory as long as they fit its share of the budget. A node that
//     splits streams its file again, routes each cell to the children it overlaps (the same separating-axis test
//     and margin as in core), deletes its file and recurses; a leaf welds its records into a small mesh (vertices
//     by their ids, cells in id order, so the sampler's tie rule picks the same cell as in core), samples it with
//     the brick sampler and deletes its file. Interior bricks, padding and encoding are as in core.
//
// What differs from the in-core build, by design: node ids are given at split time (each split takes a block of
// consecutive ids for its children, which keeps the store's rules) so they depend on the schedule, and an interior
// node's error is measured at its children's samples only (its data points would have to be streamed again), then
// made monotone as in core. The tree, every brick and the leaves' errors are the same (the tests compare them), at any
// memory budget; only the store's boundary section depends on the budget (dropped when its triangles need more than
// half of it: see find_boundary in out_of_core.cpp).
//
// Memory, all within `memory_budget` (measured: docs/octree-build.md): while the soup is written, a slice of the
// points and vertex scalars (half the budget beyond 48 MiB for the program; one more pass over the cells per
// slice); then 48 MiB for the program and the store writer, per worker thread the file buffers of a split (9 MiB)
// and the bricks of the subtree in progress, and the records of one node, up to a twelfth of the worker's share of
// the rest (sampling takes up to about 10 times their size). A leaf with more records than that is sampled in
// pieces: its cells are routed to the halves of its box (halved again while too large) and its lattice is sampled
// once per piece with that piece's cells, keeping the samples inside the piece, which gives its samples bit for bit
// for about the work of sampling it whole; each piece writes the data points of its part of the box to a file, each
// once (octree/leaf_points.h), and the leaf's error is measured there once its brick is whole: the same points as in
// core, so the same errors and transfer-function error entries at any budget. With options.leaf_cells, a leaf also
// writes its cell block (octree/node_cells.h, gather_welded_cells) once it stays a leaf: from its welded mesh, with the
// mesh's own topology, after sampling (its topology and block take less than the sampler did), and the whole
// mesh's boundary faces (8 bytes each, from octree/soup_boundary.h) held through the build; a leaf sampled in pieces
// still writes one block, from all of its records at once, one such leaf at a time: that is beyond the budget's
// accounting, by up to about 65 MiB for the largest leaves of 10M tetrahedra at --memory 128MiB (measured:
// docs/octree-build.md, "Cells per leaf"). Disk: the soup (96
// bytes per tetrahedron with one scalar) and the files of the pending nodes, about twice the soup at most (and, while a
// leaf is sampled in pieces, its point file: 24 + 4F bytes a data point, a fraction of its records), next to the
// output, in the scratch folder "<path>.cells" (core/temp_files.h: removed on error, SIGINT and SIGTERM, and after a
// SIGKILL by the next build of the same output).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ugvr/io/time_series.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/vtu_cells.h"

namespace ugvr {

OctreeBuildStats build_octree_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                          const OctreeBuildOptions& options, uint64_t memory_budget,
                                          const std::string& path);

// The bytes of points and vertex scalars a pass over a .vtu's cells may hold (a slice at a time) within
// `memory_budget`: half of what is left beyond the program's own 48 MiB, at least 1 MiB (each slice costs one more
// pass over the cells). The soup's writing and the partitioned build's sample pass (mpi/piece_build_ooc.h) use it.
uint64_t soup_point_budget(uint64_t memory_budget);

// The scratch space an out-of-core build of `cells` cells cannot do without: its soup and, at the root's first split,
// the children's files beside it (each cell is routed to at least one child before the root's file is deleted), so
// twice the soup, counted with the smallest record a cell can have (a tetrahedron's). A floor, not an estimate: the
// measured peak is about that at 100M tetrahedra (docs/octree-build.md), more where cells are larger.
uint64_t out_of_core_scratch_floor(uint64_t cells, const SoupLayout& layout);
// The bytes free for scratch in `folder`: what its file system has available, or, when $UGVR_SCRATCH_FREE_BYTES is set
// (a byte count; for tests, which cannot fill a disk), that figure. The one place the variable is read: the check
// below and the viewer's choice of a partitioned build (view/scratch_pieces.h) see the same free space. Throws
// ugvr::Error naming the variable when it is not a count, or the folder when its space cannot be read.
inline constexpr const char* kScratchFreeBytesEnv = "UGVR_SCRATCH_FREE_BYTES";
uint64_t scratch_free_bytes(const std::string& folder);
// Throws ugvr::Error naming `input`, the scratch folder, what is needed and what is free, with advice (free space,
// another disk for the output, or a partitioned build's one piece at a time), when `available` < `needed`: refused
// before anything is written, not half an hour later on a full disk.
void check_out_of_core_scratch(const std::string& input, uint64_t cells, uint64_t needed, uint64_t available,
                               const std::string& scratch_folder);

// A store of some of a .vtu's cells on the whole file's lattice: a partitioned build's piece (mpi/piece_build_ooc.h).
// The soup takes the cells `keep` accepts, with their file ids and vertex ids (a leaf welds them in id order, so the
// sampler's lowest-id rule is the whole mesh's), and the root cube, the recorded bounds and the field ranges are
// `bounds` and `fields`: the whole file's, from the plan, not the kept cells'. The source streams the whole file
// either way, so its own bounds and ranges are the whole file's too; they are checked equal to the given ones (a file
// changed since the plan is refused naming the field or the bounds).
struct OutOfCoreSubset {
  std::string name;  // "piece 3", for messages
  VtuCellSource::CellFilter keep;
  Bounds bounds;
  std::vector<BrickStoreField> fields;
};
// As above for `subset`'s cells; no preview or sketch (theirs would be the whole file's). Throws ugvr::Error when
// `keep` takes no cell, naming subset.name.
OctreeBuildStats build_octree_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                          const OctreeBuildOptions& options, uint64_t memory_budget,
                                          const std::string& path, const OutOfCoreSubset& subset);

// A store with time (format version 6; docs/time-series.md, "Stores with time") of steps `steps` of a series whose
// steps are one .vtu file each, out of core within `memory_budget`, one step at a time. The first step is built as
// build_octree_out_of_core builds one: its soup routed down the tree it shapes; but each leaf's file (the records
// routed to it) is kept in the scratch folder as "leaf-<id>" instead of being deleted. The geometry is static, so a
// later step's leaf holds the same cells: each later step writes only its values (octree/step_values.h: a float per
// point and selected vertex scalar, per cell and cell scalar; no soup, no point slices), and each leaf takes its kept
// records with those values put in (read by runs of the ids they name), then is sampled as before (in pieces when
// over its worker's share); interior nodes read nothing, their bricks come from their children's. So every step's
// bricks land on the first step's node ids. The same store as build_octree_steps: the same tree, each step's bricks
// bit for bit, the same leaf errors.
//   Disk (the scratch folder "<path>.cells", next to the output): from the end of the first step to the last step
// the kept leaves, about 1.3 times the first step's soup (a cell overlapping several leaves is in each; 176 bytes a
// hexahedron with one scalar: 470 MB for 2M hexahedra at depth 5), removed one by one as the last step is done with
// them; a step's value files, 4 (Fv points + Fc cells) bytes; and a leaf over its worker's share written with its
// values, one per worker at a time. During the first step, as for one step (about twice its soup at most). Memory: a
// later step holds no points: a worker's share of records as before, plus about 4 bytes a corner and 4 (Fv + 1) a
// distinct vertex while the values are put in (less than sampling takes), and the writer's per-step node tables
// (held_for_steps).
//   The geometry is checked without a step in memory: the points and cells are hashed as they are read
// (VtuCellSource::geometry_hash), and a step whose hash differs from the first's stops the build naming both steps.
// At --error 0 only (the split rule is then geometric: one tree for every step); above 0, and with a preview or a
// sketch, throws ugvr::Error with advice.
OctreeBuildStats build_octree_out_of_core_steps(const TimeSeries& series, std::span<const uint32_t> steps,
                                                std::span<const std::string> selectors,
                                                const OctreeBuildOptions& options, uint64_t memory_budget,
                                                const std::string& path);

// Whether every selected step is one .vtu file (what build_octree_out_of_core_steps streams).
bool out_of_core_steps_possible(const TimeSeries& series, std::span<const uint32_t> steps);
// The .vtu file of step `step`; throws ugvr::Error naming the step's file(s) when it is not one .vtu file.
std::string out_of_core_step_file(const TimeSeries& series, uint32_t step);

}  // namespace ugvr
