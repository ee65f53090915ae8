// Sort-last compositing of the ranks' images over MPI (docs/mpi.md): every rank renders its box of the data into a
// premultiplied RGBA float image of the whole frame; the images are blended front to back in the kd-tree's
// visibility order and the result lands on rank 0.
//
// Algorithms: IceT's ordered blend (Moreland et al.; ParaView's compositor, from Debian's ParaView 5.11 build) with
// its radix-k, binary-swap or tree single-image strategy, or, where ugvr was built without IceT, direct send (each
// rank blends one horizontal strip of the frame from every rank's strip, then rank 0 gathers the strips; Hsu 1993's
// direct-send, as IceT's "direct" strategy does it). UGVR_COMPOSITOR picks one: icet-radixk (the default with
// IceT), icet-bswap, icet-tree, direct-send (the default without).
#pragma once
#include <span>
#include <string>
#include <vector>

namespace ugvr::mpi {

// The algorithm UGVR_COMPOSITOR names (or the default); throws ugvr::Error naming the variable for an unknown one,
// or an IceT one in a build without IceT.
std::string compositor_name();
bool have_icet();

// Collective over MPI_COMM_WORLD. `image`: this rank's premultiplied RGBA (width * height * 4 floats, the same size on
// every rank); `order`: all ranks, front to back. Returns the blended image on rank 0 and an empty vector elsewhere.
// `seconds`, when given, gets this rank's wall time inside the compositor.
std::vector<float> composite(std::vector<float> image, int width, int height, std::span<const int> order,
                             double* seconds = nullptr);

}  // namespace ugvr::mpi
