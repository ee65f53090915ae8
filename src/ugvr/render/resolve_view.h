// The transfer function and camera a still render draws with, resolved once the data is open: one set of rules for
// `ugvr render` (src/cli/cmd_render.cpp) and `ugvr.render()` (python/src/module.cpp), which gather the choices from
// flags and keyword arguments, refuse what is wrong there (naming the flag or argument), and call resolve_view.
//
// The rules, in order (docs/first-look.md):
//   Transfer function
//     1. auto (no tf given): made from the field's histogram over `range` if given, else over the field's range
//        (auto_transfer_function: under MPI a collective call, every rank must get here).
//     2. a named or file tf with `range`: rescaled to it.
//     3. a named or file tf without `keep_range`: rescaled to the field's range (left alone when that is not finite:
//        an all-NaN field, whose map would otherwise become NaN itself).
//     4. `keep_range`: the tf's own points, untouched.
//   Opacity unit distance: `unit_distance` if given (a flag, or the preset's own), else auto's own (it depends on its
//   histogram), else default_unit_distance(bounds).
//   Camera
//     1. an explicit camera (a --camera file, camera=), with `view_angle` if given.
//     2. a named view (camera_preset) of the whole domain.
//     3. auto tf: default_camera framed on what the resolved tf leaves visible (render/visible_bounds.h; under MPI a
//        collective call: every rank gets the same camera).
//     4. otherwise default_camera of the whole domain (an explicit tf keeps today's view, bit for bit).
//   view_angle defaults to 30 degrees.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "ugvr/render/camera.h"
#include "ugvr/render/renderer.h"

namespace ugvr {

// What a front end was asked for, before the data is open (validated by the front end).
struct ViewChoices {
  std::optional<Camera> camera;  // an explicit camera
  std::string view;              // a named view (camera_preset's names); empty: none
  std::optional<double> view_angle;
  bool auto_tf = true;
  TransferFunction tf;  // the named or file transfer function; ignored with auto_tf
  std::optional<std::pair<double, double>> range;
  bool keep_range = false;
  std::optional<double> unit_distance;
};

struct ResolvedView {
  TransferFunction tf;
  Camera camera;
};

// The rules above for the renderer's bound field. `field_range` is the range the map is drawn over by default: the
// renderer's, or a time store's step's own.
ResolvedView resolve_view(const Renderer& renderer, const ViewChoices& choices, const FieldRange& field_range);

}  // namespace ugvr
