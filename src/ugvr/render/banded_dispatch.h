// Dispatching a ray caster's compute program over an image, whole or in bands of rows that can be interrupted
// (FrameRequest::keep_going, renderer.h): the viewer's resting frames (full quality, exact cells) take seconds on
// llvmpipe, and a camera move that arrives meanwhile should not wait for them.
//
// The programs (shaders/lod_raycast.comp, exact_walk.comp) add `u_band_origin` (an explicit uniform location, 0 in
// both) to gl_GlobalInvocationID: a band draws its rows of the same image, pixel for pixel what one dispatch draws,
// since no pixel depends on another.
#pragma once

#include <functional>

namespace ugvr {

// At most this many bands, each a whole number of work-group rows: on llvmpipe at 512² a 5 s hybrid frame answers a
// move within about 0.3 s, and a GPU's extra synchronisation (one glFinish a band) is sixteen waits a frame.
inline constexpr int kMaxInterruptBands = 16;

// Dispatches the program in use over width × height pixels in `group` × `group` work groups, the band origin at
// uniform location `band_origin_location`. Without `keep_going`: one dispatch. With it: bands of rows, waiting for each
// (glFinish) and asking keep_going before the next; when it returns false, throws FrameInterrupted (renderer.h) with
// the origin set back to (0, 0). The caller's barriers and timer queries go around the call as around one dispatch.
void dispatch_image(int width, int height, int group, int band_origin_location,
                    const std::function<bool()>& keep_going);

// An engine's keep_going (set_keep_going) for one request's frame, cleared however the frame ends: an engine shared by
// the viewer's tabs must not ask a finished frame's question during the next tab's.
template <class Engine>
class ScopedKeepGoing {
 public:
  ScopedKeepGoing(Engine& engine, const std::function<bool()>& keep_going) : engine_(engine) {
    engine_.set_keep_going(keep_going);
  }
  ~ScopedKeepGoing() { engine_.set_keep_going({}); }
  ScopedKeepGoing(const ScopedKeepGoing&) = delete;
  ScopedKeepGoing& operator=(const ScopedKeepGoing&) = delete;

 private:
  Engine& engine_;
};

}  // namespace ugvr
