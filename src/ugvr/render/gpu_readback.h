// Bringing a ray caster's image back from the GPU: an RGBA32F texture of premultiplied radiance (rgb) and
// transmittance (a) per pixel, as the LOD and the GPU exact engines write it, composited over the background with
// composite_pixel (image.h), the CPU engine's own function.
//
// It goes through a pixel-pack buffer mapped for reading: glGetTextureImage straight into client memory ran at ~1 GB/s
// on an H200 (100 ms of a 110 ms frame at 2048x2048, bench/README.md "GPU"); compositing is spread over the cores.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "ugvr/gpu/gl_program.h"
#include "ugvr/render/image.h"

namespace ugvr {

// `readback` is the caller's buffer, kept between frames (grown when the image grows); `who` names the engine in
// errors. The context must be current and the writes to `texture` made visible (glMemoryBarrier). With `flagged`, the
// pixels (y * width + x, ascending) whose transmittance is negative, a shader's mark for "not drawn here", are listed
// there; their composite is meaningless until the caller draws them.
Image read_back_composited(GlBuffer& readback, const GlTexture& texture, int width, int height,
                           const std::array<double, 4>& background, const char* who,
                           std::vector<uint32_t>* flagged = nullptr);

}  // namespace ugvr
