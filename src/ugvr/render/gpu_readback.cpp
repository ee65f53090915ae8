#include "ugvr/render/gpu_readback.h"

#include <tbb/parallel_for.h>

#include "ugvr/core/error.h"

namespace ugvr {

Image read_back_composited(GlBuffer& readback, const GlTexture& texture, int width, int height,
                           const std::array<double, 4>& background, const char* who, std::vector<uint32_t>* flagged) {
  const size_t pixels = size_t(width) * size_t(height), bytes = pixels * 4 * sizeof(float);
  readback.reserve_readback(bytes);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, readback.id());
  glGetTextureImage(texture.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(bytes), nullptr);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
  const auto* raw =
      static_cast<const float*>(glMapNamedBufferRange(readback.id(), 0, GLsizeiptr(bytes), GL_MAP_READ_BIT));
  check_gl("reading the image back");
  if (!raw) fail_in(who, "mapping the image for reading failed");
  Image image(width, height);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const double radiance[3] = {raw[4 * i], raw[4 * i + 1], raw[4 * i + 2]};
      composite_pixel(image.rgba.data() + 4 * i, radiance, raw[4 * i + 3], background);
    }
  });
  if (flagged) {
    flagged->clear();
    for (size_t i = 0; i < pixels; ++i)
      if (raw[4 * i + 3] < 0) flagged->push_back(uint32_t(i));
  }
  glUnmapNamedBuffer(readback.id());
  return image;
}

}  // namespace ugvr
