// `mpirun -np N ugvr render MESH.pvtu --engine exact`: each rank reads only the pieces its kd box needs and keeps
// only the cells that meet the box (docs/mpi.md, "Reading only a rank's part"). Other formats are read whole on
// every rank (mpi_renderer.cpp), as before.
//
// Two passes over the pieces:
//  1. The split. Piece k is read by rank k mod N alone (so every piece once, 1/N of the file per rank), one piece at
//     a time: its points' bounds, its cell count and the centroids of a stride sample of its cells (at most
//     kMaxSplitSamples over the whole mesh, the stride from the pieces' headers). The bounds and counts are reduced,
//     the samples gathered, and every rank builds the same kd-tree from them (kd_partition.h). Why centroids rather
//     than the pieces' bounds alone: a tree over piece bounds can only be as fine as the pieces and, for pieces that
//     are not themselves boxes, balances nothing; the sample gives the cell-balanced tree of a whole read to within
//     sampling error, for the cost of reading each piece once more.
//  2. The part. Each rank reads, one at a time, the pieces whose point bounds meet its closed box, keeps the cells
//     whose bounding boxes meet the box (cells_meeting_box: restrict_walk_mesh's test, so the part is the one
//     restricting the whole mesh would keep) and drops the rest of the piece before reading the next. While a piece
//     is in memory its fields' ranges are taken over all of it, then reduced across ranks: the whole mesh's ranges,
//     so every rank maps colours alike and the default field is the one a whole read picks.
// Peak memory per rank: the part plus one piece (plus the walk mesh built from the part afterwards).
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/render/renderer.h"

namespace ugvr::mpi {

inline constexpr uint64_t kMaxSplitSamples = uint64_t(1) << 18;  // 6 MiB of centroids gathered on every rank

struct PartRead {
  // The rank's part: one unstructured block per piece with cells meeting its box, in piece order (the exact engine
  // numbers cells type-major, block-minor: the order restricting a whole read keeps).
  std::shared_ptr<Dataset> dataset;
  KdTree tree;    // the same on every rank; boxes[rank] is this rank's
  Bounds bounds;  // the whole mesh's: the union of every piece's points
  // The default fields (default_field_names's rule over the whole mesh's ranges, at most `max_fields`) and, for each
  // of them and for the selector asked for, the whole mesh's range of the values the exact engine binds (float).
  std::vector<std::string> fields;
  std::map<std::string, FieldRange> ranges;
  uint64_t cells_total = 0;  // volume cells in all pieces
  uint64_t cells_read = 0;   // in the pieces this rank read in pass 2 (decoded from the files)
  uint64_t cells_kept = 0;   // in its part
  uint32_t pieces_total = 0, pieces_read = 0;
  uint64_t split_samples = 0;  // centroids the tree was built from
  double seconds = 0;          // both passes, the exchanges included
};

// Collective over MPI_COMM_WORLD: every rank must call it with the same arguments. `selector` may be empty (the first
// default field is bound then). Throws ugvr::Error naming the file at fault (a piece that is not unstructured, a
// piece lacking a field of the first, a rank whose box holds no cells).
PartRead read_pvtu_part(const std::string& path, const std::string& selector, size_t max_fields);

}  // namespace ugvr::mpi
