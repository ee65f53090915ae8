#include "ugvr/io/codec.h"

#include <lz4.h>
#include <zlib.h>

#include <array>
#include <climits>
#include <cstring>
#include <string>
#include <utility>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

constexpr std::array<std::pair<Codec, std::string_view>, 3> kVtkCompressors = {
    {{Codec::None, ""}, {Codec::Zlib, "vtkZLibDataCompressor"}, {Codec::Lz4, "vtkLZ4DataCompressor"}}};

}  // namespace

std::string_view vtk_compressor_name(Codec codec) {
  for (const auto& [c, name] : kVtkCompressors)
    if (c == codec) return name;
  return {};
}

std::optional<Codec> codec_of_vtk_compressor(std::string_view name) {
  for (const auto& [c, n] : kVtkCompressors)
    if (n == name) return c;
  return std::nullopt;
}

void decompress(Codec codec, std::span<const std::byte> src, std::span<std::byte> dst, std::string_view file,
                uint64_t offset) {
  switch (codec) {
    case Codec::None:
      if (src.size() != dst.size()) {
        fail_at_offset(
            file, offset,
            "stored block of " + std::to_string(src.size()) + " bytes, expected " + std::to_string(dst.size()));
      }
      if (!dst.empty()) std::memcpy(dst.data(), src.data(), dst.size());
      return;
    case Codec::Zlib: {
      uLongf out_len = uLongf(dst.size());
      const int rc = uncompress(reinterpret_cast<Bytef*>(dst.data()), &out_len,
                                reinterpret_cast<const Bytef*>(src.data()), uLong(src.size()));
      if (rc != Z_OK || out_len != dst.size()) {
        fail_at_offset(file, offset,
                       "corrupt zlib block (" + std::string(rc == Z_OK ? "wrong size" : zError(rc)) + "): expected " +
                           std::to_string(dst.size()) + " bytes");
      }
      return;
    }
    case Codec::Lz4: {
      if (src.size() > size_t(INT_MAX) || dst.size() > size_t(INT_MAX)) {
        fail_at_offset(file, offset, "lz4 block larger than 2 GiB");
      }
      const int n = LZ4_decompress_safe(reinterpret_cast<const char*>(src.data()), reinterpret_cast<char*>(dst.data()),
                                        int(src.size()), int(dst.size()));
      if (n < 0 || size_t(n) != dst.size()) {
        fail_at_offset(file, offset, "corrupt lz4 block: expected " + std::to_string(dst.size()) + " bytes");
      }
      return;
    }
  }
}

std::vector<std::byte> compress(Codec codec, std::span<const std::byte> src, int level) {
  std::vector<std::byte> out;
  switch (codec) {
    case Codec::None: out.assign(src.begin(), src.end()); break;
    case Codec::Zlib: {
      uLongf len = compressBound(uLong(src.size()));
      out.resize(len);
      const int rc = compress2(reinterpret_cast<Bytef*>(out.data()), &len, reinterpret_cast<const Bytef*>(src.data()),
                               uLong(src.size()), level > 0 ? level : Z_DEFAULT_COMPRESSION);
      if (rc != Z_OK) throw Error(std::string("zlib compression failed: ") + zError(rc));
      out.resize(len);
      break;
    }
    case Codec::Lz4: {
      if (src.size() > size_t(LZ4_MAX_INPUT_SIZE)) throw Error("lz4 block larger than LZ4_MAX_INPUT_SIZE");
      out.resize(size_t(LZ4_compressBound(int(src.size()))));
      const int n = LZ4_compress_fast(reinterpret_cast<const char*>(src.data()), reinterpret_cast<char*>(out.data()),
                                      int(src.size()), int(out.size()), level > 0 ? level : 1);
      if (n <= 0) throw Error("lz4 compression failed");
      out.resize(size_t(n));
      break;
    }
  }
  return out;
}

}  // namespace ugvr
