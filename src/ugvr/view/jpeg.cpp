#include "ugvr/view/jpeg.h"

#include <turbojpeg.h>

#include <cmath>
#include <cstdint>
#include <string>

#include "ugvr/core/error.h"

namespace ugvr {

std::vector<unsigned char> jpeg_bytes(const Image& image, int quality) {
  if (image.width < 1 || image.height < 1 || image.rgba.size() != size_t(image.width) * size_t(image.height) * 4)
    fail_in("jpeg", "cannot encode an image of " + std::to_string(image.width) + " x " + std::to_string(image.height));
  const size_t pixels = size_t(image.width) * size_t(image.height);
  std::vector<unsigned char> rgb(pixels * 3);
  for (size_t i = 0; i < pixels; ++i)
    for (size_t c = 0; c < 3; ++c) {
      const float v = image.rgba[i * 4 + c];
      rgb[i * 3 + c] = uint8_t(std::lround((v > 0 ? (v < 1 ? v : 1.0f) : 0.0f) * 255.0f));
    }
  tjhandle tj = tjInitCompress();
  if (!tj) fail_in("jpeg", "cannot initialise libturbojpeg");
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const int rc = tjCompress2(tj, rgb.data(), image.width, 0, image.height, TJPF_RGB, &out, &size, TJSAMP_420, quality,
                             TJFLAG_FASTDCT);
  std::vector<unsigned char> bytes;
  std::string message;
  if (rc == 0)
    bytes.assign(out, out + size);
  else
    message = tjGetErrorStr2(tj);
  tjFree(out);
  tjDestroy(tj);
  if (rc != 0) fail_in("jpeg", "cannot encode: " + message);
  return bytes;
}

}  // namespace ugvr
