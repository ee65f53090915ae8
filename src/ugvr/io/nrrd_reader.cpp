// NRRD reader (teem's "nearly raw raster data", http://teem.sourceforge.net/nrrd/format.html), versions NRRD0001..5.
//
// Header: the magic line "NRRD000X", then "field: value" lines ('#' comments; "key:=value" pairs are ignored), ended
// by a blank line (attached data follows it) or by the end of the file (a detached .nhdr header). Fields used:
//   type             any of the spec's spellings of int8..uint64, float, double ("block" is refused)
//   dimension        3, or 4 with a leading vector axis of size <= 4 (one multi-component field)
//   sizes            one per axis, axis 0 fastest
//   endian           little | big (required when values have more than one byte and are not ASCII)
//   encoding         raw | gzip (gz) | ascii (text, txt); bzip2 and hex are refused
//   spacings         per axis ("nan" on the vector axis)
//   space directions per axis "(x,y,z)" or "none" (vector axis); only axis-aligned directions along their own axis
//                    with positive length are accepted, since ImageGrid has no direction matrix
//   space origin     "(x,y,z)"; axis mins is used when there is no space origin
//   data file        detached data, relative to the header's directory; LIST and printf-style multi-file forms are
//                    refused
//   line skip, byte skip   lines, then bytes, skipped at the start of the data (byte skip -1 with raw encoding: the
//                    data are the last bytes of the file); for gzip, byte skip counts decompressed bytes
//   content          the field name (otherwise "values")
// Other fields (kinds, centers, units, labels, ...) do not change the volume and are ignored.
//
// Memory: the size of the values is computed from the header (overflow-checked) and validated against what the data
// can hold before the array is allocated: raw data must be in the file; gzip data cannot expand by more than
// deflate's maximum ratio (1032:1); ASCII values take at least two bytes each. Raw data is read straight into the
// final array, gzip data inflated in chunks into it, to the end of the stream so that its CRC and length are checked.
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {
namespace {

constexpr uint64_t kMaxHeader = uint64_t(1) << 20;
constexpr uint64_t kMaxDeflateRatio = 1032;
// Decompressed bytes after the values that are read and discarded (to reach the gzip CRC) before the data is refused.
constexpr uint64_t kMaxTrailingBytes = uint64_t(1) << 20;

std::string trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return std::string(s);
}

std::vector<std::string> words(std::string_view s) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    const size_t start = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t') ++i;
    if (i > start) out.emplace_back(s.substr(start, i - start));
  }
  return out;
}

std::optional<ScalarType> nrrd_type(const std::string& name) {
  static const std::map<std::string, ScalarType> kTypes = {
      {"signed char", ScalarType::Int8},
      {"int8", ScalarType::Int8},
      {"int8_t", ScalarType::Int8},
      {"uchar", ScalarType::UInt8},
      {"unsigned char", ScalarType::UInt8},
      {"uint8", ScalarType::UInt8},
      {"uint8_t", ScalarType::UInt8},
      {"short", ScalarType::Int16},
      {"short int", ScalarType::Int16},
      {"signed short", ScalarType::Int16},
      {"signed short int", ScalarType::Int16},
      {"int16", ScalarType::Int16},
      {"int16_t", ScalarType::Int16},
      {"ushort", ScalarType::UInt16},
      {"unsigned short", ScalarType::UInt16},
      {"unsigned short int", ScalarType::UInt16},
      {"uint16", ScalarType::UInt16},
      {"uint16_t", ScalarType::UInt16},
      {"int", ScalarType::Int32},
      {"signed int", ScalarType::Int32},
      {"int32", ScalarType::Int32},
      {"int32_t", ScalarType::Int32},
      {"uint", ScalarType::UInt32},
      {"unsigned int", ScalarType::UInt32},
      {"uint32", ScalarType::UInt32},
      {"uint32_t", ScalarType::UInt32},
      {"longlong", ScalarType::Int64},
      {"long long", ScalarType::Int64},
      {"long long int", ScalarType::Int64},
      {"signed long long", ScalarType::Int64},
      {"signed long long int", ScalarType::Int64},
      {"int64", ScalarType::Int64},
      {"int64_t", ScalarType::Int64},
      {"ulonglong", ScalarType::UInt64},
      {"unsigned long long", ScalarType::UInt64},
      {"unsigned long long int", ScalarType::UInt64},
      {"uint64", ScalarType::UInt64},
      {"uint64_t", ScalarType::UInt64},
      {"float", ScalarType::Float32},
      {"double", ScalarType::Float64},
  };
  const auto it = kTypes.find(name);
  return it == kTypes.end() ? std::nullopt : std::optional(it->second);
}

enum class Encoding { Raw, Gzip, Ascii };

struct HeaderField {
  std::string value;
  uint64_t line = 0;
};

class NrrdReader {
 public:
  explicit NrrdReader(const std::string& path) : header_file_(path), path_(path) {}

  Dataset read() {
    parse_header();
    interpret();
    DataArray values = read_values();
    ImageGrid grid;
    grid.dims.points = dims_;
    grid.origin = origin_;
    grid.spacing = spacing_;
    Block block;
    block.name = base_name(path_);
    block.grid = grid;
    block.fields.add(Field(field_name_, Association::Vertex, std::move(values)));
    Dataset ds;
    ds.format = "NRRD (" + magic_ + ", " + std::string(scalar_type_name(type_)) + ", " + encoding_name_ +
                (detached_ ? ", detached data " + base_name(data_path_) : std::string()) + ")";
    ds.sources.push_back(path_);
    if (detached_) ds.sources.push_back(data_path_);
    ds.blocks.push_back(std::move(block));
    ds.warnings = std::move(warnings_);
    return ds;
  }

 private:
  [[noreturn]] void fail_line(uint64_t line, const std::string& message) const { fail_at_line(path_, line, message); }
  [[noreturn]] void fail_field(const std::string& key, const std::string& message) const {
    fail_line(fields_.at(key).line, "field '" + key + "': " + message);
  }
  const HeaderField* field(const std::string& key) const {
    const auto it = fields_.find(key);
    return it == fields_.end() ? nullptr : &it->second;
  }

  // Splits the header into fields; sets data_offset_/data_line_ to where attached data would begin.
  void parse_header() {
    std::string head(size_t(std::min(header_file_.size(), kMaxHeader)), '\0');
    header_file_.read_at(0, head.data(), head.size());
    size_t pos = 0;
    uint64_t line_no = 0;
    bool ended = false;
    while (pos < head.size()) {
      const size_t eol = head.find('\n', pos);
      if (eol == std::string::npos && header_file_.size() > kMaxHeader) {
        fail_line(line_no + 1, "header line beyond the first " + std::to_string(kMaxHeader) +
                                   " bytes: no blank line ends the header");
      }
      const size_t end = eol == std::string::npos ? head.size() : eol;
      std::string_view line(head.data() + pos, end - pos);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      pos = eol == std::string::npos ? head.size() : eol + 1;
      ++line_no;
      if (line_no == 1) {
        if (line.size() != 8 || !line.starts_with("NRRD000") || line[7] < '1' || line[7] > '5') {
          fail_line(1, "not a NRRD file: the first line must be NRRD0001 .. NRRD0005");
        }
        magic_ = std::string(line);
        continue;
      }
      if (line.empty()) {
        ended = true;
        break;
      }
      if (line.front() == '#') continue;
      parse_field(line, line_no);
    }
    if (!ended && header_file_.size() > kMaxHeader) {
      fail_line(line_no, "no blank line ends the header within its first " + std::to_string(kMaxHeader) + " bytes");
    }
    if (line_no == 0) fail_line(1, "empty file: not a NRRD file");
    data_offset_ = pos;
    data_line_ = line_no + 1;
    header_ended_by_blank_ = ended;
  }

  void parse_field(std::string_view line, uint64_t line_no) {
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos) {
      fail_line(line_no, "expected 'field: value', found '" + std::string(line.substr(0, 60)) + "'");
    }
    if (colon + 1 < line.size() && line[colon + 1] == '=') return;  // key/value pair: metadata only
    if (colon + 1 >= line.size() || line[colon + 1] != ' ') {
      fail_line(line_no, "expected ': ' after the field name '" + std::string(line.substr(0, colon)) + "'");
    }
    std::string key(line.substr(0, colon));
    for (char& c : key) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (key == "datafile") key = "data file";
    if (key == "lineskip") key = "line skip";
    if (key == "byteskip") key = "byte skip";
    if (key == "spacedirections") key = "space directions";
    if (key == "spaceorigin") key = "space origin";
    if (key == "axismins") key = "axis mins";
    if (fields_.count(key)) fail_line(line_no, "field '" + key + "' appears twice");
    // Checked here, not with the other fields: the LIST form goes on with file names that are not header lines.
    if (key == "data file" && trim(line.substr(colon + 2)).starts_with("LIST")) {
      fail_line(line_no, "field 'data file': multi-file data (LIST) is not supported");
    }
    fields_[key] = {trim(line.substr(colon + 2)), line_no};
  }

  template <class T>
  T number(const std::string& key, const std::string& text) const {
    T v{};
    if (!parse_number(text, v)) fail_field(key, "'" + text.substr(0, 40) + "' is not a valid number");
    return v;
  }

  const HeaderField& required(const std::string& key) const {
    if (const HeaderField* f = field(key)) return *f;
    fail_in(path_, "NRRD header lacks the required field '" + key + "'");
  }

  void interpret() {
    const std::string type_name = required("type").value;
    const auto t = nrrd_type(type_name);
    if (!t) fail_field("type", "unsupported value type '" + type_name.substr(0, 40) + "'");
    type_ = *t;

    const int dimension = number<int>("dimension", required("dimension").value);
    if (dimension != 3 && dimension != 4) {
      fail_field("dimension",
                 std::to_string(dimension) + " is not supported: volumes are 3-D, or 4-D with a leading vector axis");
    }
    const std::vector<std::string> sizes = words(required("sizes").value);
    if (int(sizes.size()) != dimension) {
      fail_field("sizes",
                 "has " + std::to_string(sizes.size()) + " entries, dimension is " + std::to_string(dimension));
    }
    std::vector<uint64_t> axis(sizes.size());
    for (size_t a = 0; a < sizes.size(); ++a) {
      axis[a] = number<uint64_t>("sizes", sizes[a]);
      if (axis[a] < 1 || axis[a] > UINT32_MAX) fail_field("sizes", "size " + sizes[a] + " is out of range 1..2^32-1");
    }
    first_space_axis_ = dimension == 4 ? 1 : 0;
    if (dimension == 4) {
      if (axis[0] > 4) {
        fail_field("sizes",
                   "4-D NRRD is read only with a leading vector axis of at most 4 components, the first "
                   "size is " +
                       sizes[0]);
      }
      components_ = int(axis[0]);
    }
    for (int a = 0; a < 3; ++a) dims_[size_t(a)] = uint32_t(axis[size_t(first_space_axis_ + a)]);
    uint64_t count = uint64_t(components_);
    for (int a = 0; a < 3; ++a) {
      if (__builtin_mul_overflow(count, uint64_t(dims_[size_t(a)]), &count)) fail_field("sizes", "too many values");
    }
    value_count_ = count;
    if (__builtin_mul_overflow(count, uint64_t(scalar_size(type_)), &byte_count_)) {
      fail_field("sizes", "the volume is larger than 2^64 bytes");
    }

    const std::string enc = required("encoding").value;
    if (enc == "raw") {
      encoding_ = Encoding::Raw;
    } else if (enc == "gzip" || enc == "gz") {
      encoding_ = Encoding::Gzip;
    } else if (enc == "ascii" || enc == "text" || enc == "txt") {
      encoding_ = Encoding::Ascii;
    } else {
      fail_field("encoding", "'" + enc.substr(0, 40) + "' is not supported (raw, gzip, ascii)");
    }
    encoding_name_ = enc;

    if (const HeaderField* e = field("endian")) {
      if (e->value != "little" && e->value != "big") fail_field("endian", "must be little or big");
      big_endian_ = e->value == "big";
    } else if (scalar_size(type_) > 1 && encoding_ != Encoding::Ascii) {
      fail_in(path_, "NRRD header lacks the field 'endian', required for " + std::string(scalar_type_name(type_)) +
                         " values in " + enc + " encoding");
    }
    if (const HeaderField* c = field("content"); c && !c->value.empty()) field_name_ = c->value;
    if (const HeaderField* s = field("space dimension")) {
      if (number<int>("space dimension", s->value) != 3) fail_field("space dimension", "only 3-D space is supported");
    }
    read_geometry(dimension);
    read_data_location();
  }

  // "(x,y,z)" -> three numbers.
  std::array<double, 3> vector3(const std::string& key, const std::string& text) const {
    if (text.size() < 2 || text.front() != '(' || text.back() != ')') {
      fail_field(key, "expected a vector '(x,y,z)', found '" + text.substr(0, 60) + "'");
    }
    std::array<double, 3> v{};
    std::string_view inner(text.data() + 1, text.size() - 2);
    for (size_t k = 0; k < 3; ++k) {
      const size_t comma = inner.find(',');
      if ((k < 2) != (comma != std::string_view::npos)) fail_field(key, "a vector must have 3 components: " + text);
      v[k] = number<double>(key, trim(inner.substr(0, comma)));
      if (!std::isfinite(v[k])) fail_field(key, "vector component is not finite: " + text);
      inner = k < 2 ? inner.substr(comma + 1) : std::string_view();
    }
    return v;
  }

  void read_geometry(int dimension) {
    if (const HeaderField* s = field("spacings")) {
      const std::vector<std::string> w = words(s->value);
      if (int(w.size()) != dimension) fail_field("spacings", "needs one entry per axis");
      for (int a = 0; a < 3; ++a) spacing_[a] = number<double>("spacings", w[size_t(first_space_axis_ + a)]);
    }
    if (const HeaderField* d = field("space directions")) {
      const std::vector<std::string> w = words(d->value);
      if (int(w.size()) != dimension) fail_field("space directions", "needs one entry per axis");
      if (dimension == 4 && w[0] != "none") fail_field("space directions", "the vector axis must be 'none'");
      for (int a = 0; a < 3; ++a) {
        const std::array<double, 3> v = vector3("space directions", w[size_t(first_space_axis_ + a)]);
        for (int k = 0; k < 3; ++k) {
          if (k != a && v[size_t(k)] != 0) {
            fail_field("space directions", "direction " + w[size_t(first_space_axis_ + a)] + " is not along axis " +
                                               std::to_string(a) +
                                               ": rotated or permuted volumes are not supported (axis-aligned only)");
          }
        }
        spacing_[a] = v[size_t(a)];
      }
    }
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(spacing_[a]) || spacing_[a] <= 0) {
        fail_in(path_, "axis " + std::to_string(a) + " spacing " + std::to_string(spacing_[a]) +
                           " is not positive: flipped or degenerate axes are not supported");
      }
    }
    if (const HeaderField* o = field("space origin")) {
      const auto v = vector3("space origin", o->value);
      origin_ = {v[0], v[1], v[2]};
    } else if (const HeaderField* m = field("axis mins")) {
      const std::vector<std::string> w = words(m->value);
      if (int(w.size()) != dimension) fail_field("axis mins", "needs one entry per axis");
      for (int a = 0; a < 3; ++a) {
        origin_[a] = number<double>("axis mins", w[size_t(first_space_axis_ + a)]);
        if (!std::isfinite(origin_[a])) fail_field("axis mins", "not finite");
      }
    }
  }

  void read_data_location() {
    if (const HeaderField* d = field("data file")) {
      const std::vector<std::string> w = words(d->value);
      if (w.empty()) fail_field("data file", "is empty");
      if (w[0] == "LIST" || w.size() > 1) {
        fail_field("data file", "multi-file data (LIST or a printf-style pattern) is not supported");
      }
      detached_ = true;
      data_path_ = w[0].front() == '/' ? w[0] : dir_name(path_) + w[0];
      data_offset_ = 0;
      data_line_ = 1;
    } else if (!header_ended_by_blank_) {
      fail_in(path_, "the NRRD header has no 'data file' field and no blank line before attached data");
    }
    if (const HeaderField* l = field("line skip")) {
      line_skip_ = number<uint64_t>("line skip", l->value);
    }
    if (const HeaderField* b = field("byte skip")) {
      byte_skip_ = number<int64_t>("byte skip", b->value);
      if (byte_skip_ < -1) fail_field("byte skip", "must be -1 or more");
      if (byte_skip_ == -1 && encoding_ != Encoding::Raw) fail_field("byte skip", "-1 is only valid for raw encoding");
    }
  }

  DataArray read_values() {
    std::optional<InputFile> detached;
    if (detached_) detached.emplace(data_path_);
    const InputFile& file = detached ? *detached : header_file_;
    // Line skip counts lines of the (undecoded) data file.
    uint64_t offset = data_offset_, line = data_line_;
    if (line_skip_ > 0) {
      TextTokenizer t(file, {offset, line});
      for (uint64_t i = 0; i < line_skip_; ++i) {
        if (t.at_end())
          fail_at_offset(file.path(), t.offset(),
                         "the data ends before line skip " + std::to_string(line_skip_) + " is done");
        t.skip_line();
      }
      offset = t.offset();
      line = t.line();
    }
    switch (encoding_) {
      case Encoding::Raw: return read_raw(file, offset);
      case Encoding::Gzip: return read_gzip(file, offset);
      case Encoding::Ascii: return read_ascii(file, offset, line);
    }
    throw Error("unreachable");
  }

  void fix_byte_order(DataArray& values) const {
    const size_t size = scalar_size(type_);
    if (size == 1 || big_endian_ == (std::endian::native == std::endian::big)) return;
    std::byte* data = values.bytes();
    for (uint64_t i = 0; i < value_count_; ++i) std::reverse(data + i * size, data + (i + 1) * size);
  }

  DataArray read_raw(const InputFile& file, uint64_t offset) {
    if (byte_skip_ == -1) {
      if (file.size() < offset || file.size() - offset < byte_count_) {
        fail_in(file.path(), "byte skip -1: the file holds " + std::to_string(file.size()) + " bytes, fewer than the " +
                                 std::to_string(byte_count_) + " bytes of data");
      }
      offset = file.size() - byte_count_;
    } else {
      offset += uint64_t(byte_skip_);
    }
    if (offset > file.size() || file.size() - offset < byte_count_) {
      fail_at_offset(file.path(), offset,
                     "raw data of " + std::to_string(byte_count_) + " bytes expected here, the file has only " +
                         std::to_string(offset > file.size() ? 0 : file.size() - offset) + " bytes left");
    }
    if (file.size() - offset > byte_count_) {
      warnings_.push_back(file.path() + ": " + std::to_string(file.size() - offset - byte_count_) +
                          " bytes after the data are ignored");
    }
    DataArray values(type_, components_, value_count_ / uint64_t(components_));
    file.read_at(offset, values.bytes(), size_t(byte_count_));
    fix_byte_order(values);
    return values;
  }

  DataArray read_gzip(const InputFile& file, uint64_t offset) {
    const uint64_t compressed = offset > file.size() ? 0 : file.size() - offset;
    const uint64_t skip = uint64_t(byte_skip_);
    uint64_t wanted = 0;
    if (__builtin_add_overflow(byte_count_, skip, &wanted) || wanted / kMaxDeflateRatio > compressed + 1) {
      fail_at_offset(file.path(), offset,
                     std::to_string(compressed) + " bytes of gzip data cannot decompress to the " +
                         std::to_string(byte_count_) + " bytes of values the header declares");
    }
    DataArray values(type_, components_, value_count_ / uint64_t(components_));
    z_stream z{};
    if (inflateInit2(&z, 15 + 32) != Z_OK) throw Error("zlib: inflateInit2 failed");  // 32: gzip or zlib header
    struct End {
      z_stream* z;
      ~End() { inflateEnd(z); }
    } end{&z};
    std::vector<unsigned char> in(size_t(1) << 20);
    std::vector<unsigned char> scratch(size_t(std::min<uint64_t>(skip, uint64_t(1) << 16)));
    uint64_t in_offset = offset, skipped = 0, produced = 0, trailing = 0;
    bool stream_end = false;
    // Inflating goes on after the array is full, to the end of the stream: only there does zlib compare the gzip
    // CRC-32 and length (or the zlib Adler-32) with what it produced, and a bit flip in the deflate data is often
    // otherwise silent (the issue-23 probe: 6 of 30 flips read as wrong values). Bytes after the values are discarded,
    // up to kMaxTrailingBytes.
    std::vector<unsigned char> discard;
    while (!stream_end) {
      if (z.avail_in == 0) {
        const size_t n = file.read_some_at(in_offset, in.data(), in.size());
        if (n == 0) break;
        z.next_in = in.data();
        z.avail_in = uInt(n);
        in_offset += n;
      }
      // Decompressed bytes go to a scratch buffer until byte skip is done, then straight into the array.
      const bool skipping = skipped < skip;
      const bool full = !skipping && produced == byte_count_;
      if (full && trailing > kMaxTrailingBytes) {
        fail_at_offset(file.path(), in_offset - z.avail_in,
                       "gzip data holds more than " + std::to_string(kMaxTrailingBytes) + " bytes beyond the " +
                           std::to_string(byte_count_) + " bytes of values the header declares");
      }
      if (full && discard.empty()) discard.resize(size_t(1) << 16);
      unsigned char* out = skipping ? scratch.data()
                           : full   ? discard.data()
                                    : reinterpret_cast<unsigned char*>(values.bytes()) + produced;
      const uint64_t room = skipping ? std::min<uint64_t>(skip - skipped, scratch.size())
                            : full   ? discard.size()
                                     : byte_count_ - produced;
      z.next_out = out;
      z.avail_out = uInt(std::min<uint64_t>(room, uint64_t(1) << 30));
      const uInt before = z.avail_out;
      const int r = inflate(&z, Z_NO_FLUSH);
      if (r != Z_OK && r != Z_STREAM_END && !(r == Z_BUF_ERROR && z.avail_in == 0)) {
        fail_at_offset(file.path(), in_offset - z.avail_in,
                       std::string("corrupt gzip data: ") + (z.msg ? z.msg : "inflate failed"));
      }
      (skipping ? skipped : full ? trailing : produced) += before - z.avail_out;
      stream_end = r == Z_STREAM_END;
    }
    if (produced < byte_count_) {
      fail_at_offset(file.path(), in_offset,
                     "gzip data ends after " + std::to_string(produced) + " bytes of values, the header declares " +
                         std::to_string(byte_count_));
    }
    if (!stream_end) {
      // The values are all there but the stream's end, with its checksum and length, is not.
      fail_at_offset(file.path(), in_offset,
                     "gzip data is truncated: the file ends before the end of the compressed stream (its CRC-32 and "
                     "length), so the values cannot be verified");
    }
    fix_byte_order(values);
    return values;
  }

  DataArray read_ascii(const InputFile& file, uint64_t offset, uint64_t line) {
    if (offset > file.size()) fail_at_offset(file.path(), offset, "ASCII data expected here");
    // Every value but the last needs a separator, so n values take at least 2n-1 bytes.
    check_count_fits(file.path(), offset, "ASCII value", value_count_, 2, file.size() - offset + 1);
    TextTokenizer t(file, {offset + (byte_skip_ > 0 ? uint64_t(byte_skip_) : 0), line});
    DataArray values(type_, components_, value_count_ / uint64_t(components_));
    values.visit([&](auto span) {
      using T = typename decltype(span)::element_type;
      for (uint64_t i = 0; i < value_count_; ++i) {
        std::string_view tok = t.next_token();
        if (!tok.empty() && tok.back() == ',') tok.remove_suffix(1);  // some writers separate with commas
        if (tok.empty()) {
          fail_at_line(
              file.path(), t.line(),
              "ASCII data ends after " + std::to_string(i) + " of " + std::to_string(value_count_) + " values");
        }
        T v{};
        if (!parse_number(tok, v)) {
          t.fail_at_token_line("'" + std::string(tok.substr(0, 40)) + "' is not a valid " +
                               std::string(scalar_type_name(type_)) + " value");
        }
        span[size_t(i)] = v;
      }
    });
    return values;
  }

  InputFile header_file_;
  std::string path_;
  std::string magic_;
  std::map<std::string, HeaderField> fields_;
  uint64_t data_offset_ = 0, data_line_ = 1;
  bool header_ended_by_blank_ = false;

  ScalarType type_ = ScalarType::UInt8;
  int components_ = 1;
  int first_space_axis_ = 0;
  std::array<uint32_t, 3> dims_{1, 1, 1};
  uint64_t value_count_ = 0, byte_count_ = 0;
  Encoding encoding_ = Encoding::Raw;
  std::string encoding_name_;
  bool big_endian_ = false;
  Vec3d spacing_{1, 1, 1};
  Vec3d origin_{0, 0, 0};
  std::string field_name_ = "values";
  bool detached_ = false;
  std::string data_path_;
  uint64_t line_skip_ = 0;
  int64_t byte_skip_ = 0;
  std::vector<std::string> warnings_;
};

}  // namespace

Dataset read_nrrd(const std::string& path) { return NrrdReader(path).read(); }

}  // namespace ugvr
