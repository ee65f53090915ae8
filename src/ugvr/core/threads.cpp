#include "ugvr/core/threads.h"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>

namespace ugvr {

int worker_threads() {
  const size_t limit = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return int(std::min<size_t>(size_t(tbb::this_task_arena::max_concurrency()), limit));
}

}  // namespace ugvr
