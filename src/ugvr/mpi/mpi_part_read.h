// `mpirun -np N ugvr render MESH --engine exact` for an input read by parts (part_source.h: a .pvtu's piece files,
// an Exodus file's cell ranges): every piece is read once in the job, by one rank, and each rank ends up with only
// the cells that meet its kd box (docs/mpi.md, "Reading only a rank's part"). Other formats are read whole on every
// rank (mpi_renderer.cpp).
//
//  1. Piece k is read by rank k mod N (its owner) and kept: its points' bounds, its cell count, its field names and
//     the centroids of a stride sample of its cells (split_sample_stride of kd_partition.h over the whole mesh's count
//     from the pieces' headers: at most kMaxSplitSamples).
//  2. Bounds and counts are reduced, the samples gathered, and every rank builds the same kd-tree from them
//     (kd_partition.h). Why centroids read by the owners and exchanged, not the pieces' bounds: a tree over pieces is
//     no finer than the pieces, and a rank reading every piece its box meets decodes most of the mesh (compact pieces
//     overlap their neighbours, so a box face meets every piece along it).
//  3. The fields' ranges are taken over each owned piece, whole, and reduced: every piece counts once, so ranks map
//     colours alike and the default field is the one a whole read picks.
//  4. Each owner cuts its pieces to every box they meet (cells_meeting_box: restrict_walk_mesh's test) and sends the
//     cuts to the boxes' ranks in one MPI_Alltoallv (append_block_bytes); a rank lays what it receives out as one
//     block per piece in piece order (the order in which restricting a whole read numbers cells).
// Memory per rank: the owned pieces (dropped one by one as they are cut) and the outgoing cuts, then the outgoing and
// incoming bytes, then the part and its walk mesh (the peak).
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/part_source.h"
#include "ugvr/render/renderer.h"

namespace ugvr::mpi {

struct PartRead {
  // The rank's part: one unstructured block per piece with cells meeting its box, in piece order (the exact engine
  // numbers cells type-major, block-minor: the order restricting a whole read keeps).
  std::shared_ptr<Dataset> dataset;
  std::string source;  // PartSource::kind(): --stats' mpi.read
  KdTree tree;         // the same on every rank; boxes[rank] is this rank's
  Bounds bounds;       // the whole mesh's: the union of every piece's points
  // The default fields (default_field_names's rule over the whole mesh's ranges, at most `max_fields`) and, for each
  // of them and for the selector asked for, the whole mesh's range of the values the exact engine binds (float).
  std::vector<std::string> fields;
  std::map<std::string, FieldRange> ranges;
  uint64_t cells_total = 0;                    // volume cells in all pieces
  uint64_t cells_read = 0;                     // in the pieces this rank owns (decoded from the files)
  uint64_t cells_kept = 0;                     // in its part
  uint32_t pieces_total = 0, pieces_read = 0;  // pieces_read: owned
  uint64_t split_samples = 0;                  // centroids the tree was built from
  double seconds = 0;                          // both passes, the exchanges included
};

// Collective over MPI_COMM_WORLD: every rank must call it with the same arguments (the same source). `selector` may
// be empty (the first default field is bound then). Throws ugvr::Error naming the file at fault (a piece that is not
// unstructured, a piece lacking a field of the first, a rank whose box holds no cells, more than 2 GiB to exchange
// for one rank). A rank failing alone (a piece it cannot read) ends the job through the error's MPI_Abort.
PartRead read_part(const PartSource& source, const std::string& selector, size_t max_fields);

}  // namespace ugvr::mpi
