// NASTRAN bulk data reader (.nas .bdf), after the MSC/NX Nastran Quick Reference Guide, "Bulk Data Entries".
//
// A file may start with executive and case control (up to "BEGIN BULK", discarded), then holds one card (entry) per
// logical record until "ENDDATA" (or the end of the file). '$' lines are comments. A card is written in one of
//   free field    fields separated by commas: "GRID,1,,0.,1.5-3,2." (8 data fields a line, then a continuation)
//   small field   10 columns of 8 characters: name, 8 data fields, continuation marker
//   large field   name ending in '*' ("GRID*"): 8 characters, 4 data fields of 16, marker; continued by lines
//                 starting with '*'
// and continued by lines starting with '+' or '*' or ',' (free field), or whose first 8 columns are blank. The first
// field of a continuation line is its marker and is skipped. Reals may omit the 'E': "1.5-3" is 1.5e-3, "1.5+3" 1.5e3;
// 'D' exponents are accepted. Blank fields read as 0 (the defaults of the fields used here).
//
// Cards read:
//   GRID     ID CP X1 X2 X3 ...          ids arbitrary (mapped); CP a coordinate system (0 = basic)
//   CORD2R   CID RID A1 A2 A3 B1 B2 B3 C1 C2 C3   rectangular system: origin A, z axis towards B, xz plane through C,
//                                        all given in system RID (chains resolved)
//   CTETRA   EID PID G1..G4 [G5..G10]    kept as tetra (corners G1..G4)
//   CPYRAM   EID PID G1..G5 [G6..G13]    pyramid
//   CPENTA   EID PID G1..G6 [G7..G15]    wedge
//   CHEXA    EID PID G1..G8 [G9..G20]    hexahedron
// Quadratic elements (any edge nodes given) are linearised to their corners. NASTRAN's corner orderings are VTK's
// (CTETRA G4 on the side G1 G2 G3 turn towards, CPENTA G1-G3 / G4-G6, CHEXA G1-G4 / G5-G8, CPYRAM apex G5): checked
// on the z88 piston (278,577 CTETRA, all of positive volume as read). Cells of negative volume are counted in a
// warning, not changed. PID becomes the Int32 cell field "PID". Every other card (loads, SPC, MAT, PSOLID, shells,
// cylindrical or spherical systems, ...) is ignored and counted in one summary warning; a GRID placed in a system
// other than CORD2R is an error.
//
// Streaming: the file is read line by line through TextTokenizer; element grid ids are resolved once all GRIDs have
// been seen (cards may come in any order), so memory is the mesh plus one id and one line number per element.
// Everything kept comes from bytes of the file, and a card's fields are capped, so memory is bounded by the input.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/id_map.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {

namespace {

constexpr size_t kMaxCardFields = 256;  // CHEXA20 needs 22, CORD2R 11; longer cards are refused
constexpr size_t kMaxIgnoredNames = 64;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = (c >= 'a' && c <= 'z') ? char(c - 'a' + 'A') : c;
  return u;
}

// NASTRAN real: "1.5", "1.5E-3", "1.5D-3", "1.5-3", "-.5+2", "7" (blank handled by the caller).
bool parse_real(std::string_view text, double& value) {
  if (text.size() > 64) return false;
  std::array<char, 80> buf{};
  size_t n = 0;
  bool exponent = false;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (c == 'D' || c == 'd' || c == 'E' || c == 'e') {
      c = 'E';
      exponent = true;
    } else if ((c == '+' || c == '-') && i > 0 && !exponent) {
      buf[n++] = 'E';  // the implicit exponent of "1.5-3"
      exponent = true;
    }
    buf[n++] = c;
  }
  return parse_number(std::string_view(buf.data(), n), value);
}

struct Element {
  CellType type;
  uint8_t corners;
  uint8_t max_nodes;
};

std::optional<Element> element_named(std::string_view name) {
  if (name == "CTETRA") return Element{CellType::Tetra, 4, 10};
  if (name == "CPYRAM") return Element{CellType::Pyramid, 5, 13};
  if (name == "CPENTA") return Element{CellType::Wedge, 6, 15};
  if (name == "CHEXA") return Element{CellType::Hexahedron, 8, 20};
  return std::nullopt;
}

struct CoordSystem {
  int64_t rid = 0;
  std::array<double, 9> abc{};  // A, B, C in system rid
  uint64_t line = 0;
};

// A rectangular frame in basic coordinates.
struct Frame {
  std::array<double, 3> origin{}, x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
  std::array<double, 3> apply(const std::array<double, 3>& p) const {
    std::array<double, 3> r{};
    for (int i = 0; i < 3; ++i) r[i] = origin[i] + x[i] * p[0] + y[i] * p[1] + z[i] * p[2];
    return r;
  }
};

class NastranReader {
 public:
  explicit NastranReader(const std::string& path) : file_(path), t_(file_) { start_reading_progress(progress_, file_); }

  Dataset read() {
    read_lines();
    finish_card();
    Block block{file_.name(), UnstructuredMesh{}, FieldSet{}};
    auto& mesh = std::get<UnstructuredMesh>(block.grid);
    transform_points();
    mesh.points = std::move(points_);
    build_cells(mesh);
    orient_wedges(mesh);
    warn_inverted(mesh);
    warn_ignored();
    block.fields.add(Field("PID", Association::Cell, DataArray::from(std::move(pids_), 1)));
    mesh.validate(path());
    Dataset d = single_block_dataset("NASTRAN bulk data", path(), std::move(block), std::move(warnings_));
    if (progress_) progress_->finish();
    return d;
  }

 private:
  const std::string& path() const { return file_.path(); }
  [[noreturn]] void fail_card(std::string_view message) const { fail_at_line(path(), card_line_, message); }

  // --- lines and cards -----------------------------------------------------------------------------------------

  void read_lines() {
    uint64_t lines = 0;
    for (;;) {
      const uint64_t line_number = t_.line();
      const std::optional<std::string_view> text = t_.read_line();
      if (!text) return;
      if (progress_ && (++lines & 0xffff) == 0) progress_->set(t_.offset());
      const std::string_view line = *text;
      const std::string_view stripped = trim(line);
      if (stripped.empty() || stripped.front() == '$') continue;
      if (is_continuation(line)) {
        if (collecting_) add_line_fields(line, true);
        continue;
      }
      finish_card();
      if (starts_with_ignore_case(stripped, "ENDDATA")) return;
      if (starts_with_ignore_case(stripped, "BEGIN")) {
        // Whatever came before was executive and case control, not cards.
        ignored_.clear();
        ignored_total_ = 0;
        continue;
      }
      start_card(line, line_number);
    }
  }

  static bool is_continuation(std::string_view line) {
    const char c = line.front();
    if (c == '+' || c == '*' || c == ',') return true;
    if (c != ' ' && c != '\t') return false;
    // Fixed format: a blank name field. A free-field card never starts with blanks in practice.
    return trim(line.substr(0, std::min<size_t>(8, line.size()))).empty() && line.find(',') == std::string_view::npos;
  }

  void start_card(std::string_view line, uint64_t line_number) {
    const size_t comma = line.find(',');
    const std::string_view raw_name = trim(
        comma != std::string_view::npos ? line.substr(0, comma) : line.substr(0, std::min<size_t>(8, line.size())));
    large_ = !raw_name.empty() && raw_name.back() == '*';
    name_ = upper(large_ ? raw_name.substr(0, raw_name.size() - 1) : raw_name);
    card_line_ = line_number;
    fields_.clear();
    collecting_ = name_ == "GRID" || name_ == "CORD2R" || element_named(name_).has_value();
    if (!collecting_) {
      note_ignored();
      return;
    }
    add_line_fields(line, false);
  }

  void note_ignored() {
    ++ignored_total_;
    std::string name = name_.substr(0, 16);
    if (ignored_.size() >= kMaxIgnoredNames && !ignored_.count(name)) name = "(others)";
    ++ignored_[name];
  }

  // Appends the data fields of one line of the current card (skipping its name or continuation marker).
  void add_line_fields(std::string_view line, bool continuation) {
    const size_t comma = line.find(',');
    const size_t per_line = (continuation ? line.front() == '*' : large_) ? 4 : 8;
    // Each line's fields start at a multiple of the per-line count (a short line is padded with blanks).
    if (continuation) {
      while (fields_.size() % per_line != 0) push_field({});
    }
    if (comma != std::string_view::npos) {
      std::vector<std::string_view> parts;
      size_t start = 0;
      for (;;) {
        const size_t next = line.find(',', start);
        parts.push_back(
            trim(line.substr(start, next == std::string_view::npos ? std::string_view::npos : next - start)));
        if (next == std::string_view::npos) break;
        start = next + 1;
        if (parts.size() > kMaxCardFields) fail_at_line(path(), t_.line() - 1, "a line with too many fields");
      }
      // parts[0] is the name or marker. A line of exactly name + 8 fields + marker ends in its marker; a longer one
      // is a writer putting the whole card on one line.
      size_t end = parts.size();
      if (end == per_line + 2 && (parts.back().empty() || parts.back().front() == '+')) --end;
      for (size_t i = 1; i < end; ++i) push_field(parts[i]);
    } else {
      const size_t width = per_line == 4 ? 16 : 8;
      for (size_t k = 0; k < per_line; ++k) {
        const size_t at = 8 + k * width;
        if (at >= line.size()) break;
        push_field(trim(line.substr(at, width)));
      }
    }
  }

  void push_field(std::string_view f) {
    if (fields_.size() >= kMaxCardFields)
      fail_card(name_ + " card with more than " + std::to_string(kMaxCardFields) + " fields");
    fields_.emplace_back(f);
  }

  std::string_view field(size_t i) const {
    return i < fields_.size() ? std::string_view(fields_[i]) : std::string_view();
  }

  int64_t integer(size_t i, std::string_view what, bool required) const {
    const std::string_view f = field(i);
    if (f.empty()) {
      if (required) fail_card(name_ + ": missing " + std::string(what) + " (field " + std::to_string(i + 2) + ")");
      return 0;
    }
    int64_t v = 0;
    if (!parse_number(f, v)) {
      fail_card(name_ + ": expected an integer for " + std::string(what) + " (field " + std::to_string(i + 2) +
                "), found '" + std::string(f.substr(0, 40)) + "'");
    }
    return v;
  }

  double real(size_t i, std::string_view what) const {
    const std::string_view f = field(i);
    if (f.empty()) return 0.0;
    double v = 0;
    if (!parse_real(f, v)) {
      fail_card(name_ + ": expected a real number for " + std::string(what) + " (field " + std::to_string(i + 2) +
                "), found '" + std::string(f.substr(0, 40)) + "'");
    }
    return v;
  }

  void finish_card() {
    if (!collecting_) return;
    collecting_ = false;
    if (name_ == "GRID") {
      read_grid();
    } else if (name_ == "CORD2R") {
      read_cord2r();
    } else {
      read_element(*element_named(name_));
    }
  }

  // --- card contents -------------------------------------------------------------------------------------------

  void read_grid() {
    const int64_t id = integer(0, "the grid id", true);
    const int64_t cp = integer(1, "the coordinate system CP", false);
    if (!grid_ids_.add(id)) fail_card("GRID " + std::to_string(id) + " defined twice");
    if (points_.size() >= std::numeric_limits<uint32_t>::max()) {
      fail_card("more than 2^32-1 GRID points: an in-memory mesh holds at most that many vertices");
    }
    Vec3f p;
    for (int c = 0; c < 3; ++c) {
      const double v = real(size_t(2 + c), "a coordinate");
      if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
        fail_card("GRID " + std::to_string(id) + ": coordinate beyond the float32 range points are kept in");
      }
      p[c] = float(v);
    }
    if (cp != 0) {
      if (!any_cp_) grid_cp_.resize(points_.size(), 0);
      any_cp_ = true;
      if (cp < std::numeric_limits<int32_t>::min() || cp > std::numeric_limits<int32_t>::max()) {
        fail_card("GRID " + std::to_string(id) + ": coordinate system id " + std::to_string(cp) + " out of range");
      }
      cp_first_line_.emplace(cp, card_line_);
    }
    if (any_cp_) grid_cp_.push_back(int32_t(cp));
    points_.push_back(p);
  }

  void read_cord2r() {
    const int64_t cid = integer(0, "the coordinate system id", true);
    CoordSystem s;
    s.rid = integer(1, "the reference system RID", false);
    s.line = card_line_;
    for (size_t k = 0; k < 9; ++k) s.abc[k] = real(2 + k, "a CORD2R point coordinate");
    if (!systems_.emplace(cid, s).second) fail_card("CORD2R " + std::to_string(cid) + " defined twice");
  }

  void read_element(const Element& e) {
    const int64_t eid = integer(0, "the element id", true);
    const int64_t pid = integer(1, "the property id PID", true);
    if (pid < std::numeric_limits<int32_t>::min() || pid > std::numeric_limits<int32_t>::max()) {
      fail_card(name_ + " " + std::to_string(eid) + ": PID " + std::to_string(pid) + " out of the Int32 range");
    }
    size_t given = fields_.size();
    while (given > 2 && fields_[given - 1].empty()) --given;
    const size_t nodes = given - 2;
    if (nodes < e.corners || nodes > e.max_nodes) {
      fail_card(name_ + " " + std::to_string(eid) + " lists " + std::to_string(nodes) + " grid points, expected " +
                std::to_string(e.corners) + " to " + std::to_string(e.max_nodes) + " (" + std::to_string(e.corners) +
                " corners, then optional edge nodes)");
    }
    for (size_t k = 0; k < nodes; ++k) {
      // Edge nodes may be left blank, corners may not; edge nodes are dropped (linearised) but must be integers.
      const int64_t g = integer(2 + k, "a grid point id", k < e.corners);
      if (k < e.corners) {
        element_grids_.push_back(g);
      } else if (g != 0) {  // blank (or 0): no edge node
        edge_grids_.emplace_back(g, card_line_);
      }
    }
    element_types_.push_back(e.type);
    element_lines_.push_back(card_line_);
    pids_.push_back(int32_t(pid));
  }

  // --- after the last card -------------------------------------------------------------------------------------

  // The basic frame of system `cid`, which the card at `used_at` (a GRID or a CORD2R) refers to.
  Frame resolve_frame(int64_t cid, int depth, uint64_t used_at) const {
    if (cid == 0) return Frame{};
    const auto it = systems_.find(cid);
    if (it == systems_.end()) {
      fail_at_line(path(), used_at,
                   "coordinate system " + std::to_string(cid) +
                       ", which is not defined by a CORD2R card (cylindrical, spherical and CORD1 systems are not "
                       "supported)");
    }
    const CoordSystem& s = it->second;
    if (depth > 32) fail_at_line(path(), s.line, "CORD2R chain too deep or circular at system " + std::to_string(cid));
    const Frame parent = resolve_frame(s.rid, depth + 1, s.line);
    const auto a = parent.apply({s.abc[0], s.abc[1], s.abc[2]});
    const auto b = parent.apply({s.abc[3], s.abc[4], s.abc[5]});
    const auto c = parent.apply({s.abc[6], s.abc[7], s.abc[8]});
    Frame f;
    f.origin = a;
    std::array<double, 3> z{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, xz{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const auto dot = [](const std::array<double, 3>& u, const std::array<double, 3>& v) {
      return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    };
    const double zl = std::sqrt(dot(z, z));
    if (!(zl > 0)) fail_at_line(path(), s.line, "CORD2R " + std::to_string(cid) + ": points A and B coincide");
    for (double& v : z) v /= zl;
    const double along = dot(xz, z);
    std::array<double, 3> x{xz[0] - along * z[0], xz[1] - along * z[1], xz[2] - along * z[2]};
    const double xl = std::sqrt(dot(x, x));
    if (!(xl > 0)) fail_at_line(path(), s.line, "CORD2R " + std::to_string(cid) + ": point C lies on the z axis");
    for (double& v : x) v /= xl;
    f.z = z;
    f.x = x;
    f.y = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    return f;
  }

  void transform_points() {
    if (!any_cp_) return;
    std::map<int64_t, Frame> frames;
    for (const auto& [cp, line] : cp_first_line_) frames.emplace(cp, resolve_frame(cp, 0, line));
    for (size_t i = 0; i < points_.size(); ++i) {
      if (grid_cp_[i] == 0) continue;
      const Frame& f = frames.at(grid_cp_[i]);
      const auto g = f.apply({points_[i][0], points_[i][1], points_[i][2]});
      for (int c = 0; c < 3; ++c) points_[i][c] = float(g[size_t(c)]);
    }
  }

  void build_cells(UnstructuredMesh& mesh) {
    if (element_types_.empty()) {
      fail_in(path(), "no solid elements (CTETRA, CPYRAM, CPENTA, CHEXA): ugvr renders volumes only" +
                          (ignored_total_ ? " (" + ignored_summary() + ")" : std::string()));
    }
    // Edge nodes are dropped, but each must still be a defined GRID: an undefined one means the card is corrupt.
    for (const auto& [g, line] : edge_grids_) {
      if (!grid_ids_.find(g)) {
        fail_at_line(path(), line,
                     "element uses GRID " + std::to_string(g) + " (an edge node), which is not defined in the file");
      }
    }
    mesh.reserve(element_types_.size(), element_grids_.size());
    std::array<uint32_t, 8> v{};
    size_t at = 0;
    for (size_t c = 0; c < element_types_.size(); ++c) {
      const uint8_t n = cell_vertex_count(element_types_[c]);
      for (uint8_t k = 0; k < n; ++k) {
        const int64_t g = element_grids_[at++];
        const std::optional<uint32_t> index = grid_ids_.find(g);
        if (!index) {
          fail_at_line(path(), element_lines_[c],
                       "element uses GRID " + std::to_string(g) + ", which is not defined in the file");
        }
        v[k] = *index;
      }
      mesh.add_cell(element_types_[c], std::span<const uint32_t>(v.data(), n));
    }
  }

  // CPENTA writers differ on which way G1 G2 G3 turns (the model's wedge, as VTK's face list, has it turned away from
  // G4 G5 G6; Gmsh-style writers turn it towards them). When most wedges come out inverted, both triangles of every
  // wedge are reversed, which mirrors them into the model's convention without moving a vertex.
  void orient_wedges(UnstructuredMesh& mesh) {
    uint64_t wedges = 0, negative = 0;
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (mesh.cell_types[c] != CellType::Wedge) continue;
      ++wedges;
      negative += cell_volume(mesh, c) < 0;
    }
    if (negative * 2 <= wedges) return;
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (mesh.cell_types[c] != CellType::Wedge) continue;
      uint32_t* v = mesh.connectivity.data() + mesh.cell_offsets[c];
      std::swap(v[1], v[2]);
      std::swap(v[4], v[5]);
    }
  }

  void warn_inverted(const UnstructuredMesh& mesh) {
    uint64_t inverted = 0, first = 0;
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (cell_volume(mesh, c) < 0 && inverted++ == 0) first = c;
    }
    if (inverted > 0) {
      warnings_.push_back(path() + ": " + std::to_string(inverted) +
                          " element(s) have negative volume (inverted in the file; first at line " +
                          std::to_string(element_lines_[first]) + ")");
    }
  }

  std::string ignored_summary() const {
    std::vector<std::pair<uint64_t, std::string>> by_count;
    for (const auto& [name, n] : ignored_) by_count.emplace_back(n, name);
    std::sort(by_count.rbegin(), by_count.rend());
    std::string detail;
    for (size_t i = 0; i < by_count.size() && i < 8; ++i) {
      detail += (i ? ", " : "") + std::to_string(by_count[i].first) + " " + by_count[i].second;
    }
    if (by_count.size() > 8) detail += ", ...";
    return "ignored " + std::to_string(ignored_total_) + " other card(s): " + detail;
  }

  void warn_ignored() {
    if (ignored_total_ > 0) warnings_.push_back(path() + ": " + ignored_summary());
  }

  InputFile file_;
  TextTokenizer t_;
  std::optional<Progress> progress_;

  // The card being read.
  std::string name_;
  bool large_ = false, collecting_ = false;
  uint64_t card_line_ = 0;
  std::vector<std::string> fields_;

  std::vector<Vec3f> points_;
  IdMap grid_ids_;
  bool any_cp_ = false;           // a GRID outside the basic system was seen
  std::vector<int32_t> grid_cp_;  // filled from the first such GRID on
  std::map<int64_t, uint64_t> cp_first_line_;
  std::map<int64_t, CoordSystem> systems_;

  std::vector<CellType> element_types_;
  std::vector<int64_t> element_grids_;                    // corner grid ids, resolved at the end
  std::vector<std::pair<int64_t, uint64_t>> edge_grids_;  // (edge node grid id, card line), checked at the end
  std::vector<uint64_t> element_lines_;
  std::vector<int32_t> pids_;

  std::map<std::string, uint64_t> ignored_;
  uint64_t ignored_total_ = 0;
  std::vector<std::string> warnings_;
};

}  // namespace

Dataset read_nastran(const std::string& path) { return NastranReader(path).read(); }

}  // namespace ugvr
