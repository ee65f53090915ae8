#include "ugvr/api/default_field.h"

#include <algorithm>

#include "ugvr/octree/input.h"

namespace ugvr {

std::unique_ptr<Renderer> open_renderer_default_field(const std::vector<std::string>& inputs, const ReadOptions& read,
                                                      RendererOptions options, OpenedInput* opened) {
  const std::vector<std::string>& engines = engine_names();
  const bool store = inputs.size() == 1 && is_brick_store(inputs[0]);
  const bool known = std::find(engines.begin(), engines.end(), options.engine) != engines.end();
  // A named field, a store, the lod or hybrid engine or a bad engine name: the factory's own path (and its errors).
  if (!options.field.empty() || store || options.engine == "lod" || options.engine == "hybrid" || !known)
    return open_renderer(inputs, read, options, opened);
  auto dataset = std::make_shared<Dataset>(read_dataset(inputs, read));
  if (opened) opened->warnings = dataset->warnings;
  if (!dataset->blocks.empty()) {
    const std::vector<std::string> names = default_field_names(dataset->blocks[0], 1);
    if (!names.empty()) options.field = names[0];
  }
  return make_renderer(std::make_shared<ExactScene>(std::move(dataset), options.progress), options);
}

}  // namespace ugvr
