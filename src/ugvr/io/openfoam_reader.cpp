// OpenFOAM case reader (format notes in openfoam_reader.h).
//
// Model: the case's internal mesh is one UnstructuredMesh. Each OpenFOAM cell is the list of faces that name it as
// owner or neighbour; it goes through PolyhedronDecomposer, which keeps hexahedra, prisms, pyramids and tetrahedra as
// native cells and splits any other polyhedron conformingly (grid/polyhedra.h). Fields are cell-centred and stay cell
// data (repeated on the pieces of a split cell); point fields (pointScalarField, ...) are vertex data. A decomposed
// case (processor*/) is read piece by piece and concatenated in processor order: points on processor boundaries are
// not merged, so they appear once per piece. One time directory is read (ReadOptions::time_step, an index into the
// time directories sorted by value, 0 included; -1 = the latest); the others are listed in the dataset's notes.
// cellZones become an Int32 cell field "cellZone" (the zone's index, -1 outside every zone).
#include "ugvr/io/openfoam_reader.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <map>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/memory.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/grid/polyhedra.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/byte_swap.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/header_counts.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/saturating_size.h"
#include "ugvr/io/step_lists.h"

namespace fs = std::filesystem;

namespace ugvr {
namespace openfoam {
namespace {

// gzip output beyond this ratio to its input cannot come from deflate (whose limit is about 1032:1): the stream is
// corrupt (the check also bounds the time a hostile stream can take).
constexpr uint64_t kMaxInflateRatio = 1032;

// A gzip file's counts are not checked against its (unknown) inflated size: vectors reserve at most this much up
// front and grow as values arrive.
constexpr uint64_t kMaxReserveBytes = uint64_t(4) << 20;

constexpr bool is_delimiter(char c) {
  return c == '(' || c == ')' || c == '{' || c == '}' || c == '[' || c == ']' || c == ';' || c == '"';
}
constexpr bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\f' || c == '\v'; }

// Bytes a word may hold: neither space nor delimiter nor '/' (a '/' is a word byte unless it starts a comment: the
// slow path decides).
constexpr auto kWordByte = [] {
  std::array<bool, 256> t{};
  for (int c = 0; c < 256; ++c) t[size_t(c)] = !is_space(char(c)) && !is_delimiter(char(c)) && c != '/';
  return t;
}();

// Components of an OpenFOAM primitive type name; 0 for one that is not a fixed-size number tuple.
int components_of(std::string_view type) {
  if (type == "scalar" || type == "label" || type == "sphericalTensor") return 1;
  if (type == "vector") return 3;
  if (type == "symmTensor") return 6;
  if (type == "tensor") return 9;
  return 0;
}

}  // namespace

// A byte stream: read() returns up to n bytes, 0 only at its end.
struct FoamFile::Source {
  virtual ~Source() = default;
  virtual size_t read(char* dst, size_t n) = 0;
};

namespace {

struct FileSource final : FoamFile::Source {
  explicit FileSource(const std::string& path) : file(path) {}
  size_t read(char* dst, size_t n) override {
    const size_t got = file.read_some_at(offset, dst, n);
    offset += got;
    return got;
  }
  InputFile file;
  uint64_t offset = 0;
};

struct MemorySource final : FoamFile::Source {
  explicit MemorySource(std::string b) : bytes(std::move(b)) {}
  size_t read(char* dst, size_t n) override {
    const size_t got = std::min<size_t>(n, bytes.size() - offset);
    std::memcpy(dst, bytes.data() + offset, got);
    offset += got;
    return got;
  }
  std::string bytes;
  size_t offset = 0;
};

// Inflates gzip (or zlib) data read from another source, a chunk at a time. Errors name the compressed offset.
struct InflateSource final : FoamFile::Source {
  InflateSource(std::string name_, std::unique_ptr<FoamFile::Source> in_, uint64_t in_size)
      : name(std::move(name_)), in(std::move(in_)), limit(kMaxInflateRatio * in_size + 4096), chunk(64 << 10, '\0') {
    if (inflateInit2(&z, 15 + 32) != Z_OK) throw Error("zlib: inflateInit2 failed");  // 32: gzip or zlib header
  }
  ~InflateSource() override { inflateEnd(&z); }
  InflateSource(const InflateSource&) = delete;
  InflateSource& operator=(const InflateSource&) = delete;

  size_t read(char* dst, size_t n) override {
    if (done || n == 0) return 0;
    z.next_out = reinterpret_cast<Bytef*>(dst);
    z.avail_out = uInt(std::min<size_t>(n, UINT32_MAX));
    while (z.avail_out == uInt(std::min<size_t>(n, UINT32_MAX))) {  // until something comes out
      if (z.avail_in == 0 && !in_end) {
        const size_t got = in->read(chunk.data(), chunk.size());
        if (got == 0) in_end = true;
        z.next_in = reinterpret_cast<Bytef*>(chunk.data());
        z.avail_in = uInt(got);
      }
      const int r = inflate(&z, Z_NO_FLUSH);
      if (r == Z_STREAM_END) {
        done = true;
        break;
      }
      if (r != Z_OK && r != Z_BUF_ERROR)
        fail_at_offset(name, z.total_in, std::string("corrupt gzip data: ") + (z.msg ? z.msg : "inflate failed"));
      if (r == Z_BUF_ERROR && z.avail_in == 0 && in_end)
        fail_at_offset(name, z.total_in, "gzip data is truncated: the file ends inside the compressed stream");
    }
    if (z.total_out > limit) fail_in(name, "gzip data inflates to more than " + std::to_string(limit) + " bytes");
    return size_t(reinterpret_cast<char*>(z.next_out) - dst);
  }

  std::string name;
  std::unique_ptr<FoamFile::Source> in;
  uint64_t limit;
  std::string chunk;
  z_stream z{};
  bool in_end = false, done = false;
};

bool gzip_magic(const char* head, size_t n) { return n >= 2 && uint8_t(head[0]) == 0x1f && uint8_t(head[1]) == 0x8b; }

}  // namespace

FoamFile::FoamFile(const std::string& path, size_t window) : name_(path) {
  auto file = std::make_unique<FileSource>(path);
  char head[2] = {};
  const size_t got = file->file.read_some_at(0, head, 2);
  const uint64_t size = file->file.size();
  open(std::move(file), size, gzip_magic(head, got), window);
}

FoamFile::FoamFile(std::string name, std::string bytes, size_t window) : name_(std::move(name)) {
  const bool gzip = gzip_magic(bytes.data(), bytes.size());
  const uint64_t size = bytes.size();
  open(std::make_unique<MemorySource>(std::move(bytes)), size, gzip, window);
}

FoamFile::~FoamFile() = default;

void FoamFile::open(std::unique_ptr<Source> raw, uint64_t raw_size, bool gzip, size_t window) {
  window = std::max(window, kMinWindow);
  if (gzip) {
    source_ = std::make_unique<InflateSource>(name_, std::move(raw), raw_size);
  } else {
    source_ = std::move(raw);
    size_ = raw_size;
    window = size_t(std::min<uint64_t>(window, std::max<uint64_t>(raw_size, kMinWindow)));  // a small file: less
  }
  buf_.assign(window, '\0');
  note_peak();
  parse_header();
}

void FoamFile::note_peak() { peak_ = std::max<uint64_t>(peak_, buf_.size() + token_.capacity()); }

bool FoamFile::refill(uint64_t keep) {
  if (eof_) return false;
  keep = std::min(keep, end());
  line_of(keep);  // count the newlines of what is discarded
  const size_t drop = size_t(keep - base_);
  if (drop > 0) {
    std::memmove(buf_.data(), buf_.data() + drop, len_ - drop);
    len_ -= drop;
    base_ = keep;
  }
  const size_t before = len_;
  while (len_ < buf_.size()) {
    const size_t got = source_->read(buf_.data() + len_, buf_.size() - len_);
    if (got == 0) {
      eof_ = true;
      break;
    }
    len_ += got;
  }
  return len_ > before;
}

// A gzip stream is read to its end once the parse is done, so that its CRC and length are checked even where the
// values end before the text does (a plain file's rest is not read: nothing there can change what was read).
void FoamFile::verify_rest() {
  if (size_) return;
  while (refill(end())) {
  }
}

uint64_t FoamFile::count_lines(uint64_t offset) {
  offset = std::min(offset, end());
  if (offset >= line_at_) {
    line_ += uint64_t(std::count(ptr(line_at_), ptr(offset), '\n'));
    line_at_ = offset;
    return line_;
  }
  // Behind the counted mark (a spot re-read after backing up): count back, within the window.
  offset = std::max(offset, base_);
  return line_ - uint64_t(std::count(ptr(offset), ptr(line_at_), '\n'));
}

void FoamFile::fail(Spot at, const std::string& message) const {
  fail_at_offset(name_, at.offset, "line " + std::to_string(at.line) + ": " + message);
}

void FoamFile::check_fits(std::string_view what, uint64_t n, uint64_t min_bytes_each, uint64_t slack) {
  if (size_) check_count_fits(name_, pos_, what, n, min_bytes_each, *size_ - std::min(pos_, *size_) + slack);
}

size_t FoamFile::reserve_for(uint64_t n, size_t each) const {
  return size_t(size_ ? n : std::min<uint64_t>(n, kMaxReserveBytes / each));
}

template <class Take>
void FoamFile::binary_values(uint64_t n, size_t each, Spot block, std::string_view what, Take&& take) {
  uint64_t done = 0;
  while (done < n) {
    uint64_t have = (end() - pos_) / each;
    if (have == 0) {
      if (!reach(pos_ + each - 1, pos_)) {
        // The text has ended (end() is its size): the same words whether the size was known up front or not.
        fail(block, std::string(what) + " needs " + size_text(sat_mul(n, each)) + " bytes of binary data, only " +
                        std::to_string(end() - block.offset) + " remain");
      }
      continue;
    }
    have = std::min(have, n - done);
    const char* p = ptr(pos_);
    for (uint64_t i = 0; i < have; ++i) take(p + i * each, done + i);
    pos_ += have * each;
    done += have;
  }
}

void FoamFile::skip_line() {
  while (more()) {
    const void* nl = std::memchr(ptr(pos_), '\n', size_t(end() - pos_));
    if (nl) {
      pos_ = base_ + uint64_t(static_cast<const char*>(nl) - buf_.data()) + 1;
      return;
    }
    pos_ = end();
  }
}

void FoamFile::skip_space() {
  while (more()) {
    // Fast path: the run of spaces inside the window.
    const char* b = ptr(pos_);
    const char* const e = buf_.data() + len_;
    while (b < e && is_space(*b)) ++b;
    pos_ = base_ + uint64_t(b - buf_.data());
    if (b == e) continue;
    if (*b != '/' || !reach(pos_ + 1, pos_)) return;
    const char d = byte(pos_ + 1);
    if (d == '/') {
      skip_line();
    } else if (d == '*') {
      const Spot at = here();
      pos_ += 2;
      for (;;) {
        if (!reach(pos_ + 1, pos_)) fail(at, "unterminated /* comment");
        if (byte(pos_) == '*' && byte(pos_ + 1) == '/') break;
        ++pos_;
      }
      pos_ += 2;
    } else {
      return;
    }
  }
}

bool FoamFile::at_end() {
  skip_space();
  return !more();
}

char FoamFile::peek() {
  skip_space();
  return more() ? byte(pos_) : '\0';
}

bool FoamFile::accept(char c) {
  if (peek() != c || !more()) return false;
  ++pos_;
  return true;
}

void FoamFile::expect(char c, std::string_view what) {
  if (!accept(c)) {
    const bool end_of_file = !more();
    fail(here(), std::string("expected '") + c + "' " + std::string(what) +
                     (end_of_file ? ", found the end of the file" : std::string(", found '") + byte(pos_) + "'"));
  }
}

bool FoamFile::accept_word(std::string_view w) {
  skip_space();
  if (!reach(pos_ + w.size() - 1, pos_) || std::string_view(ptr(pos_), w.size()) != w) return false;
  const uint64_t after = pos_ + w.size();
  if (reach(after, pos_)) {
    const char c = byte(after);
    const bool comment = c == '/' && reach(after + 1, pos_) && (byte(after + 1) == '/' || byte(after + 1) == '*');
    if (!is_space(c) && !is_delimiter(c) && !comment) return false;
  }
  pos_ = after;
  return true;
}

// A word, number or quoted string (returned without its quotes). The view stays valid until the next read.
std::string_view FoamFile::word(std::string_view what) {
  skip_space();
  if (!more()) fail(here(), "expected " + std::string(what) + ", found the end of the file");
  const Spot at = here();
  const bool quoted = byte(pos_) == '"';
  if (!quoted) {
    // Fast path: a word that ends inside the window, not at a '/' (which may start a comment).
    const char* const b = ptr(pos_);
    const char* const e = buf_.data() + len_;
    const char* q = b;
    while (q < e && kWordByte[uint8_t(*q)]) ++q;
    if (q > b && q < e && *q != '/' && size_t(q - b) <= kMaxToken) {
      pos_ += uint64_t(q - b);
      return {b, size_t(q - b)};
    }
  }
  token_.clear();
  bool spilled = false;
  uint64_t seg = quoted ? pos_ + 1 : pos_;  // the part of the token still in the window begins here
  uint64_t p = seg;
  // Moves the token's part in the window to token_ so that the window can move on to `p`.
  auto spill = [&] {
    token_.append(ptr(seg), size_t(p - seg));
    spilled = true;
    seg = p;
    note_peak();
  };
  for (;;) {
    // Checked as the token grows, whatever the window, so that every window fails at the same byte.
    if (token_.size() + (p - seg) > kMaxToken)
      fail(at, "a " + std::string(quoted ? "quoted string" : "word") + " longer than " + std::to_string(kMaxToken) +
                   " bytes where " + std::string(what) + " was expected");
    if (p >= end()) {
      spill();
      if (!reach(p, p)) {
        if (quoted) fail(at, "unterminated string");
        break;
      }
    }
    const char c = byte(p);
    if (quoted) {
      if (c == '"') break;
    } else if (is_space(c) || is_delimiter(c)) {
      break;
    } else if (c == '/') {
      if (p + 1 >= end()) spill();
      if (reach(p + 1, p) && (byte(p + 1) == '/' || byte(p + 1) == '*')) break;
    }
    ++p;
  }
  pos_ = quoted ? p + 1 : p;
  std::string_view s;
  if (spilled) {
    token_.append(ptr(seg), size_t(p - seg));
    note_peak();
    s = token_;
  } else {
    s = std::string_view(ptr(seg), size_t(p - seg));
  }
  if (!quoted && s.empty()) fail(at, "expected " + std::string(what) + ", found '" + byte(at.offset) + "'");
  return s;
}

int64_t FoamFile::integer(std::string_view what) {
  const Spot at = (skip_space(), here());
  const std::string_view w = word(what);
  int64_t v = 0;
  const auto [p, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
  if (ec != std::errc() || p != w.data() + w.size())
    fail(at, "expected " + std::string(what) + " (an integer), found '" + std::string(w.substr(0, 40)) + "'");
  return v;
}

uint64_t FoamFile::count(std::string_view what) {
  const Spot at = (skip_space(), here());
  const int64_t v = integer(what);
  if (v < 0) fail(at, std::string(what) + " is negative (" + std::to_string(v) + ")");
  return uint64_t(v);
}

double FoamFile::number(std::string_view what) {
  const Spot at = (skip_space(), here());
  const std::string_view w = word(what);
  double v = 0;
  const auto [p, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
  // Out-of-range values (1e999) are refused too: OpenFOAM never writes them.
  if (ec != std::errc() || p != w.data() + w.size())
    fail(at, "expected " + std::string(what) + " (a number), found '" + std::string(w.substr(0, 40)) + "'");
  return v;
}

// One stored number of `bytes` (4 or 8) in the file's byte order, as the type the header says (F4 or F8).
template <class F4, class F8>
static auto stored_number(const char* p, int bytes, bool big_endian) -> decltype(F8{}) {
  std::byte b[8];
  std::memcpy(b, p, size_t(bytes));
  if (big_endian != (std::endian::native == std::endian::big)) swap_bytes(b, 1, size_t(bytes));
  if (bytes == 4) {
    F4 v;
    std::memcpy(&v, b, 4);
    return v;
  }
  F8 v;
  std::memcpy(&v, b, 8);
  return v;
}

double FoamFile::binary_scalar(const char* p) const {
  return stored_number<float, double>(p, header_.scalar_bytes, header_.big_endian);
}

int64_t FoamFile::binary_label(const char* p) const {
  return stored_number<int32_t, int64_t>(p, header_.label_bytes, header_.big_endian);
}

void FoamFile::parse_header() {
  const Spot at = (skip_space(), here());
  if (word("the FoamFile header") != "FoamFile") fail(at, "not an OpenFOAM file: no FoamFile header");
  expect('{', "after FoamFile");
  while (!accept('}')) {
    const Spot key_at = (skip_space(), here());
    if (!more()) fail(here(), "the FoamFile header is not closed");
    const std::string key(word("a header keyword"));
    std::string value;
    while (!accept(';')) {
      if (peek() == '}' || !more()) fail(key_at, "header entry '" + key + "' has no ';'");
      value += (value.empty() ? "" : " ") + std::string(word("a header value"));
    }
    if (key == "format") {
      if (value != "ascii" && value != "binary") fail(key_at, "format '" + value + "' is neither ascii nor binary");
      header_.binary = value == "binary";
    } else if (key == "class") {
      header_.class_name = value;
    } else if (key == "object") {
      header_.object = value;
    } else if (key == "arch") {
      // "LSB;label=32;scalar=64": each part optional, the defaults OpenFOAM's own.
      header_.big_endian = value.find("MSB") != std::string::npos;
      for (const auto& [tag, dst] : {std::pair{"label=", &header_.label_bytes}, {"scalar=", &header_.scalar_bytes}}) {
        const size_t p = value.find(tag);
        if (p == std::string::npos) continue;
        const std::string bits = value.substr(p + std::strlen(tag), 2);
        if (bits != "32" && bits != "64") fail(key_at, "arch '" + value + "': " + tag + " must be 32 or 64");
        *dst = bits == "32" ? 4 : 8;
      }
    }
  }
}

std::vector<double> FoamFile::scalar_list(int components, std::string_view what, std::optional<uint64_t> expected) {
  const Spot at = (skip_space(), here());
  const uint64_t n = count(std::string(what) + " count");
  if (expected && n != *expected)
    fail(at, std::string(what) + " has " + std::to_string(n) + " values, expected " + std::to_string(*expected));
  const uint64_t nc = uint64_t(components);
  const size_t sb = size_t(header_.scalar_bytes);
  if (accept('{')) {  // N copies of one value: bounded by `expected`, never by the bytes
    if (!expected) fail(at, std::string(what) + ": a uniform list 'N{value}' is not expected here");
    std::vector<double> one(nc);
    if (header_.binary) {
      binary_values(nc, sb, here(), what, [&](const char* p, uint64_t i) { one[i] = binary_scalar(p); });
    } else {
      if (nc > 1) expect('(', "before a tuple");
      for (uint64_t c = 0; c < nc; ++c) one[c] = number(what);
      if (nc > 1) expect(')', "after a tuple");
    }
    expect('}', std::string("after the value of ") + std::string(what));
    std::vector<double> out(n * nc);
    for (uint64_t i = 0; i < n; ++i) std::copy(one.begin(), one.end(), out.begin() + ptrdiff_t(i * nc));
    return out;
  }
  expect('(', std::string("to open ") + std::string(what));
  std::vector<double> out;
  if (header_.binary) {
    check_fits(what, n, nc * sb, 0);
    out.reserve(reserve_for(sat_mul(n, nc), sizeof(double)));
    binary_values(sat_mul(n, nc), sb, here(), what, [&](const char* p, uint64_t) { out.push_back(binary_scalar(p)); });
    if (!more() || byte(pos_) != ')')
      fail(here(), std::string("expected ')' after the binary values of ") + std::string(what));
    ++pos_;
    return out;
  }
  // ASCII: a scalar takes at least 2 bytes ("0 "), a tuple "(0 0 0) " 2 + 2 per component.
  check_fits(what, n, nc > 1 ? 2 + 2 * nc : 2, 1);
  out.reserve(reserve_for(sat_mul(n, nc), sizeof(double)));
  for (uint64_t i = 0; i < n; ++i) {
    if (nc > 1) expect('(', "before a tuple");
    for (uint64_t c = 0; c < nc; ++c) out.push_back(number(what));
    if (nc > 1) expect(')', "after a tuple");
  }
  expect(')', std::string("to close ") + std::string(what));
  return out;
}

std::vector<int64_t> FoamFile::label_list(std::string_view what, int64_t max_label, bool allow_minus_one) {
  const Spot at = (skip_space(), here());
  const uint64_t n = count(std::string(what) + " count");
  std::vector<int64_t> out;
  auto check = [&](int64_t v, Spot where) {
    if (v > max_label || v < (allow_minus_one ? -1 : 0))
      fail(where, std::string(what) + ": label " + std::to_string(v) + " is outside 0.." + std::to_string(max_label));
  };
  if (accept('{')) fail(at, std::string(what) + ": a uniform list 'N{value}' is not expected here");
  expect('(', std::string("to open ") + std::string(what));
  if (header_.binary) {
    const size_t each = size_t(header_.label_bytes);
    check_fits(what, n, each, 0);
    out.reserve(reserve_for(n, sizeof(int64_t)));
    binary_values(n, each, here(), what, [&](const char* p, uint64_t) {
      const int64_t v = binary_label(p);
      if (v > max_label || v < (allow_minus_one ? -1 : 0)) {
        pos_ = base_ + uint64_t(p - buf_.data());  // the label's own offset and line
        check(v, here());
      }
      out.push_back(v);
    });
    if (!more() || byte(pos_) != ')')
      fail(here(), std::string("expected ')' after the binary values of ") + std::string(what));
    ++pos_;
    return out;
  }
  check_fits(what, n, 2, 1);
  out.reserve(reserve_for(n, sizeof(int64_t)));
  for (uint64_t i = 0; i < n; ++i) {
    const Spot where = (skip_space(), here());
    const int64_t v = integer(what);
    check(v, where);
    out.push_back(v);
  }
  expect(')', std::string("to close ") + std::string(what));
  return out;
}

// Skips an entry's value: tokens up to the ';' that ends it, or one {...} dictionary. A binary list "List<T> N(" is
// skipped by its byte size (its bytes are not tokens), read through the window like any other.
void FoamFile::skip_value() {
  int depth = 0;
  int pending_components = 0;  // after "List<T>" in a binary file: T's components
  for (;;) {
    const char c = peek();
    const Spot at = here();
    if (!more()) fail(at, "the file ends inside an entry");
    if (c == '{' || c == '(' || c == '[') {
      ++pos_;
      ++depth;
    } else if (c == '}' || c == ')' || c == ']') {
      if (depth == 0) fail(at, std::string("unbalanced '") + c + "'");
      ++pos_;
      if (--depth == 0 && c == '}') return;  // a dictionary ends the entry
    } else if (c == ';') {
      ++pos_;
      if (depth == 0) return;
    } else {
      const std::string_view w = word("a value");
      if (header_.binary && w.starts_with("List<") && w.ends_with(">")) {
        pending_components = components_of(w.substr(5, w.size() - 6));
        if (w == "List<label>") pending_components = -1;
        continue;
      }
      if (header_.binary && pending_components != 0 && !w.empty() && (std::isdigit(uint8_t(w[0])) != 0)) {
        int64_t n = 0;
        std::from_chars(w.data(), w.data() + w.size(), n);
        if (n < 0) fail(at, "negative list count");
        const uint64_t each = pending_components < 0 ? uint64_t(header_.label_bytes)
                                                     : uint64_t(pending_components) * uint64_t(header_.scalar_bytes);
        if (peek() == '(') {
          ++pos_;
          check_fits("list", uint64_t(n), each, 0);
          // Skipped a byte at a time in window-sized steps: n * each bytes, or the end of the text.
          binary_values(sat_mul(uint64_t(n), each), 1, here(), "list", [](const char*, uint64_t) {});
          expect(')', "after a binary list");
        }
      }
      pending_components = 0;
    }
  }
}

std::vector<Vec3f> FoamFile::points() {
  const std::vector<double> v = scalar_list(3, "points", std::nullopt);
  verify_rest();
  std::vector<Vec3f> out(v.size() / 3);
  for (size_t i = 0; i < out.size(); ++i) out[i] = Vec3f{float(v[3 * i]), float(v[3 * i + 1]), float(v[3 * i + 2])};
  return out;
}

FaceList FoamFile::faces(uint64_t point_count) {
  const int64_t max_point = int64_t(std::min<uint64_t>(point_count, UINT32_MAX)) - 1;
  FaceList f;
  if (header_.class_name == "faceCompactList") {
    // Two lists: N+1 offsets into the second, the vertex labels of all faces.
    const Spot at = (skip_space(), here());
    // An offset cannot exceed the labels that follow, let alone the file's size (which also keeps the arithmetic
    // below far from overflow; a gzip file's inflated size is bounded by deflate's ratio).
    const int64_t max_offset = int64_t(std::min<uint64_t>(size_.value_or(uint64_t(1) << 62), uint64_t(1) << 62));
    std::vector<int64_t> offsets = label_list("face offsets", max_offset, false);
    std::vector<int64_t> labels = label_list("face vertices", max_point, false);
    if (offsets.empty()) fail(at, "faceCompactList has no offsets (at least the leading 0)");
    if (offsets.front() != 0 || uint64_t(offsets.back()) != labels.size())
      fail(at, "face offsets run from " + std::to_string(offsets.front()) + " to " + std::to_string(offsets.back()) +
                   ", the vertex list holds " + std::to_string(labels.size()));
    f.offsets.resize(offsets.size());
    for (size_t i = 0; i < offsets.size(); ++i) {
      if (i > 0 && offsets[i] - offsets[i - 1] < 3)
        fail(at, "face " + std::to_string(i - 1) + " has " + std::to_string(offsets[i] - offsets[i - 1]) +
                     " vertices (at least 3)");
      f.offsets[i] = uint64_t(offsets[i]);
    }
    f.vertices.assign(labels.begin(), labels.end());
    verify_rest();
    return f;
  }
  if (header_.class_name != "faceList")
    fail(Spot{}, "class '" + header_.class_name + "' is neither faceList nor faceCompactList");
  if (header_.binary) fail(Spot{}, "a binary faceList (not faceCompactList) is not an OpenFOAM layout");
  const uint64_t n = count("face count");
  expect('(', "to open the face list");
  check_fits("face", n, 8, 1);  // "3(0 1 2)"
  f.offsets.reserve(reserve_for(sat_add(n, 1), sizeof(uint64_t)));
  f.vertices.reserve(reserve_for(sat_mul(4, n), sizeof(uint32_t)));
  for (uint64_t i = 0; i < n; ++i) {
    const Spot at = (skip_space(), here());
    const uint64_t k = count("face size");
    if (k < 3) fail(at, "face " + std::to_string(i) + " has " + std::to_string(k) + " vertices (at least 3)");
    check_fits("face vertex", k, 2, 1);
    expect('(', "to open a face");
    for (uint64_t j = 0; j < k; ++j) {
      const Spot where = (skip_space(), here());
      const int64_t v = integer("a face vertex");
      if (v < 0 || v > max_point)
        fail(where, "face " + std::to_string(i) + ": vertex " + std::to_string(v) + " is outside 0.." +
                        std::to_string(max_point));
      f.vertices.push_back(uint32_t(v));
    }
    expect(')', "to close a face");
    f.offsets.push_back(f.vertices.size());
  }
  expect(')', "to close the face list");
  verify_rest();
  return f;
}

std::vector<int64_t> FoamFile::labels(int64_t max_label, bool allow_minus_one) {
  std::vector<int64_t> out = label_list(header_.object.empty() ? "labels" : header_.object, max_label, allow_minus_one);
  verify_rest();
  return out;
}

std::vector<Patch> FoamFile::patches() {
  const uint64_t n = count("patch count");
  expect('(', "to open the patch list");
  check_fits("patch", n, 4, 0);
  std::vector<Patch> out;
  for (uint64_t i = 0; i < n; ++i) {
    Patch p;
    p.name = word("a patch name");
    expect('{', "to open patch '" + p.name + "'");
    while (!accept('}')) {
      const std::string key(word("a patch keyword"));
      if (key == "type") {
        p.type = word("the patch type");
        expect(';', "after the patch type");
      } else if (key == "nFaces" || key == "startFace") {
        (key == "nFaces" ? p.n_faces : p.start_face) = count(key);
        expect(';', "after " + key);
      } else {
        skip_value();
      }
    }
    out.push_back(std::move(p));
  }
  expect(')', "to close the patch list");
  verify_rest();
  return out;
}

std::vector<CellZone> FoamFile::cell_zones(uint64_t cell_count) {
  const uint64_t n = count("zone count");
  expect('(', "to open the zone list");
  check_fits("zone", n, 4, 0);
  std::vector<CellZone> out;
  for (uint64_t i = 0; i < n; ++i) {
    CellZone z;
    z.name = word("a zone name");
    expect('{', "to open zone '" + z.name + "'");
    while (!accept('}')) {
      const std::string key(word("a zone keyword"));
      if (key == "cellLabels") {
        // "cellLabels List<label> N(...)" (OpenFOAM's writers) or "cellLabels N(...)" (foamFormatConvert, ascii).
        accept_word("List<label>");
        const std::vector<int64_t> cells =
            label_list("zone '" + z.name + "' cellLabels", int64_t(cell_count) - 1, false);
        z.cells.assign(cells.begin(), cells.end());
        expect(';', "after cellLabels");
      } else {
        skip_value();
      }
    }
    out.push_back(std::move(z));
  }
  expect(')', "to close the zone list");
  verify_rest();
  return out;
}

std::optional<FieldValues> FoamFile::internal_field(uint64_t tuples) {
  int components = 0;
  const std::string& cls = header_.class_name;
  for (const char* prefix : {"vol", "point"}) {
    if (cls.starts_with(prefix) && cls.ends_with("Field")) {
      std::string t = cls.substr(std::strlen(prefix), cls.size() - std::strlen(prefix) - 5);
      if (!t.empty()) t[0] = char(std::tolower(uint8_t(t[0])));
      components = components_of(t);
    }
  }
  if (components == 0) fail(Spot{}, "class '" + cls + "' is not a vol/point scalar, vector or tensor field");
  while (!at_end()) {
    const Spot at = here();
    const std::string_view key = word("an entry keyword");
    if (key.starts_with("#")) {  // a directive (#include "file", #inputMode merge): the rest of its line
      skip_line();
      continue;
    }
    if (key != "internalField") {
      skip_value();
      continue;
    }
    FieldValues f;
    f.components = components;
    const std::string_view kind = word("uniform or nonuniform");
    if (kind == "uniform") {
      std::vector<double> one(static_cast<size_t>(components));
      if (components > 1) expect('(', "before a uniform tuple");
      for (double& v : one) v = number("a uniform value");
      if (components > 1) expect(')', "after a uniform tuple");
      expect(';', "after the uniform value");
      f.uniform = true;
      f.values.resize(tuples * uint64_t(components));
      for (uint64_t i = 0; i < tuples; ++i)
        std::copy(one.begin(), one.end(), f.values.begin() + ptrdiff_t(i * uint64_t(components)));
      verify_rest();
      return f;
    }
    if (kind != "nonuniform")
      fail(at, "internalField is '" + std::string(kind.substr(0, 40)) + "', neither uniform nor nonuniform");
    const Spot type_at = (skip_space(), here());
    const std::string_view list_type = word("List<type>");
    if (!list_type.starts_with("List<") || !list_type.ends_with(">") ||
        components_of(list_type.substr(5, list_type.size() - 6)) != components)
      fail(type_at, "internalField of a " + cls + " is a '" + std::string(list_type.substr(0, 40)) + "'");
    f.values = scalar_list(components, "internalField", tuples);
    expect(';', "after internalField");
    verify_rest();
    return f;
  }
  return std::nullopt;
}

bool is_openfoam_path(const std::string& path) {
  std::error_code ec;
  const fs::path p(path);
  if (fs::is_directory(p, ec)) {
    if (fs::is_directory(p / "constant" / "polyMesh", ec)) return true;
    for (const auto& e : fs::directory_iterator(p, ec))
      if (e.path().filename().string().starts_with("processor") &&
          fs::is_directory(e.path() / "constant" / "polyMesh", ec))
        return true;
    return false;
  }
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".foam" || ext == ".openfoam" || p.filename() == "controlDict";
}

}  // namespace openfoam

namespace {

using openfoam::FoamFile;

// "X" or "X.gz" in `dir`; empty when neither exists.
std::string find_file(const fs::path& dir, const std::string& name) {
  std::error_code ec;
  if (fs::is_regular_file(dir / name, ec)) return (dir / name).string();
  if (fs::is_regular_file(dir / (name + ".gz"), ec)) return (dir / (name + ".gz")).string();
  return {};
}

std::string need_file(const fs::path& dir, const std::string& name) {
  std::string f = find_file(dir, name);
  if (f.empty()) fail_in(dir.string(), "the case has no " + name + " (nor " + name + ".gz)");
  return f;
}

struct TimeDir {
  double value;
  std::string name;
};

std::vector<TimeDir> time_dirs(const fs::path& dir) {
  std::vector<TimeDir> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_directory(ec)) continue;
    const std::string n = e.path().filename().string();
    double v = 0;
    const auto [p, err] = std::from_chars(n.data(), n.data() + n.size(), v);
    if (err == std::errc() && p == n.data() + n.size()) out.push_back({v, n});
  }
  std::sort(out.begin(), out.end(), [](const TimeDir& a, const TimeDir& b) { return a.value < b.value; });
  return out;
}

// One piece (the case, or one processor directory) before it joins the dataset.
struct Piece {
  fs::path dir;
  std::vector<Vec3f> points;
  uint64_t point_count = 0;
  openfoam::FaceList faces;
  std::vector<int64_t> owner, neighbour;
  uint64_t cells = 0;
  std::vector<openfoam::Patch> patches;
  std::vector<openfoam::CellZone> zones;
  std::string format;  // "ascii" / "binary" of the faces file
};

Piece read_piece(const fs::path& dir, const std::string& time) {
  Piece piece;
  piece.dir = dir;
  // A moving mesh writes its points (and with topology changes the whole polyMesh) into the time directory.
  const fs::path constant = dir / "constant" / "polyMesh";
  const fs::path moved = dir / time / "polyMesh";
  const fs::path topo = !time.empty() && !find_file(moved, "faces").empty() ? moved : constant;
  const fs::path geom = !time.empty() && !find_file(moved, "points").empty() ? moved : topo;
  {
    FoamFile f(need_file(geom, "points"));
    piece.points = f.points();
    piece.point_count = piece.points.size();
  }
  if (piece.points.size() > UINT32_MAX)
    fail_in(geom.string(), "more than 2^32-1 points: an in-memory mesh is capped there");
  {
    FoamFile f(need_file(topo, "faces"));
    piece.format = f.header().binary ? "binary" : "ascii";
    piece.faces = f.faces(piece.points.size());
  }
  const uint64_t nf = piece.faces.size();
  const std::string owner_path = need_file(topo, "owner");
  {
    FoamFile f(owner_path);
    // A cell has at least one face: no cell label reaches the face count (which bounds what the cell arrays take).
    piece.owner = f.labels(int64_t(nf) - 1, false);
  }
  if (piece.owner.size() != nf)
    fail_in(owner_path,
            "owner has " + std::to_string(piece.owner.size()) + " labels, the mesh " + std::to_string(nf) + " faces");
  const std::string neighbour_path = need_file(topo, "neighbour");
  {
    FoamFile f(neighbour_path);
    piece.neighbour = f.labels(int64_t(nf) - 1, true);  // older cases list every face, -1 on the boundary
  }
  if (piece.neighbour.size() > nf)
    fail_in(neighbour_path, "neighbour has " + std::to_string(piece.neighbour.size()) + " labels, the mesh only " +
                                std::to_string(nf) + " faces");
  int64_t max_cell = -1;
  for (int64_t c : piece.owner) max_cell = std::max(max_cell, c);
  for (int64_t c : piece.neighbour) max_cell = std::max(max_cell, c);
  piece.cells = uint64_t(max_cell + 1);
  if (const std::string b = find_file(topo, "boundary"); !b.empty()) {
    FoamFile f(b);
    piece.patches = f.patches();
    for (const auto& p : piece.patches)
      if (p.start_face > nf || p.n_faces > nf - p.start_face)
        fail_in(b, "patch '" + p.name + "' covers faces " + std::to_string(p.start_face) + "+" +
                       std::to_string(p.n_faces) + ", the mesh has " + std::to_string(nf));
  }
  if (const std::string z = find_file(topo, "cellZones"); !z.empty()) {
    FoamFile f(z);
    piece.zones = f.cell_zones(piece.cells);
  }
  return piece;
}

// Each cell's faces (CSR over cells) and the cells to the decomposer, vertex indices shifted by `point_base`.
void add_cells(const Piece& piece, uint32_t point_base, PolyhedronDecomposer& decomposer) {
  const uint64_t nc = piece.cells;
  std::vector<uint64_t> start(nc + 1, 0);
  for (int64_t c : piece.owner) ++start[uint64_t(c) + 1];
  for (int64_t c : piece.neighbour)
    if (c >= 0) ++start[uint64_t(c) + 1];
  for (uint64_t c = 0; c < nc; ++c) start[c + 1] += start[c];
  std::vector<uint64_t> fill(start.begin(), start.end() - 1);
  std::vector<uint64_t> cell_faces(start[nc]);
  for (uint64_t f = 0; f < piece.owner.size(); ++f) cell_faces[fill[uint64_t(piece.owner[f])]++] = f;
  for (uint64_t f = 0; f < piece.neighbour.size(); ++f)
    if (piece.neighbour[f] >= 0) cell_faces[fill[uint64_t(piece.neighbour[f])]++] = f;
  std::vector<uint32_t> sizes, verts;
  for (uint64_t c = 0; c < nc; ++c) {
    sizes.clear();
    verts.clear();
    for (uint64_t k = start[c]; k < start[c + 1]; ++k) {
      const uint64_t f = cell_faces[k];
      const uint64_t b = piece.faces.offsets[f], e = piece.faces.offsets[f + 1];
      sizes.push_back(uint32_t(e - b));
      for (uint64_t i = b; i < e; ++i) verts.push_back(piece.faces.vertices[i] + point_base);
    }
    decomposer.add_polyhedron(sizes, verts);
  }
}

// Whether the file (plain or gzip) starts with a FoamFile header: other files in a time directory (notes, scripts
// that tools leave there) are skipped, not refused.
bool has_foam_header(const std::string& path) {
  const InputFile file(path);
  char head[2] = {};
  if (file.read_some_at(0, head, 2) == 2 && uint8_t(head[0]) == 0x1f && uint8_t(head[1]) == 0x8b) return true;
  std::string text(std::min<uint64_t>(file.size(), 4096), '\0');
  text.resize(file.read_some_at(0, text.data(), text.size()));
  return text.find("FoamFile") != std::string::npos;
}

std::string join_times(const std::vector<TimeDir>& times) {
  std::string s;
  for (const auto& t : times) s += (s.empty() ? "" : " ") + t.name;
  return s;
}

// The case's root directory and its pieces: processorN/ in N order, or the case itself.
std::vector<fs::path> case_piece_dirs(const std::string& path, fs::path& root) {
  std::error_code ec;
  root = fs::path(path);
  if (!fs::is_directory(root, ec)) {
    root = root.has_parent_path() ? root.parent_path() : fs::path(".");
    if (root.filename() == "system") root = root.has_parent_path() ? root.parent_path() : fs::path(".");
  }
  // The pieces: processorN/ in N order, or the case itself. processor*/ wins unless the case directory holds a
  // reconstructed mesh with at least as many time directories (after reconstructPar both exist and agree).
  std::vector<std::pair<uint64_t, fs::path>> processors;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    const std::string n = e.path().filename().string();
    uint64_t k = 0;
    if (n.size() > 9 && n.starts_with("processor") &&
        std::from_chars(n.data() + 9, n.data() + n.size(), k).ptr == n.data() + n.size() &&
        fs::is_directory(e.path() / "constant" / "polyMesh", ec))
      processors.emplace_back(k, e.path());
  }
  if (ec) fail_in(path, "cannot list the case directory: " + ec.message());
  std::sort(processors.begin(), processors.end());
  const bool reconstructed = fs::is_directory(root / "constant" / "polyMesh", ec);
  bool decomposed = !processors.empty();
  if (decomposed && reconstructed && time_dirs(root).size() >= time_dirs(processors[0].second).size())
    decomposed = false;
  if (!decomposed && !reconstructed) fail_in(root.string(), "not an OpenFOAM case: no constant/polyMesh");
  std::vector<fs::path> piece_dirs;
  if (decomposed)
    for (const auto& [k, p] : processors) piece_dirs.push_back(p);
  else
    piece_dirs.push_back(root);

  return piece_dirs;
}

}  // namespace

std::vector<double> list_openfoam_times(const std::string& path) {
  fs::path root;
  std::vector<double> out;
  for (const TimeDir& t : time_dirs(case_piece_dirs(path, root)[0])) out.push_back(t.value);
  return out;
}

std::optional<GridCounts> openfoam_header_counts(const std::string& path) {
  fs::path root;
  GridCounts counts;
  for (const fs::path& piece : case_piece_dirs(path, root)) {
    // polyMesh/owner's header note, "nPoints:882  nCells:400  nFaces:1640  nInternalFaces:760", which OpenFOAM's
    // mesh writers put there: the first few KiB of the file, inflated on the way when it is gzip (gzread reads
    // plain files as they are).
    const std::string owner = find_file(piece / "constant" / "polyMesh", "owner");
    if (owner.empty()) return std::nullopt;
    gzFile gz = gzopen(owner.c_str(), "rb");
    if (!gz) fail_in(owner, "cannot open");
    std::string head(16384, '\0');
    const int n = gzread(gz, head.data(), unsigned(head.size()));
    gzclose(gz);
    head.resize(n > 0 ? size_t(n) : 0);
    const auto value = [&](std::string_view key) -> std::optional<uint64_t> {
      const size_t at = head.find(key);
      if (at == std::string::npos) return std::nullopt;
      uint64_t v = 0;
      const char* begin = head.data() + at + key.size();
      const auto [end, ec] = std::from_chars(begin, head.data() + head.size(), v);
      if (ec != std::errc() || end == begin) return std::nullopt;
      return v;
    };
    const std::optional<uint64_t> points = value("nPoints:"), cells = value("nCells:");
    if (!points || !cells) return std::nullopt;
    counts.points = sat_add(counts.points, *points);
    counts.cells = sat_add(counts.cells, *cells);
  }
  return counts;
}

namespace {

// The files of a polyMesh directory that decide the mesh read_piece builds.
constexpr std::array<const char*, 6> kMeshFiles{"points", "faces", "owner", "neighbour", "boundary", "cellZones"};

// Whether `time` of the piece in `dir` moves its mesh: read_piece then takes the points (or the whole polyMesh) from
// the time directory's polyMesh/ instead of constant/polyMesh.
bool moves_mesh(const fs::path& dir, const std::string& time) {
  if (time.empty()) return false;
  const fs::path moved = dir / time / "polyMesh";
  return !find_file(moved, "points").empty() || !find_file(moved, "faces").empty();
}

// One step of a case as read_openfoam names it: its root, its pieces, and the time directory it reads.
struct CaseStep {
  fs::path root;
  std::vector<fs::path> piece_dirs;
  bool decomposed = false;  // processor*/ pieces, not the case itself
  std::string time;         // the time directory's name; empty when the case has none
  std::string time_note;    // the dataset's first note: the time directories and the one read
};

CaseStep case_step(const std::string& path, int64_t time_step) {
  CaseStep c;
  c.piece_dirs = case_piece_dirs(path, c.root);
  c.decomposed = c.piece_dirs.front() != c.root;
  const std::vector<TimeDir> times = time_dirs(c.piece_dirs[0]);
  if (times.empty()) {
    c.time_note = "no time directories: the mesh only";
    return c;
  }
  const int64_t n = int64_t(times.size());
  if (time_step < -1 || time_step >= n)
    fail_in(c.root.string(), "time step " + std::to_string(time_step) + " does not exist: the case has " +
                                 std::to_string(n) + " time directories (0.." + std::to_string(n - 1) +
                                 "): " + join_times(times));
  const size_t k = size_t(time_step < 0 ? n - 1 : time_step);
  c.time = times[k].name;
  c.time_note = "time directories (" + std::to_string(n) + "): " + join_times(times) + "; read " + c.time +
                " (--time-step " + std::to_string(k) + ")";
  return c;
}

// The stored identity of the constant mesh of a step's pieces; nullopt where a piece's time directory moves its mesh.
// A hash of the piece count and, per piece, its directory and each mesh file's name, size and modification time (not
// its bytes: hashing a large mesh's files would cost what reading them does).
std::optional<uint64_t> constant_mesh_key(const CaseStep& c) {
  uint64_t h = hash_mix(hash_mix(kFnvOffset, 0x666f616d), c.piece_dirs.size());  // "foam"
  for (const fs::path& dir : c.piece_dirs) {
    if (moves_mesh(dir, c.time)) return std::nullopt;
    const std::string d = dir.string();
    h = hash_mix(h, hash_bytes(d.data(), d.size()));
    for (const char* name : kMeshFiles) {
      const std::string f = find_file(dir / "constant" / "polyMesh", name);
      h = f.empty() ? hash_mix(h, hash_bytes(f.data(), f.size())) : hash_file_stamp(h, f);
    }
  }
  return h;
}

}  // namespace

// What a step's fields need from the mesh they lie on, kept from the mesh's read (openfoam_reader.h).
struct OpenFoamLayout {
  struct PieceCounts {
    fs::path dir;
    uint64_t cells = 0;   // the piece's cells before decomposition (a cell field's tuples)
    uint64_t points = 0;  // the piece's points before decomposition (a point field's tuples)
  };
  std::string root;                     // the dataset's source
  std::optional<uint64_t> mesh_key;     // constant_mesh_key of the mesh; nullopt: a mesh moved by its time directory
  std::string format;                   // the dataset's format
  std::vector<PieceCounts> pieces;      // in the mesh's order
  CellExpansion expansion;              // the polyhedra decomposition of the pieces' cells, concatenated
  std::optional<Field> cell_zone;       // "cellZone", already expanded (the mesh's, not the step's)
  std::vector<std::string> mesh_notes;  // after the time note: the decomposed case's, the cell zones'
  std::vector<std::string> tail_notes;  // after the fields': the decomposition summary, the boundary patches
};

namespace {

// The fields of time directory `time` on the mesh of `layout`, by name; a field missing from a piece, or a file that
// is not a geometric field, is skipped with a note. `zone` (the layout's cellZone field, or nothing) comes first.
FieldSet time_fields(const OpenFoamLayout& layout, std::optional<Field> zone, const std::string& time,
                     std::vector<std::string>& notes) {
  FieldSet fields;
  if (zone) fields.add(std::move(*zone));
  if (time.empty()) return fields;
  const auto& pieces = layout.pieces;
  std::error_code ec;
  std::map<std::string, std::vector<std::string>> files;  // field name -> file per piece
  for (size_t k = 0; k < pieces.size(); ++k) {
    for (const auto& e : fs::directory_iterator(pieces[k].dir / time, ec)) {
      if (!e.is_regular_file(ec)) continue;
      std::string n = e.path().filename().string();
      if (n.ends_with(".gz")) n.resize(n.size() - 3);
      if (n.empty() || n.starts_with(".") || n.ends_with("~") || n.ends_with(".orig")) continue;
      auto& v = files[n];
      v.resize(pieces.size());
      v[k] = e.path().string();
    }
  }
  std::vector<std::string> skipped;
  for (const auto& [name, per_piece] : files) {
    if (std::any_of(per_piece.begin(), per_piece.end(), [](const std::string& s) { return s.empty(); })) {
      skipped.push_back(name + " (not in every processor directory)");
      continue;
    }
    std::vector<double> values;
    int components = 0;
    std::optional<Association> assoc;
    std::string why;
    bool all_float32 = true;
    for (size_t k = 0; k < pieces.size() && why.empty(); ++k) {
      if (!has_foam_header(per_piece[k])) {
        why = "not a FoamFile";
        break;
      }
      FoamFile f(per_piece[k]);
      all_float32 = all_float32 && f.header().binary && f.header().scalar_bytes == 4;
      const std::string& cls = f.header().class_name;
      const bool vol = cls.starts_with("vol"), point = cls.starts_with("point");
      if (!(vol || point) || !cls.ends_with("Field")) {
        why = cls.empty() ? "no class" : cls;
        break;
      }
      // A point field has one tuple per point of its piece (the original points, before decomposition).
      const std::optional<openfoam::FieldValues> v = f.internal_field(vol ? pieces[k].cells : pieces[k].points);
      if (!v) {
        why = "no internalField";
        break;
      }
      components = v->components;
      assoc = vol ? Association::Cell : Association::Vertex;
      values.insert(values.end(), v->values.begin(), v->values.end());
    }
    if (!why.empty()) {
      skipped.push_back(name + " (" + why + ")");
      continue;
    }
    // Binary files written with scalar=32 keep float32 (fields keep their stored type); text and scalar=64 are
    // double.
    DataArray data;
    if (all_float32) {
      data = DataArray::from(std::vector<float>(values.begin(), values.end()), components);
    } else {
      data = DataArray::from(std::move(values), components);
    }
    Field field(name, *assoc, std::move(data));
    fields.add(*assoc == Association::Cell ? layout.expansion.expand_cell_field(field)
                                           : layout.expansion.expand_point_field(field));
  }
  if (!skipped.empty()) {
    std::string s;
    for (const auto& k : skipped) s += (s.empty() ? "" : ", ") + k;
    notes.push_back("not read from " + time + ": " + s);
  }
  return fields;
}

// The dataset's notes: the time note, the mesh's, the fields' (`field_notes`), the layout's last ones.
std::vector<std::string> step_notes(const OpenFoamLayout& layout, std::string time_note,
                                    std::vector<std::string> field_notes) {
  std::vector<std::string> notes{std::move(time_note)};
  notes.insert(notes.end(), layout.mesh_notes.begin(), layout.mesh_notes.end());
  notes.insert(notes.end(), field_notes.begin(), field_notes.end());
  notes.insert(notes.end(), layout.tail_notes.begin(), layout.tail_notes.end());
  return notes;
}

}  // namespace

std::optional<uint64_t> openfoam_mesh_key(const std::string& path, int64_t time_step) {
  return constant_mesh_key(case_step(path, time_step));
}

Dataset read_openfoam(const std::string& path, int64_t time_step) { return read_openfoam(path, time_step, nullptr); }

Dataset read_openfoam(const std::string& path, int64_t time_step, std::shared_ptr<const OpenFoamLayout>* kept) {
  const CaseStep step = case_step(path, time_step);
  const fs::path& root = step.root;
  const std::string& time = step.time;
  std::error_code ec;
  const std::string case_name = fs::weakly_canonical(root, ec).filename().string();
  auto layout = std::make_shared<OpenFoamLayout>();
  layout->root = root.string();
  // Taken before the mesh is read: a mesh file rewritten during the read then gives another key than the one kept.
  if (kept) layout->mesh_key = constant_mesh_key(step);

  std::vector<Piece> pieces;
  uint64_t total_points = 0;
  for (const fs::path& d : step.piece_dirs) {
    pieces.push_back(read_piece(d, time));
    total_points += pieces.back().points.size();
    if (total_points > UINT32_MAX) fail_in(d.string(), "more than 2^32-1 points in all: an in-memory mesh is capped");
  }
  if (step.decomposed)
    layout->mesh_notes.push_back("decomposed case: " + std::to_string(pieces.size()) +
                                 " processor directories read as pieces and concatenated; points on processor "
                                 "boundaries are not merged (each piece keeps its own copy)");

  UnstructuredMesh mesh;
  mesh.points.reserve(total_points);
  for (const Piece& p : pieces) mesh.points.insert(mesh.points.end(), p.points.begin(), p.points.end());
  PolyhedronDecomposer decomposer(mesh, root.string());
  {
    uint64_t base = 0;
    for (Piece& p : pieces) {
      add_cells(p, uint32_t(base), decomposer);
      base += p.point_count;
      // The topology is no longer needed; free it before the fields are read.
      p.faces = {};
      p.owner = {};
      p.neighbour = {};
      p.points = {};
    }
  }
  mesh.validate(root.string());
  layout->expansion = decomposer.expansion();
  for (const Piece& p : pieces) layout->pieces.push_back({p.dir, p.cells, p.point_count});

  // cellZones: zone index per cell, -1 outside every zone (zone names are taken from the first piece).
  if (!pieces[0].zones.empty()) {
    std::vector<int32_t> zone;
    zone.reserve(decomposer.input_cells());
    std::string names;
    for (size_t z = 0; z < pieces[0].zones.size(); ++z)
      names += (z ? ", " : "") + std::to_string(z) + " = " + pieces[0].zones[z].name;
    for (const Piece& p : pieces) {
      const size_t first = zone.size();
      zone.resize(first + p.cells, -1);
      for (size_t z = 0; z < p.zones.size(); ++z)
        for (uint64_t c : p.zones[z].cells) zone[first + c] = int32_t(z);
    }
    layout->cell_zone =
        decomposer.expand_cell_field(Field("cellZone", Association::Cell, DataArray::from(std::move(zone), 1)));
    layout->mesh_notes.push_back("cell field 'cellZone' (-1 outside every zone): " + names);
  }
  if (const std::string s = decomposer.summary(); !s.empty()) layout->tail_notes.push_back(s);
  if (!pieces[0].patches.empty()) {
    std::string s;
    for (const auto& p : pieces[0].patches)
      s += (s.empty() ? "" : ", ") + p.name + " (" + p.type + ", " + std::to_string(p.n_faces) + " faces)";
    layout->tail_notes.push_back("boundary patches (not rendered: the boundary is derived from the cells): " + s);
  }
  layout->format = "OpenFOAM case (" + pieces[0].format + (step.decomposed ? ", decomposed" : "") + ")";

  // The zone field is moved into the dataset unless the layout is kept for later steps (which then copy it).
  std::vector<std::string> field_notes;
  FieldSet fields = time_fields(*layout, kept ? layout->cell_zone : std::move(layout->cell_zone), time, field_notes);
  Block block{case_name, std::move(mesh), std::move(fields)};
  Dataset ds = single_block_dataset(layout->format, root.string(), std::move(block),
                                    step_notes(*layout, step.time_note, std::move(field_notes)));
  if (kept) *kept = std::move(layout);
  return ds;
}

FieldSet read_openfoam_fields(const OpenFoamLayout& layout, const std::string& path, int64_t time_step,
                              std::string& format, std::vector<std::string>& sources,
                              std::vector<std::string>& warnings) {
  const CaseStep step = case_step(path, time_step);
  if (step.root.string() != layout.root || step.piece_dirs.size() != layout.pieces.size())
    fail_in(step.root.string(), "the case's pieces are not those of the mesh held (read the step whole)");
  std::vector<std::string> field_notes;
  FieldSet fields = time_fields(layout, layout.cell_zone, step.time, field_notes);
  format = layout.format;
  sources.push_back(layout.root);
  std::vector<std::string> notes = step_notes(layout, step.time_note, std::move(field_notes));
  warnings.insert(warnings.end(), notes.begin(), notes.end());
  return fields;
}

const std::optional<uint64_t>& openfoam_layout_mesh_key(const OpenFoamLayout& layout) { return layout.mesh_key; }

}  // namespace ugvr
