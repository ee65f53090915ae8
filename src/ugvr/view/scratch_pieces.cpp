#include "ugvr/view/scratch_pieces.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "ugvr/core/memory.h"
#include "ugvr/octree/out_of_core.h"

namespace ugvr::view {
namespace {

// The share of the whole mesh's cells a piece of `pieces` holds (see the header): the root cube's axes halved in
// turn, each box grown by twice the margin of ghost level 0 (2 / (R - 1) of the root's side on each side).
double held_share(int pieces, uint32_t resolution) {
  const double margin = 2.0 / double(resolution - 1);
  const int splits = std::countr_zero(unsigned(pieces));
  double share = 1;
  for (int axis = 0; axis < 3; ++axis) {
    const int halvings = splits / 3 + (axis < splits % 3 ? 1 : 0);
    share *= std::min(1.0, std::ldexp(1.0, -halvings) + 2 * margin);
  }
  return share;
}

}  // namespace

ScratchPieces pieces_for_scratch(uint64_t cells, size_t fields, uint32_t resolution, uint64_t available,
                                 const std::string& folder) {
  ScratchPieces out;
  out.available = available;
  SoupLayout layout;
  layout.vertex_fields = uint32_t(std::max<size_t>(fields, 1));
  out.whole = out_of_core_scratch_floor(cells, layout);
  out.piece = out.whole;
  if (out.whole <= available) return out;
  out.pieces = 0;
  for (int n = 2; n <= kMaxScratchPieces; n *= 2) {
    out.piece = uint64_t(std::ceil(double(out.whole) * held_share(n, resolution) * kScratchPieceMargin));
    if (out.piece <= available) {
      out.pieces = n;
      break;
    }
  }
  const std::string need = "an out-of-core build of its " + std::to_string(cells) + " cells needs " +
                           format_bytes(out.whole) + " of scratch and " + format_bytes(available) + " is free in " +
                           folder;
  if (out.pieces > 0)
    out.why = "not enough scratch for one build (" + need + "): building " + std::to_string(out.pieces) +
              " pieces, one at a time (about " + format_bytes(out.piece) + " of scratch each)";
  return out;
}

}  // namespace ugvr::view
