// `ugvr build MESH.vtu -o OUT.json --pieces N --out-of-core` (docs/mpi.md, "Partitioned stores", *Out of core*): the
// pieces of piece_build.h, each built by the out-of-core builder (octree/out_of_core.h) in bounded memory, the mesh
// never held.
//
//  1. The plan, from the file streamed (octree/vtu_cells.h): the bounds and the vertex fields' ranges from a pass over
//     the points, the cell fields' ranges and the split sample from a pass over the cells (which holds only the
//     sampled cells' corner ids) and one more over the points for those corners. The kd-tree is built from the
//     centroids of cells 0, s, 2s, ... (split_sample_stride, kd_partition.h: the rule of a .pvtu part read, at most
//     kMaxSplitSamples), so its boxes can differ from an in-core plan's, which splits every centroid; any kd boxes
//     composite exactly, the sample only changes the balance.
//  2. Piece k: the file streamed again into a soup of the cells piece_holds (its box grown by the ghost margin meets
//     the cell's bounding box: piece_cells' rule), with their file ids and vertex ids, so a leaf welds them in id
//     order as the whole mesh's would be (the sampler's lowest-id rule), and the whole file's bounds, root and ranges
//     (OutOfCoreSubset). The same piece store as the in-core piece build of the same plan (tested brick for brick).
//     Its counts (cells owned by centroid, ghost cells) are taken while the soup is written.
//  3. Disk: one piece's scratch at a time per process ("<piece>.ugvr.cells": its soup and pending node files, about
//     twice the piece's soup at most), removed as the piece finishes. Time: N + 1 passes over the file (the plan's,
//     then one per piece) instead of one: what keeps the scratch to a piece's.
#pragma once
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/mpi/piece_build.h"
#include "ugvr/mpi/piece_index.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct OutOfCorePiecePlan {
  // The split and the frame; cells / ghost_cells are 0 until build_piece_out_of_core has counted a piece (under
  // mpirun each rank counts its own: sum them before writing the index).
  PiecePlan plan;
  std::vector<BrickStoreField> fields;  // the whole mesh's: names, associations, ranges
  uint64_t cells = 0;                   // the mesh's volume cells
  uint64_t split_samples = 0;           // the centroids the tree was built from
  double seconds = 0;
};

// The plan of `pieces` (check_piece_count) pieces of the .vtu at `vtu_path`, streamed within `memory_budget` (the
// sample's point passes take half of it beyond 48 MiB, as the out-of-core build's soup does). `selectors` as
// build_octree_out_of_core takes them. Throws ugvr::Error naming the file, --pieces or --ghost-level.
OutOfCorePiecePlan plan_pieces_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                           int pieces, uint32_t resolution, int ghost_level, uint64_t memory_budget,
                                           const Progress::Observer& observer = {});

// Piece k's store at `path`, out of core within `memory_budget`; sets plan.plan.cells[k] and ghost_cells[k]. Throws
// ugvr::Error (a piece holding no cell names it; options with a preview or a sketch are refused).
OctreeBuildStats build_piece_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors,
                                         OutOfCorePiecePlan& plan, int k, const OctreeBuildOptions& options,
                                         uint64_t memory_budget, const std::string& path);

// The whole partitioned store of `pieces` pieces in this process (what `ugvr view` and `ugvr render` build into their
// cache when one out-of-core build's scratch does not fit the disk: view/scratch_pieces.h): the plan, then every piece
// one after another (one piece's scratch at a time) into piece_folder(index_path), each with its record
// (piece_record.h), a piece whose store and record match this plan's (an interrupted earlier build's) kept as
// `ugvr build --resume` keeps it; then the index at `index_path`, written last (atomically), so an index that exists
// names finished pieces. The same stores and index as `ugvr build VTU --pieces N --out-of-core --ghost-level L` with
// `options`. `progress`: (what, fraction of the whole build), the plan's pass counted as one piece's; an exception it
// throws stops the build (a piece under way leaves nothing). `warn`: called with what a piece's build noted ("piece 3
// of 8: " and OctreeBuildStats::boundary_note: its store leaves out the exact boundary, whose triangles need more than
// half of the budget). Throws ugvr::Error as the steps do.
using BuildWarning = std::function<void(const std::string&)>;
PieceIndex build_index_out_of_core(const std::string& vtu_path, std::span<const std::string> selectors, int pieces,
                                   int ghost_level, OctreeBuildOptions options, uint64_t memory_budget,
                                   const std::string& index_path, const Progress::Observer& progress = {},
                                   const BuildWarning& warn = {});

}  // namespace ugvr
