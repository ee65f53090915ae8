// The public facade (include/ugvr/ugvr.h) over the library's modules.
#include "ugvr/ugvr.h"

#include <filesystem>

#include "ugvr/api/default_field.h"
#include "ugvr/core/file.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/render/resolve_view.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

namespace {

// `stop` is where a progress callback that returns false says so; the builder polls it as its cancel flag, together
// with the caller's own flag (folded in at each report).
OctreeBuildOptions octree_options(const StoreOptions& o, std::atomic<bool>& stop) {
  OctreeBuildOptions b;
  b.resolution = o.brick;
  b.max_depth = o.max_depth;
  b.error = o.error;
  b.threads = o.threads;
  b.cancel = o.cancel;
  if (o.float32) b.encoding.samples = SampleEncoding::Float32;
  if (o.progress) {
    b.cancel = &stop;
    b.progress = [&o, &stop](const std::string& label, double fraction) {
      if (!o.progress(label, fraction) || (o.cancel && o.cancel->load())) stop = true;
    };
  }
  validate_build_options(b);
  return b;
}

StoreSummary summary_of(const OctreeBuildStats& s, std::vector<std::string> fields, bool out_of_core) {
  StoreSummary out;
  out.fields = std::move(fields);
  out.cells = s.cells, out.nodes = s.nodes, out.leaves = s.leaves, out.bricks = s.bricks;
  out.bytes = s.store_bytes, out.max_level = s.max_level, out.seconds = s.seconds;
  out.out_of_core = out_of_core;
  return out;
}

void check_store_path(const std::string& output) {
  if (extension_lower(output) != ".ugvr") throw Error(output + ": the output must be a .ugvr file");
}

}  // namespace

const char* version() { return UGVR_VERSION; }

namespace {

// In core, recording `inputs` (none for a dataset made in memory) in the store.
StoreSummary build_in_core(const Dataset& dataset, const std::string& output, const StoreOptions& options,
                           const std::vector<std::string>& inputs) {
  check_store_path(output);
  std::atomic<bool> stop{false};
  OctreeBuildOptions b = octree_options(options, stop);
  b.inputs = inputs;
  const OctreeInput input = prepare_octree_input(dataset, options.fields);
  std::vector<std::string> names;
  for (const BrickStoreField& f : input.fields) names.push_back(f.name);
  return summary_of(build_octree(input, b, output), std::move(names), false);
}

}  // namespace

StoreSummary build_store_from_dataset(const Dataset& dataset, const std::string& output, const StoreOptions& options) {
  return build_in_core(dataset, output, options, {});
}

StoreSummary build_store(const std::vector<std::string>& inputs, const std::string& output, const StoreOptions& options,
                         const ReadOptions& read) {
  check_store_path(output);
  const bool vtu = inputs.size() == 1 && extension_lower(inputs[0]) == ".vtu";
  if (options.out_of_core && !vtu) throw Error(inputs.at(0) + ": out of core reads a single .vtu file");
  const bool out_of_core =
      options.out_of_core || (vtu && std::filesystem::file_size(inputs[0]) > options.memory_bytes / 5 * 2);
  if (!out_of_core) return build_in_core(read_dataset(inputs, read), output, options, inputs);
  std::atomic<bool> stop{false};
  OctreeBuildOptions b = octree_options(options, stop);
  b.inputs = inputs;
  const OctreeBuildStats s = build_octree_out_of_core(inputs[0], options.fields, b, options.memory_bytes, output);
  std::vector<std::string> names;
  const BrickStoreReader store(output);
  for (const BrickStoreField& f : store.layout().fields) names.push_back(f.name);
  return summary_of(s, std::move(names), true);
}

namespace {

RendererOptions renderer_options(const RendererConfig& c) {
  RendererOptions r;
  r.engine = c.engine;
  r.interactive = c.interactive;
  r.field = c.field;
  r.gpu = c.gpu;
  r.lod.atlas_budget_bytes = c.gpu_memory_bytes;
  r.lod.step_voxels = c.step_voxels;
  r.time_critical.resting_step_voxels = c.step_voxels;
  r.time_critical.ram_budget_bytes = c.ram_memory_bytes;
  try {
    r.cut = parse_cut_spec(c.cut);
  } catch (const Error& e) {
    throw OptionError("cut", e.what());
  }
  r.progress = c.progress;
  return r;
}

// The factory's OptionError says which option; the message carries it for callers that see ugvr::Error only.
template <class F>
std::unique_ptr<Renderer> naming_options(F&& f) {
  try {
    return f();
  } catch (const OptionError& e) {
    throw OptionError(e.option, e.option + ": " + e.what());
  }
}

}  // namespace

std::unique_ptr<Renderer> open_renderer(const std::vector<std::string>& inputs, const RendererConfig& config,
                                        const ReadOptions& read) {
  return naming_options([&] { return open_renderer_default_field(inputs, read, renderer_options(config)); });
}

std::unique_ptr<Renderer> make_renderer(std::shared_ptr<const Dataset> dataset, const RendererConfig& config) {
  return naming_options([&] {
    RendererOptions o = renderer_options(config);
    if (o.field.empty() && dataset && !dataset->blocks.empty()) {
      const std::vector<std::string> names = default_field_names(dataset->blocks[0], 1);
      if (!names.empty()) o.field = names[0];  // the first that varies, as open_renderer
    }
    return make_renderer(std::make_shared<ExactScene>(std::move(dataset), o.progress), o);
  });
}

FrameRequest default_request(const Renderer& renderer, int width, int height, std::string_view view) {
  FrameRequest r;
  // `ugvr render`'s defaults: auto, its default view framed on what auto leaves visible (render/resolve_view.h).
  ViewChoices choices;
  choices.view = std::string(view);
  ResolvedView resolved = resolve_view(renderer, choices, renderer.field_range());
  r.tf = std::move(resolved.tf);
  r.camera = resolved.camera;
  r.settings.width = width, r.settings.height = height;
  r.settings.field = renderer.field_name();
  r.settings.validate("default_request");
  return r;
}

}  // namespace ugvr
