// When a mesh over the memory budget is built out of core (`ugvr view`, `ugvr render`) and the cache directory's disk
// has too little free space for one whole out-of-core build's scratch (octree/out_of_core.h,
// out_of_core_scratch_floor), the viewer builds a partitioned store instead (`ugvr build --pieces N --out-of-core`,
// docs/mpi.md), one piece's scratch at a time, into the cache, and draws its index. This chooses N.
//
// Decided before anything is read, from the headers' cell count and the fields asked for:
//  - the whole build's need is the builder's floor counted with a vertex field per selector (one when none is named):
//    a vertex field's record is the larger, so this is never below the floor the builder checks;
//  - a piece holds the cells whose bounding box meets its kd box grown by the ghost margin (mpi/piece_build.h), at
//    ghost level 0 two voxels of the root's lattice on every side; without the bounds, the mesh is taken to fill its
//    root cube and the kd split to halve the axes in turn, so a piece holds the product over the axes of
//    (its share of the axis + twice the margin), capped at 1, of the whole;
//  - a margin of kScratchPieceMargin over that for the kd split's balance (by a sample of the centroids) and the
//    mesh's shape.
// N is the least power of two up to kMaxScratchPieces whose piece fits the free space; none: the build is refused as
// before (the builder's check says why and what to do).
#pragma once

#include <cstdint>
#include <string>

namespace ugvr::view {

inline constexpr int kMaxScratchPieces = 64;
// The pieces' ghost level: 0, `ugvr build --pieces`'s default, whose samples are the whole store's at every level.
inline constexpr int kScratchPiecesGhostLevel = 0;
inline constexpr double kScratchPieceMargin = 1.25;

struct ScratchPieces {
  uint64_t whole = 0;      // the whole build's scratch (the builder's floor)
  uint64_t piece = 0;      // one piece's, estimated, for `pieces` (the largest tried when none fits)
  uint64_t available = 0;  // free for scratch
  int pieces = 1;          // 1: the whole build fits; 0: no piece count up to kMaxScratchPieces fits
  // "an out-of-core build of its 20000 cells needs 3.7 MiB of scratch and 1.5 MiB is free in DIR: building 8
  // pieces, one at a time (about 1.2 MiB of scratch each)"; empty when the whole build fits.
  std::string why;
};

// `cells` volume cells (0: unknown, taken to fit), `fields` selected (0: the default one), `resolution` the bricks',
// `available` the bytes free in `folder` (named in `why`).
ScratchPieces pieces_for_scratch(uint64_t cells, size_t fields, uint32_t resolution, uint64_t available,
                                 const std::string& folder);

}  // namespace ugvr::view
