#include "ugvr/render/lod/hybrid_select.h"

#include <algorithm>
#include <cmath>

#include "ugvr/render/lod/view_metrics.h"

namespace ugvr {

std::vector<ExactCandidate> exact_candidates(const BrickStoreReader& store, std::span<const uint64_t> cut,
                                             const Camera& camera, int width, int height, const TfNodeErrors& tf) {
  std::vector<ExactCandidate> out;
  if (!store.has_cells()) return out;
  const ViewMetrics view(camera, width, height, store.layout().root);
  for (uint64_t n : cut) {
    if (store.cell_block(n).offset == 0) continue;
    const double e = tf.ready() ? tf.error(n) : std::nan("");
    if (e == 0) continue;
    const double data_error = std::isnan(e) ? 1.0 : e;
    out.push_back({n, view.texel_pixels(store.bounds(n), store.resolution()) * data_error});
  }
  std::sort(out.begin(), out.end(), [](const ExactCandidate& a, const ExactCandidate& b) {
    return a.priority != b.priority ? a.priority > b.priority : a.node < b.node;
  });
  return out;
}

}  // namespace ugvr
