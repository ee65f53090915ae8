#include "ugvr/mpi/mpi_compositor.h"

#include <mpi.h>

#include <chrono>
#include <cstdlib>
#include <string_view>

#include "ugvr/core/error.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/mpi/mpi_session.h"

#ifdef UGVR_HAVE_ICET
#include <IceT.h>
#include <IceTMPI.h>
#endif

namespace ugvr::mpi {
namespace {

constexpr const char* kNames[] = {"icet-radixk", "icet-bswap", "icet-tree", "direct-send"};

// Direct send: rank r owns rows [r * height / n, (r + 1) * height / n); every rank sends each owner its strip
// (MPI_Alltoallv), each owner blends the n strips in visibility order, rank 0 gathers the blended strips.
std::vector<float> direct_send(const std::vector<float>& image, int width, int height, std::span<const int> order) {
  const int n = size(), me = rank();
  std::vector<int> counts(static_cast<size_t>(n)), displs(static_cast<size_t>(n));
  for (int r = 0; r < n; ++r) {
    const int row0 = int(int64_t(height) * r / n), row1 = int(int64_t(height) * (r + 1) / n);
    counts[size_t(r)] = (row1 - row0) * width * 4;
    displs[size_t(r)] = row0 * width * 4;
  }
  const int mine = counts[size_t(me)];
  // The strips every rank sent me, rank after rank.
  std::vector<float> strips(size_t(mine) * size_t(n));
  std::vector<int> recv_counts(static_cast<size_t>(n), mine), recv_displs(static_cast<size_t>(n));
  for (int r = 0; r < n; ++r) recv_displs[size_t(r)] = r * mine;
  MPI_Alltoallv(image.data(), counts.data(), displs.data(), MPI_FLOAT, strips.data(), recv_counts.data(),
                recv_displs.data(), MPI_FLOAT, MPI_COMM_WORLD);
  std::vector<float> blended(strips.begin() + std::ptrdiff_t(order[0]) * mine,
                             strips.begin() + std::ptrdiff_t(order[0] + 1) * mine);
  for (size_t i = 1; i < order.size(); ++i)
    blend_under(blended, std::span<const float>(strips.data() + size_t(order[i]) * size_t(mine), size_t(mine)));
  std::vector<float> out(me == 0 ? image.size() : 0);
  MPI_Gatherv(blended.data(), mine, MPI_FLOAT, out.data(), counts.data(), displs.data(), MPI_FLOAT, 0, MPI_COMM_WORLD);
  return out;
}

#ifdef UGVR_HAVE_ICET
// One IceT context for the process, made on first use (icetCreateContext is collective).
struct IceTState {
  IceTCommunicator comm = nullptr;
  IceTContext context = nullptr;
  int width = 0, height = 0;
};
IceTState& icet_state() {
  static IceTState s;
  return s;
}

std::vector<float> icet_composite(const std::vector<float>& image, int width, int height, std::span<const int> order,
                                  std::string_view strategy) {
  IceTState& s = icet_state();
  if (!s.context) {
    s.comm = icetCreateMPICommunicator(MPI_COMM_WORLD);
    s.context = icetCreateContext(s.comm);
    icetDiagnostics(ICET_DIAG_ERRORS);
  }
  icetSetContext(s.context);
  if (s.width != width || s.height != height) {
    icetResetTiles();
    icetAddTile(0, 0, width, height, 0);  // one tile, displayed by rank 0
    s.width = width, s.height = height;
  }
  icetSetColorFormat(ICET_IMAGE_COLOR_RGBA_FLOAT);
  icetSetDepthFormat(ICET_IMAGE_DEPTH_NONE);
  icetCompositeMode(ICET_COMPOSITE_MODE_BLEND);  // premultiplied "under", front to back
  icetStrategy(ICET_STRATEGY_SEQUENTIAL);        // one tile: the single-image strategy does the work
  icetSingleImageStrategy(strategy == "icet-bswap"  ? ICET_SINGLE_IMAGE_STRATEGY_BSWAP
                          : strategy == "icet-tree" ? ICET_SINGLE_IMAGE_STRATEGY_TREE
                                                    : ICET_SINGLE_IMAGE_STRATEGY_RADIXK);
  icetEnable(ICET_ORDERED_COMPOSITE);
  icetDisable(ICET_CORRECT_COLORED_BACKGROUND);  // the background is applied once, after compositing
  std::vector<IceTInt> ranks(order.begin(), order.end());
  icetCompositeOrder(ranks.data());
  // No bounding box is set: every rank's image may cover the whole frame (its box projects anywhere). The matrices
  // only serve to project bounds, so identities do.
  const IceTDouble identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const IceTFloat transparent[4] = {0, 0, 0, 0};
  const IceTInt viewport[4] = {0, 0, width, height};
  IceTImage result = icetCompositeImage(image.data(), nullptr, viewport, identity, identity, transparent);
  if (rank() != 0) return {};
  if (icetImageGetNumPixels(result) != IceTSizeType(width) * height)
    fail_in("IceT", "the composited image has " + std::to_string(icetImageGetNumPixels(result)) + " pixels, not " +
                        std::to_string(int64_t(width) * height));
  const IceTFloat* px = icetImageGetColorcf(result);
  return std::vector<float>(px, px + size_t(width) * size_t(height) * 4);
}
#endif

}  // namespace

bool have_icet() {
#ifdef UGVR_HAVE_ICET
  return true;
#else
  return false;
#endif
}

std::string compositor_name() {
  const char* env = std::getenv("UGVR_COMPOSITOR");
  std::string name = env && *env ? env : have_icet() ? "icet-radixk" : "direct-send";
  bool known = false;
  for (const char* n : kNames) known |= name == n;
  if (!known)
    fail_in("UGVR_COMPOSITOR",
            "unknown compositor \"" + name + "\" (valid: icet-radixk, icet-bswap, icet-tree, " + "direct-send)");
  if (name.starts_with("icet") && !have_icet())
    fail_in("UGVR_COMPOSITOR", "\"" + name + "\": this ugvr was built without IceT (docs/mpi.md)");
  return name;
}

std::vector<float> composite(std::vector<float> image, int width, int height, std::span<const int> order,
                             double* seconds) {
  const std::string name = compositor_name();
  if (image.size() != size_t(width) * size_t(height) * 4) fail_in("compositing", "image size does not match");
  if (int(order.size()) != size()) fail_in("compositing", "the order must name every rank once");
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<float> out;
  if (size() == 1) {
    out = std::move(image);
  } else if (name == "direct-send") {
    out = direct_send(image, width, height, order);
  } else {
#ifdef UGVR_HAVE_ICET
    out = icet_composite(image, width, height, order, name);
#endif
  }
  if (seconds) *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace ugvr::mpi
