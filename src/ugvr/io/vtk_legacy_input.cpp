#include "ugvr/io/vtk_legacy_input.h"

#include <bit>
#include <cstring>
#include <limits>
#include <type_traits>

#include "ugvr/core/error.h"
#include "ugvr/io/byte_swap.h"

namespace ugvr::vtk_legacy {

namespace {

std::string lower_copy(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = (c >= 'A' && c <= 'Z') ? char(c - 'A' + 'a') : c;
  return out;
}

std::string printable(std::string_view token) {
  std::string s = "'";
  for (char c : token.substr(0, 40)) s += (c >= 32 && c < 127) ? c : '?';
  return s + (token.size() > 40 ? "...'" : "'");
}

// BINARY legacy files are big-endian whatever machine wrote them.
template <class T>
void from_big_endian(std::span<T> values) {
  if constexpr (std::endian::native == std::endian::little)
    swap_bytes(std::as_writable_bytes(values).data(), values.size(), sizeof(T));
}

// Calls f(T{}) with the C++ type of a ScalarType.
template <class F>
decltype(auto) with_scalar_type(ScalarType t, F&& f) {
  switch (t) {
    case ScalarType::Int8: return f(int8_t{});
    case ScalarType::UInt8: return f(uint8_t{});
    case ScalarType::Int16: return f(int16_t{});
    case ScalarType::UInt16: return f(uint16_t{});
    case ScalarType::Int32: return f(int32_t{});
    case ScalarType::UInt32: return f(uint32_t{});
    case ScalarType::Int64: return f(int64_t{});
    case ScalarType::UInt64: return f(uint64_t{});
    case ScalarType::Float32: return f(float{});
    case ScalarType::Float64: break;
  }
  return f(double{});
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

std::optional<ValueType> parse_value_type(std::string_view name) {
  struct Entry {
    std::string_view name;
    ScalarType stored;
    uint8_t file_bytes;
    bool is_string;
  };
  static constexpr Entry kTypes[] = {
      {"bit", ScalarType::UInt8, 0, false},
      {"char", ScalarType::Int8, 1, false},
      {"signed_char", ScalarType::Int8, 1, false},
      {"unsigned_char", ScalarType::UInt8, 1, false},
      {"short", ScalarType::Int16, 2, false},
      {"unsigned_short", ScalarType::UInt16, 2, false},
      {"int", ScalarType::Int32, 4, false},
      {"unsigned_int", ScalarType::UInt32, 4, false},
      // "long" is written with the writer's sizeof(long): 8 bytes on the LP64 systems that write VTK files.
      {"long", ScalarType::Int64, 8, false},
      {"unsigned_long", ScalarType::UInt64, 8, false},
      {"vtktypeint64", ScalarType::Int64, 8, false},
      {"vtktypeuint64", ScalarType::UInt64, 8, false},
      // vtkDataWriter writes vtkIdType arrays as 32-bit ints in BINARY files; VTK reads them back as 64-bit ids.
      {"vtkidtype", ScalarType::Int64, 4, false},
      {"float", ScalarType::Float32, 4, false},
      {"double", ScalarType::Float64, 8, false},
      {"string", ScalarType::UInt8, 1, true},
      {"utf8_string", ScalarType::UInt8, 1, true},
  };
  const std::string lower = lower_copy(name);
  for (const Entry& e : kTypes) {
    if (lower == e.name) return ValueType{std::string(e.name), e.stored, e.file_bytes, e.is_string};
  }
  return std::nullopt;
}

std::string decode_name(std::string_view encoded) {
  std::string out;
  out.reserve(encoded.size());
  for (size_t i = 0; i < encoded.size(); ++i) {
    if (encoded[i] == '%' && i + 2 < encoded.size()) {
      const int hi = hex_digit(encoded[i + 1]), lo = hex_digit(encoded[i + 2]);
      if (hi >= 0 && lo >= 0) {
        out += char(hi * 16 + lo);
        i += 2;
        continue;
      }
    }
    out += encoded[i];
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// LegacyInput

LegacyInput::LegacyInput(const InputFile& file, bool binary, TextTokenizer::Mark start)
    : tokens_(file, start), binary_(binary) {}

void LegacyInput::fail(std::string_view message) const {
  if (binary_) tokens_.fail_at_token_offset(message);
  tokens_.fail_at_token_line(message);
}

void LegacyInput::fail_at(TextTokenizer::Mark where, std::string_view message) const {
  if (binary_) fail_at_offset(path(), where.offset, message);
  fail_at_line(path(), where.line, message);
}

std::string_view LegacyInput::word(std::string_view what) {
  const std::string_view token = tokens_.next_token();
  if (token.empty()) fail("unexpected end of file: expected " + std::string(what));
  return token;
}

template <class T>
T LegacyInput::number(std::string_view what, std::string_view expected) {
  const std::string_view token = word(what);
  T value{};
  if (!parse_number(token, value)) {
    fail("expected " + std::string(expected) + " for " + std::string(what) + ", found " + printable(token));
  }
  return value;
}

uint64_t LegacyInput::count(std::string_view what) { return number<uint64_t>(what, "a count"); }

int LegacyInput::components(std::string_view what) {
  const uint64_t n = count(what);
  if (n < 1 || n > uint64_t(kMaxComponents)) {
    fail(std::string(what) + " must be between 1 and " + std::to_string(kMaxComponents) + ", not " + std::to_string(n));
  }
  return int(n);
}

double LegacyInput::real(std::string_view what) { return number<double>(what, "a number"); }

ValueType LegacyInput::value_type(std::string_view what) {
  const std::string_view token = word(what);
  std::optional<ValueType> t = parse_value_type(token);
  if (!t) {
    fail("unknown data type " + printable(token) + " for " + std::string(what) +
         " (expected bit, char, unsigned_char, short, unsigned_short, int, unsigned_int, long, unsigned_long, "
         "vtktypeint64, vtktypeuint64, vtkIdType, float or double)");
  }
  return *t;
}

void LegacyInput::expect_keyword(std::string_view keyword) {
  const std::string_view token = word(keyword);
  if (!equals_ignore_case(token, keyword)) {
    fail("expected " + std::string(keyword) + ", found " + printable(token));
  }
}

void LegacyInput::check_fits(std::string_view what, uint64_t values, uint64_t binary_bytes_each) {
  const uint64_t left = tokens_.bytes_left();
  if (binary_) {
    if (binary_bytes_each == 0) {  // packed bits
      if (values / 8 + (values % 8 != 0) > left) {
        fail_at_offset(path(), tokens_.offset(),
                       std::string(what) + ": " + std::to_string(values) + " bits need more than the " +
                           std::to_string(left) + " bytes left in the file");
      }
      return;
    }
    check_count_fits(path(), tokens_.offset(), what, values, binary_bytes_each, left);
    return;
  }
  // ASCII: every value but the last needs a separator after it, so n values take at least 2n - 1 bytes.
  if (values > (left + 1) / 2) {
    fail_at_line(path(), tokens_.line(),
                 std::string(what) + " count " + std::to_string(values) +
                     " needs at least 2 bytes per value but only " + std::to_string(left) +
                     " bytes remain in the file");
  }
}

uint64_t LegacyInput::value_count(std::string_view what, uint64_t tuples, int components) {
  if (components > 0 && tuples > std::numeric_limits<uint64_t>::max() / uint64_t(components)) {
    fail(std::string(what) + ": " + std::to_string(tuples) + " tuples of " + std::to_string(components) +
         " components is more values than can exist");
  }
  return tuples * uint64_t(components);
}

void LegacyInput::begin_block() {
  if (binary_) tokens_.skip_line();
}

DataArray LegacyInput::read_array(const ValueType& type, uint64_t tuples, int components, std::string_view what) {
  if (type.is_string) fail(std::string(what) + ": string arrays cannot be read as numbers");
  const uint64_t n = value_count(what, tuples, components);
  begin_block();
  check_fits(what, n, type.file_bytes);
  DataArray array(type.stored, components, tuples);
  array.visit([&](auto values) { read_values(type, values, what, 0); });
  skip_metadata(components);
  return array;
}

template <class T>
void LegacyInput::read_values(const ValueType& type, std::span<T> out, std::string_view what, uint64_t first) {
  if (!binary_) {
    if constexpr (std::is_same_v<T, uint8_t>) {
      if (type.is_bit()) {
        // VTK reads each bit as an int and stores "is it non-zero".
        for (size_t i = 0; i < out.size(); ++i) {
          const std::string_view token = tokens_.next_token();
          int64_t v = 0;
          if (!parse_number(token, v)) fail_value(what, first + i, token, true);
          out[i] = v != 0;
        }
        return;
      }
    }
    read_ascii(out, what, first);
    return;
  }
  if constexpr (std::is_same_v<T, uint8_t>) {
    if (type.is_bit()) {
      // Most significant bit first (vtkBitArray). Bit arrays are read whole, so `out` starts on a byte.
      std::vector<uint8_t> packed(out.size() / 8 + (out.size() % 8 != 0));
      tokens_.read_bytes(packed.data(), packed.size());
      for (size_t i = 0; i < out.size(); ++i) out[i] = (packed[i / 8] >> (7 - i % 8)) & 1;
      return;
    }
  }
  if (type.file_bytes == sizeof(T)) {
    tokens_.read_bytes(out.data(), out.size_bytes());
    from_big_endian(out);
    return;
  }
  if constexpr (std::is_same_v<T, int64_t>) {
    if (type.file_bytes == 4) {  // vtkIdType, written as 32-bit ints
      std::vector<int32_t> narrow(std::min<size_t>(out.size(), kChunkValues));
      for (size_t done = 0; done < out.size();) {
        const size_t n = std::min(narrow.size(), out.size() - done);
        tokens_.read_bytes(narrow.data(), n * sizeof(int32_t));
        from_big_endian(std::span<int32_t>(narrow.data(), n));
        for (size_t i = 0; i < n; ++i) out[done + i] = narrow[i];
        done += n;
      }
      return;
    }
  }
  fail(std::string(what) + ": data type " + type.name + " cannot be read here");  // not reached for known types
}

template <class T>
void LegacyInput::read_ascii(std::span<T> out, std::string_view what, uint64_t first) {
  for (size_t i = 0; i < out.size(); ++i) {
    const std::string_view token = tokens_.next_token();
    if (!parse_number(token, out[i])) fail_value(what, first + i, token, std::is_integral_v<T>);
  }
}

void LegacyInput::fail_value(std::string_view what, uint64_t index, std::string_view token, bool integer) {
  if (token.empty()) {
    fail("unexpected end of file in " + std::string(what) + ": value " + std::to_string(index) + " is missing");
  }
  fail(std::string("expected ") + (integer ? "an integer of the declared type" : "a number") + " for " +
       std::string(what) + " (value " + std::to_string(index) + "), found " + printable(token));
}

template <class V>
void LegacyInput::read_converted(const ValueType& type, std::span<V> out, std::string_view what, uint64_t first) {
  if (type.is_bit() || type.is_string) fail(std::string(what) + " cannot be of type " + type.name);
  with_scalar_type(type.stored, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_same_v<T, V>) {
      read_values(type, out, what, first);
    } else if constexpr (std::is_integral_v<V> && std::is_floating_point_v<T>) {
      fail(std::string(what) + " must be integers, not " + type.name);
    } else {
      std::vector<T> raw(out.size());
      read_values(type, std::span<T>(raw), what, first);
      for (size_t i = 0; i < raw.size(); ++i) {
        if constexpr (std::is_same_v<T, uint64_t> && std::is_same_v<V, int64_t>) {
          if (raw[i] > uint64_t(std::numeric_limits<int64_t>::max())) {
            fail(std::string(what) + ": value " + std::to_string(first + i) + " (" + std::to_string(raw[i]) +
                 ") is too large");
          }
        }
        out[i] = V(raw[i]);
      }
    }
  });
}

template void LegacyInput::read_converted<int64_t>(const ValueType&, std::span<int64_t>, std::string_view, uint64_t);
template void LegacyInput::read_converted<double>(const ValueType&, std::span<double>, std::string_view, uint64_t);

DeferredArray LegacyInput::skip_array(const ValueType& type, uint64_t tuples, int components, std::string_view what) {
  const uint64_t n = value_count(what, tuples, components);
  if (type.is_string) {
    skip_string_array(n, what);
    return {};
  }
  begin_block();
  check_fits(what, n, type.file_bytes);
  const DeferredArray deferred{tokens_.mark(), type, n};
  if (binary_) {
    // check_fits has bounded n * file_bytes by the bytes left, so the product cannot overflow.
    tokens_.skip_bytes(type.is_bit() ? n / 8 + (n % 8 != 0) : n * type.file_bytes);
  } else {
    with_scalar_type(type.stored, [&](auto tag) {
      using T = decltype(tag);
      std::vector<T> chunk(size_t(std::min(n, kChunkValues)));
      for (uint64_t done = 0; done < n;) {
        const size_t k = size_t(std::min<uint64_t>(n - done, chunk.size()));
        read_values(type, std::span<T>(chunk.data(), k), what, done);
        done += k;
      }
    });
  }
  skip_metadata(components);
  return deferred;
}

DeferredArray LegacyInput::pass_over_array(const ValueType& type, uint64_t tuples, int components,
                                           std::string_view what) {
  if (!binary_ && !type.is_string) {
    const uint64_t n = value_count(what, tuples, components);
    begin_block();
    check_fits(what, n, type.file_bytes);
    const DeferredArray deferred{tokens_.mark(), type, n};
    for (uint64_t i = 0; i < n; ++i)
      if (tokens_.next_token().empty()) fail_value(what, i, {}, type.is_integer());
    skip_metadata(components);
    return deferred;
  }
  return skip_array(type, tuples, components, what);  // BINARY: a seek; string arrays have their own layout
}

void LegacyInput::skip_string_array(uint64_t values, std::string_view what) {
  // Both layouts spend at least one byte per string (its newline, or its length byte).
  tokens_.skip_line();  // the rest of the header line
  check_count_fits(path(), tokens_.offset(), what, values, 1, tokens_.bytes_left());
  for (uint64_t i = 0; i < values; ++i) {
    if (tokens_.at_end()) fail_at(tokens_.mark(), "unexpected end of file in string array " + std::string(what));
    if (!binary_) {
      tokens_.skip_line();
      continue;
    }
    // vtkDataWriter: the top two bits of the first byte give the size of a big-endian length (11: 6 bits in that
    // byte, 10: 14 bits in 2 bytes, 01: 30 bits in 4 bytes, 00: 8 bytes).
    uint8_t head[8] = {};
    tokens_.read_bytes(head, 1);
    const int kind = head[0] >> 6;
    const size_t length_bytes = kind == 3 ? 1 : kind == 2 ? 2 : kind == 1 ? 4 : 8;
    if (length_bytes > 1) tokens_.read_bytes(head + 1, length_bytes - 1);
    uint64_t length = head[0] & (kind == 0 ? 0xff : 0x3f);
    for (size_t b = 1; b < length_bytes; ++b) length = (length << 8) | head[b];
    tokens_.skip_bytes(length);
  }
  skip_metadata(1);
}

void LegacyInput::skip_lookup_table(uint64_t entries) {
  const uint64_t n = value_count("LOOKUP_TABLE", entries, 4);
  begin_block();
  check_fits("LOOKUP_TABLE", n, 1);
  if (binary_) {
    tokens_.skip_bytes(n);
    return;
  }
  std::vector<float> chunk(size_t(std::min(n, kChunkValues)));
  for (uint64_t done = 0; done < n;) {
    const size_t k = size_t(std::min<uint64_t>(n - done, chunk.size()));
    read_ascii(std::span<float>(chunk.data(), k), "LOOKUP_TABLE", done);
    done += k;
  }
}

void LegacyInput::skip_metadata(int components) {
  if (!equals_ignore_case(tokens_.peek_token(), "METADATA")) return;
  tokens_.next_token();
  tokens_.skip_line();
  skip_metadata_body(components);
}

void LegacyInput::skip_metadata_body(int components) {
  // Line by line, as VTK reads it: a blank line (or the end of the file) ends the block. COMPONENT_NAMES is followed
  // by exactly one line per component, which may be anything, so those lines are skipped without looking at them.
  for (;;) {
    if (tokens_.at_end()) return;
    if (tokens_.at_line_end()) {
      tokens_.skip_line();
      return;
    }
    const bool names = starts_with_ignore_case(tokens_.peek_token(), "COMPONENT_NAMES");
    tokens_.skip_line();
    for (int i = 0; names && i < components && !tokens_.at_end(); ++i) tokens_.skip_line();
  }
}

// ---------------------------------------------------------------------------------------------------------------
// ValueCursor

ValueCursor::ValueCursor(const InputFile& file, bool binary, const DeferredArray& array, std::string what)
    : input_(file, binary, array.start),
      type_(array.type),
      what_(std::move(what)),
      left_(array.count),
      unread_(array.count),
      buffer_offset_(array.start.offset) {
  if (!type_.is_integer() || type_.is_bit() || type_.is_string) {
    input_.fail_at(array.start, what_ + " must be integers, not " + type_.name);
  }
}

void ValueCursor::refill() {
  buffer_.resize(size_t(std::min<uint64_t>(unread_, 4096)));
  buffer_offset_ = input_.tokens().offset();
  input_.read_converted<int64_t>(type_, std::span<int64_t>(buffer_), what_, read_);
  read_ += buffer_.size();
  unread_ -= buffer_.size();
  pos_ = 0;
}

int64_t ValueCursor::next() {
  if (left_ == 0) fail(what_ + ": read past its " + std::to_string(read_) + " values");
  --left_;
  if (!input_.binary()) {
    // Straight from the tokenizer, so that an error names the line of this very value.
    const std::string_view token = input_.tokens().next_token();
    int64_t v = 0;
    if (!parse_number(token, v)) {
      fail(token.empty() ? "unexpected end of file in " + what_
                         : "expected an integer for " + what_ + " (value " + std::to_string(read_) + "), found " +
                               printable(token));
    }
    ++read_;
    return v;
  }
  if (pos_ == buffer_.size()) refill();
  return buffer_[pos_++];
}

void ValueCursor::take(std::span<int64_t> out) {
  for (int64_t& v : out) v = next();
}

void ValueCursor::fail(std::string_view message) const {
  if (!input_.binary()) input_.fail(message);
  const uint64_t value = pos_ > 0 ? pos_ - 1 : 0;
  fail_at_offset(input_.path(), buffer_offset_ + value * type_.file_bytes, message);
}

}  // namespace ugvr::vtk_legacy
