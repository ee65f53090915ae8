// Image files and image comparison: PNG (libpng) and PFM round trips, malformed files, RMS / PSNR / SSIM.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/render/image.h"

namespace ugvr {
namespace {

using test::error_of;

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A gradient with a distinct value in every channel of every pixel, so a transposed or flipped image shows.
Image gradient(int w, int h, float alpha = 1.0f) {
  Image im(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float* p = im.pixel(x, y);
      p[0] = float(x) / float(w);
      p[1] = float(y) / float(h);
      p[2] = float(x + 2 * y) / float(w + 2 * h);
      p[3] = alpha;
    }
  }
  return im;
}

Image constant(int w, int h, float v) {
  Image im(w, h);
  for (size_t i = 0; i < im.rgba.size(); ++i) im.rgba[i] = (i % 4 == 3) ? 1.0f : v;
  return im;
}

// PNG colour type byte of the IHDR chunk: 2 = RGB, 6 = RGBA.
int png_color_type(const std::string& path) { return (unsigned char)read_bytes(path).at(25); }

TEST(Image, PngRoundTripRgb) {
  test::ScratchDir dir;
  const Image im = gradient(37, 23);
  write_png(dir.file("a.png"), im);
  EXPECT_EQ(png_color_type(dir.file("a.png")), 2);
  const Image back = read_png(dir.file("a.png"));
  ASSERT_EQ(back.width, 37);
  ASSERT_EQ(back.height, 23);
  for (size_t i = 0; i < im.rgba.size(); ++i) EXPECT_NEAR(back.rgba[i], im.rgba[i], 0.5 / 255 + 1e-6) << i;
}

TEST(Image, PngRoundTripRgbaWhenAnyAlphaBelowOne) {
  test::ScratchDir dir;
  Image im = gradient(16, 9);
  im.pixel(3, 4)[3] = 0.25f;
  write_png(dir.file("a.png"), im);
  EXPECT_EQ(png_color_type(dir.file("a.png")), 6);
  const Image back = read_png(dir.file("a.png"));
  for (size_t i = 0; i < im.rgba.size(); ++i) EXPECT_NEAR(back.rgba[i], im.rgba[i], 0.5 / 255 + 1e-6) << i;
}

TEST(Image, PngClampsOutOfRangeValues) {
  test::ScratchDir dir;
  Image im = constant(2, 2, 0.5f);
  im.pixel(0, 0)[0] = 2.0f;
  im.pixel(1, 0)[1] = -1.0f;
  im.pixel(0, 1)[2] = std::numeric_limits<float>::quiet_NaN();
  write_png(dir.file("c.png"), im);
  const Image back = read_png(dir.file("c.png"));
  EXPECT_EQ(back.pixel(0, 0)[0], 1.0f);
  EXPECT_EQ(back.pixel(1, 0)[1], 0.0f);
  EXPECT_EQ(back.pixel(0, 1)[2], 0.0f);
}

TEST(Image, PngErrorsNameTheFile) {
  test::ScratchDir dir;
  write_bytes(dir.file("not.png"), "hello, this is not a png");
  EXPECT_NE(error_of([&] { read_png(dir.file("not.png")); }).find("not.png"), std::string::npos);
  // A valid PNG cut in half: the signature passes, the data ends early.
  write_png(dir.file("full.png"), gradient(64, 64));
  const std::string bytes = read_bytes(dir.file("full.png"));
  write_bytes(dir.file("cut.png"), bytes.substr(0, bytes.size() / 2));
  const std::string e = error_of([&] { read_png(dir.file("cut.png")); });
  EXPECT_NE(e.find("cut.png"), std::string::npos) << e;
  EXPECT_NE(error_of([&] { write_png(dir.file("nodir/x.png"), gradient(2, 2)); }).find("x.png"), std::string::npos);
  EXPECT_NE(error_of([&] { write_png(dir.file("empty.png"), Image()); }).find("empty.png"), std::string::npos);
}

TEST(Image, PfmRoundTripIsExact) {
  test::ScratchDir dir;
  Image im = gradient(13, 7);
  im.pixel(1, 2)[0] = 12.5f;  // HDR values and negatives survive a float map
  im.pixel(2, 1)[1] = -3.25f;
  write_pfm(dir.file("a.pfm"), im);
  const std::string bytes = read_bytes(dir.file("a.pfm"));
  ASSERT_EQ(bytes.substr(0, 3), "PF\n");
  const Image back = read_pfm(dir.file("a.pfm"));
  EXPECT_EQ(back, im);  // alpha 1 in both
}

TEST(Image, PfmRowsAreStoredBottomToTopLittleEndian) {
  test::ScratchDir dir;
  Image im(1, 2);
  im.pixel(0, 0)[0] = 1.0f;  // top
  im.pixel(0, 1)[0] = 2.0f;  // bottom
  im.pixel(0, 0)[3] = im.pixel(0, 1)[3] = 1.0f;
  write_pfm(dir.file("r.pfm"), im);
  const std::string bytes = read_bytes(dir.file("r.pfm"));
  const std::string header = "PF\n1 2\n-1.0\n";
  ASSERT_EQ(bytes.size(), header.size() + 24);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  float first = 0;
  std::memcpy(&first, bytes.data() + header.size(), 4);  // the test host is little-endian
  EXPECT_EQ(first, 2.0f);
}

TEST(Image, PfmReadsBigEndianAndGray) {
  test::ScratchDir dir;
  // Big-endian gray 2 x 1: 0.5 then 0.25 (0x3f000000, 0x3e800000).
  const std::string header = "Pf\n2 1\n1.0\n";
  write_bytes(dir.file("g.pfm"), header + std::string("\x3f\x00\x00\x00\x3e\x80\x00\x00", 8));
  const Image im = read_pfm(dir.file("g.pfm"));
  ASSERT_EQ(im.width, 2);
  ASSERT_EQ(im.height, 1);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(im.pixel(0, 0)[c], 0.5f);
    EXPECT_EQ(im.pixel(1, 0)[c], 0.25f);
  }
  EXPECT_EQ(im.pixel(0, 0)[3], 1.0f);
}

TEST(Image, MalformedPfmErrorsNameFileAndOffset) {
  test::ScratchDir dir;
  const std::string path = dir.file("bad.pfm");
  auto error_for = [&](const std::string& bytes) {
    write_bytes(path, bytes);
    return error_of([&] { read_pfm(path); });
  };
  auto expect = [&](const std::string& bytes, const std::string& where, const std::string& what) {
    const std::string e = error_for(bytes);
    EXPECT_NE(e.find("bad.pfm"), std::string::npos) << e;
    EXPECT_NE(e.find(where), std::string::npos) << e;
    EXPECT_NE(e.find(what), std::string::npos) << e;
  };
  const std::string pixel(12, '\0');
  expect("P6\n1 1\n255\n" + pixel, "byte 0", "not a PFM");
  expect("PF\nx 1\n-1\n" + pixel, "byte 3", "width");
  expect("PF\n1 0\n-1\n" + pixel, "byte 5", "height");
  expect("PF\n1 1\n0\n" + pixel, "byte 7", "scale");
  expect("PF\n1 1\nabc\n" + pixel, "byte 7", "scale");
  expect("PF\n1 1", "", "header ends");
  expect("", "", "header ends");
  // Short data: 2 x 2 RGB needs 48 bytes.
  expect("PF\n2 2\n-1\n" + pixel, "byte 10", "pixel");
  expect("PF\n1 1\n-1\n" + pixel + "xx", "byte 22", "unexpected");
  // A huge size in the header is refused before any allocation.
  expect("PF\n2000000000 2000000000\n-1\n" + pixel, "byte 28", "pixel");
}

TEST(Image, WriteImageByExtension) {
  test::ScratchDir dir;
  const Image im = gradient(4, 3);
  write_image(dir.file("a.PNG"), im);
  write_image(dir.file("a.pfm"), im);
  EXPECT_EQ(read_png(dir.file("a.PNG")).width, 4);
  EXPECT_EQ(read_pfm(dir.file("a.pfm")), im);
  const std::string e = error_of([&] { write_image(dir.file("a.jpg"), im); });
  EXPECT_NE(e.find("a.jpg"), std::string::npos) << e;
  EXPECT_NE(e.find(".png"), std::string::npos) << e;
}

// Bilinear between pixel centres: a 2x1 ramp magnified to 4x1 gives the centres' values at 1/4 and 3/4 of the way
// and clamps at the edges; a linear ramp stays linear inside; a constant stays constant; same size is a copy.
TEST(Image, ResizeBilinear) {
  Image two(2, 1);
  two.pixel(0, 0)[0] = 0.0f;
  two.pixel(1, 0)[0] = 1.0f;
  const Image four = resize_bilinear(two, 4, 1);
  const float expected[4] = {0.0f, 0.25f, 0.75f, 1.0f};
  for (int x = 0; x < 4; ++x) EXPECT_FLOAT_EQ(four.pixel(x, 0)[0], expected[x]) << x;
  Image ramp(8, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      float* p = ramp.pixel(x, y);
      p[0] = float(x) / 7, p[1] = float(y) / 7, p[2] = 0.5f, p[3] = 1;
    }
  const Image big = resize_bilinear(ramp, 16, 12);
  ASSERT_EQ(big.width, 16);
  ASSERT_EQ(big.height, 12);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x) {
      const double sx = std::clamp((x + 0.5) * 8 / 16 - 0.5, 0.0, 7.0),
                   sy = std::clamp((y + 0.5) * 8 / 12 - 0.5, 0.0, 7.0);
      EXPECT_NEAR(big.pixel(x, y)[0], sx / 7, 1e-6);
      EXPECT_NEAR(big.pixel(x, y)[1], sy / 7, 1e-6);
      EXPECT_FLOAT_EQ(big.pixel(x, y)[2], 0.5f);
      EXPECT_FLOAT_EQ(big.pixel(x, y)[3], 1.0f);
    }
  EXPECT_EQ(resize_bilinear(ramp, 8, 8), ramp);
  EXPECT_THROW(resize_bilinear(ramp, 0, 4), Error);
  EXPECT_THROW(resize_bilinear(Image(), 4, 4), Error);
}

TEST(Image, CompareIdenticalImages) {
  const Image a = gradient(20, 10);
  const ImageDifference d = compare_images(a, a);
  EXPECT_EQ(d.rms, 0);
  EXPECT_EQ(d.max_abs, 0);
  EXPECT_TRUE(std::isinf(d.psnr_db) && d.psnr_db > 0);
  EXPECT_DOUBLE_EQ(ssim(a, a), 1.0);
}

TEST(Image, CompareConstantOffset) {
  // Every channel off by 0.1: rms = 0.1, mse = 0.01, PSNR = 20 dB.
  const Image a = constant(16, 16, 0.5f), b = constant(16, 16, 0.6f);
  const ImageDifference d = compare_images(a, b);
  EXPECT_NEAR(d.rms, 0.1, 1e-6);
  EXPECT_NEAR(d.max_abs, 0.1, 1e-6);
  EXPECT_NEAR(d.psnr_db, 20.0, 1e-4);
  // Constant images: variances 0, so SSIM is the luminance term (2 m1 m2 + C1) / (m1^2 + m2^2 + C1).
  const double c1 = 1e-4;
  EXPECT_NEAR(ssim(a, b), (2 * 0.5 * 0.6 + c1) / (0.25 + 0.36 + c1), 1e-6);
}

TEST(Image, CompareIgnoresAlphaAndChecksSize) {
  Image a = constant(8, 8, 0.3f), b = a;
  b.pixel(2, 2)[3] = 0.0f;
  EXPECT_EQ(compare_images(a, b).rms, 0);
  Image c = a;
  c.pixel(0, 0)[1] = 1.3f;  // one channel of one pixel off by 1
  const ImageDifference d = compare_images(a, c);
  EXPECT_NEAR(d.max_abs, 1.0, 1e-6);
  EXPECT_NEAR(d.rms, std::sqrt(1.0 / (64 * 3)), 1e-6);
  EXPECT_NE(error_of([&] { compare_images(a, constant(8, 9, 0)); }), "(no error)");
  EXPECT_NE(error_of([&] { ssim(a, constant(9, 8, 0)); }), "(no error)");
}

TEST(Image, SsimDropsWithStructureChanges) {
  const Image a = gradient(64, 64);
  Image noisy = a;
  uint32_t state = 12345;
  for (size_t i = 0; i < noisy.rgba.size(); ++i) {
    if (i % 4 == 3) continue;
    state = state * 1664525u + 1013904223u;
    noisy.rgba[i] += (float(state >> 8) / float(1 << 24) - 0.5f) * 0.2f;
  }
  const double s = ssim(a, noisy);
  EXPECT_LT(s, 0.95);
  EXPECT_GT(s, 0.0);
  // Small images still get one window.
  EXPECT_DOUBLE_EQ(ssim(constant(3, 2, 0.2f), constant(3, 2, 0.2f)), 1.0);
}

}  // namespace
}  // namespace ugvr
