// The viewer's picture of a grid before its brick store exists (`ugvr view MESH` while the store is built): the exact
// CPU engine (render/exact), at a reduced image scale while the view moves so that frames keep coming at about the
// tab's frame-rate target, and at full size once the view rests (that frame is converged: the exact image).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "ugvr/grid/dataset.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/image.h"
#include "ugvr/view/view_request.h"

namespace ugvr::view {

class ExactPreview {
 public:
  // Builds the exact engine's walk mesh (can take seconds for millions of cells). Throws ugvr::Error.
  explicit ExactPreview(std::shared_ptr<const Dataset> dataset);

  // One tab's adaptive image scale.
  struct Tab {
    double scale = 0.5;
  };
  struct Frame {
    Image image;
    bool converged = false;  // full size: the exact image of the request
    double seconds = 0, scale = 1;
  };
  // `resting`: the request is the one the previous frame showed; then the frame is drawn at full size. Binds
  // request.settings.field first (a FieldSet selector; empty: the dataset's first field). Throws ugvr::Error.
  Frame render(Tab& tab, const ViewRequest& request, bool resting);

  Bounds bounds() const { return engine_.bounds(); }

 private:
  std::shared_ptr<const Dataset> dataset_;
  ExactEngine engine_;
  std::string field_;  // selector bound now
  bool bound_ = false;
};

}  // namespace ugvr::view
