// EnSight Gold reader: a .case file (or a .sos master-server file listing .case files) naming one geometry file and
// variable files, each ASCII, C binary or Fortran binary.
//
// What is read.
//   .case   FORMAT (type: ensight gold), GEOMETRY (model: [ts] [fs] file), VARIABLE (scalar / vector / tensor symm /
//           tensor asym / complex scalar / complex vector, per node or per element: [ts] [fs] description file(s)),
//           TIME (time set, number of steps, filename start number + increment or filename numbers, time values),
//           FILE (file set, [filename index], number of steps). File names with '*' wildcards are numbered per step
//           (the '*'s give the zero-padded width); a file set without wildcards is one file holding every step between
//           BEGIN TIME STEP / END TIME STEP. One step is read, chosen by ReadOptions::time_step (0-based, -1 = the
//           last) in the time set with the most steps; every other item (geometry, each variable) uses its own time
//           set's last step at or before that time. Steps read as a sequence are the [time] issue's business.
//   .geo    header (two description lines, node id off|assign|given|ignore, element id ..., optional extents), then
//           parts: "coordinates" + element sections (unstructured) or "block" (structured: curvilinear, rectilinear,
//           uniform, each optionally iblanked).
//   vars    per part, "coordinates" / element sections / "block", each component written whole (all x, then all y...),
//           optionally "undef" (a marker value read as NaN) or "partial" (values for listed entries, NaN elsewhere).
//
// Byte layouts. C binary: strings are 80 bytes, integers int32, reals float32; the first string of a geometry file
// is "C Binary". Fortran binary: the same values inside records framed by int32 byte counts; a value may sit in any
// record (writers group them differently), only a record boundary inside one value is refused. Byte order is not
// stated by the format. Fortran: the order in which the first record marker reads 80. C binary: the order in which
// the first part number is plausible (0..2^20; 1 in the wrong order reads 2^24), else in which the count after it is
// (0..file size), else the native one; a variable file is taken in the geometry's order unless its first part
// number (or Fortran marker) reads plausibly only in the other.
//
// Mapping to ugvr's model. One Block per part with volume cells, named by the part's description line. Linear 3-D
// elements keep their vertices (penta6 in VTK's wedge order, as vtkEnSightGoldReader maps it); quadratic ones
// (tetra10, pyramid13, penta15, hexa20) keep their corners; nfaced polyhedra go through PolyhedronDecomposer
// (grid/polyhedra.h). 0-D, 1-D and 2-D elements (point, bar, tria, quad, nsided) and ghost elements (g_*) are dropped
// with a warning, and their per-element values with them; a case without a single volume cell is refused. Points are
// kept as the part lists them (unused ones too), so per-node values map one to one. Structured blocks become
// StructuredGrid / RectilinearGrid / ImageGrid; an iblanked rectilinear or uniform block becomes a StructuredGrid
// (only it carries IBLANK), with EnSight's 0 = blanked as in the model. Complex variables keep their real part only
// (the imaginary file is not read; a warning says so). Symmetric tensors are 6 components in the file's order
// (11 22 33 12 13 23), asymmetric ones 9. A .sos file's servers' cases are read in turn and their blocks
// concatenated, each server's block named "description (server k)" when there are several servers.
//
// Not read (each refused with a message saying so): EnSight 6 files, "change_coords_only" models, "block range" and
// "with_ghost" blocks, time values or filename numbers given in separate files. Structured blocks never carry ids.
//
// Robustness: the files are streamed (TextTokenizer for ASCII, bounded-chunk positional reads for binary); every
// count is checked against the bytes the file has left before anything is allocated for it, and every error names
// the file and the line (ASCII) or byte offset (binary).
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/grid/polyhedra.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/ensight_fields.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/saturating_size.h"
#include "ugvr/io/step_lists.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

std::string trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r' || s[b] == '\n' || s[b] == '\0')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r' || s[e - 1] == '\n' || s[e - 1] == '\0'))
    --e;
  return std::string(s.substr(b, e - b));
}

// An 80-byte binary string: up to its first NUL, surrounding blanks removed.
std::string binary_string(const char* s) {
  const char* nul = static_cast<const char*>(std::memchr(s, 0, 80));
  return trim(std::string_view(s, nul ? size_t(nul - s) : 80));
}

std::vector<std::string> split_words(std::string_view s) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    const size_t b = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t' && s[i] != '\r') ++i;
    if (i > b) out.emplace_back(s.substr(b, i - b));
  }
  return out;
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

enum class Encoding { Ascii, CBinary, FortranBinary };

// ---------------------------------------------------------------------------------------------------------------
// One geometry or variable file as a stream of strings (text lines / 80-byte strings), integers and reals.

class EnsStream {
 public:
  EnsStream(const InputFile& file, Encoding enc, bool big_endian) : file_(file), enc_(enc) {
    swap_ = big_endian != (std::endian::native == std::endian::big);
    if (enc_ == Encoding::Ascii) text_.emplace(file_);
    // Fortran: every file starts with an 80-byte record (a description or "Fortran Binary"), whose marker gives
    // the file's own byte order.
    if (enc_ == Encoding::FortranBinary && file_.size() >= 4) {
      uint32_t m;
      file_.read_at(0, &m, 4);
      const uint32_t as_set = swap_ ? __builtin_bswap32(m) : m, other = swap_ ? m : __builtin_bswap32(m);
      if (as_set != 80 && other == 80) swap_ = !swap_;
    }
  }

  // A part number. In a C binary file whose first part number reads implausibly (negative or over 2^20) but
  // plausibly byte-swapped, the file is in the other byte order than assumed (a variable file written on another
  // machine than its geometry): the order flips for the rest of the file.
  int32_t read_part_number() {
    const int32_t v = read_int("the part number");
    if (enc_ != Encoding::CBinary || part_seen_) return v;
    part_seen_ = true;
    const int32_t w = int32_t(__builtin_bswap32(uint32_t(v)));
    if ((v < 0 || v > (1 << 20)) && w >= 0 && w <= (1 << 20)) {
      swap_ = !swap_;
      return w;
    }
    return v;
  }

  Encoding encoding() const { return enc_; }
  const InputFile& file() const { return file_; }
  void set_big_endian(bool big) { swap_ = big != (std::endian::native == std::endian::big); }

  uint64_t offset() const { return text_ ? text_->offset() : off_; }
  uint64_t bytes_left() const { return file_.size() - std::min(file_.size(), offset()); }

  bool at_end() {
    if (text_) {
      mid_line_ = false;
      return !text_->skip_space();
    }
    return off_ >= file_.size() && rec_left_ == 0;
  }

  [[noreturn]] void fail(const std::string& message) const {
    if (text_) fail_at_line(file_.path(), text_->line(), message);
    fail_at_offset(file_.path(), off_, message);
  }

  // ASCII: the next line (keyword lines skip blank lines first; description lines are taken as they are). Binary: the
  // next 80-byte string, trailing blanks and NULs removed.
  std::string read_string(bool keyword, const char* what) {
    if (text_) {
      if (mid_line_) {
        text_->skip_line();
        mid_line_ = false;
      }
      if (keyword && !text_->skip_space()) fail(std::string("the file ends where ") + what + " should be");
      const auto line = text_->read_line(4096);
      if (!line) fail(std::string("the file ends where ") + what + " should be");
      return trim(*line);
    }
    char buf[80];
    take(buf, 80, what);
    return binary_string(buf);
  }
  // The next keyword without consuming it ("" at the end of the file).
  std::string peek_keyword() {
    if (text_) {
      if (mid_line_) {
        text_->skip_line();
        mid_line_ = false;
      }
      if (!text_->skip_space()) return "";
      const TextTokenizer::Mark m = text_->mark();
      TextTokenizer look(file_, m, std::min<size_t>(TextTokenizer::kDefaultChunk, 2 * TextTokenizer::kMaxToken));
      const auto line = look.read_line(4096);
      return line ? trim(*line) : "";
    }
    if (at_end()) return "";
    const uint64_t o = off_, r = rec_left_;
    char buf[80];
    take(buf, 80, "a keyword");
    off_ = o;
    rec_left_ = r;
    return binary_string(buf);
  }

  int32_t read_int(const char* what) {
    int32_t v = 0;
    read_ints(1, what, [&](uint64_t, int32_t x) { v = x; });
    return v;
  }
  float read_float(const char* what) {
    float v = 0;
    read_floats(1, what, [&](uint64_t, float x) { v = x; });
    return v;
  }

  template <class Sink>
  void read_ints(uint64_t n, const char* what, Sink&& sink) {
    if (text_) {
      for (uint64_t i = 0; i < n; ++i) sink(i, text_->next_number<int32_t>(what));
      mid_line_ = true;
      return;
    }
    values<uint32_t>(n, what, [&](uint64_t i, uint32_t u) { sink(i, int32_t(u)); });
  }
  template <class Sink>
  void read_floats(uint64_t n, const char* what, Sink&& sink) {
    if (text_) {
      for (uint64_t i = 0; i < n; ++i) sink(i, ascii_float(what));
      mid_line_ = true;
      return;
    }
    values<uint32_t>(n, what, [&](uint64_t i, uint32_t u) { sink(i, std::bit_cast<float>(u)); });
  }
  void skip_values(uint64_t n, const char* what) {
    read_ints(n, what, [](uint64_t, int32_t) {});
  }
  void skip_floats(uint64_t n, const char* what) {
    read_floats(n, what, [](uint64_t, float) {});
  }

  // Guards an allocation of `count` items of at least `bytes_each` bytes in the file (ASCII: 2 bytes, a digit and a
  // separator, per value).
  void check_fits(const std::string& what, uint64_t count, uint64_t values_each) const {
    const uint64_t each = sat_mul(values_each, text_ ? 2 : 4);
    check_count_fits(file_.path(), offset(), what, count, std::max<uint64_t>(each, 1), bytes_left());
  }

 private:
  // A real in ASCII. Fortran's E format drops the 'e' when the exponent has three digits ("3.300003+000", as in
  // VTK's own elements.Evec); such a number is read with the 'e' put back.
  float ascii_float(const char* what) {
    const std::string_view t = text_->next_token();
    if (t.empty()) fail(std::string("the file ends where ") + what + " should be");
    float v;
    if (parse_number<float>(t, v)) return v;
    const size_t sign = t.find_last_of("+-");
    if (sign != std::string_view::npos && sign > 0 && t.size() <= 64 &&
        (std::isdigit(static_cast<unsigned char>(t[sign - 1])) || t[sign - 1] == '.')) {
      const std::string fixed = std::string(t.substr(0, sign)) + "e" + std::string(t.substr(sign));
      if (parse_number<float>(fixed, v)) return v;
    }
    text_->fail_at_token_line(std::string("expected a number for ") + what + ", found '" + std::string(t) + "'");
  }

  // Binary: exactly n bytes, following Fortran records across their boundaries.
  void take(void* dst, size_t n, const char* what) {
    auto* out = static_cast<char*>(dst);
    while (n > 0) {
      size_t k = n;
      if (enc_ == Encoding::FortranBinary) {
        if (rec_left_ == 0) open_record(what);
        k = size_t(std::min<uint64_t>(n, rec_left_));
      }
      if (off_ > file_.size() || file_.size() - off_ < k) {
        fail(std::string("the file ends at byte ") + std::to_string(file_.size()) + ", inside " + what);
      }
      file_.read_at(off_, out, k);
      off_ += k;
      out += k;
      n -= k;
      if (enc_ == Encoding::FortranBinary) {
        rec_left_ -= k;
        if (rec_left_ == 0) close_record(what);
      }
    }
  }
  uint32_t marker(const char* what) {
    if (file_.size() - std::min(file_.size(), off_) < 4)
      fail(std::string("the file ends at byte ") + std::to_string(file_.size()) +
           ", where a Fortran record marker should be (reading " + what + ")");
    uint32_t m;
    file_.read_at(off_, &m, 4);
    return swap_ ? __builtin_bswap32(m) : m;
  }
  void open_record(const char* what) {
    const uint32_t m = marker(what);
    if (m == 0 || m > 0x7fffffffu || m > file_.size() - off_ - 4) {
      fail("Fortran record marker " + std::to_string(int32_t(m)) + " is not a record length that fits the file (" +
           "reading " + what + ")");
    }
    rec_start_ = off_;
    rec_len_ = m;
    rec_left_ = m;
    off_ += 4;
  }
  void close_record(const char* what) {
    const uint32_t m = marker(what);
    if (m != rec_len_) {
      fail("Fortran record marker " + std::to_string(int32_t(m)) + " does not match the " + std::to_string(rec_len_) +
           " of the record that began at byte " + std::to_string(rec_start_) + " (reading " + what + ")");
    }
    off_ += 4;
  }

  template <class Raw, class Sink>
  void values(uint64_t count, const char* what, Sink&& sink) {
    constexpr uint64_t kChunk = uint64_t(1) << 14;
    if (enc_ == Encoding::CBinary && sat_mul(count, sizeof(Raw)) > bytes_left()) {
      fail(std::string("the file ends at byte ") + std::to_string(file_.size()) + ", but " + size_text(count) +
           " values of " + what + " should start here");
    }
    Raw buffer[kChunk];
    for (uint64_t done = 0; done < count;) {
      const uint64_t n = std::min(count - done, kChunk);
      take(buffer, size_t(n * sizeof(Raw)), what);
      for (uint64_t k = 0; k < n; ++k) {
        Raw u = buffer[k];
        if (swap_) u = __builtin_bswap32(u);
        sink(done + k, u);
      }
      done += n;
    }
  }

  const InputFile& file_;
  Encoding enc_;
  bool swap_ = false;
  bool part_seen_ = false;
  std::optional<TextTokenizer> text_;
  bool mid_line_ = false;
  uint64_t off_ = 0;
  uint64_t rec_left_ = 0, rec_len_ = 0, rec_start_ = 0;
};

// Encoding from the first bytes of a geometry file, and for binary its byte order from the plausibility of the first
// part number and count (or the first Fortran record marker).
struct FileKind {
  Encoding enc = Encoding::Ascii;
  bool big_endian = false;
};

FileKind detect_geo_kind(const InputFile& f) {
  char head[84] = {};
  const size_t n = f.read_some_at(0, head, sizeof head);
  FileKind k;
  if (starts_with_ignore_case(binary_string(head), "c binary")) {
    k.enc = Encoding::CBinary;
  } else if (n == 84 && starts_with_ignore_case(binary_string(head + 4), "fortran binary")) {
    k.enc = Encoding::FortranBinary;
    uint32_t m;
    std::memcpy(&m, head, 4);
    // The first record is the 80-byte "Fortran Binary" string: its marker reads 80 in the file's byte order.
    k.big_endian = (m == 80) == (std::endian::native == std::endian::big);
    return k;
  } else {
    return k;  // ASCII (anything else fails in the ASCII parse, naming the line)
  }
  // C binary: find the first "part" string (80-byte strings from byte 80 on) and judge the int32 after it.
  const uint64_t size = f.size();
  for (uint64_t at = 80; at + 88 <= size && at < 80 * 16; at += 40) {
    // Strings sit at multiples of 80, or 24 bytes later after the six floats of an "extents" record.
    const uint64_t off = at % 80 == 0 ? at : at - 40 + 24;
    char s[80];
    f.read_at(off, s, 80);
    if (binary_string(s) != "part") continue;
    uint32_t raw[2];  // part number, then (after its 80-byte description and "coordinates"/"block") a count
    f.read_at(off + 80, &raw[0], 4);
    raw[1] = 0;
    if (off + 84 + 160 + 4 <= size) f.read_at(off + 84 + 160, &raw[1], 4);
    auto value = [&](uint32_t r, bool swap) { return int64_t(int32_t(swap ? __builtin_bswap32(r) : r)); };
    // Part numbers are small (EnSight numbers parts from 1): 1 read in the wrong order is 2^24. The count after the
    // part header decides only when the part number fits both orders (or neither).
    auto part_ok = [&](bool swap) { return value(raw[0], swap) >= 0 && value(raw[0], swap) <= (int64_t(1) << 20); };
    auto count_ok = [&](bool swap) { return value(raw[1], swap) >= 0 && uint64_t(value(raw[1], swap)) <= size; };
    const bool native_big = std::endian::native == std::endian::big;
    bool swapped;
    if (part_ok(false) != part_ok(true)) {
      swapped = part_ok(true);
    } else if (count_ok(false) != count_ok(true)) {
      swapped = count_ok(true);
    } else if (part_ok(false) || count_ok(false)) {
      swapped = false;  // both orders plausible: the native one
    } else {
      fail_at_offset(f.path(), off + 80, "neither byte order gives a plausible part number and count here");
    }
    k.big_endian = swapped != native_big;
    return k;
  }
  return k;  // no part in the first strings: the reader will say what is missing
}

// ---------------------------------------------------------------------------------------------------------------
// Element types.

struct ElementType {
  const char* name;
  int nodes;                                             // nodes per element in the file (0: nsided / nfaced)
  int dim;                                               // 0..3
  CellType cell{};                                       // for kept 3-D types
  int corners = 0;                                       // nodes kept (in EnSight order, mapped through `order`)
  std::array<uint8_t, 8> order{0, 1, 2, 3, 4, 5, 6, 7};  // model vertex k = file node order[k]
};

const ElementType* find_element_type(std::string_view name) {
  static const ElementType kTypes[] = {
      {"point", 1, 0},
      {"bar2", 2, 1},
      {"bar3", 3, 1},
      {"tria3", 3, 2},
      {"tria6", 6, 2},
      {"quad4", 4, 2},
      {"quad8", 8, 2},
      {"nsided", 0, 2},
      {"tetra4", 4, 3, CellType::Tetra, 4},
      {"tetra10", 10, 3, CellType::Tetra, 4},
      {"pyramid5", 5, 3, CellType::Pyramid, 5},
      {"pyramid13", 13, 3, CellType::Pyramid, 5},
      // EnSight's penta winds its triangles the other way round from VTK's wedge (vtkEnSightGoldReader's wedgeMap).
      {"penta6", 6, 3, CellType::Wedge, 6, {0, 2, 1, 3, 5, 4, 6, 7}},
      {"penta15", 15, 3, CellType::Wedge, 6, {0, 2, 1, 3, 5, 4, 6, 7}},
      {"hexa8", 8, 3, CellType::Hexahedron, 8},
      {"hexa20", 20, 3, CellType::Hexahedron, 8},
      {"nfaced", 0, 3},
  };
  for (const ElementType& t : kTypes)
    if (name == t.name) return &t;
  return nullptr;
}

// ---------------------------------------------------------------------------------------------------------------
// Geometry.

struct Section {
  std::string type;  // element type name as written (with a "g_" prefix for ghosts)
  uint64_t count = 0;
  bool kept = false;  // its elements are input cells of the part
};

struct Part {
  int32_t number = 0;
  std::string name;
  bool structured = false;
  // Unstructured.
  UnstructuredMesh mesh;
  std::unique_ptr<PolyhedronDecomposer> decomposer;
  std::vector<Section> sections;
  uint64_t dropped = 0;  // lower-dimensional and ghost elements
  // Structured.
  Grid grid;
  uint64_t points = 0;       // original points (values per node)
  uint64_t input_cells = 0;  // values per element that are kept
  uint64_t block_cells = 0;  // a structured part's grid's cells ("block" values per element)
  // Fields-only reads (a part of the layout kept from the mesh's read, io/step_fields.h): no mesh, no decomposer; the
  // decomposer's expansion instead.
  std::optional<CellExpansion> expansion;
  std::string summary;  // ... and its summary
  FieldSet fields;      // on original points / input cells

  bool has_volume() const { return input_cells > 0; }
};

struct Geometry {
  std::vector<std::unique_ptr<Part>> parts;
  std::vector<std::string> warnings;
  Part* find(int32_t number) {
    for (auto& p : parts)
      if (p->number == number) return p.get();
    return nullptr;
  }
};

bool ids_listed(const std::string& line, const char* which, EnsStream& s) {
  const auto w = split_words(lower(line));
  if (w.size() < 3 || w[0] != which || w[1] != "id")
    s.fail("expected '" + std::string(which) + " id <off|given|assign|ignore>', found '" + line + "'");
  if (w[2] == "given" || w[2] == "ignore") return true;
  if (w[2] == "off" || w[2] == "assign") return false;
  s.fail("unknown " + std::string(which) + " id mode '" + w[2] + "' (expected off, given, assign or ignore)");
}

class GeoReader {
 public:
  explicit GeoReader(EnsStream& s) : s_(s) {}

  // Reads one step's geometry from the current position: header and parts, up to the end of the file or an
  // END TIME STEP.
  Geometry read() {
    Geometry g;
    s_.read_string(false, "the first description line");
    s_.read_string(false, "the second description line");
    node_ids_ = ids_listed(s_.read_string(true, "the 'node id' line"), "node", s_);
    element_ids_ = ids_listed(s_.read_string(true, "the 'element id' line"), "element", s_);
    if (lower(s_.peek_keyword()).starts_with("extents")) {
      s_.read_string(true, "extents");
      s_.skip_floats(6, "extents");
    }
    for (;;) {
      const std::string k = lower(s_.peek_keyword());
      if (k.empty() || k.starts_with("end time step")) break;
      if (k != "part") s_.fail("expected 'part', found '" + k + "'");
      s_.read_string(true, "part");
      read_part(g);
    }
    return g;
  }

 private:
  void read_part(Geometry& g) {
    auto p = std::make_unique<Part>();
    p->number = s_.read_part_number();
    if (g.find(p->number)) s_.fail("part " + std::to_string(p->number) + " is listed twice");
    p->name = s_.read_string(false, "the part description");
    if (p->name.empty()) p->name = "part " + std::to_string(p->number);
    const std::string k = lower(s_.read_string(true, "'coordinates' or 'block'"));
    if (k.starts_with("coordinates")) {
      read_unstructured(*p, g);
    } else if (k.starts_with("block")) {
      read_block(*p, k, g);
    } else {
      s_.fail("expected 'coordinates' or 'block' in part " + std::to_string(p->number) + ", found '" + k + "'");
    }
    g.parts.push_back(std::move(p));
  }

  void read_unstructured(Part& p, Geometry& g) {
    const std::string tag = "part " + std::to_string(p.number);
    const int32_t nn = s_.read_int("the number of nodes");
    if (nn < 0) s_.fail(tag + ": negative node count " + std::to_string(nn));
    s_.check_fits(tag + " node", uint64_t(nn), 3 + (node_ids_ ? 1 : 0));
    if (node_ids_) s_.skip_values(uint64_t(nn), "node ids");
    p.points = uint64_t(nn);
    p.mesh.points.resize(size_t(nn));
    for (int c = 0; c < 3; ++c) {
      s_.read_floats(uint64_t(nn), "node coordinates",
                     [&](uint64_t i, float v) { (&p.mesh.points[size_t(i)].x)[c] = v; });
    }
    p.decomposer = std::make_unique<PolyhedronDecomposer>(p.mesh, s_.file().path());
    for (;;) {
      const std::string k = lower(s_.peek_keyword());
      if (k.empty() || k == "part" || k.starts_with("end time step")) break;
      const std::string name = s_.read_string(true, "an element type");
      const std::string lname = lower(name);
      const bool ghost = lname.starts_with("g_");
      const ElementType* t = find_element_type(ghost ? std::string_view(lname).substr(2) : std::string_view(lname));
      if (!t) s_.fail(tag + ": unknown element type '" + name + "'");
      const int32_t ne = s_.read_int("the number of elements");
      if (ne < 0) s_.fail(tag + ": negative element count " + std::to_string(ne) + " for " + name);
      Section sec{lname, uint64_t(ne), t->dim == 3 && !ghost};
      s_.check_fits(tag + " " + name + " element", uint64_t(ne),
                    uint64_t(std::max(t->nodes, 1)) + (element_ids_ ? 1 : 0));
      if (element_ids_) s_.skip_values(uint64_t(ne), "element ids");
      if (t->nodes > 0) {
        read_fixed(p, *t, sec, tag);
      } else if (std::string_view(t->name) == "nsided") {
        uint64_t total = 0;
        s_.read_ints(uint64_t(ne), "nsided node counts", [&](uint64_t, int32_t v) {
          if (v < 3) s_.fail(tag + ": an nsided element of " + std::to_string(v) + " nodes");
          total = sat_add(total, uint64_t(v));
        });
        s_.check_fits(tag + " nsided connectivity entry", total, 1);
        s_.skip_values(total, "nsided connectivity");
      } else {
        read_nfaced(p, sec, tag);
      }
      if (sec.kept) {
        p.input_cells += sec.count;
      } else {
        p.dropped += sec.count;
        dropped_[sec.type] += sec.count;
      }
      p.sections.push_back(sec);
    }
    if (p.dropped > 0) {
      std::string detail;
      for (const auto& [type, n] : dropped_) detail += (detail.empty() ? "" : ", ") + std::to_string(n) + " " + type;
      g.warnings.push_back(s_.file().name() + ": part " + std::to_string(p.number) + " (" + p.name + "): ignored " +
                           std::to_string(p.dropped) + " element(s) that are not volume cells or are ghosts (" +
                           detail + "); their per-element values are dropped with them");
      dropped_.clear();
    }
  }

  uint32_t node_index(int32_t v, uint64_t nn, const std::string& tag) {
    if (v < 1 || uint64_t(v) > nn)
      s_.fail(tag + ": node " + std::to_string(v) + " is out of range 1.." + std::to_string(nn));
    return uint32_t(v - 1);
  }

  void read_fixed(Part& p, const ElementType& t, const Section& sec, const std::string& tag) {
    const uint64_t nn = p.points;
    const uint64_t npe = uint64_t(t.nodes);
    std::vector<uint32_t> nodes(npe);
    std::array<uint32_t, 8> cell{};
    uint64_t element = 0;
    s_.read_ints(sec.count * npe, "element connectivity", [&](uint64_t i, int32_t v) {
      const uint64_t k = i % npe;
      nodes[k] = node_index(v, nn, tag + " " + t.name + " element " + std::to_string(element + 1));
      if (k + 1 < npe) return;
      ++element;
      if (!sec.kept) return;
      for (int c = 0; c < t.corners; ++c) cell[size_t(c)] = nodes[t.order[size_t(c)]];
      p.decomposer->add_native(t.cell, std::span<const uint32_t>(cell.data(), size_t(t.corners)));
    });
  }

  void read_nfaced(Part& p, const Section& sec, const std::string& tag) {
    const uint64_t ne = sec.count;
    std::vector<uint32_t> faces_per_element(ne);
    uint64_t total_faces = 0;
    s_.read_ints(ne, "nfaced face counts", [&](uint64_t i, int32_t v) {
      if (v < 4) s_.fail(tag + ": nfaced element " + std::to_string(i + 1) + " has " + std::to_string(v) + " faces");
      faces_per_element[size_t(i)] = uint32_t(v);
      total_faces = sat_add(total_faces, uint64_t(v));
    });
    s_.check_fits(tag + " nfaced face", total_faces, 1);
    std::vector<uint32_t> face_sizes(static_cast<size_t>(total_faces));
    uint64_t total_nodes = 0;
    s_.read_ints(total_faces, "nfaced face node counts", [&](uint64_t i, int32_t v) {
      if (v < 3) s_.fail(tag + ": an nfaced face of " + std::to_string(v) + " nodes");
      face_sizes[size_t(i)] = uint32_t(v);
      total_nodes = sat_add(total_nodes, uint64_t(v));
    });
    s_.check_fits(tag + " nfaced connectivity entry", total_nodes, 1);
    std::vector<uint32_t> conn(static_cast<size_t>(total_nodes));
    s_.read_ints(total_nodes, "nfaced connectivity",
                 [&](uint64_t i, int32_t v) { conn[size_t(i)] = node_index(v, p.points, tag + " nfaced element"); });
    if (!sec.kept) return;
    uint64_t f = 0, c = 0;
    for (uint64_t e = 0; e < ne; ++e) {
      const uint64_t nf = faces_per_element[size_t(e)];
      uint64_t nodes = 0;
      for (uint64_t k = 0; k < nf; ++k) nodes += face_sizes[size_t(f + k)];
      p.decomposer->add_polyhedron(std::span<const uint32_t>(face_sizes.data() + f, size_t(nf)),
                                   std::span<const uint32_t>(conn.data() + c, size_t(nodes)));
      f += nf;
      c += nodes;
    }
  }

  void read_block(Part& p, const std::string& line, Geometry& g) {
    const std::string tag = "part " + std::to_string(p.number);
    const auto w = split_words(line);
    bool iblanked = false, uniform = false, rectilinear = false;
    for (size_t i = 1; i < w.size(); ++i) {
      if (w[i] == "iblanked") {
        iblanked = true;
      } else if (w[i] == "uniform") {
        uniform = true;
      } else if (w[i] == "rectilinear") {
        rectilinear = true;
      } else if (w[i] == "curvilinear") {
      } else {
        s_.fail(tag + ": '" + line + "' is not read (only curvilinear, rectilinear and uniform blocks, optionally " +
                "iblanked; 'range' and 'with_ghost' are not supported)");
      }
    }
    p.structured = true;
    std::array<int32_t, 3> d{};
    s_.read_ints(3, "block dimensions", [&](uint64_t i, int32_t v) { d[size_t(i)] = v; });
    GridDims dims;
    uint64_t n = 1;
    for (int k = 0; k < 3; ++k) {
      if (d[size_t(k)] < 1) s_.fail(tag + ": block dimension " + "ijk"[k] + " = " + std::to_string(d[size_t(k)]));
      dims.points[size_t(k)] = uint32_t(d[size_t(k)]);
      n = sat_mul(n, uint64_t(d[size_t(k)]));
    }
    p.points = n;
    const uint64_t values_per_point = (rectilinear || uniform ? 0 : 3) + (iblanked ? 1 : 0);
    if (values_per_point > 0) s_.check_fits(tag + " block point", n, values_per_point);
    if (rectilinear) {
      s_.check_fits(tag + " rectilinear coordinate", uint64_t(d[0]) + d[1] + d[2], 1);
      RectilinearGrid r;
      r.dims = dims;
      for (int c = 0; c < 3; ++c) {
        r.coords[size_t(c)].resize(dims.points[size_t(c)]);
        s_.read_floats(dims.points[size_t(c)], "rectilinear coordinates",
                       [&](uint64_t i, float v) { r.coords[size_t(c)][size_t(i)] = v; });
      }
      p.grid = std::move(r);
    } else if (uniform) {
      ImageGrid im;
      im.dims = dims;
      std::array<float, 6> o{};
      s_.read_floats(6, "uniform block origin and spacing", [&](uint64_t i, float v) { o[size_t(i)] = v; });
      im.origin = {o[0], o[1], o[2]};
      im.spacing = {o[3], o[4], o[5]};
      p.grid = im;
    } else {
      StructuredGrid sg;
      sg.dims = dims;
      sg.points.resize(size_t(n));
      for (int c = 0; c < 3; ++c)
        s_.read_floats(n, "block coordinates", [&](uint64_t i, float v) { (&sg.points[size_t(i)].x)[c] = v; });
      p.grid = std::move(sg);
    }
    if (iblanked) {
      StructuredGrid sg = to_curvilinear(p.grid);
      sg.iblank.resize(size_t(n));
      s_.read_ints(n, "iblank values", [&](uint64_t i, int32_t v) { sg.iblank[size_t(i)] = v; });
      if (!std::holds_alternative<StructuredGrid>(p.grid)) {
        g.warnings.push_back(s_.file().name() + ": part " + std::to_string(p.number) + " (" + p.name + "): iblanked " +
                             (rectilinear ? "rectilinear" : "uniform") +
                             " block read as a curvilinear grid (only curvilinear grids carry IBLANK)");
      }
      p.grid = std::move(sg);
    }
    p.block_cells = grid_cell_count(p.grid);
    p.input_cells = dims.cell_count();
    if (p.input_cells == 0) {
      g.warnings.push_back(s_.file().name() + ": part " + std::to_string(p.number) + " (" + p.name +
                           "): ignored a block of dimensions " + std::to_string(d[0]) + "x" + std::to_string(d[1]) +
                           "x" + std::to_string(d[2]) + ", which has no volume cells");
    }
  }

  static StructuredGrid to_curvilinear(const Grid& grid) {
    if (const auto* s = std::get_if<StructuredGrid>(&grid)) return *s;
    StructuredGrid sg;
    std::visit(
        [&](const auto& gr) {
          using G = std::decay_t<decltype(gr)>;
          if constexpr (std::is_same_v<G, ImageGrid> || std::is_same_v<G, RectilinearGrid>) {
            sg.dims = gr.dims;
            sg.points.reserve(size_t(gr.dims.point_count()));
            for (uint32_t k = 0; k < gr.dims.points[2]; ++k)
              for (uint32_t j = 0; j < gr.dims.points[1]; ++j)
                for (uint32_t i = 0; i < gr.dims.points[0]; ++i) {
                  const Vec3d q = gr.point(i, j, k);
                  sg.points.push_back(Vec3f{float(q.x), float(q.y), float(q.z)});
                }
          }
        },
        grid);
    return sg;
  }

  EnsStream& s_;
  bool node_ids_ = false, element_ids_ = false;
  std::map<std::string, uint64_t> dropped_;
};

// ---------------------------------------------------------------------------------------------------------------
// Variables.

enum class VarAssoc { Node, Element };

struct Variable {
  std::string kind;  // "scalar", "vector", "tensor symm", "tensor asym"
  int components = 1;
  VarAssoc assoc = VarAssoc::Node;
  bool complex = false;
  std::optional<int> ts, fs;
  std::string name;
  std::string file;  // (real part for complex)
  uint64_t line = 0;
};

// Reads one step of one variable file into the parts' fields.
void read_variable_step(EnsStream& s, const Variable& v, Geometry& g, bool store) {
  s.read_string(false, "the description line");
  const int nc = v.components;
  while (true) {
    const std::string k = lower(s.peek_keyword());
    if (k.empty() || k.starts_with("end time step")) break;
    if (k != "part") s.fail("expected 'part', found '" + k + "'");
    s.read_string(true, "part");
    const int32_t number = s.read_part_number();
    Part* p = g.find(number);
    if (!p) s.fail("part " + std::to_string(number) + " is not in the geometry");
    const std::string tag = "part " + std::to_string(number);
    const bool per_node = v.assoc == VarAssoc::Node;
    const uint64_t tuples = per_node ? p->points : p->input_cells;
    std::vector<float> values;
    const bool keep = store && p->has_volume();
    if (keep) values.assign(size_t(tuples * uint64_t(nc)), kNaN);
    size_t section = 0;
    uint64_t cell_base = 0;
    // One run of values: `n` entries of `nc` components (component-major in the file) going to tuples
    // base + (partial ? ids : 0..n).
    auto read_run = [&](const std::string& header, uint64_t n, uint64_t base, bool keep_values) {
      const auto w = split_words(header);
      const bool undef = w.size() > 1 && w[1] == "undef";
      const bool partial = w.size() > 1 && w[1] == "partial";
      float undef_value = 0;
      if (undef) undef_value = s.read_float("the undef value");
      std::vector<uint64_t> ids;
      uint64_t count = n;
      if (partial) {
        const int32_t np = s.read_int("the partial count");
        if (np < 0 || uint64_t(np) > n)
          s.fail(tag + ": partial count " + std::to_string(np) + " outside 0.." + std::to_string(n));
        count = uint64_t(np);
        ids.resize(size_t(count));
        s.read_ints(count, "partial ids", [&](uint64_t i, int32_t id) {
          if (id < 1 || uint64_t(id) > n)
            s.fail(tag + ": partial id " + std::to_string(id) + " outside 1.." + std::to_string(n));
          ids[size_t(i)] = uint64_t(id - 1);
        });
      }
      s.check_fits(tag + " '" + v.name + "' value", count, uint64_t(nc));
      for (int c = 0; c < nc; ++c) {
        s.read_floats(count, "variable values", [&](uint64_t i, float x) {
          if (!keep_values) return;
          if (undef && x == undef_value) x = kNaN;
          const uint64_t t = base + (partial ? ids[size_t(i)] : i);
          values[size_t(t * uint64_t(nc) + uint64_t(c))] = x;
        });
      }
    };
    for (;;) {
      const std::string h = lower(s.peek_keyword());
      if (h.empty() || h == "part" || h.starts_with("end time step")) break;
      s.read_string(true, "a section keyword");
      if (h.starts_with("coordinates")) {
        if (!per_node || p->structured)
          s.fail(tag + ": 'coordinates' in a " + std::string(per_node ? "structured part" : "per-element variable"));
        read_run(h, p->points, 0, keep);
      } else if (h.starts_with("block")) {
        if (!p->structured) s.fail(tag + ": 'block' values for an unstructured part");
        read_run(h, per_node ? p->points : p->block_cells, 0, keep);
      } else {
        if (per_node || p->structured) s.fail(tag + ": unexpected '" + h + "' in a per-node or structured variable");
        const std::string type = split_words(h).empty() ? h : split_words(h)[0];
        // The next geometry section of that type (writers keep the geometry's order; a type may repeat).
        size_t j = section;
        uint64_t base = cell_base;
        while (j < p->sections.size() && p->sections[j].type != type) {
          if (p->sections[j].kept) base += p->sections[j].count;
          ++j;
        }
        if (j == p->sections.size())
          s.fail(tag + ": element type '" + type + "' is not in this part's geometry (or not in its order)");
        read_run(h, p->sections[j].count, base, keep && p->sections[j].kept);
        if (p->sections[j].kept) base += p->sections[j].count;
        section = j + 1;
        cell_base = base;
      }
    }
    if (!keep) continue;
    if (p->fields.find(v.name, per_node ? Association::Vertex : Association::Cell))
      s.fail(tag + ": values for '" + v.name + "' are given twice");
    p->fields.add(
        Field(v.name, per_node ? Association::Vertex : Association::Cell, DataArray::from(std::move(values), nc)));
  }
}

// ---------------------------------------------------------------------------------------------------------------
// The case file.

struct TimeSet {
  std::vector<double> times;
  std::vector<int64_t> numbers;  // filename numbers per step
};
struct FileSet {
  // (filename index or -1, steps in that file)
  std::vector<std::pair<int64_t, uint64_t>> files;
};

struct CaseFile {
  std::string path, dir;
  std::optional<int> model_ts, model_fs;
  std::string model;
  uint64_t model_line = 0;
  std::vector<Variable> variables;
  std::map<int, TimeSet> time_sets;
  std::map<int, FileSet> file_sets;
  std::vector<std::string> warnings;
};

bool is_int(const std::string& s, int& v) { return parse_number<int>(s, v); }

CaseFile parse_case(const std::string& path) {
  InputFile f(path);
  const std::string text = f.read_all(uint64_t(64) << 20);
  CaseFile c;
  c.path = path;
  c.dir = dir_name(path);
  std::vector<std::string> lines;
  for (size_t b = 0; b <= text.size();) {
    size_t e = text.find('\n', b);
    if (e == std::string::npos) e = text.size();
    lines.push_back(text.substr(b, e - b));
    b = e + 1;
  }
  std::string section;
  bool format_seen = false;
  int cur_ts = -1, cur_fs = -1;
  int64_t cur_index = -1;
  // Numbers that may continue over the following lines: collects `count` of them starting with `rest`.
  size_t li = 0;
  auto fail_line = [&](const std::string& m) -> void { fail_at_line(path, li + 1, m); };
  auto numbers = [&](std::string rest, uint64_t count, const char* what) {
    std::vector<double> out;
    for (;;) {
      for (const std::string& w : split_words(rest)) {
        double v;
        if (!parse_number<double>(w, v)) fail_line(std::string("'") + w + "' is not a number (" + what + ")");
        out.push_back(v);
      }
      if (out.size() >= count) break;
      if (++li >= lines.size())
        fail_line(std::string("the file ends before all ") + std::to_string(count) + " " + what);
      rest = lines[li];
    }
    if (out.size() != count)
      fail_line(std::string("more ") + what + " than the " + std::to_string(count) + " expected");
    return out;
  };
  uint64_t pending_steps = 0;
  bool numbers_given = false;
  int64_t start = 0, increment = 1;
  auto finish_ts = [&] {
    if (cur_ts < 0) return;
    TimeSet& t = c.time_sets[cur_ts];
    if (!numbers_given) {
      t.numbers.resize(size_t(pending_steps));
      for (uint64_t i = 0; i < pending_steps; ++i) t.numbers[size_t(i)] = start + int64_t(i) * increment;
    }
    if (t.times.size() != pending_steps)
      fail_in(path, "time set " + std::to_string(cur_ts) + " lists " + std::to_string(t.times.size()) +
                        " time values for " + std::to_string(pending_steps) + " steps");
  };
  for (li = 0; li < lines.size(); ++li) {
    std::string line = trim(lines[li]);
    if (line.empty() || line[0] == '#') continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) {
      const std::string s = lower(line);
      if (section == "time") {
        finish_ts();
        cur_ts = -1;
      }
      if (s == "format" || s == "geometry" || s == "variable" || s == "time" || s == "file" || s == "material" ||
          s == "block_continuation" || s == "scripts") {
        section = s == "format" || s == "geometry" || s == "variable" || s == "time" || s == "file" ? s : "other";
        continue;
      }
      fail_line("unexpected line '" + line + "'");
    }
    const std::string key = lower(trim(line.substr(0, colon)));
    const std::string value = trim(line.substr(colon + 1));
    if (section == "format") {
      if (key == "type") {
        const std::string v = lower(value);
        if (v.find("gold") == std::string::npos)
          fail_line("'type: " + value + "': only EnSight Gold is read (not EnSight 6 or 5)");
        format_seen = true;
      }
    } else if (section == "geometry") {
      if (key == "model") {
        auto w = split_words(value);
        int v;
        size_t i = 0;
        if (i < w.size() && is_int(w[i], v) && w.size() > 1) c.model_ts = v, ++i;
        if (i < w.size() && is_int(w[i], v) && w.size() > 2) c.model_fs = v, ++i;
        if (i >= w.size()) fail_line("'model:' names no file");
        c.model = w[i];
        c.model_line = li + 1;
        for (size_t j = i + 1; j < w.size(); ++j)
          if (lower(w[j]).starts_with("change_coords_only")) fail_line("'change_coords_only' geometry is not read");
      } else {
        c.warnings.push_back(base_name(path) + ": '" + key + ":' geometry ignored (only the model is read)");
      }
    } else if (section == "variable") {
      Variable v;
      v.line = li + 1;
      std::string k = key;
      if (k.starts_with("complex ")) v.complex = true, k = k.substr(8);
      if (k.ends_with(" per node")) {
        v.assoc = VarAssoc::Node;
        k = k.substr(0, k.size() - 9);
      } else if (k.ends_with(" per element")) {
        v.assoc = VarAssoc::Element;
        k = k.substr(0, k.size() - 12);
      } else {
        c.warnings.push_back(base_name(path) + ": variable '" + key + ":' ignored (only per-node and per-element " +
                             "variables are read)");
        continue;
      }
      if (k == "scalar") {
        v.components = 1;
      } else if (k == "vector") {
        v.components = 3;
      } else if (k == "tensor symm" || k == "tensor") {
        v.components = 6;
      } else if (k == "tensor asym") {
        v.components = 9;
      } else {
        c.warnings.push_back(base_name(path) + ": variable '" + key + ":' ignored (unknown kind)");
        continue;
      }
      if (v.complex && v.components > 3) fail_line("complex " + k + " is not an EnSight variable kind");
      v.kind = k;
      auto w = split_words(value);
      // [ts] [fs] description file   (complex: [ts] [fs] description real_file imaginary_file frequency)
      const size_t tail = v.complex ? 4 : 2;
      if (w.size() < tail) fail_line("variable line '" + line + "' has too few words");
      const size_t lead = w.size() - tail;
      if (lead > 2) fail_line("variable line '" + line + "': descriptions and file names must not contain spaces");
      int n;
      if (lead >= 1) {
        if (!is_int(w[0], n)) fail_line("'" + w[0] + "' is not a time set number");
        v.ts = n;
      }
      if (lead >= 2) {
        if (!is_int(w[1], n)) fail_line("'" + w[1] + "' is not a file set number");
        v.fs = n;
      }
      v.name = w[lead];
      v.file = w[lead + 1];
      if (v.complex) {
        c.warnings.push_back(base_name(path) + ": complex variable '" + v.name +
                             "': its real part is read, the imaginary part (" + w[lead + 2] + ") is not");
      }
      c.variables.push_back(v);
    } else if (section == "time") {
      if (key == "time set") {
        finish_ts();
        int n = 0;
        const auto w = split_words(value);
        if (w.empty() || !is_int(w[0], n)) fail_line("'time set:' needs a number");
        if (c.time_sets.count(n)) fail_line("time set " + std::to_string(n) + " is defined twice");
        cur_ts = n;
        c.time_sets[n];
        pending_steps = 0;
        numbers_given = false;
        start = 0;
        increment = 1;
      } else if (cur_ts < 0) {
        fail_line("'" + key + ":' before 'time set:'");
      } else if (key == "number of steps") {
        int64_t n;
        if (!parse_number<int64_t>(value, n) || n < 0 || n > int64_t(text.size()))
          fail_line("'" + value + "' is not a plausible number of steps");
        pending_steps = uint64_t(n);
      } else if (key == "filename start number") {
        if (!parse_number<int64_t>(value, start)) fail_line("'" + value + "' is not a number");
      } else if (key == "filename increment") {
        if (!parse_number<int64_t>(value, increment)) fail_line("'" + value + "' is not a number");
      } else if (key == "filename numbers") {
        const auto v = numbers(value, pending_steps, "filename numbers");
        TimeSet& t = c.time_sets[cur_ts];
        t.numbers.clear();
        for (double x : v) t.numbers.push_back(int64_t(x));
        numbers_given = true;
      } else if (key == "time values") {
        c.time_sets[cur_ts].times = numbers(value, pending_steps, "time values");
      } else if (key == "filename numbers file" || key == "time values file") {
        fail_line("'" + key + ":' is not read (give the list in the case file)");
      }
    } else if (section == "file") {
      int64_t n;
      if (key == "file set") {
        if (!parse_number<int64_t>(value, n)) fail_line("'file set:' needs a number");
        cur_fs = int(n);
        cur_index = -1;
        c.file_sets[cur_fs];
      } else if (cur_fs < 0) {
        fail_line("'" + key + ":' before 'file set:'");
      } else if (key == "filename index") {
        if (!parse_number<int64_t>(value, cur_index)) fail_line("'filename index:' needs a number");
      } else if (key == "number of steps") {
        if (!parse_number<int64_t>(value, n) || n < 0 || n > int64_t(1) << 31)
          fail_line("'" + value + "' is not a plausible number of steps");
        c.file_sets[cur_fs].files.push_back({cur_index, uint64_t(n)});
      }
    }
  }
  li = lines.size() - 1;
  if (section == "time") finish_ts();
  if (!format_seen) fail_in(path, "no 'type: ensight gold' in a FORMAT section: not an EnSight Gold case file");
  if (c.model.empty()) fail_in(path, "no 'model:' line in a GEOMETRY section");
  return c;
}

// '*' wildcards replaced by the zero-padded number.
std::string apply_wildcards(const std::string& pattern, int64_t number) {
  const size_t b = pattern.find('*');
  if (b == std::string::npos) return pattern;
  size_t e = b;
  while (e < pattern.size() && pattern[e] == '*') ++e;
  std::string digits = std::to_string(number);
  if (digits.size() < e - b) digits.insert(0, e - b - digits.size(), '0');
  return pattern.substr(0, b) + digits + pattern.substr(e);
}

// Where one item (geometry or variable) of the chosen time is: its file and which of the file's steps.
struct Located {
  std::string path;
  uint64_t step_in_file = 0;  // 0 and single_step for a file that holds one step without markers
  bool multi_step = false;
};

// ---------------------------------------------------------------------------------------------------------------

// What a step's variables need of the geometry they lie on, kept from the geometry's read (ensight_fields.h): each
// part's counts, element sections and polyhedra decomposition, and the geometry file's encoding and notes.
struct PartLayout {
  int32_t number = 0;
  std::string name;
  bool structured = false;
  uint64_t points = 0, input_cells = 0, block_cells = 0;
  std::vector<Section> sections;
  std::optional<CellExpansion> expansion;  // unstructured parts
  std::string summary;                     // the decomposer's
};

}  // namespace

struct EnsightLayout {
  std::optional<uint64_t> mesh_key;  // ensight_mesh_key of the case when read
  std::string geo_path;
  FileKind kind;
  std::vector<std::string> geo_warnings;
  std::vector<PartLayout> parts;  // in the geometry's order
};

namespace {

PartLayout part_layout(const Part& p) {
  PartLayout l{p.number, p.name, p.structured, p.points, p.input_cells, p.block_cells, p.sections, {}, {}};
  if (p.decomposer) {
    l.expansion = p.decomposer->expansion();
    l.summary = p.decomposer->summary();
  }
  return l;
}

// The geometry a step's variables are read against, without its mesh: parts with the layout's counts and sections.
Geometry skeleton(const EnsightLayout& layout) {
  Geometry g;
  for (const PartLayout& l : layout.parts) {
    auto p = std::make_unique<Part>();
    p->number = l.number;
    p->name = l.name;
    p->structured = l.structured;
    p->points = l.points;
    p->input_cells = l.input_cells;
    p->block_cells = l.block_cells;
    p->sections = l.sections;
    p->expansion = l.expansion;
    p->summary = l.summary;
    g.parts.push_back(std::move(p));
  }
  return g;
}

// A part's fields as its block carries them: a structured part's as read; an unstructured part's expanded over its
// polyhedra decomposition (the decomposer's, or a layout's), whose summary joins `warnings`.
FieldSet part_fields(Part& p, const std::string& geo_path, std::vector<std::string>& warnings) {
  if (p.structured) return std::move(p.fields);
  const CellExpansion& x = p.decomposer ? p.decomposer->expansion() : *p.expansion;
  FieldSet out;
  for (const Field& f : p.fields)
    out.add(f.association() == Association::Vertex ? x.expand_point_field(f) : x.expand_cell_field(f));
  const std::string summary = p.decomposer ? p.decomposer->summary() : p.summary;
  if (!summary.empty())
    warnings.push_back(base_name(geo_path) + ": part " + std::to_string(p.number) + " (" + p.name + "): " + summary);
  return out;
}

std::string resolve_in(const CaseFile& c, const std::string& name) {
  if (!name.empty() && name[0] == '/') return name;
  return c.dir + name;
}

class EnsightCaseReader {
 public:
  EnsightCaseReader(const std::string& path, int64_t time_step) : requested_(time_step), c_(parse_case(path)) {}

  // The step whole; where `kept` is given, the layout of its geometry for later fields-only reads.
  Dataset read(std::shared_ptr<EnsightLayout>* kept = nullptr) {
    choose_time();
    Dataset ds;
    ds.sources.push_back(c_.path);
    ds.warnings = c_.warnings;
    const Located geo = locate(c_.model, c_.model_ts, c_.model_fs, c_.model_line);
    InputFile gf(geo.path);
    const FileKind kind = detect_geo_kind(gf);
    kind_ = kind;
    EnsStream gs(gf, kind.enc, kind.big_endian);
    if (kind.enc != Encoding::Ascii) gs.read_string(true, "the 'C Binary' / 'Fortran Binary' line");
    seek_step(gs, geo, nullptr, nullptr);
    Geometry g = GeoReader(gs).read();
    ds.sources.push_back(geo.path);
    std::shared_ptr<EnsightLayout> layout;
    if (kept) {
      layout = std::make_shared<EnsightLayout>();
      layout->geo_path = geo.path;
      layout->kind = kind;
      layout->geo_warnings = g.warnings;
    }
    for (auto& w : g.warnings) ds.warnings.push_back(std::move(w));
    read_variables(g, ds.sources);
    uint64_t file_cells = 0;
    for (auto& p : g.parts) {
      file_cells += p->input_cells + p->dropped;
      if (layout) layout->parts.push_back(part_layout(*p));
      if (!p->has_volume()) continue;
      Block b;
      b.name = p->name;
      b.fields = part_fields(*p, geo.path, ds.warnings);
      if (p->structured) {
        b.grid = std::move(p->grid);
      } else {
        p->decomposer.reset();
        p->mesh.validate(geo.path);
        b.grid = std::move(p->mesh);
      }
      b.validate_fields(geo.path);
      ds.blocks.push_back(std::move(b));
    }
    if (ds.blocks.empty()) {
      fail_in(geo.path, "none of its " + std::to_string(g.parts.size()) + " part(s) (" + std::to_string(file_cells) +
                            " elements) has a volume cell (tetra, pyramid, penta, hexa, nfaced or a 3-D block); "
                            "ugvr renders volumes only");
    }
    ds.format = format_text();
    if (kept) *kept = std::move(layout);
    return ds;
  }

  // The step's variables on the layout's geometry, bit for bit those read() gives (one FieldSet per block), with its
  // format, sources and warnings; the geometry file is not opened.
  std::vector<FieldSet> read_fields(const EnsightLayout& layout, std::string& format, std::vector<std::string>& sources,
                                    std::vector<std::string>& warnings) {
    choose_time();
    sources.push_back(c_.path);
    warnings.insert(warnings.end(), c_.warnings.begin(), c_.warnings.end());
    kind_ = layout.kind;
    Geometry g = skeleton(layout);
    sources.push_back(layout.geo_path);
    warnings.insert(warnings.end(), layout.geo_warnings.begin(), layout.geo_warnings.end());
    read_variables(g, sources);
    std::vector<FieldSet> blocks;
    for (auto& p : g.parts)
      if (p->has_volume()) blocks.push_back(part_fields(*p, layout.geo_path, warnings));
    format = format_text();
    return blocks;
  }

 private:
  // Every variable's file at the chosen time, read into the parts' fields (in the geometry's encoding).
  void read_variables(Geometry& g, std::vector<std::string>& sources) {
    for (const Variable& v : c_.variables) {
      const Located at = locate(v.file, v.ts, v.fs, v.line);
      InputFile vf(at.path);
      EnsStream vs(vf, kind_.enc, kind_.big_endian);
      if (kind_.enc != Encoding::Ascii) {
        const std::string first = lower(vs.peek_keyword());
        if (first.starts_with("c binary") || first.starts_with("fortran binary")) vs.read_string(true, "binary tag");
      }
      seek_step(vs, at, &v, &g);
      read_variable_step(vs, v, g, true);
      sources.push_back(at.path);
    }
  }

  std::string format_text() const {
    return std::string("EnSight Gold (") +
           (kind_.enc == Encoding::Ascii     ? "ASCII"
            : kind_.enc == Encoding::CBinary ? "C binary"
                                             : "Fortran binary") +
           (kind_.enc == Encoding::Ascii ? ""
            : kind_.big_endian           ? ", big-endian"
                                         : ", little-endian") +
           ")" + time_text_;
  }

  void choose_time() {
    // The time set with the most steps is the case's time line.
    const TimeSet* line = nullptr;
    int line_id = 0;
    for (const auto& [id, t] : c_.time_sets) {
      if (!line || t.times.size() > line->times.size()) line = &t, line_id = id;
    }
    if (!line || line->times.empty()) {
      if (requested_ > 0)
        fail_in(c_.path, "time step " + std::to_string(requested_) + " does not exist: the case has no time steps");
      return;
    }
    const uint64_t steps = line->times.size();
    if (requested_ >= int64_t(steps) || requested_ < -1)
      fail_in(c_.path, "time step " + std::to_string(requested_) + " does not exist: the case has " +
                           std::to_string(steps) + " time steps (0.." + std::to_string(steps - 1) + ")");
    const uint64_t step = requested_ < 0 ? steps - 1 : uint64_t(requested_);
    time_ = line->times[size_t(step)];
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", time_);
    time_text_ = ", time step " + std::to_string(step) + " of " + std::to_string(steps) + " (time set " +
                 std::to_string(line_id) + ", t = " + buf + ")";
  }

  // This item's step at the chosen time: its time set's last step at or before it (the first when none is).
  uint64_t step_of(const TimeSet& t) const {
    uint64_t s = 0;
    for (uint64_t i = 0; i < t.times.size(); ++i)
      if (t.times[size_t(i)] <= time_) s = i;
    return s;
  }

  Located locate(const std::string& pattern, std::optional<int> ts, std::optional<int> fs, uint64_t line) {
    Located at;
    const bool wild = pattern.find('*') != std::string::npos;
    if (!ts) {
      if (wild) fail_at_line(c_.path, line, "'" + pattern + "' has wildcards but no time set");
      at.path = resolve(pattern);
      return at;
    }
    const auto it = c_.time_sets.find(*ts);
    if (it == c_.time_sets.end()) fail_at_line(c_.path, line, "time set " + std::to_string(*ts) + " is not defined");
    const TimeSet& t = it->second;
    if (t.times.empty()) fail_at_line(c_.path, line, "time set " + std::to_string(*ts) + " has no steps");
    const uint64_t step = step_of(t);
    if (!fs) {
      at.path = resolve(wild ? apply_wildcards(pattern, t.numbers[size_t(step)]) : pattern);
      return at;
    }
    const auto fit = c_.file_sets.find(*fs);
    if (fit == c_.file_sets.end()) fail_at_line(c_.path, line, "file set " + std::to_string(*fs) + " is not defined");
    uint64_t left = step;
    for (const auto& [index, n] : fit->second.files) {
      if (left < n) {
        at.path = resolve(index >= 0 ? apply_wildcards(pattern, index) : pattern);
        at.step_in_file = left;
        at.multi_step = true;
        return at;
      }
      left -= n;
    }
    fail_at_line(c_.path, line,
                 "file set " + std::to_string(*fs) + " has fewer steps than time set " + std::to_string(*ts));
  }

  std::string resolve(const std::string& name) const { return resolve_in(c_, name); }

  // For a file holding several steps: skips to the wanted step's BEGIN TIME STEP (earlier steps are parsed and
  // dropped: the format has no index to jump by that every writer writes). Files of one step may have no markers.
  void seek_step(EnsStream& s, const Located& at, const Variable* v, Geometry* g) {
    const std::string k = lower(s.peek_keyword());
    if (!k.starts_with("begin time step")) {
      if (at.multi_step && at.step_in_file > 0)
        s.fail("expected 'BEGIN TIME STEP': the case's file set says this file holds " +
               std::to_string(at.step_in_file + 1) + " steps or more");
      return;
    }
    for (uint64_t i = 0;; ++i) {
      s.read_string(true, "BEGIN TIME STEP");
      if (i == at.step_in_file) return;
      if (v) {
        // A variable's earlier steps are parsed against the chosen step's geometry (the same counts) and dropped.
        read_variable_step(s, *v, *g, false);
      } else {
        (void)GeoReader(s).read();
      }
      if (!lower(s.peek_keyword()).starts_with("end time step")) s.fail("expected 'END TIME STEP'");
      s.read_string(true, "END TIME STEP");
      if (!lower(s.peek_keyword()).starts_with("begin time step"))
        s.fail("expected 'BEGIN TIME STEP' of step " + std::to_string(i + 1) + " of this file");
    }
  }

  int64_t requested_;
  CaseFile c_;
  FileKind kind_;
  double time_ = 0;
  std::string time_text_;
};

// A .sos (server-of-servers) file: each server's case file, read in turn; blocks concatenated.
Dataset read_ensight_sos(const std::string& path, int64_t time_step) {
  InputFile f(path);
  const std::string text = f.read_all(uint64_t(1) << 20);
  std::vector<std::string> cases;
  bool gold = false;
  std::string directory;
  uint64_t line_no = 0;
  for (size_t b = 0; b <= text.size();) {
    size_t e = text.find('\n', b);
    if (e == std::string::npos) e = text.size();
    const std::string line = trim(std::string_view(text).substr(b, e - b));
    b = e + 1;
    ++line_no;
    const size_t colon = line.find(':');
    if (line.empty() || line[0] == '#' || colon == std::string::npos) continue;
    const std::string key = lower(trim(line.substr(0, colon))), value = trim(line.substr(colon + 1));
    if (key == "type") {
      if (lower(value).find("master_server") == std::string::npos || lower(value).find("gold") == std::string::npos)
        fail_at_line(path, line_no, "'type: " + value + "': expected 'master_server gold'");
      gold = true;
    } else if (key == "directory") {
      directory = value;
    } else if (key == "casefile") {
      if (value.empty()) fail_at_line(path, line_no, "'casefile:' names no file");
      std::string c = value;
      if (c[0] != '/') {
        const std::string beside = dir_name(path) + c;
        if (!directory.empty() && !std::filesystem::exists(beside))
          c = (directory[0] == '/' ? directory : dir_name(path) + directory) + "/" + c;
        else
          c = beside;
      }
      cases.push_back(c);
      if (cases.size() > 4096) fail_at_line(path, line_no, "more than 4096 servers");
    }
  }
  if (!gold) fail_in(path, "no 'type: master_server gold' line: not an EnSight Gold server-of-servers file");
  if (cases.empty()) fail_in(path, "lists no 'casefile:'");
  Dataset ds;
  ds.sources.push_back(path);
  for (size_t k = 0; k < cases.size(); ++k) {
    Dataset one = EnsightCaseReader(cases[k], time_step).read();
    if (k == 0) ds.format = one.format + ", " + std::to_string(cases.size()) + " server(s) of " + base_name(path);
    for (auto& s : one.sources) ds.sources.push_back(std::move(s));
    for (auto& w : one.warnings) ds.warnings.push_back(std::move(w));
    for (auto& b : one.blocks) {
      if (cases.size() > 1) b.name += " (server " + std::to_string(k) + ")";
      ds.blocks.push_back(std::move(b));
    }
  }
  return ds;
}

}  // namespace

std::vector<double> list_ensight_times(const std::string& path) {
  // A .sos's servers share one time line, but finding their cases means parsing the .sos: not listed (one step).
  if (extension_lower(path) == ".sos") return {};
  const CaseFile c = parse_case(path);
  const TimeSet* line = nullptr;  // the time set with the most steps, as EnsightCaseReader::choose_time
  for (const auto& [id, t] : c.time_sets)
    if (!line || t.times.size() > line->times.size()) line = &t;
  return line ? line->times : std::vector<double>{};
}

Dataset read_ensight(const std::string& path, int64_t time_step) {
  if (extension_lower(path) == ".sos") return read_ensight_sos(path, time_step);
  return EnsightCaseReader(path, time_step).read();
}

std::optional<uint64_t> ensight_mesh_key(const std::string& path) {
  if (extension_lower(path) == ".sos") return std::nullopt;
  const CaseFile c = parse_case(path);
  // A geometry with a time set of several steps and '*' wildcards (a file per step) or a file set (steps in one file)
  // changes per step; wildcards without a time set (or with one step) are left to the whole read.
  if (c.model.find('*') != std::string::npos) return std::nullopt;
  if (c.model_ts && c.model_fs) {
    const auto it = c.time_sets.find(*c.model_ts);
    if (it == c.time_sets.end() || it->second.times.size() != 1) return std::nullopt;
  }
  return hash_file_stamp(hash_mix(kFnvOffset, 0x656e7369), resolve_in(c, c.model));  // "ensi"
}

Dataset read_ensight(const std::string& path, int64_t time_step, std::shared_ptr<const EnsightLayout>* kept) {
  if (!kept || extension_lower(path) == ".sos") return read_ensight(path, time_step);
  // Taken before the geometry is read: a geometry rewritten during the read gives another key than the one kept.
  const std::optional<uint64_t> key = ensight_mesh_key(path);
  std::shared_ptr<EnsightLayout> layout;
  Dataset ds = EnsightCaseReader(path, time_step).read(&layout);
  layout->mesh_key = key;
  *kept = std::move(layout);
  return ds;
}

const std::optional<uint64_t>& ensight_layout_mesh_key(const EnsightLayout& layout) { return layout.mesh_key; }

std::vector<FieldSet> read_ensight_fields(const EnsightLayout& layout, const std::string& path, int64_t time_step,
                                          std::string& format, std::vector<std::string>& sources,
                                          std::vector<std::string>& warnings) {
  return EnsightCaseReader(path, time_step).read_fields(layout, format, sources, warnings);
}

}  // namespace ugvr
