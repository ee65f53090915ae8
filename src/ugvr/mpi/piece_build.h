// `ugvr build INPUT -o OUT.json --pieces N` (docs/mpi.md, "Partitioned stores"): a kd-tree splits the mesh's cells
// (by centroid, balanced by count: kd_partition.h) into N boxes, and each piece is an ordinary brick store of its box,
// built by the in-core builder (octree/builder.h) from the cells that meet the box grown by the ghost margin. The same
// pieces out of core, the mesh never held: piece_build_ooc.h (plan_frame and piece_holds are the rules both share).
//
// What makes a piece's samples inside its box those of the whole-mesh store:
//  - the same lattice: every piece's root cube and recorded bounds are the whole mesh's (OctreeInput::bounds);
//  - the same split thresholds and quantisation: every piece records the whole mesh's field ranges;
//  - the ghost layer: a piece holds every cell whose bounding box meets its box grown by
//    ghost_margin = 2 × (root side) / (R − 1), two voxels of the root's lattice (the coarsest). A ray sample in the
//    closed box reads the 8 lattice points of its voxel (within one voxel of the box, at any level), and the padding
//    that fills a lattice point without data reads its 26 neighbours (one voxel more); the root's voxel is the largest.
//    A point within the margin lies only in cells whose bounding box meets the grown box, all of which the piece
//    holds, in their original order (the sampler takes the lowest id among the cells containing a point), so its
//    sample and validity are the whole store's bit for bit, at every level. (The sampler counts a point within 1e-8
//    of a cell's parametric domain as inside it; only at the margin's very edge could a cell left out claim one.)
//  - boundary faces: the piece's boundary is the mesh's inside the grown box plus the ghost layer's outer faces,
//    which lie outside the grown box (a cell left out has a bounding box missing it), so no ray clipped to the box
//    crosses one; the shader's inside/outside rule sees a valid mesh's boundary either way.
// `ghost_level` L > 0 trades exactness at the coarse levels for fewer ghost cells: the margin becomes two voxels of
// level L (2 × side / ((R − 1) 2^L)), so samples are the whole store's at levels >= L only; a coarser node the cut
// picks near a box face then reads padding where the whole store has data (a seam at the face, at that level).
// Where a piece's tree may differ from the whole store's: a node larger than the margin that crosses the grown box's
// faces (level <= 3 for R = 32) sees only the piece's cells, so its split test and error may differ, and so may the
// cut that picks it. Nodes that lie inside the grown box are the whole store's.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/piece_index.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"

namespace ugvr {

struct PiecePlan {
  KdTree tree;          // boxes = the pieces' kd cells
  Bounds bounds, root;  // the whole mesh's
  double ghost_margin = 0;
  int ghost_level = 0;  // the coarsest level whose samples inside a box are the whole store's
  // Per piece: cells whose centroid lies in the box (each cell in exactly one piece), and the cells held beyond those.
  std::vector<uint64_t> cells, ghost_cells;
};

// The kd split of input's cells into `pieces` (a power of two, check_piece_count) and every piece's cell counts.
// ghost_level in [0, kMaxOctreeLevel] (above). Throws ugvr::Error naming --pieces or --ghost-level.
// `tree` given (with `pieces` boxes): that split instead of one over every centroid; an out-of-core plan's, built
// from a sample (piece_build_ooc.h), so that an in-core build of the same plan can be compared with it.
PiecePlan plan_pieces(const OctreeInput& input, int pieces, uint32_t resolution, int ghost_level = 0,
                      const KdTree* tree = nullptr);

// A plan's frame without its split or counts: the whole mesh's bounds and root, and the ghost margin of
// `ghost_level` (checked as plan_pieces checks it).
PiecePlan plan_frame(const Bounds& bounds, uint32_t resolution, int ghost_level);

// Whether piece k holds a cell with bounding box `cell` (of its float32 vertices, in double): the box grown by the
// ghost margin meets piece k's closed box. The one rule of piece_cells and of the out-of-core pieces.
bool piece_holds(const PiecePlan& plan, int k, const Bounds& cell);

// Piece k's cells (in id order): those whose bounding box meets its box grown by the ghost margin.
std::vector<uint64_t> piece_cells(const OctreeInput& input, const PiecePlan& plan, int k);

// Builds piece k's store at `path` (atomically), with options as for build_octree. Throws ugvr::Error.
OctreeBuildStats build_piece(const OctreeInput& input, const PiecePlan& plan, int k, const OctreeBuildOptions& options,
                             const std::string& path);

// The piece stores' names for an index at `index_path` ("DIR/NAME.json" -> "NAME.d/piece-K.ugvr", relative to DIR),
// and the folder they go in (created by the caller).
std::string piece_store_name(const std::string& index_path, int k);
std::string piece_folder(const std::string& index_path);

// The index of a plan whose stores have been written (their sizes are read from the files); `fields` the whole
// mesh's (names, associations, ranges).
PieceIndex make_piece_index(const OctreeInput& input, const PiecePlan& plan, const std::string& index_path,
                            uint32_t resolution);
PieceIndex make_piece_index(const std::vector<BrickStoreField>& fields, const PiecePlan& plan,
                            const std::string& index_path, uint32_t resolution);

}  // namespace ugvr
