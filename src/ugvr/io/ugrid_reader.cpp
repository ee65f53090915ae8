// AFLR3 / fun3d UGRID reader (.ugrid and its binary variants).
//
// Layout (UG_IO "UGRID 3D grid file type"); node indices are 1-based:
//   nnodes ntri nquad ntet npyr nprism nhex                 7 ints
//   x y z                                                   nnodes x 3 reals
//   surface triangles, quadrilaterals                        ntri x 3, nquad x 4 ints
//   surface ids                                              ntri + nquad ints
//   tetrahedra, pyramids, prisms, hexahedra                  ntet x 4, npyr x 5, nprism x 6, nhex x 8 ints
//   optional records (reconnection flags, boundary conditions, ...) that are not read
//
// Variants, named by the suffix before ".ugrid":
//   (none)        ASCII, whitespace-separated
//   .b8  / .lb8   C binary (no record markers), big / little-endian, float64 reals, int32 ints
//   .b4  / .lb4   the same with float32 reals
//   .b8l / .lb8l  float64 reals, int64 ints
//   .r8  / .lr8   Fortran unformatted: [7 ints] then one record holding everything else, each record enclosed by
//   .r4  / .lr4   int32 byte counts; float64 / float32 reals, int32 ints
// A file without a variant suffix whose first bytes are not ASCII text is identified by its size: every binary layout
// is tried and the one whose size matches exactly (and whose record markers agree) is taken; none or several is an
// error. With a variant in the name, trailing bytes (the optional records) are allowed with a warning.
//
// Cell orderings: UGRID lists every cell by the inward right-hand rule (a first face whose normal points into the
// cell). Tetrahedra and hexahedra then coincide with VTK's; VTK's wedge has its first triangle facing out, so prisms
// swap 1<->2 and 4<->5; the UGRID pyramid has its apex third and its base 1-4-5-2, so VTK's (0,1,2,3,4) are UGRID's
// (2,1,4,5,3) (as meshio reads it). The tests check that every cell gets a positive volume.
// Surface triangles and quadrilaterals are boundary faces, not volume cells: only their counts are reported.
//
// Errors name the file and the line (ASCII) or byte offset (binary); counts are checked against the bytes left
// before anything is reserved.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/saturating_size.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {
namespace {

constexpr uint64_t kMaxRecord = uint64_t(std::numeric_limits<int32_t>::max());

struct Variant {
  const char* suffix;
  bool ascii;
  bool big_endian;
  int real_bytes;
  int int_bytes;
  bool fortran;
};

constexpr Variant kAscii{"", true, false, 8, 4, false};
constexpr std::array<Variant, 10> kBinaryVariants = {{
    {"b8", false, true, 8, 4, false},
    {"lb8", false, false, 8, 4, false},
    {"b4", false, true, 4, 4, false},
    {"lb4", false, false, 4, 4, false},
    {"b8l", false, true, 8, 8, false},
    {"lb8l", false, false, 8, 8, false},
    {"r8", false, true, 8, 4, true},
    {"lr8", false, false, 8, 4, true},
    {"r4", false, true, 4, 4, true},
    {"lr4", false, false, 4, 4, true},
}};

std::string variant_name(const Variant& v) {
  if (v.ascii) return "ASCII";
  return std::string(".") + v.suffix + " (" + (v.big_endian ? "big" : "little") + "-endian " +
         (v.fortran ? "Fortran records" : "C binary") + ", float" + std::to_string(8 * v.real_bytes) + ", int" +
         std::to_string(8 * v.int_bytes) + ")";
}

// The variant the file name gives ("wing.lb8.ugrid" -> lb8), if any.
std::optional<Variant> variant_from_name(const std::string& path) {
  std::string name = base_name(path);
  for (char& c : name) c = (c >= 'A' && c <= 'Z') ? char(c - 'A' + 'a') : c;
  if (name.ends_with(".ugrid")) name.resize(name.size() - 6);
  const size_t dot = name.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const std::string suffix = name.substr(dot + 1);
  for (const Variant& v : kBinaryVariants) {
    if (suffix == v.suffix) return v;
  }
  return std::nullopt;
}

enum Count { kNodes, kTri, kQuad, kTet, kPyr, kPrism, kHex };
using Counts = std::array<uint64_t, 7>;
constexpr std::array<int, 7> kValuesPer = {3, 3, 4, 4, 5, 6, 8};  // per node (reals) / per element (ints)

uint64_t int_values(const Counts& c) {
  uint64_t n = sat_add(c[kTri], c[kQuad]);  // surface ids
  for (int k = kTri; k <= kHex; ++k) n = sat_add(n, sat_mul(c[size_t(k)], uint64_t(kValuesPer[size_t(k)])));
  return n;
}

// Bytes of everything after the header, without record markers.
uint64_t data_bytes(const Counts& c, const Variant& v) {
  return sat_add(sat_mul(sat_mul(c[kNodes], 3), uint64_t(v.real_bytes)), sat_mul(int_values(c), uint64_t(v.int_bytes)));
}

uint64_t header_bytes(const Variant& v) { return 7 * uint64_t(v.int_bytes) + (v.fortran ? 8 : 0); }

uint64_t file_bytes(const Counts& c, const Variant& v) {
  return sat_add(sat_add(header_bytes(v), data_bytes(c, v)), v.fortran ? 8 : 0);
}

// Decodes one binary integer of the variant from raw bytes.
int64_t decode_int(const unsigned char* p, const Variant& v) {
  uint64_t u = 0;
  for (int i = 0; i < v.int_bytes; ++i) {
    const int shift = 8 * (v.big_endian ? v.int_bytes - 1 - i : i);
    u |= uint64_t(p[i]) << shift;
  }
  if (v.int_bytes == 4) return int32_t(uint32_t(u));
  return int64_t(u);
}

int32_t decode_marker(const unsigned char* p, bool big_endian) {
  const Variant v{"", false, big_endian, 8, 4, false};
  return int32_t(decode_int(p, v));
}

// Reads the header of a binary variant without throwing: nullopt (with `why`) when it does not fit the file.
std::optional<Counts> binary_header(const InputFile& f, const Variant& v, std::string& why) {
  const uint64_t need = header_bytes(v);
  if (f.size() < need) {
    why =
        "the file has " + std::to_string(f.size()) + " bytes, fewer than the " + std::to_string(need) + "-byte header";
    return std::nullopt;
  }
  std::array<unsigned char, 72> raw{};
  f.read_at(0, raw.data(), size_t(need));
  const unsigned char* p = raw.data();
  if (v.fortran) {
    for (const uint64_t at : {uint64_t(0), need - 4}) {
      const int32_t m = decode_marker(p + at, v.big_endian);
      if (uint64_t(m) != 7 * uint64_t(v.int_bytes)) {
        why = "record marker at byte " + std::to_string(at) + " is " + std::to_string(m) + ", expected " +
              std::to_string(7 * v.int_bytes);
        return std::nullopt;
      }
    }
    p += 4;
  }
  Counts c{};
  for (size_t k = 0; k < 7; ++k) {
    const int64_t n = decode_int(p + k * size_t(v.int_bytes), v);
    if (n < 0) {
      why = "count " + std::to_string(k + 1) + " of the header is negative (" + std::to_string(n) + ")";
      return std::nullopt;
    }
    c[k] = uint64_t(n);
  }
  return c;
}

// ASCII files hold printable characters and whitespace only; binary headers start with small ints whose high (or low)
// bytes are zero.
bool looks_like_text(const InputFile& f) {
  unsigned char head[64];
  const size_t n = f.read_some_at(0, head, sizeof head);
  for (size_t i = 0; i < n; ++i) {
    const unsigned char c = head[i];
    if (!((c >= 32 && c < 127) || c == '\t' || c == '\r' || c == '\n')) return false;
  }
  return true;  // an empty file too: the ASCII reader says what is missing
}

// The binary layout whose exact size is the file's, for a file named without a variant.
Variant detect_by_size(const InputFile& f) {
  std::vector<const Variant*> matches;
  std::string tried;
  for (const Variant& v : kBinaryVariants) {
    std::string why;
    const std::optional<Counts> c = binary_header(f, v, why);
    if (c) {
      const uint64_t want = file_bytes(*c, v);
      if (want == f.size()) {
        matches.push_back(&v);
        continue;
      }
      why = "header implies " + size_text(want) + " bytes";
    }
    tried += std::string("\n  .") + v.suffix + ": " + why;
  }
  if (matches.size() == 1) return *matches[0];
  if (matches.empty()) {
    fail_in(f.path(), "not ASCII, and no binary UGRID layout fits its " + std::to_string(f.size()) +
                          " bytes (name the variant, e.g. NAME.lb8.ugrid):" + tried);
  }
  std::string names;
  for (const Variant* v : matches) names += std::string(names.empty() ? "" : ", ") + "." + v->suffix;
  fail_in(f.path(), "its size fits several binary UGRID layouts (" + names +
                        "); name the variant in the file name, e.g. NAME.lb8.ugrid");
}

class UgridReader {
 public:
  explicit UgridReader(const std::string& path) : file_(path), t_(file_) {
    start_reading_progress(progress_, file_);
    if (const std::optional<Variant> v = variant_from_name(path)) {
      v_ = *v;
      named_ = true;
    } else if (looks_like_text(file_)) {
      v_ = kAscii;
    } else {
      v_ = detect_by_size(file_);
    }
  }

  Dataset read() {
    read_header();
    read_points();
    skip_surface();
    UnstructuredMesh mesh;
    mesh.reserve(c_[kTet] + c_[kPyr] + c_[kPrism] + c_[kHex],
                 4 * c_[kTet] + 5 * c_[kPyr] + 6 * c_[kPrism] + 8 * c_[kHex]);
    read_cells(mesh, kTet, CellType::Tetra, {0, 1, 2, 3, 0, 0, 0, 0});
    read_cells(mesh, kPyr, CellType::Pyramid, {1, 0, 3, 4, 2, 0, 0, 0});
    read_cells(mesh, kPrism, CellType::Wedge, {0, 2, 1, 3, 5, 4, 0, 0});
    read_cells(mesh, kHex, CellType::Hexahedron, {0, 1, 2, 3, 4, 5, 6, 7});
    read_trailer();
    if (mesh.cell_count() == 0) fail_in(path(), "the file has no volume elements; ugvr renders volumes only");
    mesh.points = std::move(points_);
    mesh.validate(path());
    if (c_[kTri] + c_[kQuad] > 0) {
      warnings_.push_back(path() + ": the boundary surface (" + std::to_string(c_[kTri]) + " triangles, " +
                          std::to_string(c_[kQuad]) + " quadrilaterals) is not loaded; only volume cells are");
    }
    Dataset d = single_block_dataset("UGRID " + variant_name(v_), path(), Block{base_name(path()), std::move(mesh), {}},
                                     std::move(warnings_));
    if (progress_) progress_->finish();
    return d;
  }

 private:
  const std::string& path() const { return file_.path(); }

  // --- values ---------------------------------------------------------------------------------------------------

  int64_t integer(std::string_view what) {
    if (v_.ascii) return t_.next_number<int64_t>(what);
    unsigned char raw[8];
    last_offset_ = t_.offset();
    t_.read_bytes(raw, size_t(v_.int_bytes));
    return decode_int(raw, v_);
  }

  double real(std::string_view what) {
    if (v_.ascii) return t_.next_number<double>(what);
    last_offset_ = t_.offset();
    if (v_.real_bytes == 4) {
      uint32_t u;
      t_.read_bytes(&u, 4);
      if (v_.big_endian != (std::endian::native == std::endian::big)) u = __builtin_bswap32(u);
      return double(std::bit_cast<float>(u));
    }
    uint64_t u;
    t_.read_bytes(&u, 8);
    if (v_.big_endian != (std::endian::native == std::endian::big)) u = __builtin_bswap64(u);
    return std::bit_cast<double>(u);
  }

  [[noreturn]] void fail(std::string_view message) const {
    if (v_.ascii) t_.fail_at_token_line(message);
    fail_at_offset(path(), last_offset_, message);
  }

  // A Fortran record marker that must equal `want`.
  void marker(uint64_t want, std::string_view record) {
    if (!v_.fortran) return;
    const uint64_t at = t_.offset();
    unsigned char raw[4];
    t_.read_bytes(raw, 4);
    const int32_t m = decode_marker(raw, v_.big_endian);
    if (want > kMaxRecord) {
      fail_at_offset(path(), at,
                     "the " + std::string(record) + " record of " + std::to_string(want) +
                         " bytes is too long for 4-byte Fortran record markers (subrecords are not supported)");
    }
    if (uint64_t(uint32_t(m)) != want) {
      fail_at_offset(path(), at,
                     "Fortran record marker is " + std::to_string(m) + ", expected " + std::to_string(want) +
                         " (the size of the " + std::string(record) + " record)");
    }
  }

  // --- sections -------------------------------------------------------------------------------------------------

  void read_header() {
    static constexpr std::array<const char*, 7> kNames = {
        "the number of nodes",      "the number of surface triangles", "the number of surface quadrilaterals",
        "the number of tetrahedra", "the number of pyramids",          "the number of prisms",
        "the number of hexahedra"};
    marker(7 * uint64_t(v_.int_bytes), "header");
    for (size_t k = 0; k < 7; ++k) {
      const int64_t n = integer(kNames[k]);
      if (n < 0) fail(std::string(kNames[k]) + " is negative (" + std::to_string(n) + ")");
      c_[k] = uint64_t(n);
    }
    marker(7 * uint64_t(v_.int_bytes), "header");
    if (c_[kNodes] > std::numeric_limits<uint32_t>::max()) {
      fail(std::to_string(c_[kNodes]) + " nodes: an in-memory mesh holds at most 2^32-1 vertices");
    }
    // Everything the header announces must be in the file before anything is reserved (ASCII values take 2 bytes).
    const uint64_t reals = sat_mul(c_[kNodes], 3), ints = int_values(c_);
    const uint64_t values = sat_add(reals, ints);
    if (v_.ascii) {
      check_count_fits(path(), t_.offset(), "value", values, 2, t_.bytes_left());
    } else {
      const uint64_t need = sat_add(data_bytes(c_, v_), v_.fortran ? 8 : 0);
      if (need > t_.bytes_left()) {
        fail_at_offset(path(), t_.offset(),
                       "the header announces " + std::to_string(c_[kNodes]) + " nodes and " +
                           std::to_string(c_[kTet] + c_[kPyr] + c_[kPrism] + c_[kHex]) + " volume elements (" +
                           size_text(need) + " bytes) but only " + std::to_string(t_.bytes_left()) + " bytes follow");
      }
    }
    marker(data_bytes(c_, v_), "data");
  }

  void read_points() {
    points_.resize(size_t(c_[kNodes]));
    for (Vec3f& p : points_) {
      for (int k = 0; k < 3; ++k) {
        const double v = real("a node coordinate");
        if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
          fail("node coordinate " + std::to_string(v) + " is beyond the float32 range points are kept in");
        }
        p[k] = float(v);
      }
      if (progress_) progress_->set(t_.offset());
    }
  }

  // Boundary faces and their surface ids: read past (checked as integers in ASCII files).
  void skip_surface() {
    const uint64_t n = 3 * c_[kTri] + 4 * c_[kQuad] + c_[kTri] + c_[kQuad];
    if (!v_.ascii) {
      t_.skip_bytes(n * uint64_t(v_.int_bytes));
      return;
    }
    for (uint64_t i = 0; i < n; ++i) t_.next_number<int64_t>("a surface face node or id");
  }

  void read_cells(UnstructuredMesh& mesh, Count kind, CellType type, const std::array<uint8_t, 8>& to_vtk) {
    const int n = kValuesPer[size_t(kind)];
    std::array<uint32_t, 8> v{};
    const std::string what = "a node index of a " + std::string(cell_name(type));
    for (uint64_t cell = 0; cell < c_[size_t(kind)]; ++cell) {
      for (int k = 0; k < n; ++k) {
        const int64_t id = integer(what);
        if (id < 1 || uint64_t(id) > c_[kNodes]) {
          fail(std::string(cell_name(type)) + " " + std::to_string(cell + 1) + " uses node " + std::to_string(id) +
               ", outside [1, " + std::to_string(c_[kNodes]) + "]");
        }
        v[size_t(k)] = uint32_t(id - 1);
      }
      std::array<uint32_t, 8> vtk{};
      for (int k = 0; k < n; ++k) vtk[size_t(k)] = v[to_vtk[size_t(k)]];
      mesh.add_cell(type, std::span<const uint32_t>(vtk.data(), size_t(n)));
    }
    if (progress_) progress_->set(t_.offset());
  }

  void read_trailer() {
    marker(data_bytes(c_, v_), "data");
    if (v_.ascii) {
      if (t_.skip_space()) {
        warnings_.push_back(path() + ":" + std::to_string(t_.line()) +
                            ": ignored the optional records after the volume elements");
      }
      return;
    }
    if (t_.bytes_left() > 0) {
      if (!named_) fail_at_offset(path(), t_.offset(), "unexpected bytes after the volume elements");
      warnings_.push_back(path() + ": ignored " + std::to_string(t_.bytes_left()) +
                          " bytes after the volume "
                          "elements (optional UGRID records)");
    }
  }

  InputFile file_;
  TextTokenizer t_;
  Variant v_ = kAscii;
  bool named_ = false;
  std::optional<Progress> progress_;
  Counts c_{};
  std::vector<Vec3f> points_;
  uint64_t last_offset_ = 0;
  std::vector<std::string> warnings_;
};

}  // namespace

Dataset read_ugrid(const std::string& path) { return UgridReader(path).read(); }

}  // namespace ugvr
