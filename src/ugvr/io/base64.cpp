#include "ugvr/io/base64.h"

#include <array>

namespace ugvr {

namespace {

// Decoding table: 0..63 for the alphabet, kSpace for whitespace, kPad for '=', kBad for everything else. Any value
// >= 64 makes the fast path fall back to the character-by-character one.
constexpr uint8_t kSpace = 64, kPad = 65, kBad = 255;

constexpr std::array<uint8_t, 256> make_table() {
  std::array<uint8_t, 256> t{};
  for (auto& v : t) v = kBad;
  constexpr std::string_view alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (size_t i = 0; i < alphabet.size(); ++i) t[uint8_t(alphabet[i])] = uint8_t(i);
  t[uint8_t(' ')] = t[uint8_t('\n')] = t[uint8_t('\r')] = t[uint8_t('\t')] = kSpace;
  t[uint8_t('=')] = kPad;
  return t;
}
constexpr std::array<uint8_t, 256> kTable = make_table();

}  // namespace

Base64Decoder::Result Base64Decoder::decode(std::string_view in, std::span<std::byte> out) {
  const auto* s = reinterpret_cast<const unsigned char*>(in.data());
  const size_t n = in.size();
  size_t i = 0, o = 0;
  while (i < n && o + 3 <= out.size()) {
    if (chars_ == 0 && padding_ == 0) {
      // Fast path: whole quanta of four alphabet characters.
      while (i + 4 <= n && o + 3 <= out.size()) {
        const uint32_t a = kTable[s[i]], b = kTable[s[i + 1]], c = kTable[s[i + 2]], d = kTable[s[i + 3]];
        if ((a | b | c | d) >= 64) break;
        const uint32_t q = (a << 18) | (b << 12) | (c << 6) | d;
        out[o] = std::byte(q >> 16);
        out[o + 1] = std::byte(q >> 8);
        out[o + 2] = std::byte(q);
        i += 4;
        o += 3;
      }
      if (i >= n || o + 3 > out.size()) break;
    }
    const uint8_t v = kTable[s[i]];
    if (v < 64) {
      if (padding_ > 0) return {i, o, true};  // data after '=' inside a quantum
      bits_ = (bits_ << 6) | v;
      if (++chars_ == 4) {
        out[o] = std::byte(bits_ >> 16);
        out[o + 1] = std::byte(bits_ >> 8);
        out[o + 2] = std::byte(bits_);
        o += 3;
        bits_ = 0;
        chars_ = 0;
      }
    } else if (v == kSpace) {
      // skipped
    } else if (v == kPad) {
      if (chars_ < 2) return {i, o, true};
      if (chars_ == 3) {  // "xxx=": 18 bits, 2 bytes
        out[o] = std::byte(bits_ >> 10);
        out[o + 1] = std::byte(bits_ >> 2);
        o += 2;
        bits_ = 0;
        chars_ = 0;
      } else if (padding_ == 0) {  // "xx=" so far: one more '=' ends it
        padding_ = 1;
      } else {  // "xx==": 12 bits, 1 byte
        out[o] = std::byte(bits_ >> 4);
        o += 1;
        bits_ = 0;
        chars_ = 0;
        padding_ = 0;
      }
    } else {
      return {i, o, true};
    }
    ++i;
  }
  return {i, o, false};
}

int Base64Decoder::finish(std::span<std::byte> out) {
  int produced = 0;
  if (chars_ == 1) {
    produced = -1;
  } else if (chars_ == 2 && !out.empty()) {
    out[0] = std::byte(bits_ >> 4);
    produced = 1;
  } else if (chars_ == 3 && out.size() >= 2) {
    out[0] = std::byte(bits_ >> 10);
    out[1] = std::byte(bits_ >> 2);
    produced = 2;
  }
  bits_ = 0;
  chars_ = 0;
  padding_ = 0;
  return produced;
}

std::string base64_encode(std::span<const std::byte> data) {
  constexpr std::string_view alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string s;
  s.reserve((data.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= data.size(); i += 3) {
    const uint32_t q = (uint32_t(data[i]) << 16) | (uint32_t(data[i + 1]) << 8) | uint32_t(data[i + 2]);
    s += alphabet[q >> 18];
    s += alphabet[(q >> 12) & 63];
    s += alphabet[(q >> 6) & 63];
    s += alphabet[q & 63];
  }
  if (const size_t rest = data.size() - i; rest > 0) {
    const uint32_t q = (uint32_t(data[i]) << 16) | (rest == 2 ? uint32_t(data[i + 1]) << 8 : 0);
    s += alphabet[q >> 18];
    s += alphabet[(q >> 12) & 63];
    s += rest == 2 ? alphabet[(q >> 6) & 63] : '=';
    s += '=';
  }
  return s;
}

}  // namespace ugvr
