// JPEG encoding of rendered images (libturbojpeg) for the browser viewer's interactive frames: 8-bit RGB, alpha
// dropped (viewer images are composited over an opaque background), 4:2:0 chroma, quality 85 by default. Lossy on
// purpose: a 512² frame is ~20-40 KiB instead of ~300 KiB of PNG, which is what keeps a remote session interactive;
// the converged frame goes out as PNG (image.h png_bytes) instead.
#pragma once

#include <vector>

#include "ugvr/render/image.h"

namespace ugvr {

// Throws ugvr::Error for an empty or inconsistent image, or when libturbojpeg fails.
std::vector<unsigned char> jpeg_bytes(const Image& image, int quality = 85);

}  // namespace ugvr
