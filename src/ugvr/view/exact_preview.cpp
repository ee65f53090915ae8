#include "ugvr/view/exact_preview.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace ugvr::view {

namespace {
// Smallest scale while moving: below this the picture says too little to steer by.
constexpr double kMinScale = 0.1;
}  // namespace

ExactPreview::ExactPreview(std::shared_ptr<const Dataset> dataset) : dataset_(std::move(dataset)), engine_(*dataset_) {}

ExactPreview::Frame ExactPreview::render(Tab& tab, const ViewRequest& request, bool resting) {
  if (!bound_ || request.settings.field != field_) {
    engine_.set_field(*dataset_, request.settings.field);
    field_ = request.settings.field;
    bound_ = true;
  }
  const bool full = resting || request.fps <= 0;
  Frame f;
  f.scale = full ? 1.0 : tab.scale;
  RenderSettings rs = request.settings;
  rs.width = std::max(1, int(std::lround(request.width * f.scale)));
  rs.height = std::max(1, int(std::lround(request.height * f.scale)));
  const auto start = std::chrono::steady_clock::now();
  Image image = engine_.render(request.camera, request.tf, rs);
  f.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  f.image = full ? std::move(image) : resize_bilinear(image, request.width, request.height);
  f.converged = full;
  if (!full && f.seconds > 0) {
    // Time grows with the pixel count: scale by the square root of the ratio, damped against timing noise.
    const double ideal = f.scale * std::sqrt((1.0 / request.fps) / f.seconds);
    tab.scale = std::clamp(0.5 * (tab.scale + ideal), kMinScale, 1.0);
  }
  return f;
}

}  // namespace ugvr::view
