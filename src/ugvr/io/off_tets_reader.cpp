// Tetrahedral OFF reader (.off): the tetrahedral meshes distributed with the HAVS, Bunyk et al. and ZSweep
// volume-rendering papers (spx, blunt fin, oxygen post, delta wing, ...). Not Geomview's polygonal OFF.
//
// Layout, whitespace-separated, one record per line, indices 0-based:
//   [OFF]                     optional keyword line (some copies carry Geomview's magic)
//   npoints ntets [0]         counts (a third count, Geomview's edge count, must be 0)
//   x y z [s]                 npoints lines: a point, with its scalar or without
//   [4] a b c d [s]           ntets lines: a tetrahedron, optionally prefixed by its vertex count (4) like a
//                             Geomview face, optionally followed by a per-tetrahedron scalar
//   [s ...]                   only when points and tetrahedra carry no scalar: npoints scalars after the tetrahedra
// The variant is read from the number of values on the first point line and on the first tetrahedron line; every
// later line must have the same number. A point scalar is the Float64 vertex field "scalar", a tetrahedron scalar the
// Float64 cell field "scalar". Which variant was found is named in Dataset::format.
//
// Ambiguity: without a point scalar, a tetrahedron line of 5 integers starting with 4 could be "4 a b c d" or
// "a b c d s" with a = 4; such files are refused rather than guessed (write the scalar with a decimal point, or drop
// the count prefix).
//
// Orientation: these files come from renderers that do not care about it, so the reader measures the tetrahedra and,
// when most are inverted in VTK's convention, swaps vertices 1 and 2 of every one; tetrahedra still inverted after
// that are counted in a warning.
//
// Streaming: TextTokenizer; counts are checked against the bytes left before anything is reserved.
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {

namespace {

bool is_integer_text(std::string_view s) {
  int64_t v;
  return parse_number(s, v);
}

class OffTetsReader {
 public:
  explicit OffTetsReader(const std::string& path) : file_(path), t_(file_) {}

  Dataset read() {
    read_counts();
    read_points();
    read_tetrahedra();
    read_trailing_scalars();

    cells_.points = std::move(points_);
    Block block{file_.name(), std::move(cells_), FieldSet{}};
    auto& mesh = std::get<UnstructuredMesh>(block.grid);
    std::vector<std::string> warnings;
    bool flipped = false;
    const uint64_t inverted = orient_tetrahedra_by_majority(mesh, flipped);
    if (inverted > 0) {
      warnings.push_back(path() + ": " + std::to_string(inverted) +
                         " tetrahedra have negative volume after orientation (inverted in the file)");
    }
    if (!point_scalars_.empty()) {
      block.fields.add(Field("scalar", Association::Vertex, DataArray::from(std::move(point_scalars_), 1)));
    }
    if (!tet_scalars_.empty()) {
      block.fields.add(Field("scalar", Association::Cell, DataArray::from(std::move(tet_scalars_), 1)));
    }
    mesh.validate(path());
    return single_block_dataset("tetrahedral OFF (" + variant_ + (flipped ? ", reoriented to VTK's convention)" : ")"),
                                path(), std::move(block), std::move(warnings));
  }

 private:
  const std::string& path() const { return file_.path(); }
  [[noreturn]] void fail(std::string_view message) const { t_.fail_at_token_line(message); }

  // The values of the current line, up to `max` of them (more is an error); the line must not be empty.
  std::vector<std::string> line_tokens(size_t max, std::string_view what) {
    std::vector<std::string> tokens;
    if (!t_.skip_space()) {
      t_.next_token();
      fail("unexpected end of file: expected " + std::string(what));
    }
    do {
      tokens.emplace_back(t_.next_token());
      if (tokens.size() > max) fail("too many values on the line of " + std::string(what));
    } while (!t_.at_line_end());
    return tokens;
  }

  // Reads the next value of a record of `n` values; the first one may be on a later line, the others must be on
  // the same line.
  template <class T>
  T value(size_t k, size_t n, std::string_view what) {
    if (k > 0 && t_.at_line_end()) {
      fail("expected " + std::to_string(n) + " values on this line (" + std::string(what) + "), found " +
           std::to_string(k));
    }
    return t_.next_number<T>(what);
  }

  void end_record(size_t n, std::string_view what) {
    if (!t_.at_line_end()) {
      t_.next_token();
      fail("more than " + std::to_string(n) + " values on the line of " + std::string(what) +
           " (the first such line has " + std::to_string(n) + ")");
    }
  }

  void read_counts() {
    if (equals_ignore_case(t_.peek_token(), "OFF")) {
      t_.next_token();
      keyword_ = true;
    }
    const std::vector<std::string> counts = line_tokens(3, "the counts \"npoints ntets\"");
    if (counts.size() < 2) fail("expected the counts \"npoints ntets\" on one line");
    if (!parse_number(counts[0], npoints_) || !parse_number(counts[1], ntets_)) {
      fail("expected the counts \"npoints ntets\", found '" + counts[0].substr(0, 40) + " " + counts[1].substr(0, 40) +
           "'");
    }
    uint64_t third = 0;
    if (counts.size() == 3 && (!parse_number(counts[2], third) || third != 0)) {
      fail("a third count must be 0 (Geomview's edge count), found '" + counts[2].substr(0, 40) + "'");
    }
    if (npoints_ > std::numeric_limits<uint32_t>::max()) {
      fail(std::to_string(npoints_) + " points: an in-memory mesh holds at most 2^32-1 vertices");
    }
    // A point line holds at least 3 values, a tetrahedron line 4.
    check_count_fits(path(), t_.offset(), "point", npoints_, 6, t_.bytes_left());
    check_count_fits(path(), t_.offset(), "tetrahedron", ntets_, 8, t_.bytes_left() - npoints_ * 6);
  }

  float coordinate(double v) const {
    if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
      fail("coordinate " + std::to_string(v) + " is beyond the float32 range points are kept in");
    }
    return float(v);
  }

  void read_points() {
    points_.resize(npoints_);
    if (npoints_ == 0) return;
    const std::vector<std::string> first = line_tokens(4, "the first point");
    if (first.size() < 3)
      fail("a point line needs \"x y z\" or \"x y z scalar\", found " + std::to_string(first.size()) + " values");
    point_values_ = first.size();
    if (point_values_ == 4) point_scalars_.resize(npoints_);
    for (size_t c = 0; c < point_values_; ++c) {
      double v;
      if (!parse_number(first[c], v))
        fail("expected a number in the first point line, found '" + first[c].substr(0, 40) + "'");
      if (c < 3)
        points_[0][int(c)] = coordinate(v);
      else
        point_scalars_[0] = v;
    }
    for (uint64_t i = 1; i < npoints_; ++i) {
      for (size_t c = 0; c < point_values_; ++c) {
        const double v = value<double>(c, point_values_, "a point");
        if (c < 3)
          points_[i][int(c)] = coordinate(v);
        else
          point_scalars_[i] = v;
      }
      end_record(point_values_, "a point");
    }
  }

  // Decides the tetrahedron line layout from the first one.
  void tet_layout(const std::vector<std::string>& first) {
    const size_t n = first.size();
    const bool starts_with_4 = first[0] == "4";
    if (n == 4) {
      prefixed_ = false;
      tet_scalar_ = false;
    } else if (n == 6 && starts_with_4) {
      prefixed_ = tet_scalar_ = true;
    } else if (n == 5) {
      const bool last_integer = is_integer_text(first[4]);
      if (point_values_ == 4) {
        // Points carry the scalar, so a fifth value is the vertex count prefix.
        if (!starts_with_4) fail("a tetrahedron line of 5 values must start with its vertex count 4");
        prefixed_ = true;
      } else if (starts_with_4 && last_integer) {
        fail("ambiguous tetrahedron line '" + first[0] + " " + first[1] + " " + first[2] + " " + first[3] + " " +
             first[4] + "': \"4 a b c d\" or \"a b c d scalar\"? Write scalars with a decimal point or drop the 4");
      } else {
        tet_scalar_ = true;
      }
    } else {
      fail("a tetrahedron line needs \"a b c d\" (optionally prefixed by 4 and followed by a scalar), found " +
           std::to_string(n) + " values");
    }
  }

  uint32_t vertex(int64_t id) const {
    if (id < 0 || uint64_t(id) >= npoints_) {
      fail("vertex index " + std::to_string(id) + " is outside [0, " + std::to_string(npoints_) +
           ") (indices are 0-based)");
    }
    return uint32_t(id);
  }

  void read_tetrahedra() {
    cells_.reserve(ntets_, ntets_ * 4);
    if (ntets_ == 0) return;
    const std::vector<std::string> first = line_tokens(6, "the first tetrahedron");
    tet_layout(first);
    tet_values_ = first.size();
    if (tet_scalar_) tet_scalars_.resize(ntets_);
    std::array<uint32_t, 4> v{};
    const size_t base = prefixed_ ? 1 : 0;
    for (size_t k = 0; k < 4; ++k) {
      int64_t id;
      if (!parse_number(first[base + k], id))
        fail("expected a vertex index, found '" + first[base + k].substr(0, 40) + "'");
      v[k] = vertex(id);
    }
    if (tet_scalar_ && !parse_number(first[base + 4], tet_scalars_[0])) {
      fail("expected a number for the tetrahedron's scalar, found '" + first[base + 4].substr(0, 40) + "'");
    }
    cells_.add_cell(CellType::Tetra, v);
    for (uint64_t c = 1; c < ntets_; ++c) {
      if (prefixed_ && value<int64_t>(0, tet_values_, "a tetrahedron") != 4) {
        fail("a tetrahedron line must start with its vertex count 4, as the first one does");
      }
      for (size_t k = 0; k < 4; ++k) v[k] = vertex(value<int64_t>(base + k, tet_values_, "a tetrahedron"));
      if (tet_scalar_) tet_scalars_[c] = value<double>(base + 4, tet_values_, "a tetrahedron");
      end_record(tet_values_, "a tetrahedron");
      cells_.add_cell(CellType::Tetra, v);
    }
  }

  // Variant (c): neither points nor tetrahedra carry a scalar, and the point scalars follow the tetrahedra.
  void read_trailing_scalars() {
    if (!t_.skip_space()) {
      variant_ = describe();
      return;
    }
    if (point_values_ == 4 || tet_scalar_) {
      t_.next_token();
      fail("unexpected data after the " + std::to_string(ntets_) + " tetrahedra");
    }
    point_scalars_.resize(npoints_);
    for (uint64_t i = 0; i < npoints_; ++i) point_scalars_[i] = t_.next_number<double>("a point scalar");
    if (t_.skip_space()) {
      t_.next_token();
      fail("unexpected data after the " + std::to_string(npoints_) + " point scalars");
    }
    variant_ = describe() + ", point scalars after the tetrahedra";
  }

  std::string describe() const {
    std::string s = keyword_ ? "OFF keyword, " : "";
    s += point_values_ == 4 ? "x y z scalar per point" : "x y z per point";
    s += prefixed_ ? ", 4 a b c d" : ", a b c d";
    s += tet_scalar_ ? " scalar per tetrahedron" : " per tetrahedron";
    return s;
  }

  InputFile file_;
  TextTokenizer t_;
  bool keyword_ = false, prefixed_ = false, tet_scalar_ = false;
  uint64_t npoints_ = 0, ntets_ = 0;
  size_t point_values_ = 3, tet_values_ = 4;
  std::vector<Vec3f> points_;
  std::vector<double> point_scalars_, tet_scalars_;
  UnstructuredMesh cells_;
  std::string variant_;
};

}  // namespace

Dataset read_off_tets(const std::string& path) { return OffTetsReader(path).read(); }

}  // namespace ugvr
