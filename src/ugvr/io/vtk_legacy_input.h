// Building blocks of the legacy VTK reader (vtk_legacy_reader.cpp documents the format): the data types a legacy file
// names, and LegacyInput, a TextTokenizer that knows whether the file is ASCII or BINARY and reads typed arrays the
// way vtkDataReader::ReadArray does (binary data starts after the rest of the header line, is big-endian, and may be
// followed by a METADATA block). Errors name the line in ASCII files and the byte offset in BINARY ones.
// Internal to the reader; not part of the public io API.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/grid/data_array.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr::vtk_legacy {

// A data type as a legacy file names it ("float", "vtktypeint64", ...).
struct ValueType {
  std::string name;        // lower case, as in messages
  ScalarType stored{};     // the DataArray type values are kept in
  uint8_t file_bytes = 0;  // bytes per value in BINARY files; 0 for "bit" (packed, most significant bit first)
  bool is_string = false;  // "string" / "utf8_string": skipped, never kept

  bool is_bit() const { return !is_string && file_bytes == 0; }
  bool is_integer() const { return stored != ScalarType::Float32 && stored != ScalarType::Float64; }
};

// nullopt for names legacy VTK does not define (matched case-insensitively, as VTK does).
std::optional<ValueType> parse_value_type(std::string_view name);

// Array names in legacy files escape bytes as %XX (VTK writes spaces as %20); malformed escapes stay as they are.
std::string decode_name(std::string_view encoded);

// Where an array's data starts, to be read later with a ValueCursor.
struct DeferredArray {
  TextTokenizer::Mark start;
  ValueType type;
  uint64_t count = 0;
};

class LegacyInput {
 public:
  static constexpr int kMaxComponents = 1 << 20;
  static constexpr uint64_t kChunkValues = uint64_t(1) << 16;

  LegacyInput(const InputFile& file, bool binary, TextTokenizer::Mark start = {});

  TextTokenizer& tokens() { return tokens_; }
  const std::string& path() const { return tokens_.file().path(); }
  bool binary() const { return binary_; }
  void set_binary(bool binary) { binary_ = binary; }

  // Fails at the last token: its line in ASCII files, its byte offset in BINARY ones.
  [[noreturn]] void fail(std::string_view message) const;
  // Fails at a remembered position, reported the same way.
  [[noreturn]] void fail_at(TextTokenizer::Mark where, std::string_view message) const;

  // Header words. `what` says what was expected, for the message at the end of the file or on a bad value.
  std::string_view word(std::string_view what);
  uint64_t count(std::string_view what);
  int components(std::string_view what);
  double real(std::string_view what);
  ValueType value_type(std::string_view what);
  void expect_keyword(std::string_view keyword);

  // Fails unless `values` values of at least `bytes_each` bytes (ASCII: 2, a digit and a separator) can still be in
  // the file: counts are checked against the bytes left before anything is allocated.
  void check_fits(std::string_view what, uint64_t values, uint64_t binary_bytes_each);
  // values = tuples * components, failing instead of overflowing.
  uint64_t value_count(std::string_view what, uint64_t tuples, int components);

  // In BINARY files the data of a block starts after the line of its keyword (VTK consumes the rest of that line);
  // a no-op in ASCII files. Called once before each block.
  void begin_block();

  // A whole array in its stored type (BINARY values byte-swapped from big-endian), then any METADATA after it.
  DataArray read_array(const ValueType& type, uint64_t tuples, int components, std::string_view what);
  // Starts reading `count` values of an array piece by piece: begin_block(), then the count check. Then call
  // read_chunks() and, after the array, skip_metadata().
  void begin_array(const ValueType& type, uint64_t count, std::string_view what) {
    begin_block();
    check_fits(what, count, type.file_bytes);
  }
  // Reads `count` values converted to V (int64_t or double) in chunks, calling f(first, std::span<const V>) for each
  // (`first` is the index of the chunk's first value). Integer values that do not fit in V fail; `type` must not be
  // bit or string.
  template <class V, class F>
  void read_chunks(const ValueType& type, uint64_t count, std::string_view what, F&& f) {
    std::vector<V> chunk;
    for (uint64_t done = 0; done < count;) {
      chunk.resize(size_t(std::min<uint64_t>(count - done, kChunkValues)));
      read_converted(type, std::span<V>(chunk), what, done);
      f(done, std::span<const V>(chunk));
      done += chunk.size();
    }
  }
  // Skips an array (checking that it is there and, in ASCII, that its values are numbers); returns where its data
  // starts, to be read later with a ValueCursor.
  DeferredArray skip_array(const ValueType& type, uint64_t tuples, int components, std::string_view what);
  // Passes over an array without looking at its values (a fields-only step read's points and cells, whose stored
  // bytes a geometry key has shown to be those of a mesh read whole): BINARY seeks past its bytes, ASCII counts its
  // words without parsing them. Returns where its data starts, as skip_array does.
  DeferredArray pass_over_array(const ValueType& type, uint64_t tuples, int components, std::string_view what);
  // Skips a string array (VTK: one line per value in ASCII, length-prefixed in BINARY).
  void skip_string_array(uint64_t values, std::string_view what);
  // Skips "LOOKUP_TABLE name size" data: size RGBA entries (bytes in BINARY, numbers in ASCII).
  void skip_lookup_table(uint64_t entries);

  // VTK 5.1 writes "METADATA" after an array: lines (COMPONENT_NAMES followed by one name per component,
  // INFORMATION n followed by NAME/DATA lines) up to a blank line. Skips such a block if one comes next.
  void skip_metadata(int components);
  // The body of a METADATA block whose keyword line has been consumed.
  void skip_metadata_body(int components);

  // Reads out.size() values of `type` converted to V; `first` (the index of out[0] in its array) is for messages.
  template <class V>
  void read_converted(const ValueType& type, std::span<V> out, std::string_view what, uint64_t first);

 private:
  // The next word parsed as a T; fails saying that `expected` ("a count") was expected for `what`.
  template <class T>
  T number(std::string_view what, std::string_view expected);
  template <class T>
  void read_values(const ValueType& type, std::span<T> out, std::string_view what, uint64_t first);
  template <class T>
  void read_ascii(std::span<T> out, std::string_view what, uint64_t first);
  [[noreturn]] void fail_value(std::string_view what, uint64_t index, std::string_view token, bool integer);

  TextTokenizer tokens_;
  bool binary_;
};

// Integer values of a deferred array read in order (cell connectivity, offsets and types, which the reader combines
// only after it has seen all three). Errors name the line of the value (ASCII) or its byte offset (BINARY).
class ValueCursor {
 public:
  ValueCursor(const InputFile& file, bool binary, const DeferredArray& array, std::string what);

  uint64_t left() const { return left_; }
  // The next value; the caller keeps within count.
  int64_t next();
  void take(std::span<int64_t> out);
  // Fails at the value read last.
  [[noreturn]] void fail(std::string_view message) const;

 private:
  void refill();

  LegacyInput input_;
  ValueType type_;
  std::string what_;
  uint64_t left_;                // values not yet returned
  uint64_t unread_;              // values not yet read from the file (BINARY reads ahead into buffer_)
  uint64_t read_ = 0;            // values read from the file so far
  std::vector<int64_t> buffer_;  // BINARY only (ASCII values come straight from the tokenizer)
  size_t pos_ = 0;
  uint64_t buffer_offset_ = 0;  // file offset of buffer_[0]
};

}  // namespace ugvr::vtk_legacy
