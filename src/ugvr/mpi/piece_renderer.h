// Renders a partitioned store (piece_index.h) or some of its pieces: each piece's store with the LOD engine, its rays
// clipped to the piece's kd box (LodEngine::set_clip_box), and the pieces' images blended front to back in the
// kd-tree's visibility order. Without MPI `ugvr render INDEX` draws every piece in one process; under mpirun each rank
// draws its kd subtree's pieces with this renderer and the ranks' images are composited by IceT (mpi_renderer.h).
// Emission-absorption splits exactly at the boxes' faces, so the result is the whole store's image up to the
// sampling shift at each face (docs/mpi.md).
#pragma once
#include <memory>
#include <vector>

#include "ugvr/mpi/piece_index.h"
#include "ugvr/render/renderer.h"
#include "ugvr/render/renderer_factory.h"

namespace ugvr {

// Opens pieces `pieces` of `index` (all when empty) on one GL context (options.gl_context, else one from
// options.gpu). LOD engine only (options.engine "auto" or "lod": OptionError("engine") otherwise), one cut per frame
// (options.interactive: OptionError("fps")). A piece whose store is missing or damaged throws ugvr::Error naming its
// file. Each frame is drawn over a transparent background with early ray termination off, then laid over the
// request's background.
std::unique_ptr<Renderer> open_piece_renderer(const PieceIndex& index, std::vector<int> pieces,
                                              const RendererOptions& options);

}  // namespace ugvr
