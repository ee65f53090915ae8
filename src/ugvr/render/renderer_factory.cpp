#include "ugvr/render/renderer_factory.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "ugvr/store/brick_store_format.h"

namespace ugvr {

namespace {

// Runs f; an ugvr::Error it throws becomes an OptionError naming `option`.
template <class F>
auto for_option(const std::string& option, F&& f) {
  try {
    return f();
  } catch (const OptionError&) {
    throw;
  } catch (const Error& e) {
    throw OptionError(option, e.what());
  }
}

template <class R>
std::unique_ptr<Renderer> bound(std::unique_ptr<R> r, const RendererOptions& options) {
  if (!options.field.empty()) for_option("field", [&] { r->set_field(options.field); });
  return r;
}

}  // namespace

const std::vector<std::string>& engine_names() {
  static const std::vector<std::string> names = {"auto", "exact", "lod", "hybrid"};
  return names;
}

bool is_brick_store(const std::string& path) {
  if (std::filesystem::path(path).extension() == ".ugvr") return true;
  // A build's coarse preview or point sketch ("<output>.preview", "<output>.sketch") by its signature.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  char head[sizeof store_format::kMagic] = {};
  return in.read(head, sizeof head) && std::memcmp(head, store_format::kMagic, sizeof head) == 0;
}

const std::vector<std::string>& device_names() {
  static const std::vector<std::string> names = {"auto", "cpu", "gpu"};
  return names;
}

std::unique_ptr<Renderer> make_renderer(std::shared_ptr<ExactScene> scene, const RendererOptions& options) {
  const std::string& device = options.device;
  const std::vector<std::string>& names = device_names();
  if (std::find(names.begin(), names.end(), device) == names.end())
    throw OptionError("device", "unknown device \"" + device + "\" (valid: auto, cpu, gpu)");
  // The caller's GL context, else one opened on the device `gpu` names.
  auto context = [&]() -> std::shared_ptr<const GlContext> {
    return options.gl_context ? options.gl_context : std::make_shared<GlContext>(options.gpu);
  };
  bool on_gpu = false;
  if (device != "cpu") {
    if (scene->gpu_engine) {
      on_gpu = true;
    } else if (device == "gpu") {
      auto gl = for_option("gpu", context);
      for_option("device", [&] { return &scene->gpu(std::move(gl), options.exact_gpu); });
      on_gpu = true;
    } else if (scene->gpu_unavailable.empty()) {
      // auto: a hardware GPU that holds the mesh, else the CPU engine (ExactScene::use_gpu_if_it_pays).
      try {
        on_gpu = scene->use_gpu_if_it_pays(context(), options.exact_gpu);
      } catch (const Error& e) {
        scene->gpu_unavailable = e.what();  // no GL context at all
      }
    }
  }
  return bound(std::make_unique<ExactRenderer>(std::move(scene), on_gpu), options);
}

std::unique_ptr<Renderer> make_renderer(std::shared_ptr<LodScene> scene, const RendererOptions& options) {
  if (options.interactive)
    return bound(std::make_unique<InteractiveLodRenderer>(std::move(scene), options.time_critical), options);
  return bound(std::make_unique<LodRenderer>(std::move(scene), options.cut), options);
}

std::unique_ptr<Renderer> open_renderer(const std::vector<std::string>& inputs, const ReadOptions& read,
                                        const RendererOptions& options, OpenedInput* opened) {
  const std::vector<std::string>& names = engine_names();
  if (std::find(names.begin(), names.end(), options.engine) == names.end()) {
    std::string valid;
    for (const std::string& n : names) valid += (valid.empty() ? "" : ", ") + n;
    throw OptionError("engine", "unknown engine \"" + options.engine + "\" (valid: " + valid + ")");
  }
  const bool store = inputs.size() == 1 && is_brick_store(inputs[0]);
  const bool hybrid = options.engine == "hybrid";
  const bool lod = options.engine == "lod" || hybrid || (options.engine == "auto" && store);
  if (!lod && store) throw OptionError("engine", "a brick store (.ugvr) renders with the lod or hybrid engine");
  if (lod) {
    if (!store)
      throw OptionError("engine", "the " + options.engine +
                                      " engine renders one brick store (.ugvr, made by `ugvr build`" +
                                      (hybrid ? " --cells)" : ")"));
    auto gl = for_option("gpu", [&] { return std::make_shared<GlContext>(options.gpu); });
    LodOptions lo = options.lod;
    // hybrid: the LOD engine drawing exact cells where the store keeps them (docs/hybrid.md).
    if (hybrid) lo.hybrid = true;
    return make_renderer(std::make_shared<LodScene>(inputs[0], std::move(gl), lo), options);
  }
  auto dataset = std::make_shared<Dataset>(read_dataset(inputs, read));
  if (opened) opened->warnings = dataset->warnings;
  return make_renderer(std::make_shared<ExactScene>(std::move(dataset), options.progress), options);
}

}  // namespace ugvr
