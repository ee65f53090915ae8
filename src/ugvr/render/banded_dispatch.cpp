#include "ugvr/render/banded_dispatch.h"

#include <epoxy/gl.h>

#include <algorithm>

#include "ugvr/render/renderer.h"

namespace ugvr {

void dispatch_image(int width, int height, int group, int band_origin_location,
                    const std::function<bool()>& keep_going) {
  const GLuint groups_x = GLuint((width + group - 1) / group), groups_y = GLuint((height + group - 1) / group);
  if (!keep_going) {
    glDispatchCompute(groups_x, groups_y, 1);
    return;
  }
  const GLuint band = std::max<GLuint>(1, (groups_y + kMaxInterruptBands - 1) / kMaxInterruptBands);
  for (GLuint y = 0; y < groups_y; y += band) {
    // Asked before each band, the first too: a view that changed before the frame began needs none of it.
    if (!keep_going()) {
      glUniform2i(band_origin_location, 0, 0);
      throw FrameInterrupted();
    }
    glUniform2i(band_origin_location, 0, GLint(y) * group);
    glDispatchCompute(groups_x, std::min(band, groups_y - y), 1);
    glFinish();  // the band is drawn: the next question is asked after it, not after all of them were queued
  }
  glUniform2i(band_origin_location, 0, 0);
}

}  // namespace ugvr
