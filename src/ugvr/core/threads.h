// How many worker threads parallel work gets: the task arena's concurrency capped by a oneTBB global_control limit
// (`--threads N`). The arena alone reports the machine's cores even under such a limit.
#pragma once

namespace ugvr {

int worker_threads();

}  // namespace ugvr
