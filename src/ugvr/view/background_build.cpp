#include "ugvr/view/background_build.h"

#include <filesystem>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/octree/input.h"

namespace ugvr::view {

BackgroundBuild::BackgroundBuild(std::shared_ptr<const Dataset> dataset, std::vector<std::string> fields,
                                 OctreeBuildOptions options, std::string path, std::function<void()> before)
    : path_(std::move(path)) {
  options.cancel = &cancel_;
  thread_ = std::thread([this, dataset = std::move(dataset), fields = std::move(fields), options, before]() mutable {
    if (before) before();
    run(std::move(dataset), std::move(fields), options);
  });
}

BackgroundBuild::~BackgroundBuild() {
  cancel_ = true;
  if (thread_.joinable()) thread_.join();
}

BackgroundBuild::State BackgroundBuild::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

void BackgroundBuild::run(std::shared_ptr<const Dataset> dataset, std::vector<std::string> fields,
                          OctreeBuildOptions options) {
  // This build's own progress (not the process-wide observer: another build may run beside it).
  options.progress = [this](const std::string& label, double fraction) {
    std::lock_guard lock(mutex_);
    state_.label = label;
    state_.fraction = fraction;
  };
  try {
    std::filesystem::create_directories(std::filesystem::path(path_).parent_path());
    const OctreeInput input = prepare_octree_input(*dataset, fields);
    build_octree(input, options, path_);
    std::lock_guard lock(mutex_);
    state_.stage = Stage::Done;
    state_.fraction = 1;
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    state_.stage = Stage::Failed;
    state_.error = e.what();
  }
}

}  // namespace ugvr::view
