#include "ugvr/view/background_build.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/octree/input.h"
#include "ugvr/octree/out_of_core.h"

namespace ugvr::view {

namespace {

// An exclusive flock on PATH.lock for as long as it lives; the holder removes the file when done. That leaves a small
// window in which a third viewer locks a new file while a waiting one holds the old one: both may then build, which
// costs time but no store (each writes its own temporary file and renames it into place whole).
class CacheEntryLock {
 public:
  explicit CacheEntryLock(const std::string& store_path) : path_(store_path + ".lock") {
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) fail_in(path_, std::string("cannot open the cache entry's lock file: ") + std::strerror(errno));
  }
  ~CacheEntryLock() {
    if (locked_) ::unlink(path_.c_str());
    if (fd_ >= 0) ::close(fd_);  // releases the lock
  }
  CacheEntryLock(const CacheEntryLock&) = delete;
  CacheEntryLock& operator=(const CacheEntryLock&) = delete;
  bool try_lock() { return locked_ = ::flock(fd_, LOCK_EX | LOCK_NB) == 0; }

 private:
  std::string path_;
  int fd_ = -1;
  bool locked_ = false;
};

}  // namespace

BackgroundBuild::BackgroundBuild(std::shared_ptr<const Dataset> dataset, std::vector<std::string> fields,
                                 OctreeBuildOptions options, std::string path, std::function<void()> before)
    : path_(std::move(path)) {
  options.cancel = &cancel_;
  thread_ = std::thread([this, dataset = std::move(dataset), fields = std::move(fields), options, before]() mutable {
    if (before) before();
    run(std::move(dataset), {}, std::move(fields), options);
  });
}

BackgroundBuild::BackgroundBuild(OutOfCore input, std::vector<std::string> fields, OctreeBuildOptions options,
                                 std::string path, std::function<void()> before)
    : path_(std::move(path)) {
  if (options.preview_depth > 0) {
    options.on_preview = [this, depth = options.preview_depth,
                          then = std::move(options.on_preview)](const std::string& preview) {
      {
        std::lock_guard lock(mutex_);
        state_.preview = preview;
        state_.preview_depth = depth;
        state_.preview_sketch = false;
      }
      if (then) then(preview);
    };
    if (options.point_sketch)
      options.on_sketch = [this, then = std::move(options.on_sketch)](const std::string& sketch, int depth) {
        {
          std::lock_guard lock(mutex_);
          state_.preview = sketch;
          state_.preview_depth = depth;
          state_.preview_sketch = true;
        }
        if (then) then(sketch, depth);
      };
  }
  thread_ = std::thread([this, input = std::move(input), fields = std::move(fields), options, before]() mutable {
    if (before) before();
    run(nullptr, input, std::move(fields), options);
  });
}

BackgroundBuild::BackgroundBuild(Work work, std::string path) : path_(std::move(path)), work_(std::move(work)) {
  thread_ = std::thread([this] { run(nullptr, {}, {}, {}); });
}

BackgroundBuild::~BackgroundBuild() {
  cancel_ = true;
  if (thread_.joinable()) thread_.join();
}

BackgroundBuild::State BackgroundBuild::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

void BackgroundBuild::run(std::shared_ptr<const Dataset> dataset, const OutOfCore& out_of_core,
                          std::vector<std::string> fields, OctreeBuildOptions options) {
  // This build's own progress (not the process-wide observer: another build may run beside it).
  const bool in_core = dataset != nullptr;
  options.progress = [this, in_core](const std::string& label, double fraction) {
    // The out-of-core build takes no cancel flag: it stops here instead, at its next report (the exception unwinds
    // it like its own errors do: its scratch folder and temporary store are removed). Never at a step's final
    // report (fraction 1), which may come from a destructor.
    if (!in_core && cancel_ && fraction < 1) throw Error("octree build cancelled");
    std::lock_guard lock(mutex_);
    state_.label = label;
    state_.fraction = fraction;
  };
  try {
    std::filesystem::create_directories(std::filesystem::path(path_).parent_path());
    CacheEntryLock entry_lock(path_);
    if (!entry_lock.try_lock()) {
      {
        std::lock_guard guard(mutex_);
        state_.label = "waiting for another viewer's build";
      }
      while (!entry_lock.try_lock()) {
        if (cancel_) throw Error("cancelled");
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    }
    if (std::filesystem::exists(path_)) {  // written (renamed into place complete) by the build we waited for
      std::lock_guard guard(mutex_);
      state_.stage = Stage::Done;
      state_.fraction = 1;
      state_.reused = true;
      return;
    }
    if (in_core) {
      const OctreeInput input = prepare_octree_input(*dataset, fields);
      build_octree(input, options, path_);
    } else if (work_) {
      work_(options.progress);
    } else {
      const OctreeBuildStats built =
          build_octree_out_of_core(out_of_core.vtu, fields, options, out_of_core.memory_budget, path_);
      std::lock_guard lock(mutex_);
      state_.note = built.boundary_note;
    }
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
