#include "ugvr/render/image.h"

#include <png.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr {
namespace {

// Catches images whose pixel vector disagrees with their size before anything indexes it.
void check_image(std::string_view path, const Image& image) {
  if (image.width < 1 || image.height < 1 || image.rgba.size() != size_t(image.width) * size_t(image.height) * 4)
    fail_in(path, "cannot write an image of " + std::to_string(image.width) + " x " + std::to_string(image.height) +
                      " pixels holding " + std::to_string(image.rgba.size()) + " floats");
}

uint8_t to_byte(float v) {
  // NaN fails both comparisons and becomes 0, so a broken pixel shows as black instead of undefined behaviour.
  const float c = v > 0 ? (v < 1 ? v : 1.0f) : 0.0f;
  return uint8_t(std::lround(c * 255.0f));
}

// ---- libpng glue. libpng reports errors by longjmp; everything with a destructor lives in the callers of the
// functions that call setjmp, and the callbacks hold no such objects, so no destructor is ever skipped.

struct PngIo {
  std::vector<unsigned char>* out = nullptr;  // writing
  const unsigned char* in = nullptr;          // reading
  size_t in_size = 0, in_pos = 0;
  char message[256] = {};
};

PngIo& io_of(png_structp png) { return *static_cast<PngIo*>(png_get_io_ptr(png)); }

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* io = static_cast<PngIo*>(png_get_error_ptr(png));
  std::snprintf(io->message, sizeof io->message, "%s", message ? message : "libpng error");
  png_longjmp(png, 1);
}

// libpng's default would print to stderr; warnings (unknown chunks, gamma notes) do not change the pixels we read.
void on_png_warning(png_structp, png_const_charp) {}

void on_png_write(png_structp png, png_bytep data, size_t n) {
  PngIo& io = io_of(png);
  bool ok = true;
  try {
    io.out->insert(io.out->end(), data, data + n);
  } catch (const std::bad_alloc&) {
    ok = false;  // an exception must not unwind through libpng's C frames
  }
  if (!ok) png_error(png, "out of memory");
}

void on_png_flush(png_structp) {}

void on_png_read(png_structp png, png_bytep data, size_t n) {
  PngIo& io = io_of(png);
  if (n > io.in_size - io.in_pos) png_error(png, "truncated PNG data");
  std::memcpy(data, io.in + io.in_pos, n);
  io.in_pos += n;
}

struct PngWriteGuard {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngWriteGuard() { png_destroy_write_struct(&png, info ? &info : nullptr); }
};

struct PngReadGuard {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReadGuard() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
};

bool encode_png(png_structp png, png_infop info, int width, int height, int color_type, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_rows(png, info, rows);
  png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  return true;
}

// What decode_png leaves for read_png: 8- or 16-bit (big-endian) samples, 3 or 4 channels.
struct DecodedPng {
  png_uint_32 width = 0, height = 0;
  int channels = 0, bit_depth = 0;
  std::vector<unsigned char> pixels;
  std::vector<png_bytep> rows;
};

bool decode_png(png_structp png, png_infop info, DecodedPng& out) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  // Deflate cannot compress better than about 1032:1, so a header promising more pixels than the file could hold
  // is a corrupt (or hostile) file; refuse it before allocating. (Row bytes before the transformations below.)
  const double raw_bytes = (double(png_get_rowbytes(png, info)) + 1) * double(png_get_image_height(png, info));
  if (raw_bytes > 1100.0 * double(io_of(png).in_size) + 1e6)
    png_error(png, "image size in the header is larger than the compressed data can hold");
  // Palette, low-bit gray and tRNS become plain 8-bit samples (and alpha); gray becomes RGB.
  png_set_expand(png);
  png_set_gray_to_rgb(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  out.width = png_get_image_width(png, info);
  out.height = png_get_image_height(png, info);
  out.channels = png_get_channels(png, info);
  out.bit_depth = png_get_bit_depth(png, info);
  if (out.channels != 3 && out.channels != 4) png_error(png, "unsupported channel layout");
  if (out.bit_depth != 8 && out.bit_depth != 16) png_error(png, "unsupported bit depth");
  const size_t row_bytes = png_get_rowbytes(png, info);
  out.pixels.resize(row_bytes * out.height);
  out.rows.resize(out.height);
  for (png_uint_32 y = 0; y < out.height; ++y) out.rows[y] = out.pixels.data() + y * row_bytes;
  png_read_image(png, out.rows.data());
  png_read_end(png, nullptr);
  return true;
}

// ---- PFM

uint32_t load_u32(const unsigned char* p, bool little_endian) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  if (little_endian != (std::endian::native == std::endian::little)) v = __builtin_bswap32(v);
  return v;
}

void store_le(unsigned char* p, float f) {
  uint32_t v = std::bit_cast<uint32_t>(f);
  if constexpr (std::endian::native != std::endian::little) v = __builtin_bswap32(v);
  std::memcpy(p, &v, 4);
}

// A header token quoted in a message: at most 16 bytes, non-ASCII shown as '?' so binary garbage stays readable.
std::string printable(std::string_view token) {
  std::string s(token.substr(0, 16));
  for (char& c : s)
    if (c < 0x20 || c > 0x7e) c = '?';
  return s;
}

bool is_pfm_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// Header tokens with their byte offsets, for messages that point at the bad token.
class PfmHeader {
 public:
  PfmHeader(const std::string& path, std::string text) : path_(path), text_(std::move(text)) {}

  // Next whitespace-delimited token; `what` names it in the error when the header ends first.
  std::string_view token(std::string_view what) {
    while (pos_ < text_.size() && is_pfm_space(text_[pos_])) ++pos_;
    const size_t start = pos_;
    while (pos_ < text_.size() && !is_pfm_space(text_[pos_])) ++pos_;
    if (start == pos_ || pos_ == text_.size())
      fail_at_offset(path_, start, "PFM header ends before the " + std::string(what));
    token_offset_ = start;
    return std::string_view(text_).substr(start, pos_ - start);
  }
  uint64_t token_offset() const { return token_offset_; }
  // The single whitespace byte that ends the header; the pixel data starts after it.
  uint64_t data_offset() const { return pos_ + 1; }

 private:
  const std::string& path_;
  std::string text_;
  size_t pos_ = 0;
  uint64_t token_offset_ = 0;
};

int pfm_side(PfmHeader& h, const std::string& path, std::string_view what) {
  const std::string_view t = h.token(what);
  int v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc() || end != t.data() + t.size() || v < 1)
    fail_at_offset(path, h.token_offset(),
                   "expected the " + std::string(what) + " as a positive integer, found \"" + printable(t) + "\"");
  return v;
}

}  // namespace

std::vector<unsigned char> png_bytes(const Image& image, std::string_view source) {
  check_image(source, image);
  const size_t pixels = size_t(image.width) * size_t(image.height);
  // Decided on the stored 8-bit alpha: an alpha that rounds to 255 is lost in either layout, so RGB is lossless then.
  bool opaque = true;
  for (size_t i = 0; i < pixels && opaque; ++i) opaque = to_byte(image.rgba[i * 4 + 3]) == 255;
  const int channels = opaque ? 3 : 4;
  std::vector<unsigned char> bytes(pixels * size_t(channels));
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < channels; ++c) bytes[i * size_t(channels) + size_t(c)] = to_byte(image.rgba[i * 4 + size_t(c)]);
  std::vector<png_bytep> rows(size_t(image.height));
  for (int y = 0; y < image.height; ++y)
    rows[size_t(y)] = bytes.data() + size_t(y) * size_t(image.width) * size_t(channels);

  std::vector<unsigned char> encoded;
  encoded.reserve(bytes.size() / 2 + 1024);
  PngIo io;
  io.out = &encoded;
  PngWriteGuard guard;
  guard.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &io, on_png_error, on_png_warning);
  if (!guard.png) throw std::bad_alloc();
  guard.info = png_create_info_struct(guard.png);
  if (!guard.info) throw std::bad_alloc();
  png_set_write_fn(guard.png, &io, on_png_write, on_png_flush);
  if (!encode_png(guard.png, guard.info, image.width, image.height,
                  opaque ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_RGB_ALPHA, rows.data()))
    fail_in(source, std::string("cannot encode PNG: ") + io.message);
  return encoded;
}

void write_png(const std::string& path, const Image& image) {
  const std::vector<unsigned char> encoded = png_bytes(image, path);
  AtomicOutputFile out(path);
  out.write(encoded.data(), encoded.size());
  out.commit();
}

Image read_png(const std::string& path) {
  const InputFile in(path);
  const std::string data = in.read_all();
  if (data.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(data.data()), 0, 8) != 0)
    fail_at_offset(path, 0, "not a PNG file (bad signature)");
  PngIo io;
  io.in = reinterpret_cast<const unsigned char*>(data.data());
  io.in_size = data.size();
  PngReadGuard guard;
  guard.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, on_png_error, on_png_warning);
  if (!guard.png) throw std::bad_alloc();
  guard.info = png_create_info_struct(guard.png);
  if (!guard.info) throw std::bad_alloc();
  png_set_read_fn(guard.png, &io, on_png_read);
  // Our images are at most 16384 on a side; the limit keeps a corrupt header from asking for gigabytes.
  png_set_user_limits(guard.png, 1u << 16, 1u << 16);
  DecodedPng d;
  if (!decode_png(guard.png, guard.info, d)) fail_in(path, std::string("invalid PNG: ") + io.message);

  Image image(int(d.width), int(d.height));
  const size_t pixels = size_t(d.width) * size_t(d.height);
  const size_t channels = size_t(d.channels);
  for (size_t i = 0; i < pixels; ++i) {
    float* px = image.rgba.data() + i * 4;
    px[3] = 1.0f;
    for (size_t c = 0; c < channels; ++c) {
      const size_t k = i * channels + c;
      px[c] = d.bit_depth == 8 ? float(d.pixels[k]) / 255.0f
                               : float((unsigned(d.pixels[2 * k]) << 8) | d.pixels[2 * k + 1]) / 65535.0f;
    }
  }
  return image;
}

void write_pfm(const std::string& path, const Image& image) {
  check_image(path, image);
  const std::string header = "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
  AtomicOutputFile out(path);
  out.write(header);
  std::vector<unsigned char> row(size_t(image.width) * 12);
  for (int y = image.height - 1; y >= 0; --y) {
    for (int x = 0; x < image.width; ++x) {
      const float* px = image.pixel(x, y);
      for (int c = 0; c < 3; ++c) store_le(row.data() + size_t(x) * 12 + size_t(c) * 4, px[c]);
    }
    out.write(row.data(), row.size());
  }
  out.commit();
}

Image read_pfm(const std::string& path) {
  const InputFile in(path);
  // A valid header is well under 100 bytes; reading a bounded prefix keeps a garbage file from being slurped.
  std::string prefix(std::min<uint64_t>(in.size(), 256), '\0');
  in.read_at(0, prefix.data(), prefix.size());
  PfmHeader h(path, prefix);
  const std::string_view magic = h.token("magic");
  if (magic != "PF" && magic != "Pf")
    fail_at_offset(path, h.token_offset(),
                   "not a PFM file (expected \"PF\" or \"Pf\", found \"" + printable(magic) + "\")");
  const size_t channels = magic == "PF" ? 3 : 1;
  const int width = pfm_side(h, path, "width");
  const int height = pfm_side(h, path, "height");
  const std::string_view scale_text = h.token("scale");
  double scale = 0;
  const auto [end, ec] = std::from_chars(scale_text.data(), scale_text.data() + scale_text.size(), scale);
  if (ec != std::errc() || end != scale_text.data() + scale_text.size() || !std::isfinite(scale) || scale == 0)
    fail_at_offset(path, h.token_offset(),
                   "expected the scale as a non-zero number, found \"" + printable(scale_text) + "\"");
  const bool little_endian = scale < 0;

  const uint64_t data_offset = h.data_offset();
  const uint64_t pixels = uint64_t(width) * uint64_t(height);
  const uint64_t row_bytes = uint64_t(width) * channels * 4;
  const uint64_t bytes_left = in.size() - data_offset;
  check_count_fits(path, data_offset, "pixel", pixels, channels * 4, bytes_left);
  if (bytes_left > pixels * channels * 4)
    fail_at_offset(path, data_offset + pixels * channels * 4,
                   std::to_string(bytes_left - pixels * channels * 4) + " unexpected bytes after the pixel data");

  Image image(width, height);
  std::vector<unsigned char> row(row_bytes);
  for (int r = 0; r < height; ++r) {
    in.read_at(data_offset + uint64_t(r) * row_bytes, row.data(), row.size());
    // The file's first row is the image's bottom row.
    float* dst = image.pixel(0, height - 1 - r);
    for (int x = 0; x < width; ++x) {
      for (size_t c = 0; c < 3; ++c) {
        const size_t src = (size_t(x) * channels + (channels == 3 ? c : 0)) * 4;
        dst[size_t(x) * 4 + c] = std::bit_cast<float>(load_u32(row.data() + src, little_endian));
      }
      dst[size_t(x) * 4 + 3] = 1.0f;
    }
  }
  return image;
}

void write_image(const std::string& path, const Image& image) {
  const std::string ext = extension_lower(path);
  if (ext == ".png")
    write_png(path, image);
  else if (ext == ".pfm")
    write_pfm(path, image);
  else
    fail_in(path, "unsupported image extension \"" + ext + "\" (expected .png or .pfm)");
}

ImageDifference compare_images(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    throw Error("cannot compare images of different sizes: " + std::to_string(a.width) + " x " +
                std::to_string(a.height) + " and " + std::to_string(b.width) + " x " + std::to_string(b.height));
  const size_t pixels = size_t(a.width) * size_t(a.height);
  double sum_sq = 0, max_abs = 0;
  for (size_t i = 0; i < pixels; ++i) {
    for (size_t c = 0; c < 3; ++c) {
      const double d = double(a.rgba[i * 4 + c]) - double(b.rgba[i * 4 + c]);
      sum_sq += d * d;
      max_abs = std::max(max_abs, std::abs(d));
    }
  }
  ImageDifference r;
  const double mse = pixels ? sum_sq / double(pixels * 3) : 0.0;
  r.rms = std::sqrt(mse);
  r.max_abs = max_abs;
  r.psnr_db = mse > 0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
  return r;
}

double ssim(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    throw Error("cannot compute the SSIM of images of different sizes: " + std::to_string(a.width) + " x " +
                std::to_string(a.height) + " and " + std::to_string(b.width) + " x " + std::to_string(b.height));
  if (a.width < 1 || a.height < 1) return 1.0;
  const size_t w = size_t(a.width), h = size_t(a.height);
  auto luminance = [](const Image& im) {
    std::vector<double> y(im.rgba.size() / 4);
    for (size_t i = 0; i < y.size(); ++i)
      y[i] = 0.2126 * im.rgba[i * 4] + 0.7152 * im.rgba[i * 4 + 1] + 0.0722 * im.rgba[i * 4 + 2];
    return y;
  };
  const std::vector<double> ya = luminance(a), yb = luminance(b);
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;  // (K1 L)^2, (K2 L)^2 with L = 1
  // An image smaller than a window gets one window spanning it, so tiny images still get a score.
  const size_t win_w = std::min<size_t>(8, w), win_h = std::min<size_t>(8, h);
  double total = 0;
  size_t windows = 0;
  for (size_t y0 = 0; y0 + win_h <= h; y0 += 4) {
    for (size_t x0 = 0; x0 + win_w <= w; x0 += 4) {
      double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
      for (size_t y = y0; y < y0 + win_h; ++y) {
        for (size_t x = x0; x < x0 + win_w; ++x) {
          const double pa = ya[y * w + x], pb = yb[y * w + x];
          sa += pa;
          sb += pb;
          saa += pa * pa;
          sbb += pb * pb;
          sab += pa * pb;
        }
      }
      const double n = double(win_w * win_h);
      const double ma = sa / n, mb = sb / n;
      const double va = std::max(0.0, saa / n - ma * ma), vb = std::max(0.0, sbb / n - mb * mb);
      const double cov = sab / n - ma * mb;
      total += ((2 * ma * mb + kC1) * (2 * cov + kC2)) / ((ma * ma + mb * mb + kC1) * (va + vb + kC2));
      ++windows;
    }
  }
  return total / double(windows);
}

void composite_pixel(float* px, const double radiance[3], double transmittance, const std::array<double, 4>& bg) {
  const double out_a = 1 - transmittance * (1 - bg[3]);
  const double inv = out_a > 0 ? 1 / out_a : 0;
  for (int c = 0; c < 3; ++c)
    px[c] = float(std::clamp((radiance[c] + bg[size_t(c)] * (transmittance * bg[3])) * inv, 0.0, 1.0));
  px[3] = float(std::clamp(out_a, 0.0, 1.0));
}

}  // namespace ugvr

namespace ugvr {

Image resize_bilinear(const Image& src, int width, int height) {
  if (src.width < 1 || src.height < 1 || width < 1 || height < 1)
    fail_in("resize", "image sizes must be >= 1 (from " + std::to_string(src.width) + "x" + std::to_string(src.height) +
                          " to " + std::to_string(width) + "x" + std::to_string(height) + ")");
  if (src.width == width && src.height == height) return src;
  // Per output column: the two source columns and the weight of the second (the same for every row).
  struct Tap {
    int i0, i1;
    float w;
  };
  auto taps = [](int from, int to) {
    std::vector<Tap> t(static_cast<size_t>(to));
    const double ratio = double(from) / double(to);
    for (int i = 0; i < to; ++i) {
      const double x = std::clamp((i + 0.5) * ratio - 0.5, 0.0, double(from - 1));
      const int i0 = int(x);
      t[size_t(i)] = {i0, std::min(i0 + 1, from - 1), float(x - i0)};
    }
    return t;
  };
  const std::vector<Tap> tx = taps(src.width, width), ty = taps(src.height, height);
  Image out(width, height);
  for (int y = 0; y < height; ++y) {
    const Tap& v = ty[size_t(y)];
    for (int x = 0; x < width; ++x) {
      const Tap& h = tx[size_t(x)];
      const float *a = src.pixel(h.i0, v.i0), *b = src.pixel(h.i1, v.i0);
      const float *c = src.pixel(h.i0, v.i1), *d = src.pixel(h.i1, v.i1);
      float* o = out.pixel(x, y);
      for (int k = 0; k < 4; ++k) {
        const float top = a[k] + h.w * (b[k] - a[k]), bottom = c[k] + h.w * (d[k] - c[k]);
        o[k] = top + v.w * (bottom - top);
      }
    }
  }
  return out;
}

}  // namespace ugvr
