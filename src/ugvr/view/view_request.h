// One browser tab's requested view, built up from its client messages (view_protocol.h): always the LATEST request,
// never a queue. The I/O thread applies messages (under the server's lock); the render thread copies `request` when
// it renders a frame.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/view/view_protocol.h"

namespace ugvr::view {

// What the render thread draws for a tab. settings.field names the field (empty: the scene's current one).
struct ViewRequest {
  int width = 512, height = 512;
  Camera camera;
  TransferFunction tf;
  RenderSettings settings;
  double fps = 10;
  double step_voxels = 0.5;
  std::string engine;  // the engine the tab picked ("engine" message); empty: the scene's (SceneInfo::engine)
  // The series' step to show ("time" message; none: the scene's, SceneInfo::time_step), and whether the page plays
  // (the next step is read ahead).
  std::optional<uint32_t> time_step;
  bool playing = false;
  // The degree of interest ("interest" message; LodOptions' focus, roi, context_*): the store's engines draw with it.
  std::vector<FocusRange> focus;
  std::optional<RegionOfInterest> roi;
  double context_saturation = 0.2, context_opacity = 0.3;
  bool operator==(const ViewRequest&) const = default;
};

struct ViewState {
  ViewRequest request;
  bool ready = false;         // said hello
  bool full_quality = false;  // asked for one converged frame now
  uint64_t generation = 0;    // accepted messages so far (FrameStatus.request)
  // The generation of the last message that changed what is drawn (the request, hello, a full-quality ask). A
  // message that changes nothing (a repeated camera, the same step again) counts in `generation` but draws no frame:
  // the server acknowledges it instead (view_protocol.h, "ack").
  uint64_t changed = 0;
  // Transfer-function edits compose: a preset, then explicit points, then the opacity scale.
  std::string tf_preset = "viridis";
  double tf_opacity = 1;
  std::vector<ColorPoint> tf_colors;
  std::vector<OpacityPoint> tf_opacities;
  double unit_distance = 0;  // opacity unit distance; <= 0: a hundredth of the bounds' diagonal
};

// The state of a new tab: the scene's camera, field, preset and fps target.
ViewState initial_view(const SceneInfo& scene);
// The transfer function `state` asks for, over the field's range.
TransferFunction compose_tf(const ViewState& state, const SceneInfo& scene);
// Applies one message. A settings "field" must name one of scene.fields; switching to another field drops explicit
// transfer-function points (the preset is rescaled to the new range) and moves iso values outside the new range to
// its middle. An engine must be one of scene.engines; a time step one of scene.times. Throws ugvr::Error "FIELD: ..."
// and leaves `state` unchanged when the result is invalid. Every accepted message advances `generation`; one that
// changes the request (or says hello, or asks for full quality) also sets `changed` to it.
void apply_message(ViewState& state, const ClientMessage& message, const SceneInfo& scene);

}  // namespace ugvr::view
