#include "ugvr/io/text_tokenizer.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <type_traits>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

constexpr bool is_space(char c) { return c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

char lower(char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; }

// Shows a token in a message: printable, and short even when the token is not.
std::string quoted(std::string_view token) {
  std::string s = "'";
  for (char c : token.substr(0, 40)) s += (c >= 32 && c < 127) ? c : '?';
  return s + (token.size() > 40 ? "...'" : "'");
}

}  // namespace

bool equals_ignore_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) { return lower(x) == lower(y); });
}

bool starts_with_ignore_case(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && equals_ignore_case(s.substr(0, prefix.size()), prefix);
}

template <class T>
bool parse_number(std::string_view text, T& value) {
  // from_chars takes no '+', which C/C++ writers may emit ("+1.5e+00" is written by some Fortran codes as well).
  if (text.size() > 1 && text.front() == '+' && text[1] != '-' && text[1] != '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if constexpr (std::is_floating_point_v<T>) {
    const auto [ptr, ec] = std::from_chars(first, last, value);
    if (ec == std::errc::result_out_of_range && ptr == last) {
      // Overflow or underflow: take what strtod gives (+-HUGE_VAL, or 0 / a denormal), as iostreams would keep
      // reading. The token is short (bounded by the tokenizer), so a terminated copy is cheap.
      const std::string copy(text);
      value = std::is_same_v<T, float> ? T(std::strtof(copy.c_str(), nullptr)) : T(std::strtod(copy.c_str(), nullptr));
      return true;
    }
    return ec == std::errc() && ptr == last;
  } else {
    const auto [ptr, ec] = std::from_chars(first, last, value);
    return ec == std::errc() && ptr == last;
  }
}

#define UGVR_PARSE_NUMBER(T) template bool parse_number<T>(std::string_view, T&);
UGVR_PARSE_NUMBER(int8_t)
UGVR_PARSE_NUMBER(uint8_t)
UGVR_PARSE_NUMBER(int16_t)
UGVR_PARSE_NUMBER(uint16_t)
UGVR_PARSE_NUMBER(int32_t)
UGVR_PARSE_NUMBER(uint32_t)
UGVR_PARSE_NUMBER(int64_t)
UGVR_PARSE_NUMBER(uint64_t)
UGVR_PARSE_NUMBER(float)
UGVR_PARSE_NUMBER(double)
#undef UGVR_PARSE_NUMBER

TextTokenizer::TextTokenizer(const InputFile& file, Mark start, size_t chunk)
    : file_(file), buffer_offset_(std::min(start.offset, file.size())), line_(start.line) {
  // A buffer of at least two tokens lets any token fit after the unread bytes are moved to the front; one byte more
  // than the rest of the file is enough for anything in it (small files get small buffers).
  const uint64_t rest = file.size() - buffer_offset_;
  buffer_.resize(rest < chunk ? size_t(rest) + 1 : std::max(chunk, 2 * kMaxToken));
  token_offset_ = buffer_offset_;
  token_line_ = line_;
}

size_t TextTokenizer::fill(size_t want) {
  if (available() >= want) return available();
  if (pos_ > 0) {
    std::memmove(buffer_.data(), buffer_.data() + pos_, available());
    buffer_offset_ += pos_;
    end_ -= pos_;
    pos_ = 0;
  }
  while (end_ < want && end_ < buffer_.size()) {
    const uint64_t at = buffer_offset_ + end_;
    if (at >= file_.size()) break;
    const size_t n = file_.read_some_at(at, buffer_.data() + end_, buffer_.size() - end_);
    if (n == 0) break;  // the file shrank while we read it; the caller sees the end of the data
    end_ += n;
  }
  return available();
}

bool TextTokenizer::skip_space() {
  for (;;) {
    if (pos_ == end_ && fill(1) == 0) return false;
    const char c = buffer_[pos_];
    if (!is_space(c)) return true;
    if (c == '\n') ++line_;
    ++pos_;
  }
}

std::string_view TextTokenizer::next_token() {
  if (!skip_space()) {
    token_offset_ = offset();
    token_line_ = line_;
    return {};
  }
  token_offset_ = offset();
  token_line_ = line_;
  size_t length = 0;
  for (;;) {
    while (pos_ + length < end_ && !is_space(buffer_[pos_ + length])) ++length;
    if (pos_ + length < end_) break;  // ended by whitespace
    if (length > kMaxToken) {
      fail_at_token_line("a token longer than " + std::to_string(kMaxToken) +
                         " bytes: " + quoted({buffer_.data() + pos_, length}));
    }
    if (fill(length + 1) == length) break;  // ended by the end of the file
  }
  // The same limit whether or not the token happened to fit in the buffer.
  if (length > kMaxToken) {
    fail_at_token_line("a token longer than " + std::to_string(kMaxToken) +
                       " bytes: " + quoted({buffer_.data() + pos_, length}));
  }
  const std::string_view token(buffer_.data() + pos_, length);
  pos_ += length;
  return token;
}

std::string_view TextTokenizer::peek_token() {
  const std::string_view token = next_token();
  pos_ -= token.size();  // the token is still in the buffer and holds no newline
  return token;
}

bool TextTokenizer::at_line_end() {
  for (;;) {
    if (pos_ == end_ && fill(1) == 0) return true;
    const char c = buffer_[pos_];
    if (c == '\n') return true;
    if (c != ' ' && c != '\t' && c != '\r') return false;
    ++pos_;
  }
}

void TextTokenizer::skip_line() {
  for (;;) {
    if (pos_ == end_ && fill(1) == 0) return;
    const char* begin = buffer_.data() + pos_;
    const char* nl = static_cast<const char*>(std::memchr(begin, '\n', end_ - pos_));
    if (nl) {
      pos_ += size_t(nl - begin) + 1;
      ++line_;
      return;
    }
    pos_ = end_;
  }
}

std::optional<std::string_view> TextTokenizer::read_line(size_t max_length) {
  max_length = std::min(max_length, buffer_.size() - 1);  // longer lines cannot be held (or, in small files, exist)
  if (pos_ == end_ && fill(1) == 0) return std::nullopt;
  token_offset_ = offset();
  token_line_ = line_;
  size_t length = 0;
  bool newline = false;
  for (;;) {
    const char* begin = buffer_.data() + pos_ + length;
    const char* nl = static_cast<const char*>(std::memchr(begin, '\n', end_ - pos_ - length));
    if (nl) {
      length += size_t(nl - begin);
      newline = true;
      break;
    }
    length = available();
    if (length > max_length) break;
    if (fill(length + 1) == length) break;  // last line, without LF
  }
  if (length > max_length) fail_at_token_line("a line longer than " + std::to_string(max_length) + " bytes");
  std::string_view text(buffer_.data() + pos_, length);
  pos_ += length + (newline ? 1 : 0);
  if (newline) ++line_;
  if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
  return text;
}

template <class T>
T TextTokenizer::next_number(std::string_view what) {
  const std::string_view token = next_token();
  T value{};
  if (token.empty()) fail_at_token_line("unexpected end of file: expected " + std::string(what));
  if (!parse_number(token, value)) {
    const char* kind = std::is_floating_point_v<T> ? "a number" : (std::is_signed_v<T> ? "an integer" : "a count");
    std::string range;
    if constexpr (std::is_integral_v<T>) {
      range = " in [" + std::to_string(std::numeric_limits<T>::min()) + ", " +
              std::to_string(std::numeric_limits<T>::max()) + "]";
    }
    fail_at_token_line("expected " + std::string(kind) + range + " for " + std::string(what) + ", found " +
                       quoted(token));
  }
  return value;
}

#define UGVR_NEXT_NUMBER(T) template T TextTokenizer::next_number<T>(std::string_view);
UGVR_NEXT_NUMBER(int8_t)
UGVR_NEXT_NUMBER(uint8_t)
UGVR_NEXT_NUMBER(int16_t)
UGVR_NEXT_NUMBER(uint16_t)
UGVR_NEXT_NUMBER(int32_t)
UGVR_NEXT_NUMBER(uint32_t)
UGVR_NEXT_NUMBER(int64_t)
UGVR_NEXT_NUMBER(uint64_t)
UGVR_NEXT_NUMBER(float)
UGVR_NEXT_NUMBER(double)
#undef UGVR_NEXT_NUMBER

void TextTokenizer::read_bytes(void* dst, size_t n) {
  if (n > bytes_left()) {
    fail_at_offset(file_.path(), offset(),
                   "unexpected end of file: needed " + std::to_string(n) + " bytes, the file has " +
                       std::to_string(bytes_left()) + " left");
  }
  auto* out = static_cast<char*>(dst);
  const size_t from_buffer = std::min(n, available());
  std::memcpy(out, buffer_.data() + pos_, from_buffer);
  pos_ += from_buffer;
  out += from_buffer;
  n -= from_buffer;
  if (n == 0) return;
  if (n >= buffer_.size() / 2) {
    // Large blocks go straight from the file into place; the (now empty) buffer restarts after them.
    file_.read_at(offset(), out, n);
    buffer_offset_ = offset() + n;
    pos_ = end_ = 0;
    return;
  }
  if (fill(n) < n) fail_at_offset(file_.path(), offset(), "unexpected end of file (file shrank while reading)");
  std::memcpy(out, buffer_.data() + pos_, n);
  pos_ += n;
}

void TextTokenizer::skip_bytes(uint64_t n) {
  if (n > bytes_left()) {
    fail_at_offset(file_.path(), offset(),
                   "unexpected end of file: a block of " + std::to_string(n) + " bytes starts here, the file has " +
                       std::to_string(bytes_left()) + " left");
  }
  if (n <= available()) {
    pos_ += size_t(n);
    return;
  }
  buffer_offset_ = offset() + n;
  pos_ = end_ = 0;
}

void TextTokenizer::fail_at_token_line(std::string_view message) const {
  fail_at_line(file_.path(), token_line_, message);
}

void TextTokenizer::fail_at_token_offset(std::string_view message) const {
  fail_at_offset(file_.path(), token_offset_, message);
}

}  // namespace ugvr
