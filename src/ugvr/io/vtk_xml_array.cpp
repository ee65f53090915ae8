#include "ugvr/io/vtk_xml_array.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "ugvr/core/error.h"
#include "ugvr/io/base64.h"
#include "ugvr/io/byte_swap.h"

namespace ugvr {

namespace {

constexpr size_t kTextChunk = size_t(1) << 20;      // characters of ascii or base64 text read at a time
constexpr size_t kDecodedChunk = size_t(3) << 18;   // decoded base64 bytes buffered (a multiple of 3)
constexpr size_t kScratchValues = size_t(1) << 16;  // values converted at a time
constexpr size_t kMaxToken = 256;                   // longest ascii number accepted
constexpr uint64_t kMaxBlockSize = uint64_t(1) << 30;

std::string describe(const XmlArray& a) { return a.label.empty() ? std::string("DataArray") : a.label; }

// Largest size a compressed block of `packed` bytes can expand to: deflate encodes at most 258 bytes in 2 bits
// (1032:1) plus zlib's 6-byte frame; an LZ4 sequence at most 255 bytes per length byte. Anything above is a corrupt
// or hostile header, refused before a buffer is sized by it.
uint64_t max_expansion(Codec codec, uint64_t packed) {
  const uint64_t ratio = codec == Codec::Zlib ? 1032 : 256;
  return packed > (UINT64_MAX - 64) / ratio ? UINT64_MAX : packed * ratio + 64;
}

// double -> float without the undefined behaviour of converting a value beyond float's range: +-infinity instead.
float saturate_to_float(double v) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (v > kMax) return std::numeric_limits<float>::infinity();
  if (v < -kMax) return -std::numeric_limits<float>::infinity();
  return float(v);
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
// Byte sources: the encoded bytes of one array in order, from the file.

class XmlByteSource {
 public:
  explicit XmlByteSource(const XmlArrayReader& owner) : owner_(owner) {}
  virtual ~XmlByteSource() = default;
  // Exactly n bytes, or fails naming the array.
  virtual void read(std::byte* dst, size_t n) = 0;
  // Upper bound on the bytes still available (to check sizes claimed by headers before allocating).
  virtual uint64_t max_remaining() const = 0;
  // File offset of the next encoded byte (of the text for base64), for messages.
  virtual uint64_t offset() const = 0;
  // Passes over n bytes: reads them (a base64 source must decode through them), or seeks where the bytes are raw.
  virtual void skip(uint64_t n) {
    std::byte scratch[4096];
    for (; n > 0;) {
      const size_t k = size_t(std::min<uint64_t>(n, sizeof scratch));
      read(scratch, k);
      n -= k;
    }
  }

 protected:
  const XmlArrayReader& owner_;
};

namespace {

class RawSource final : public XmlByteSource {
 public:
  RawSource(const XmlArrayReader& owner, const InputFile& file, uint64_t begin, uint64_t end)
      : XmlByteSource(owner), file_(file), pos_(begin), end_(end) {}

  void read(std::byte* dst, size_t n) override {
    if (n > end_ - pos_) {
      owner_.fail("data ends at byte " + std::to_string(end_) + ", " + std::to_string(n) + " bytes needed at byte " +
                  std::to_string(pos_) + " (truncated file?)");
    }
    file_.read_at(pos_, dst, n);
    pos_ += n;
  }
  uint64_t max_remaining() const override { return end_ - pos_; }
  uint64_t offset() const override { return pos_; }
  void skip(uint64_t n) override {
    if (n > end_ - pos_) read(nullptr, size_t(n));  // fails, naming the array
    pos_ += n;
  }

 private:
  const InputFile& file_;
  uint64_t pos_, end_;
};

class Base64Source final : public XmlByteSource {
 public:
  Base64Source(const XmlArrayReader& owner, const InputFile& file, uint64_t begin, uint64_t end)
      : XmlByteSource(owner), file_(file), text_pos_(begin), end_(end) {}

  void read(std::byte* dst, size_t n) override {
    while (n > 0) {
      if (dec_pos_ == dec_len_) refill(n);
      const size_t k = std::min(n, dec_len_ - dec_pos_);
      std::memcpy(dst, decoded_.data() + dec_pos_, k);
      dec_pos_ += k;
      dst += k;
      n -= k;
    }
  }
  uint64_t max_remaining() const override {
    return (end_ - text_pos_ + (text_len_ - text_at_)) / 4 * 3 + 3 + (dec_len_ - dec_pos_);
  }
  uint64_t offset() const override { return text_pos_ - (text_len_ - text_at_); }

 private:
  // Decodes more bytes; `want` (bytes still requested) sizes the next text read so small arrays read little.
  void refill(size_t want) {
    // Buffers no larger than the text needs: small arrays (and fuzz inputs) should not pay for megabytes.
    if (decoded_.empty()) decoded_.resize(size_t(std::min<uint64_t>(kDecodedChunk, ((end_ - text_pos_) / 4 + 2) * 3)));
    dec_pos_ = dec_len_ = 0;
    while (dec_len_ == 0) {
      if (text_at_ == text_len_ && !ended_) read_text(want);
      if (text_at_ == text_len_) {
        // End of the text: an unpadded final quantum may still hold bytes.
        const int tail = decoder_.finish(std::span(decoded_));
        if (tail < 0) owner_.fail("base64 data ends in the middle of a 4-character group");
        if (tail == 0) {
          owner_.fail("base64 data ends at byte " + std::to_string(offset()) + " but " + std::to_string(want) +
                      " more bytes are needed");
        }
        dec_len_ = size_t(tail);
        ended_ = true;
        return;
      }
      const auto r = decoder_.decode(std::string_view(text_.data() + text_at_, text_len_ - text_at_),
                                     std::span(decoded_.data(), decoded_.size()));
      text_at_ += r.consumed;
      dec_len_ = r.produced;
      if (r.stopped_at_invalid) {
        const char c = text_[text_at_];
        // In appended data the next markup ("</AppendedData>") ends the base64 stream.
        if (c != '<') {
          fail_at_offset(file_.path(), offset(),
                         owner_.array().label + ": invalid character " + printable(c) + " in base64 data");
        }
        text_len_ = text_at_;
        ended_ = true;
      }
    }
  }

  void read_text(size_t want) {
    if (text_.empty()) text_.resize(size_t(std::min<uint64_t>(kTextChunk, end_ - text_pos_)));
    const uint64_t wanted_chars = std::min<uint64_t>(kTextChunk, uint64_t(want) / 3 * 4 + 64);
    const size_t n = size_t(std::min<uint64_t>(wanted_chars, end_ - text_pos_));
    text_at_ = 0;
    text_len_ = n == 0 ? 0 : file_.read_some_at(text_pos_, text_.data(), n);
    text_pos_ += text_len_;
    if (text_len_ == 0) ended_ = true;
  }

  static std::string printable(char c) {
    if (c >= 0x20 && c < 0x7f) return std::string("'") + c + "'";
    return "(byte " + std::to_string(int(static_cast<unsigned char>(c))) + ")";
  }

  const InputFile& file_;
  uint64_t text_pos_, end_;  // next text byte to read from the file, end of the text
  std::vector<char> text_;
  size_t text_at_ = 0, text_len_ = 0;
  std::vector<std::byte> decoded_;
  size_t dec_pos_ = 0, dec_len_ = 0;
  Base64Decoder decoder_;
  bool ended_ = false;
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
// XmlBinaryStream: the header, then the values' bytes, decompressing block by block.

class XmlBinaryStream {
 public:
  XmlBinaryStream(const XmlArrayReader& owner, std::unique_ptr<XmlByteSource> source, const XmlEncoding& encoding,
                  std::string_view path)
      : owner_(owner), source_(std::move(source)), encoding_(encoding), path_(path) {
    if (encoding_.codec == Codec::None) {
      size_ = read_word();
      if (size_ > source_->max_remaining()) {
        owner_.fail("header claims " + std::to_string(size_) + " bytes of data but only " +
                    std::to_string(source_->max_remaining()) + " remain (truncated file?)");
      }
    } else {
      read_block_header();
    }
  }

  uint64_t size() const { return size_; }
  uint64_t consumed() const { return consumed_; }
  // The encoded bytes the header and the values take (raw sources: file bytes), from the header alone.
  uint64_t stored_bytes() const {
    const uint64_t word = encoding_.header_uint64 ? 8 : 4;
    if (encoding_.codec == Codec::None) return word + size_;
    uint64_t packed = 0;
    for (uint64_t p : packed_sizes_) packed += p;  // checked against the bytes available by read_block_header
    return (3 + uint64_t(packed_sizes_.size())) * word + packed;
  }

  // Passes over n bytes of values: a seek for uncompressed data (a rank reading a range of a raw appended array),
  // decompressing through them otherwise.
  void skip(uint64_t n) {
    if (encoding_.codec != Codec::None || n > size_ - consumed_) {
      std::vector<std::byte> scratch(size_t(std::min<uint64_t>(n, uint64_t(1) << 20)));
      for (; n > 0;) {
        const uint64_t k = std::min<uint64_t>(n, scratch.size());
        read(scratch.data(), k);
        n -= k;
      }
      return;
    }
    consumed_ += n;
    source_->skip(n);
  }

  void read(std::byte* dst, uint64_t n) {
    if (n > size_ - consumed_) {
      owner_.fail("needs " + std::to_string(n) + " more bytes but the array holds only " +
                  std::to_string(size_ - consumed_));
    }
    consumed_ += n;
    if (encoding_.codec == Codec::None) {
      source_->read(dst, size_t(n));
      return;
    }
    while (n > 0) {
      if (block_pos_ == block_.size()) {
        // A whole block wanted: decompress straight into the destination.
        if (n >= block_bytes(next_block_)) {
          const uint64_t len = block_bytes(next_block_);
          inflate_next(std::span(dst, size_t(len)));
          dst += len;
          n -= len;
          continue;
        }
        block_.resize(size_t(block_bytes(next_block_)));
        inflate_next(std::span(block_));
        block_pos_ = 0;
      }
      const size_t k = size_t(std::min<uint64_t>(n, block_.size() - block_pos_));
      std::memcpy(dst, block_.data() + block_pos_, k);
      block_pos_ += k;
      dst += k;
      n -= k;
    }
  }

 private:
  uint64_t read_word() {
    if (encoding_.header_uint64) {
      uint64_t v;
      source_->read(reinterpret_cast<std::byte*>(&v), 8);
      return encoding_.big_endian ? __builtin_bswap64(v) : v;
    }
    uint32_t v;
    source_->read(reinterpret_cast<std::byte*>(&v), 4);
    return encoding_.big_endian ? __builtin_bswap32(v) : v;
  }

  void read_block_header() {
    const uint64_t header_at = source_->offset();
    const uint64_t nblocks = read_word();
    block_size_ = read_word();
    last_size_ = read_word();
    const uint64_t word = encoding_.header_uint64 ? 8 : 4;
    check_count_fits(path_, header_at, owner_.array().label + ": compressed block", nblocks, word,
                     source_->max_remaining());
    if (nblocks == 0) return;
    if (block_size_ == 0 || block_size_ > kMaxBlockSize || last_size_ > block_size_) {
      fail_at_offset(path_, header_at,
                     owner_.array().label + ": corrupt compression header: block size " + std::to_string(block_size_) +
                         ", last block " + std::to_string(last_size_) + " (block size must be 1..2^30 bytes and the " +
                         "last block no larger)");
    }
    if (nblocks - 1 > (UINT64_MAX - block_size_) / block_size_) {
      fail_at_offset(path_, header_at, owner_.array().label + ": compression header claims an impossible size");
    }
    size_ = (nblocks - 1) * block_size_ + (last_size_ ? last_size_ : block_size_);
    packed_sizes_.resize(size_t(nblocks));
    uint64_t packed_total = 0;
    for (uint64_t i = 0; i < nblocks; ++i) {
      packed_sizes_[i] = read_word();
      if (packed_sizes_[i] > UINT64_MAX - packed_total)
        packed_total = UINT64_MAX;
      else
        packed_total += packed_sizes_[i];
      if (block_bytes(i) > max_expansion(encoding_.codec, packed_sizes_[i])) {
        fail_at_offset(path_, header_at,
                       owner_.array().label + ": corrupt compression header: block " + std::to_string(i) + " of " +
                           std::to_string(packed_sizes_[i]) + " compressed bytes cannot expand to " +
                           std::to_string(block_bytes(i)) + " bytes");
      }
    }
    if (packed_total > source_->max_remaining()) {
      fail_at_offset(path_, header_at,
                     owner_.array().label + ": compression header lists " + std::to_string(packed_total) +
                         " compressed bytes but only " + std::to_string(source_->max_remaining()) +
                         " remain (truncated file?)");
    }
  }

  uint64_t block_bytes(uint64_t i) const {
    return i + 1 == packed_sizes_.size() && last_size_ != 0 ? last_size_ : block_size_;
  }

  void inflate_next(std::span<std::byte> dst) {
    const uint64_t at = source_->offset();
    packed_.resize(size_t(packed_sizes_[next_block_]));
    source_->read(packed_.data(), packed_.size());
    decompress(encoding_.codec, packed_, dst, path_, at);
    ++next_block_;
  }

  const XmlArrayReader& owner_;
  std::unique_ptr<XmlByteSource> source_;
  XmlEncoding encoding_;
  std::string path_;
  uint64_t size_ = 0, consumed_ = 0;
  // Compressed arrays only.
  uint64_t block_size_ = 0, last_size_ = 0;
  std::vector<uint64_t> packed_sizes_;
  size_t next_block_ = 0;
  std::vector<std::byte> packed_, block_;
  size_t block_pos_ = 0;
};

// ---------------------------------------------------------------------------------------------------------------
// XmlAsciiTokens: whitespace-separated tokens of an element's text, read in chunks.

class XmlAsciiTokens {
 public:
  XmlAsciiTokens(const XmlArrayReader& owner, const InputFile& file, uint64_t begin, uint64_t end)
      : owner_(owner), file_(file), file_pos_(begin), end_(end) {}

  // The next token, or false at the end of the text. The view stays valid until the next call.
  bool next(std::string_view& token, uint64_t& token_offset) {
    while (true) {
      while (pos_ < len_ && is_space(buf_[pos_])) ++pos_;
      if (pos_ < len_) break;
      if (!refill(0)) return false;
    }
    size_t e = pos_;
    while (true) {
      while (e < len_ && !is_space(buf_[e])) ++e;
      if (e - pos_ > kMaxToken) {
        fail_at_offset(file_.path(), offset_of(pos_),
                       owner_.array().label + ": ascii value longer than " + std::to_string(kMaxToken) + " characters");
      }
      if (e < len_ || file_pos_ == end_) break;
      const size_t done = e - pos_;
      if (!refill(done)) break;
      e = pos_ + done;
    }
    token = std::string_view(buf_.data() + pos_, e - pos_);
    token_offset = offset_of(pos_);
    pos_ = e;
    return true;
  }

  uint64_t text_bytes_left() const { return end_ - file_pos_ + (len_ - pos_); }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }
  uint64_t offset_of(size_t buffer_pos) const { return file_pos_ - len_ + buffer_pos; }

  // Reads more text, keeping the `keep` characters from pos_ (a token cut by the chunk boundary) at the front.
  bool refill(size_t keep) {
    if (file_pos_ == end_) return false;
    // Room for a chunk (no more than the text) after the `keep` <= kMaxToken characters carried over.
    if (buf_.empty()) buf_.resize(size_t(std::min<uint64_t>(kTextChunk, end_ - file_pos_)) + kMaxToken + 1);
    std::memmove(buf_.data(), buf_.data() + pos_, keep);
    const size_t n = size_t(std::min<uint64_t>(buf_.size() - kMaxToken - 1, end_ - file_pos_));
    file_.read_at(file_pos_, buf_.data() + keep, n);
    file_pos_ += n;
    pos_ = 0;
    len_ = keep + n;
    return true;
  }

  const XmlArrayReader& owner_;
  const InputFile& file_;
  uint64_t file_pos_, end_;
  std::vector<char> buf_;
  size_t pos_ = 0, len_ = 0;
};

// ---------------------------------------------------------------------------------------------------------------
// XmlArrayReader

XmlArrayReader::XmlArrayReader(const InputFile& file, const XmlEncoding& encoding, const XmlArray& array)
    : file_(file), encoding_(encoding), array_(array), value_size_(scalar_size(array.type)) {
  if (array_.begin > file_.size() || array_.end > file_.size() || array_.begin > array_.end) {
    fail("data offset " + std::to_string(array_.begin) + " is outside the file of " + std::to_string(file_.size()) +
         " bytes");
  }
  switch (array_.format) {
    case XmlArrayFormat::Ascii:
      ascii_ = std::make_unique<XmlAsciiTokens>(*this, file_, array_.begin, array_.end);
      return;
    case XmlArrayFormat::Binary:
      // Inline binary is always base64; a compressor applies as for appended data.
      binary_ = std::make_unique<XmlBinaryStream>(
          *this, std::make_unique<Base64Source>(*this, file_, array_.begin, array_.end), encoding_, file_.path());
      break;
    case XmlArrayFormat::Appended: {
      std::unique_ptr<XmlByteSource> src;
      if (encoding_.appended_base64)
        src = std::make_unique<Base64Source>(*this, file_, array_.begin, array_.end);
      else
        src = std::make_unique<RawSource>(*this, file_, array_.begin, array_.end);
      binary_ = std::make_unique<XmlBinaryStream>(*this, std::move(src), encoding_, file_.path());
      break;
    }
  }
  if (binary_->size() % value_size_ != 0) {
    fail("holds " + std::to_string(binary_->size()) + " bytes, not a whole number of " +
         std::string(scalar_type_name(array_.type)) + " values");
  }
}

XmlArrayReader::~XmlArrayReader() = default;

void XmlArrayReader::fail(const std::string& message) const {
  fail_at_offset(file_.path(), array_.element_offset, describe(array_) + ": " + message);
}

std::optional<uint64_t> XmlArrayReader::value_count() const {
  if (binary_) return binary_->size() / value_size_;
  return std::nullopt;
}

std::optional<std::pair<uint64_t, uint64_t>> XmlArrayReader::stored_extent() const {
  if (array_.format != XmlArrayFormat::Appended) return std::pair{array_.begin, array_.end};
  if (encoding_.appended_base64) return std::nullopt;
  return std::pair{array_.begin, array_.begin + binary_->stored_bytes()};
}

void XmlArrayReader::expect_count(uint64_t count, const std::string& what) {
  if (binary_) {
    if (binary_->size() / value_size_ != count) {
      fail("holds " + std::to_string(binary_->size() / value_size_) + " values, expected " + std::to_string(count) +
           " (" + what + ")");
    }
    return;
  }
  // Each ascii value takes a character and all but the last a separator.
  const uint64_t text = ascii_->text_bytes_left();
  if (count > 0 && count - 1 > text / 2) {
    fail("text of " + std::to_string(text) + " bytes cannot hold the " + std::to_string(count) + " values expected (" +
         what + ")");
  }
}

void XmlArrayReader::read_native_bytes(std::byte* dst, uint64_t count) {
  if (binary_) {
    binary_->read(dst, count * value_size_);
    if (encoding_.big_endian && value_size_ > 1) swap_bytes(dst, count, value_size_);
  } else {
    switch (array_.type) {
      case ScalarType::Int8: parse_ascii(reinterpret_cast<int8_t*>(dst), count); break;
      case ScalarType::UInt8: parse_ascii(reinterpret_cast<uint8_t*>(dst), count); break;
      case ScalarType::Int16: parse_ascii(reinterpret_cast<int16_t*>(dst), count); break;
      case ScalarType::UInt16: parse_ascii(reinterpret_cast<uint16_t*>(dst), count); break;
      case ScalarType::Int32: parse_ascii(reinterpret_cast<int32_t*>(dst), count); break;
      case ScalarType::UInt32: parse_ascii(reinterpret_cast<uint32_t*>(dst), count); break;
      case ScalarType::Int64: parse_ascii(reinterpret_cast<int64_t*>(dst), count); break;
      case ScalarType::UInt64: parse_ascii(reinterpret_cast<uint64_t*>(dst), count); break;
      case ScalarType::Float32: parse_ascii(reinterpret_cast<float*>(dst), count); break;
      case ScalarType::Float64: parse_ascii(reinterpret_cast<double*>(dst), count); break;
    }
  }
  values_read_ += count;
}

template <class S>
void XmlArrayReader::parse_ascii(S* dst, uint64_t count) {
  for (uint64_t i = 0; i < count; ++i) {
    std::string_view tok;
    uint64_t at = 0;
    if (!ascii_->next(tok, at)) {
      fail("ascii text ends after " + std::to_string(values_read_ + i) + " values; more are needed");
    }
    const std::string_view number = tok.starts_with('+') ? tok.substr(1) : tok;
    const char* first = number.data();
    const char* last = first + number.size();
    std::from_chars_result r{};
    S value{};
    if constexpr (std::is_floating_point_v<S>) {
      r = std::from_chars(first, last, value);
      // from_chars refuses numbers beyond the type's range; strtod semantics (overflow to infinity, underflow to
      // zero) are what writers expect. The token is known to be a well-formed number by then.
      if (r.ec == std::errc::result_out_of_range && r.ptr == last) {
        const double wide = std::strtod(std::string(number).c_str(), nullptr);
        value = std::is_same_v<S, float> ? S(saturate_to_float(wide)) : S(wide);
        r.ec = std::errc();
      }
    } else {
      // Parse wide, then range-check, so "300" in a UInt8 array is reported rather than wrapped.
      std::conditional_t<std::is_signed_v<S>, int64_t, uint64_t> wide{};
      r = std::from_chars(first, last, wide);
      if (r.ec == std::errc() && !std::in_range<S>(wide)) r.ec = std::errc::result_out_of_range;
      value = S(wide);
    }
    if (r.ec != std::errc() || r.ptr != last || number.empty()) {
      fail_at_offset(file_.path(), at,
                     describe(array_) + ": '" + std::string(tok.substr(0, 40)) + "' is not a valid " +
                         std::string(scalar_type_name(array_.type)) + " value");
    }
    dst[i] = value;
  }
}

template <class T>
void XmlArrayReader::read_native(std::span<T> out) {
  if (scalar_type_of<T>() != array_.type) fail("internal error: read in the wrong type");
  read_native_bytes(reinterpret_cast<std::byte*>(out.data()), out.size());
}

template void XmlArrayReader::read_native(std::span<int8_t>);
template void XmlArrayReader::read_native(std::span<uint8_t>);
template void XmlArrayReader::read_native(std::span<int16_t>);
template void XmlArrayReader::read_native(std::span<uint16_t>);
template void XmlArrayReader::read_native(std::span<int32_t>);
template void XmlArrayReader::read_native(std::span<uint32_t>);
template void XmlArrayReader::read_native(std::span<int64_t>);
template void XmlArrayReader::read_native(std::span<uint64_t>);
template void XmlArrayReader::read_native(std::span<float>);
template void XmlArrayReader::read_native(std::span<double>);

namespace {

template <class T, class S>
bool convert_values(const S* src, T* dst, size_t n) {
  if constexpr (std::is_same_v<T, int64_t>) {
    if constexpr (std::is_floating_point_v<S>) {
      return false;
    } else if constexpr (std::is_same_v<S, uint64_t>) {
      for (size_t i = 0; i < n; ++i) {
        if (src[i] > uint64_t(INT64_MAX)) return false;
        dst[i] = int64_t(src[i]);
      }
    } else {
      for (size_t i = 0; i < n; ++i) dst[i] = int64_t(src[i]);
    }
  } else if constexpr (std::is_same_v<T, float> && std::is_same_v<S, double>) {
    // A double beyond float's range would be undefined behaviour to convert; it becomes +-infinity.
    for (size_t i = 0; i < n; ++i) dst[i] = saturate_to_float(src[i]);
  } else {
    for (size_t i = 0; i < n; ++i) dst[i] = T(src[i]);
  }
  return true;
}

}  // namespace

template <class T>
void XmlArrayReader::read_converted(std::span<T> out) {
  if (scalar_type_of<T>() == array_.type) {
    read_native_bytes(reinterpret_cast<std::byte*>(out.data()), out.size());
    return;
  }
  if (scratch_.size() < std::min(kScratchValues, out.size()) * 8)
    scratch_.resize(std::min(kScratchValues, out.size()) * 8);
  size_t done = 0;
  while (done < out.size()) {
    const size_t n = std::min(kScratchValues, out.size() - done);
    read_native_bytes(scratch_.data(), n);
    bool ok = true;
    T* dst = out.data() + done;
    // The scratch buffer holds the values in the array's own type; scratch_ is suitably aligned (operator new).
    switch (array_.type) {
      case ScalarType::Int8: ok = convert_values(reinterpret_cast<const int8_t*>(scratch_.data()), dst, n); break;
      case ScalarType::UInt8: ok = convert_values(reinterpret_cast<const uint8_t*>(scratch_.data()), dst, n); break;
      case ScalarType::Int16: ok = convert_values(reinterpret_cast<const int16_t*>(scratch_.data()), dst, n); break;
      case ScalarType::UInt16: ok = convert_values(reinterpret_cast<const uint16_t*>(scratch_.data()), dst, n); break;
      case ScalarType::Int32: ok = convert_values(reinterpret_cast<const int32_t*>(scratch_.data()), dst, n); break;
      case ScalarType::UInt32: ok = convert_values(reinterpret_cast<const uint32_t*>(scratch_.data()), dst, n); break;
      case ScalarType::Int64: ok = convert_values(reinterpret_cast<const int64_t*>(scratch_.data()), dst, n); break;
      case ScalarType::UInt64: ok = convert_values(reinterpret_cast<const uint64_t*>(scratch_.data()), dst, n); break;
      case ScalarType::Float32: ok = convert_values(reinterpret_cast<const float*>(scratch_.data()), dst, n); break;
      case ScalarType::Float64: ok = convert_values(reinterpret_cast<const double*>(scratch_.data()), dst, n); break;
    }
    if (!ok) {
      fail(std::is_same_v<T, int64_t> && (array_.type == ScalarType::Float32 || array_.type == ScalarType::Float64)
               ? "must be an integer array, not " + std::string(scalar_type_name(array_.type))
               : "value above 2^63-1 where an id or offset is expected");
    }
    done += n;
  }
}

void XmlArrayReader::read(std::span<int64_t> out) { read_converted(out); }
void XmlArrayReader::read(std::span<float> out) { read_converted(out); }
void XmlArrayReader::read(std::span<double> out) { read_converted(out); }

void XmlArrayReader::skip(uint64_t count) {
  if (binary_) {
    binary_->skip(count * value_size_);
    values_read_ += count;
    return;
  }
  if (scratch_.size() < std::min<uint64_t>(kScratchValues, count) * 8) {
    scratch_.resize(size_t(std::min<uint64_t>(kScratchValues, count)) * 8);
  }
  while (count > 0) {
    const uint64_t n = std::min<uint64_t>(kScratchValues, count);
    read_native_bytes(scratch_.data(), n);
    count -= n;
  }
}

void XmlArrayReader::finish() {
  if (binary_) {
    if (binary_->consumed() != binary_->size()) {
      fail("holds " + std::to_string(binary_->size() / value_size_) + " values but only " +
           std::to_string(values_read_) + " are used");
    }
    return;
  }
  std::string_view tok;
  uint64_t at = 0;
  if (ascii_->next(tok, at)) {
    fail_at_offset(file_.path(), at,
                   describe(array_) + ": more values than expected: only " + std::to_string(values_read_) +
                       " are used, found '" + std::string(tok.substr(0, 40)) + "' after them");
  }
}

}  // namespace ugvr
