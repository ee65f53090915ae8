// Run under mpirun by tests/mpi/test_mpi_frame_stop.cpp: drives the compositing renderer (mpi_renderer.h) directly,
// with a keep_going on rank 0 that the test chooses per frame, which the `ugvr` command line cannot do. Every rank
// draws the same frames in the same order and writes what happened to each into OUT_DIR/rank<R>.json:
//   whole            no keep_going: the reference image
//   stop_first       rank 0's first question says stop
//   after_stop       every question says go on (the next frame after an interrupted one)
//   slow_done        rank 1 starts its part 1 s late (UGVR_MPI_SLOW_RANK); every question says go on
//   slow_stop        rank 1 starts its part 60 s late; rank 0's question says stop 0.5 s into the frame, long after
//                    its own part is drawn
//   after_slow_stop  every question says go on
// For each: interrupted, seconds, questions (rank 0's), and on rank 0 whether the image is the reference's bit for bit.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "ugvr/mpi/mpi_renderer.h"
#include "ugvr/mpi/mpi_session.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/transfer_function.h"

namespace {

using Clock = std::chrono::steady_clock;
namespace um = ugvr::mpi;

struct Probe {
  ugvr::Renderer& renderer;
  ugvr::FrameRequest base;
  ugvr::Image whole;
  nlohmann::json out;

  // `answer(question number, seconds into the frame)`: rank 0's question; empty: a frame without keep_going.
  void frame(const std::string& name, const std::function<bool(int, double)>& answer) {
    ugvr::FrameRequest request = base;
    std::atomic<int> questions{0};
    const Clock::time_point start = Clock::now();
    if (answer) {
      if (um::rank() == 0)
        request.keep_going = [&] {
          const int n = ++questions;
          return answer(n, std::chrono::duration<double>(Clock::now() - start).count());
        };
      else
        request.keep_going = [] { return true; };  // the flag: rank 0 decides
    }
    nlohmann::json& o = out[name];
    o["interrupted"] = false;
    try {
      ugvr::Frame f = renderer.render(request);
      if (um::rank() == 0) {
        if (name == "whole") whole = f.image;
        o["same_as_whole"] = f.image == whole;
      }
    } catch (const ugvr::FrameInterrupted&) {
      o["interrupted"] = true;
    }
    o["seconds"] = std::chrono::duration<double>(Clock::now() - start).count();
    o["questions"] = questions.load();
  }
};

int run(const std::string& mesh, const std::string& out_dir) {
  ugvr::RendererOptions options;
  options.engine = "exact";
  auto renderer = um::open_renderer({mesh}, ugvr::ReadOptions{}, options);
  const ugvr::FieldRange range = renderer->field_range();
  ugvr::FrameRequest base;
  base.camera = ugvr::default_camera(renderer->bounds());
  base.tf = ugvr::default_transfer_function(range.min, range.max, renderer->bounds());
  base.settings.width = base.settings.height = 48;
  base.full_quality = true;  // a resting frame, as the viewer asks for it
  Probe p{*renderer, base, {}, {}};
  const auto go_on = [](int, double) { return true; };
  p.frame("whole", {});
  p.frame("stop_first", [](int n, double) { return n > 1; });
  p.frame("after_stop", go_on);
  setenv("UGVR_MPI_SLOW_RANK", "1:1", 1);
  p.frame("slow_done", go_on);
  setenv("UGVR_MPI_SLOW_RANK", "1:60", 1);
  p.frame("slow_stop", [](int, double seconds) { return seconds < 0.5; });
  unsetenv("UGVR_MPI_SLOW_RANK");
  p.frame("after_slow_stop", go_on);
  std::ofstream(out_dir + "/rank" + std::to_string(um::rank()) + ".json") << p.out.dump(1);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  um::init(&argc, &argv);
  if (argc != 3) {
    std::fprintf(stderr, "usage: mpirun -np N %s MESH OUT_DIR\n", argv[0]);
    um::abort_job("bad arguments", 2);
  }
  int code = 0;
  try {
    code = run(argv[1], argv[2]);
  } catch (const std::exception& e) {
    um::abort_job(e.what(), 1);  // the other ranks may be inside a collective
  }
  um::finalize();
  return code;
}
