// Opening data for a first look: the field a renderer shows when the caller names none. Shared by `ugvr render` and
// the public API's open_renderer, so that both show the same field.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "ugvr/render/renderer_factory.h"

namespace ugvr {

// Opens `inputs` as open_renderer (render/renderer_factory.h) does. When options.field is empty and the input is a
// mesh for the exact engine, binds the first field whose range is not constant (default_field_names in
// octree/input.h: vertex IBLANK skipped, the first field when none varies; a vector means its magnitude), the field
// `ugvr build` voxelizes by default: a constant field (PLOT3D Density on the LOX post) draws a blank-looking image.
// A store's renderer makes the same choice among the store's fields itself (lod_renderer.cpp).
std::unique_ptr<Renderer> open_renderer_default_field(const std::vector<std::string>& inputs, const ReadOptions& read,
                                                      RendererOptions options, OpenedInput* opened = nullptr);

}  // namespace ugvr
