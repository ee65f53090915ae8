// TextTokenizer: buffered, forward-only reading of a text (or mixed text and binary) file through InputFile, for the
// ASCII readers. The file is read in chunks, never whole, so memory stays at one chunk however large the input.
//
// It tracks the byte offset and the 1-based line of the next unread byte, and remembers where the last token began,
// so that a reader can fail with "FILE:LINE: ..." (text) or "FILE: byte N: ..." (binary) naming the exact spot.
// Line counting covers the text methods only: bytes taken with read_bytes()/skip_bytes() are binary and their
// newline bytes are not counted (formats that mix text and binary report binary positions as byte offsets).
//
// A tokenizer may start at any offset of the file with a known line number, so a reader can remember a position
// (mark()) and come back to it later with a second tokenizer while the first one goes on (the legacy VTK reader reads
// cell connectivity this way once it has seen the cell types that follow it).
//
// Whitespace is space, tab, CR, LF, VT and FF. Tokens are bounded (max_token) so that a hostile file without
// whitespace cannot make the buffer grow: such a token fails instead.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/file.h"

namespace ugvr {

class TextTokenizer {
 public:
  static constexpr size_t kDefaultChunk = size_t(1) << 20;
  static constexpr size_t kMaxToken = size_t(64) << 10;

  // A position to come back to: the offset of a byte and the line it is on.
  struct Mark {
    uint64_t offset = 0;
    uint64_t line = 1;
  };

  // Reads `file` (which must outlive the tokenizer) from `start`, or from its beginning. `chunk` is the buffer size
  // (at least 2 * kMaxToken; less when the rest of the file is smaller).
  TextTokenizer(const InputFile& file, Mark start, size_t chunk = kDefaultChunk);
  explicit TextTokenizer(const InputFile& file) : TextTokenizer(file, Mark{0, 1}) {}

  const InputFile& file() const { return file_; }
  // Offset and line of the next unread byte.
  uint64_t offset() const { return buffer_offset_ + pos_; }
  uint64_t line() const { return line_; }
  Mark mark() const { return {offset(), line_}; }
  uint64_t bytes_left() const { return file_.size() - offset(); }
  bool at_end() const { return offset() >= file_.size(); }
  // Where the token most recently returned by next_token() (or peeked) began.
  uint64_t token_offset() const { return token_offset_; }
  uint64_t token_line() const { return token_line_; }

  // Skips whitespace, newlines included; returns false at the end of the file.
  bool skip_space();
  // The next whitespace-separated token, or an empty view at the end of the file. The view stays valid until the next
  // call on this tokenizer. A token longer than kMaxToken fails.
  std::string_view next_token();
  // The next token without consuming it (the whitespace before it is consumed).
  std::string_view peek_token();

  // Skips spaces, tabs and CR on the current line; true when the line has nothing more (next byte is LF, or end of
  // file). Does not consume the LF.
  bool at_line_end();
  // Consumes the rest of the current line including its LF (or up to the end of the file).
  void skip_line();
  // The rest of the current line without its LF and trailing CR, consuming the LF; nullopt at the end of the file.
  // Fails if the line is longer than max_length.
  std::optional<std::string_view> read_line(size_t max_length = kMaxToken);

  // Parses the next token as a number of type T (any integer or floating type); fails naming `what` and the line.
  template <class T>
  T next_number(std::string_view what);

  // Binary: exactly n bytes / skip n bytes; fails at the current offset if the file has fewer left.
  void read_bytes(void* dst, size_t n);
  void skip_bytes(uint64_t n);

  // "FILE:LINE: message" at the line of the last token / "FILE: byte N: message" at the last token's offset.
  [[noreturn]] void fail_at_token_line(std::string_view message) const;
  [[noreturn]] void fail_at_token_offset(std::string_view message) const;

 private:
  // Makes at least `want` bytes available from pos_ when the file has them (moving the unread bytes to the front of
  // the buffer first); returns the count available.
  size_t fill(size_t want);
  size_t available() const { return end_ - pos_; }

  const InputFile& file_;
  std::vector<char> buffer_;
  uint64_t buffer_offset_ = 0;  // file offset of buffer_[0]
  size_t pos_ = 0, end_ = 0;    // unread bytes are buffer_[pos_, end_)
  uint64_t line_ = 1;
  uint64_t token_offset_ = 0, token_line_ = 1;
};

// Parses the whole of `text` as a number of type T (any integer or floating type). A leading '+' is accepted;
// floating values accept "nan" and "inf", and values beyond the type's range become +-inf or 0 as strtod would.
// Integers out of range are rejected.
template <class T>
bool parse_number(std::string_view text, T& value);

// Case-insensitive ASCII comparison (keywords of text formats).
bool equals_ignore_case(std::string_view a, std::string_view b);
bool starts_with_ignore_case(std::string_view s, std::string_view prefix);

}  // namespace ugvr
