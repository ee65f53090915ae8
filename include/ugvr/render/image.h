// Rendered images. An Image holds float RGBA pixels, row 0 at the TOP (as CameraRays numbers them), row-major,
// 4 floats per pixel. Values are final: the volume composited over the background, straight (not premultiplied)
// colour in [0, 1], linear (no gamma: VTK and ParaView write their colour maps' values unchanged, and so do we, so
// images compare directly). Alpha is 1 - (1 - A_volume) * (1 - A_background).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ugvr {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgba;

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgba(size_t(w) * size_t(h) * 4, 0.0f) {}
  float* pixel(int x, int y) { return rgba.data() + (size_t(y) * size_t(width) + size_t(x)) * 4; }
  const float* pixel(int x, int y) const { return rgba.data() + (size_t(y) * size_t(width) + size_t(x)) * 4; }
  bool operator==(const Image&) const = default;
};

// Writes a ray's result into pixel `px` (4 floats): premultiplied `radiance` with `transmittance` left, composited over
// the straight-colour `background` as described above. Every engine ends its rays here, so their images compare.
void composite_pixel(float* px, const double radiance[3], double transmittance,
                     const std::array<double, 4>& background);

// 8-bit PNG (libpng): RGB when every alpha is 1, RGBA otherwise; values clamped to [0, 1] and rounded. Written to a
// temporary file and renamed. Throws ugvr::Error naming the path.
void write_png(const std::string& path, const Image& image);
// The same PNG in memory (the browser viewer streams it); `source` names the image in errors.
std::vector<unsigned char> png_bytes(const Image& image, std::string_view source = "image");
// Reads an 8-bit RGB/RGBA/gray PNG into an Image (values / 255, alpha 1 when absent). Throws ugvr::Error.
Image read_png(const std::string& path);

// Portable float map: "PF" (3 channels, RGB), little-endian (scale -1), rows stored bottom to top as the format
// requires. Alpha is not stored. Written atomically.
void write_pfm(const std::string& path, const Image& image);
// Reads "PF" (RGB) or "Pf" (gray, copied to RGB) of either byte order; alpha = 1. Throws ugvr::Error naming the file
// and offset for malformed headers or short data.
Image read_pfm(const std::string& path);

// Writes PNG or PFM by the path's extension (.png / .pfm); throws for any other extension.
void write_image(const std::string& path, const Image& image);

// Differences over the RGB channels (alpha ignored); both images must have the same size (throws otherwise).
struct ImageDifference {
  double rms = 0;      // sqrt(mean of squared channel differences)
  double max_abs = 0;  // largest channel difference
  double psnr_db = 0;  // 10 log10(1 / mse), peak 1; +infinity for identical images
};
ImageDifference compare_images(const Image& a, const Image& b);
// Mean SSIM of the luminance (0.2126 R + 0.7152 G + 0.0722 B), 8x8 windows with stride 4, constants of Wang et al.
// 2004 for a dynamic range of 1. 1 for identical images.
double ssim(const Image& a, const Image& b);

// `src` magnified or minified to width × height by bilinear interpolation between pixel centres (edges clamped):
// how the time-critical renderer shows a frame it ray cast at a reduced scale. Throws for an empty source or size.
Image resize_bilinear(const Image& src, int width, int height);

}  // namespace ugvr
