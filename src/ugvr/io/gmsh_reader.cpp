// Gmsh MSH reader (.msh), versions 2.2 and 4.1, ASCII and binary.
//
// A file is a sequence of sections "$Name ... $EndName". Read here:
//   $MeshFormat     "version file-type data-size": version 2.x or 4.1, file-type 0 (ASCII) or 1 (binary), data-size
//                   sizeof(size_t) of the writer (8; 4.1 binary uses it for counts and tags, 4 is accepted too).
//                   Binary files follow the line with the int 1, whose bytes give the file's byte order.
//   $Nodes    2.2   "n" (ASCII), then n x "tag x y z" (binary: int tag, 3 doubles)
//             4.1   "numBlocks numNodes minTag maxTag", then per entity block "dim entityTag parametric n", the n
//                   node tags, then the n coordinates "x y z" followed by `dim` parametric coordinates when
//                   parametric is 1 (skipped). Binary: counts and tags size_t, dim/entityTag/parametric int.
//   $Elements 2.2   "n" (ASCII), then n x "tag type ntags tags... nodes...". Binary: after the count, groups of
//                   "type count ntags" (ints) each followed by `count` elements "tag tags... nodes..." (ints).
//             4.1   "numBlocks numElements minTag maxTag", per entity block "dim entityTag type n", then n x
//                   "tag nodes..." (binary: size_t).
//   $Entities 4.1   points "tag x y z nPhys phys...", curves / surfaces / volumes "tag minXYZ maxXYZ nPhys phys...
//                   nBounding bounding..." (binary: tags int, counts size_t, coordinates double). Only the volumes'
//                   first physical tag is kept, to label cells.
//   $NodeData / $ElementData   string tags (each a quoted line; the first is the field name), real tags (the first
//                   is the time), integer tags (time step, components, count, partition), then count x "tag
//                   values..." (binary: int tag, doubles; the tags before the values stay ASCII). Values become
//                   Float64 vertex / cell fields; entities without a value get NaN (with a warning). Several time
//                   steps of one name: the last one is kept, with a warning. Blocks of the same step (one per
//                   partition) are merged.
//   $ElementNodeData (values per element corner, discontinuous) is skipped with a warning; so are $PhysicalNames,
//                   $PartitionedEntities, $Periodic and any unknown section (found by its $End line).
//
// Cells: volume elements are kept, higher-order ones linearised to their corner nodes (listed first, as in VTK), and
// lower-dimensional elements (points, lines, triangles, quadrangles of any order) dropped with one warning. Gmsh
// orders tetrahedra, hexahedra and pyramids as VTK does; its prism has the triangle (0,1,2) turning towards (3,4,5)
// while VTK's wedge has it turning away, so prisms swap 1<->2 and 4<->5 (the tests check every cell's volume > 0).
// Node and element tags are arbitrary positive numbers, mapped to indices (dense table when compact, sorted
// otherwise). Cells get an Int32 field "gmsh:physical" (2.2: the first element tag; 4.1: the first physical tag of
// the volume entity, from $Entities) or, for a 4.1 file without physical groups, "gmsh:entity".
//
// Errors name the file and the line (ASCII) or the byte offset (binary). Every count is checked against the bytes left
// before anything is reserved (ASCII values take at least 2 bytes, binary ones their size).
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {
namespace {

constexpr uint64_t kAbsent = std::numeric_limits<uint64_t>::max();
constexpr uint64_t kDropped = kAbsent - 1;
constexpr int64_t kMaxComponents = 1024;

// What a Gmsh element type is: its node count, dimension and (for volumes) the cell it becomes.
struct GmshType {
  int nodes = 0;
  int dim = 0;
  CellType cell{};
  const char* name = "";
};

std::optional<GmshType> gmsh_type(int64_t code) {
  const auto vol = [](int n, CellType c, const char* name) { return GmshType{n, 3, c, name}; };
  const auto low = [](int n, int dim, const char* name) { return GmshType{n, dim, CellType::Tetra, name}; };
  switch (code) {
    case 4: return vol(4, CellType::Tetra, "4-node tetrahedron");
    case 11: return vol(10, CellType::Tetra, "10-node tetrahedron");
    case 29: return vol(20, CellType::Tetra, "20-node tetrahedron");
    case 30: return vol(35, CellType::Tetra, "35-node tetrahedron");
    case 31: return vol(56, CellType::Tetra, "56-node tetrahedron");
    case 71: return vol(84, CellType::Tetra, "84-node tetrahedron");
    case 72: return vol(120, CellType::Tetra, "120-node tetrahedron");
    case 73: return vol(165, CellType::Tetra, "165-node tetrahedron");
    case 74: return vol(220, CellType::Tetra, "220-node tetrahedron");
    case 75: return vol(286, CellType::Tetra, "286-node tetrahedron");
    case 5: return vol(8, CellType::Hexahedron, "8-node hexahedron");
    case 12: return vol(27, CellType::Hexahedron, "27-node hexahedron");
    case 17: return vol(20, CellType::Hexahedron, "20-node hexahedron");
    case 92: return vol(64, CellType::Hexahedron, "64-node hexahedron");
    case 93: return vol(125, CellType::Hexahedron, "125-node hexahedron");
    case 6: return vol(6, CellType::Wedge, "6-node prism");
    case 13: return vol(18, CellType::Wedge, "18-node prism");
    case 18: return vol(15, CellType::Wedge, "15-node prism");
    case 90: return vol(40, CellType::Wedge, "40-node prism");
    case 91: return vol(75, CellType::Wedge, "75-node prism");
    case 7: return vol(5, CellType::Pyramid, "5-node pyramid");
    case 14: return vol(14, CellType::Pyramid, "14-node pyramid");
    case 19: return vol(13, CellType::Pyramid, "13-node pyramid");
    case 15: return low(1, 0, "point");
    case 1: return low(2, 1, "2-node line");
    case 8: return low(3, 1, "3-node line");
    case 26: return low(4, 1, "4-node line");
    case 27: return low(5, 1, "5-node line");
    case 28: return low(6, 1, "6-node line");
    case 62: return low(7, 1, "7-node line");
    case 63: return low(8, 1, "8-node line");
    case 64: return low(9, 1, "9-node line");
    case 65: return low(10, 1, "10-node line");
    case 66: return low(11, 1, "11-node line");
    case 2: return low(3, 2, "3-node triangle");
    case 9: return low(6, 2, "6-node triangle");
    case 20: return low(9, 2, "9-node triangle");
    case 21: return low(10, 2, "10-node triangle");
    case 22: return low(12, 2, "12-node triangle");
    case 23: return low(15, 2, "15-node triangle");
    case 24: return low(15, 2, "15-node triangle (incomplete)");
    case 25: return low(21, 2, "21-node triangle");
    case 42: return low(28, 2, "28-node triangle");
    case 43: return low(36, 2, "36-node triangle");
    case 44: return low(45, 2, "45-node triangle");
    case 45: return low(55, 2, "55-node triangle");
    case 46: return low(66, 2, "66-node triangle");
    case 3: return low(4, 2, "4-node quadrangle");
    case 10: return low(9, 2, "9-node quadrangle");
    case 16: return low(8, 2, "8-node quadrangle");
    case 36: return low(16, 2, "16-node quadrangle");
    case 37: return low(25, 2, "25-node quadrangle");
    case 38: return low(36, 2, "36-node quadrangle");
    case 39: return low(12, 2, "12-node quadrangle");
    case 40: return low(16, 2, "16-node quadrangle (incomplete)");
    case 41: return low(20, 2, "20-node quadrangle");
    case 47: return low(49, 2, "49-node quadrangle");
    case 48: return low(64, 2, "64-node quadrangle");
    case 49: return low(81, 2, "81-node quadrangle");
    case 50: return low(100, 2, "100-node quadrangle");
    case 51: return low(121, 2, "121-node quadrangle");
    default: return std::nullopt;
  }
}

// Gmsh corner order -> VTK order: only the prism differs (see the top of the file).
constexpr std::array<uint8_t, 6> kPrismToVtk = {0, 2, 1, 3, 5, 4};

// Arbitrary (file) tags -> indices: a dense table when the tags are compact, else a sorted list.
class TagMap {
 public:
  // Returns a tag that occurs twice, if one does.
  std::optional<uint64_t> build(std::vector<std::pair<uint64_t, uint64_t>> entries) {
    uint64_t max = 0;
    for (const auto& e : entries) max = std::max(max, e.first);
    dense_.clear();
    sorted_.clear();
    if (max / 2 <= entries.size() + 512) {
      dense_.assign(size_t(max) + 1, kAbsent);
      for (const auto& [tag, value] : entries) {
        if (dense_[size_t(tag)] != kAbsent) return tag;
        dense_[size_t(tag)] = value;
      }
      return std::nullopt;
    }
    std::sort(entries.begin(), entries.end());
    for (size_t i = 1; i < entries.size(); ++i) {
      if (entries[i].first == entries[i - 1].first) return entries[i].first;
    }
    sorted_ = std::move(entries);
    return std::nullopt;
  }

  uint64_t find(uint64_t tag) const {
    if (!sorted_.empty()) {
      const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(tag, uint64_t(0)));
      return (it != sorted_.end() && it->first == tag) ? it->second : kAbsent;
    }
    return tag < dense_.size() ? dense_[size_t(tag)] : kAbsent;
  }

 private:
  std::vector<uint64_t> dense_;
  std::vector<std::pair<uint64_t, uint64_t>> sorted_;
};

// Reads the values of a Gmsh file: ASCII numbers, or binary ints / size_t / doubles of the file's byte order. Text
// items of binary files (section counts of 2.2, data tags) are read with text().
class GmshInput {
 public:
  explicit GmshInput(const InputFile& file) : t_(file) {}

  TextTokenizer& tokens() { return t_; }
  const std::string& path() const { return t_.file().path(); }
  bool binary() const { return binary_; }
  void set_binary(bool binary, bool swap, int size_bytes) {
    binary_ = binary;
    swap_ = swap;
    size_bytes_ = size_bytes;
  }
  int size_bytes() const { return size_bytes_; }
  uint64_t bytes_left() const { return t_.bytes_left(); }

  // Minimum bytes one value takes in the file (for check_count_fits): binary values their size, ASCII ones a digit
  // and a separator.
  uint64_t int_bytes() const { return binary_ ? 4 : 2; }
  uint64_t size_value_bytes() const { return binary_ ? uint64_t(size_bytes_) : 2; }
  uint64_t real_bytes() const { return binary_ ? 8 : 2; }

  template <class T>
  T text(std::string_view what) {
    const T v = t_.next_number<T>(what);
    last_offset_ = t_.token_offset();
    return v;
  }

  // An "int" of the format.
  int64_t integer(std::string_view what) {
    if (!binary_) return text<int64_t>(what);
    uint32_t u;
    read_raw(&u, 4);
    return int32_t(swap_ ? __builtin_bswap32(u) : u);
  }
  // A "size_t" of the format (4.1 counts and tags).
  uint64_t size_value(std::string_view what) {
    if (!binary_) return text<uint64_t>(what);
    if (size_bytes_ == 4) {
      uint32_t u;
      read_raw(&u, 4);
      return swap_ ? __builtin_bswap32(u) : u;
    }
    uint64_t u;
    read_raw(&u, 8);
    return swap_ ? __builtin_bswap64(u) : u;
  }
  double real(std::string_view what) {
    if (!binary_) return text<double>(what);
    uint64_t u;
    read_raw(&u, 8);
    return std::bit_cast<double>(swap_ ? __builtin_bswap64(u) : u);
  }
  // A non-negative int (binary tags of 2.2 and of data sections).
  uint64_t tag(std::string_view what) {
    if (!binary_) return text<uint64_t>(what);
    const int64_t v = integer(what);
    if (v < 0) fail("expected a non-negative " + std::string(what) + ", found " + std::to_string(v));
    return uint64_t(v);
  }
  // An int in [lo, hi].
  int64_t integer_in(std::string_view what, int64_t lo, int64_t hi) {
    const int64_t v = integer(what);
    if (v < lo || v > hi) {
      fail("expected " + std::string(what) + " in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], found " +
           std::to_string(v));
    }
    return v;
  }

  // In binary files the values start after the newline that ends the current text line.
  void begin_binary_values() {
    if (binary_) t_.skip_line();
  }

  void check_fits(std::string_view what, uint64_t count, uint64_t bytes_each) {
    check_count_fits(path(), t_.offset(), what, count, bytes_each, t_.bytes_left());
  }

  // Fails at the last value read: its line in ASCII files, its byte offset in binary ones.
  [[noreturn]] void fail(std::string_view message) const {
    if (binary_) fail_at_offset(path(), last_offset_, message);
    t_.fail_at_token_line(message);
  }

 private:
  void read_raw(void* dst, size_t n) {
    last_offset_ = t_.offset();
    t_.read_bytes(dst, n);
  }

  TextTokenizer t_;
  bool binary_ = false, swap_ = false;
  int size_bytes_ = 8;
  uint64_t last_offset_ = 0;
};

std::string trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return std::string(s);
}

// A data field as it is being filled.
struct PendingField {
  std::string name;
  Association association;
  int64_t step = 0;
  DataArray data;
  std::vector<bool> defined;
  uint64_t replaced = 0;  // earlier time steps dropped
};

class GmshReader {
 public:
  explicit GmshReader(const std::string& path) : file_(path), in_(file_) { start_reading_progress(progress_, file_); }

  Dataset read() {
    read_format();
    for (;;) {
      const std::string section(in_.tokens().next_token());
      if (progress_) progress_->set(in_.tokens().offset());
      if (section.empty()) break;
      read_section(section);
    }
    return finish();
  }

 private:
  const std::string& path() const { return file_.path(); }
  TextTokenizer& t() { return in_.tokens(); }

  // --- sections ----------------------------------------------------------------------------------------------------

  void read_format() {
    const std::string first(t().next_token());
    if (first != "$MeshFormat") fail_at_line(path(), t().token_line(), "not a Gmsh file: expected $MeshFormat");
    const std::string version(t().next_token());
    if (version.empty()) t().fail_at_token_line("unexpected end of file: expected the MSH version");
    if (version == "4.1") {
      v4_ = true;
    } else if (version.starts_with("2")) {
      v4_ = false;
    } else {
      t().fail_at_token_line("unsupported MSH version '" + version.substr(0, 20) +
                             "' (ugvr reads 2.2 and 4.1; convert with gmsh -format msh41)");
    }
    version_ = version;
    const int64_t file_type = t().next_number<int64_t>("the file type (0 ASCII, 1 binary)");
    if (file_type != 0 && file_type != 1) t().fail_at_token_line("file type must be 0 (ASCII) or 1 (binary)");
    const int64_t data_size = t().next_number<int64_t>("the data size");
    if (data_size != 8 && !(v4_ && data_size == 4)) {
      t().fail_at_token_line("unsupported data size " + std::to_string(data_size) + " (expected 8)");
    }
    if (file_type == 1) {
      t().skip_line();
      const uint64_t at = t().offset();
      uint32_t one;
      t().read_bytes(&one, 4);
      if (one != 1 && __builtin_bswap32(one) != 1) {
        fail_at_offset(path(), at, "expected the int 1 that gives the byte order of a binary Gmsh file");
      }
      in_.set_binary(true, one != 1, int(data_size));
    } else {
      in_.set_binary(false, false, int(data_size));
    }
    expect_end("MeshFormat");
  }

  void read_section(const std::string& section) {
    if (!section.starts_with("$") || section.starts_with("$End")) {
      t().fail_at_token_line("expected a section ($Name), found '" + section.substr(0, 40) + "'");
    }
    const std::string name = section.substr(1);
    if (name == "Nodes") {
      if (nodes_read_) t().fail_at_token_line("a second $Nodes section");
      v4_ ? read_nodes_v4() : read_nodes_v2();
      finish_nodes();
      expect_end(name);
    } else if (name == "Elements") {
      if (!nodes_read_) t().fail_at_token_line("$Elements before $Nodes");
      if (elements_read_) t().fail_at_token_line("a second $Elements section");
      v4_ ? read_elements_v4() : read_elements_v2();
      elements_read_ = true;
      expect_end(name);
    } else if (name == "Entities" && v4_) {
      read_entities();
      expect_end(name);
    } else if (name == "NodeData" || name == "ElementData") {
      read_data(name == "NodeData" ? Association::Vertex : Association::Cell, name);
      expect_end(name);
    } else {
      if (name == "ElementNodeData") {
        warnings_.push_back(path() + ": skipped $ElementNodeData (values per element corner are not supported)");
      }
      skip_section(name);
    }
  }

  void expect_end(const std::string& name) {
    const std::string_view token = t().next_token();
    if (token != "$End" + name) {
      const std::string found =
          token.empty() ? std::string("the end of the file") : "'" + std::string(token.substr(0, 40)) + "'";
      if (in_.binary()) fail_at_offset(path(), t().token_offset(), "expected $End" + name + ", found " + found);
      t().fail_at_token_line("expected $End" + name + ", found " + found);
    }
  }

  // Skips to the line "$EndName". ASCII: line by line (lines stay counted); binary: byte by byte, since binary
  // payloads have no lines.
  void skip_section(const std::string& name) {
    const std::string end = "$End" + name;
    const uint64_t start_line = t().token_line(), start_offset = t().token_offset();
    if (!in_.binary()) {
      while (const std::optional<std::string_view> line = t().read_line()) {
        if (trim(*line) == end) return;
      }
      fail_at_line(path(), start_line, "section $" + name + " has no " + end + " line");
    }
    size_t matched = 0;
    while (!t().at_end()) {
      char c;
      t().read_bytes(&c, 1);
      if (c == end[matched]) {
        if (++matched == end.size()) return;
      } else {
        matched = c == end[0] ? 1 : 0;
      }
    }
    fail_at_offset(path(), start_offset, "section $" + name + " has no " + end);
  }

  // --- $Entities (4.1) ----------------------------------------------------------------------------------------------

  void read_entities() {
    in_.begin_binary_values();
    std::array<uint64_t, 4> counts{};
    for (int dim = 0; dim < 4; ++dim) counts[size_t(dim)] = in_.size_value("the number of entities");
    for (int dim = 0; dim < 4; ++dim) {
      // A point is a tag and 3 coordinates, other entities a tag, a box and two counts.
      in_.check_fits("$Entities", counts[size_t(dim)], dim == 0 ? 3 * in_.real_bytes() : 6 * in_.real_bytes());
      for (uint64_t i = 0; i < counts[size_t(dim)]; ++i) {
        const int64_t tag = in_.integer("an entity tag");
        for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) in_.real("an entity coordinate");
        const uint64_t nphysical = in_.size_value("the number of physical tags");
        in_.check_fits("physical tag", nphysical, in_.int_bytes());
        for (uint64_t p = 0; p < nphysical; ++p) {
          const int64_t physical = in_.integer("a physical tag");
          if (dim == 3 && p == 0) {
            volume_physical_[tag] = int32_t(std::clamp<int64_t>(physical, INT32_MIN, INT32_MAX));
          }
        }
        if (dim == 0) continue;
        const uint64_t nbounding = in_.size_value("the number of bounding entities");
        in_.check_fits("bounding entity", nbounding, in_.int_bytes());
        for (uint64_t b = 0; b < nbounding; ++b) in_.integer("a bounding entity tag");
      }
    }
  }

  // The start of a v4 $Nodes or $Elements section (`what`: "node" or "element"): the number of entity blocks and of
  // nodes or elements in all, checked to fit in the file; the minimum and maximum tags that follow are skipped.
  struct V4SectionHeader {
    uint64_t blocks, count;
  };
  V4SectionHeader read_v4_section_header(const std::string& what) {
    in_.begin_binary_values();
    const uint64_t blocks = in_.size_value("the number of entity blocks");
    const uint64_t count = in_.size_value("the number of " + what + "s");
    in_.size_value("the minimum " + what + " tag");
    in_.size_value("the maximum " + what + " tag");
    in_.check_fits(what + " entity block", blocks, 3 * in_.int_bytes() + in_.size_value_bytes());
    return {blocks, count};
  }

  // --- $Nodes -------------------------------------------------------------------------------------------------------

  void read_nodes_v2() {
    nodes_line_ = t().token_line();
    nodes_offset_ = t().token_offset();
    const uint64_t n = in_.text<uint64_t>("the number of nodes");
    reserve_nodes(n, in_.binary() ? 4 + 24 : 8);
    in_.begin_binary_values();
    for (uint64_t i = 0; i < n; ++i) {
      node_tags_.push_back(in_.tag("a node tag"));
      read_point();
    }
  }

  void read_nodes_v4() {
    nodes_line_ = t().token_line();
    nodes_offset_ = t().token_offset();
    const auto [blocks, n] = read_v4_section_header("node");
    reserve_nodes(n, in_.binary() ? uint64_t(in_.size_bytes()) + 24 : 8);
    for (uint64_t b = 0; b < blocks; ++b) {
      const int64_t dim = in_.integer_in("the entity dimension", 0, 3);
      in_.integer("the entity tag");
      const int64_t parametric = in_.integer_in("the parametric flag", 0, 1);
      const uint64_t count = in_.size_value("the number of nodes in the block");
      if (count > n - node_tags_.size()) {
        in_.fail("node block of " + std::to_string(count) + " nodes exceeds the " + std::to_string(n) +
                 " nodes the section declares");
      }
      for (uint64_t i = 0; i < count; ++i) node_tags_.push_back(in_.size_value("a node tag"));
      const int extra = parametric ? int(dim) : 0;  // u (curves), u v (surfaces), u v w (volumes)
      for (uint64_t i = 0; i < count; ++i) {
        read_point();
        for (int k = 0; k < extra; ++k) in_.real("a parametric coordinate");
      }
    }
    if (node_tags_.size() != n) {
      in_.fail("the node blocks hold " + std::to_string(node_tags_.size()) + " nodes but the section declares " +
               std::to_string(n));
    }
  }

  void reserve_nodes(uint64_t n, uint64_t bytes_each) {
    in_.check_fits("node", n, bytes_each);
    if (n > std::numeric_limits<uint32_t>::max()) {
      in_.fail(std::to_string(n) + " nodes: an in-memory mesh holds at most 2^32-1 vertices");
    }
    node_tags_.reserve(size_t(n));
    points_.reserve(size_t(n));
  }

  void read_point() {
    Vec3f p;
    for (int k = 0; k < 3; ++k) {
      const double v = in_.real("a node coordinate");
      if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
        in_.fail("node coordinate " + std::to_string(v) + " is beyond the float32 range points are kept in");
      }
      p[k] = float(v);
    }
    points_.push_back(p);
  }

  void finish_nodes() {
    nodes_read_ = true;
    std::vector<std::pair<uint64_t, uint64_t>> entries(node_tags_.size());
    for (size_t i = 0; i < node_tags_.size(); ++i) entries[i] = {node_tags_[i], i};
    node_tags_ = {};
    if (const std::optional<uint64_t> twice = node_map_.build(std::move(entries))) {
      const std::string message = "node tag " + std::to_string(*twice) + " is defined twice in $Nodes";
      if (in_.binary()) fail_at_offset(path(), nodes_offset_, message);
      fail_at_line(path(), nodes_line_, message);
    }
  }

  // --- $Elements ----------------------------------------------------------------------------------------------------

  void read_elements_v2() {
    const uint64_t n = in_.text<uint64_t>("the number of elements");
    // An element is at least "tag type ntags node" (4 ints).
    in_.check_fits("element", n, 4 * in_.int_bytes());
    elements_.reserve(size_t(n));
    if (!in_.binary()) {
      for (uint64_t i = 0; i < n; ++i) {
        const uint64_t tag = in_.tag("an element tag");
        const GmshType& type = element_type(in_.integer("an element type"));
        read_element_v2(tag, type, uint64_t(in_.integer_in("the number of element tags", 0, 1 << 20)));
      }
      return;
    }
    in_.begin_binary_values();
    for (uint64_t done = 0; done < n;) {
      const GmshType& type = element_type(in_.integer("an element type"));
      const int64_t follow = in_.integer_in("the number of elements that follow", 1, int64_t(n - done));
      const int64_t ntags = in_.integer_in("the number of element tags", 0, 1 << 20);
      for (int64_t e = 0; e < follow; ++e) read_element_v2(in_.tag("an element tag"), type, uint64_t(ntags));
      done += uint64_t(follow);
    }
  }

  void read_element_v2(uint64_t tag, const GmshType& type, uint64_t ntags) {
    in_.check_fits("element tag", ntags, in_.int_bytes());
    int32_t physical = 0;
    for (uint64_t k = 0; k < ntags; ++k) {
      const int64_t v = in_.integer("an element tag");
      if (k == 0) physical = int32_t(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX));
    }
    if (ntags > 0) has_physical_ = true;
    node_ids_.resize(size_t(type.nodes));
    for (uint64_t& id : node_ids_) id = in_.tag("a node tag");
    add_element(tag, type, physical);
  }

  void read_elements_v4() {
    const auto [blocks, n] = read_v4_section_header("element");
    // An element is at least its tag and one node.
    in_.check_fits("element", n, 2 * in_.size_value_bytes());
    elements_.reserve(size_t(n));
    uint64_t done = 0;
    const bool physical_groups = !volume_physical_.empty();
    for (uint64_t b = 0; b < blocks; ++b) {
      in_.integer_in("the entity dimension", 0, 3);
      const int64_t entity = in_.integer("the entity tag");
      const GmshType& type = element_type(in_.integer("an element type"));
      const uint64_t count = in_.size_value("the number of elements in the block");
      if (count > n - done) {
        in_.fail("element block of " + std::to_string(count) + " elements exceeds the " + std::to_string(n) +
                 " elements the section declares");
      }
      int32_t label = int32_t(std::clamp<int64_t>(entity, INT32_MIN, INT32_MAX));
      if (physical_groups) {
        const auto it = volume_physical_.find(entity);
        label = it == volume_physical_.end() ? 0 : it->second;
      }
      node_ids_.resize(size_t(type.nodes));
      for (uint64_t e = 0; e < count; ++e) {
        const uint64_t tag = in_.size_value("an element tag");
        for (uint64_t& id : node_ids_) id = in_.size_value("a node tag");
        add_element(tag, type, label);
      }
      done += count;
    }
    if (done != n) {
      in_.fail("the element blocks hold " + std::to_string(done) + " elements but the section declares " +
               std::to_string(n));
    }
    has_physical_ = physical_groups;
    label_name_ = physical_groups ? "gmsh:physical" : "gmsh:entity";
  }

  // How many of an element's first node tags add_element looks up as corners (none for a dropped element).
  static size_t cell_vertex_count_or_zero(const GmshType& type) {
    return type.dim < 3 ? 0 : size_t(cell_vertex_count(type.cell));
  }

  const GmshType& element_type(int64_t code) {
    const std::optional<GmshType> type = gmsh_type(code);
    if (!type) {
      in_.fail("unsupported Gmsh element type " + std::to_string(code) +
               " (volume types read: tetrahedra, hexahedra, prisms and pyramids, linear or higher order)");
    }
    current_type_ = *type;
    return current_type_;
  }

  void add_element(uint64_t tag, const GmshType& type, int32_t label) {
    ++file_elements_;
    // Every node tag the element stores must be defined, also the mid-edge ones a higher-order element is linearised
    // away from and those of dropped lower-dimensional elements: an unknown tag anywhere means the element section
    // is corrupt. (The corners are looked up again below; the map is a hash table.)
    for (size_t k = cell_vertex_count_or_zero(type); k < node_ids_.size(); ++k) {
      if (node_map_.find(node_ids_[k]) == kAbsent) {
        in_.fail("element " + std::to_string(tag) + " uses node tag " + std::to_string(node_ids_[k]) +
                 ", which $Nodes does not define");
      }
    }
    if (type.dim < 3) {
      elements_.emplace_back(tag, kDropped);
      ++dropped_[type.name];
      return;
    }
    const uint8_t corners = cell_vertex_count(type.cell);
    std::array<uint32_t, 8> v{};
    for (uint8_t k = 0; k < corners; ++k) {
      const uint64_t index = node_map_.find(node_ids_[k]);
      if (index == kAbsent) {
        in_.fail("element " + std::to_string(tag) + " uses node tag " + std::to_string(node_ids_[k]) +
                 ", which $Nodes does not define");
      }
      v[type.cell == CellType::Wedge ? kPrismToVtk[k] : k] = uint32_t(index);
    }
    elements_.emplace_back(tag, mesh_.cell_count());
    mesh_.add_cell(type.cell, std::span<const uint32_t>(v.data(), corners));
    labels_.push_back(label);
  }

  // --- $NodeData / $ElementData -------------------------------------------------------------------------------------

  void read_data(Association association, const std::string& section) {
    const uint64_t section_line = t().token_line();
    if (!elements_read_) t().fail_at_token_line("$" + section + " before $Nodes and $Elements");
    if (association == Association::Cell && !element_map_built_) build_element_map();

    const uint64_t nstrings = in_.text<uint64_t>("the number of string tags");
    in_.check_fits("string tag", nstrings, 2);
    t().skip_line();
    std::string name;
    for (uint64_t i = 0; i < nstrings; ++i) {
      const std::optional<std::string_view> line = t().read_line();
      if (!line) fail_at_line(path(), t().line(), "unexpected end of file: expected a string tag");
      std::string s = trim(*line);
      if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
      if (i == 0) name = s;
    }
    if (name.empty()) name = "gmsh:data@" + std::to_string(section_line);
    const uint64_t nreals = in_.text<uint64_t>("the number of real tags");
    in_.check_fits("real tag", nreals, 2);
    for (uint64_t i = 0; i < nreals; ++i) in_.text<double>("a real tag");
    const uint64_t nints = in_.text<uint64_t>("the number of integer tags");
    if (nints < 3) in_.fail("$" + section + " needs 3 integer tags (time step, components, count)");
    in_.check_fits("integer tag", nints, 2);
    int64_t step = 0, components = 0, count = 0;
    for (uint64_t i = 0; i < nints; ++i) {
      const int64_t v = in_.text<int64_t>("an integer tag");
      if (i == 0) step = v;
      if (i == 1) components = v;
      if (i == 1 && (v < 1 || v > kMaxComponents)) {
        in_.fail("component count " + std::to_string(v) + " is outside [1, " + std::to_string(kMaxComponents) + "]");
      }
      if (i == 2) count = v;
      if (i == 2 && v < 0) in_.fail("negative value count " + std::to_string(v));
    }
    in_.check_fits("data value", uint64_t(count), in_.int_bytes() + uint64_t(components) * in_.real_bytes());
    PendingField& field = field_for(name, association, step, int(components));
    in_.begin_binary_values();
    std::vector<double> values(static_cast<size_t>(components));
    for (int64_t i = 0; i < count; ++i) {
      const uint64_t tag = in_.tag(association == Association::Vertex ? "a node tag" : "an element tag");
      for (double& v : values) v = in_.real("a data value");
      const uint64_t index = association == Association::Vertex ? node_map_.find(tag) : element_map_.find(tag);
      if (index == kAbsent) {
        in_.fail("$" + section + " '" + name + "' gives a value for " +
                 (association == Association::Vertex ? "node " : "element ") + std::to_string(tag) +
                 ", which the mesh does not define");
      }
      if (index == kDropped) continue;
      std::copy(values.begin(), values.end(),
                field.data.values<double>().begin() + ptrdiff_t(index * uint64_t(components)));
      field.defined[size_t(index)] = true;
    }
  }

  void build_element_map() {
    element_map_built_ = true;
    if (const std::optional<uint64_t> twice = element_map_.build(std::move(elements_))) {
      in_.fail("element tag " + std::to_string(*twice) + " is defined twice in $Elements");
    }
    elements_ = {};
  }

  // The field a data block fills: a new one, the same time step of an earlier block (another partition), or a later
  // time step that replaces it.
  PendingField& field_for(const std::string& name, Association association, int64_t step, int components) {
    const uint64_t tuples = association == Association::Vertex ? points_.size() : mesh_.cell_count();
    const auto key = std::make_pair(association, name);
    const auto it = field_index_.find(key);
    if (it != field_index_.end()) {
      PendingField& f = fields_[it->second];
      if (f.step == step) {
        if (f.data.components() != components) {
          in_.fail("'" + name + "' has " + std::to_string(components) + " components here but " +
                   std::to_string(f.data.components()) + " in an earlier block of the same time step");
        }
        return f;
      }
      const uint64_t replaced = f.replaced + 1;
      f = make_field(name, association, step, components, tuples);
      f.replaced = replaced;
      return f;
    }
    field_index_.emplace(key, fields_.size());
    fields_.push_back(make_field(name, association, step, components, tuples));
    return fields_.back();
  }

  static PendingField make_field(const std::string& name, Association association, int64_t step, int components,
                                 uint64_t tuples) {
    PendingField f{name, association, step, DataArray(ScalarType::Float64, components, tuples), {}, 0};
    std::fill(f.data.values<double>().begin(), f.data.values<double>().end(), std::nan(""));
    f.defined.assign(size_t(tuples), false);
    return f;
  }

  // --- result -------------------------------------------------------------------------------------------------------

  Dataset finish() {
    if (!nodes_read_) fail_in(path(), "no $Nodes section");
    if (!elements_read_) fail_in(path(), "no $Elements section");
    if (mesh_.cell_count() == 0) {
      fail_in(path(), "none of its " + std::to_string(file_elements_) +
                          " elements is a volume element (tetrahedron, pyramid, prism, hexahedron); ugvr renders "
                          "volumes only");
    }
    if (!dropped_.empty()) {
      uint64_t total = 0;
      std::string detail;
      for (const auto& [type_name, count] : dropped_) {
        total += count;
        detail += (detail.empty() ? "" : ", ") + std::to_string(count) + " " + type_name;
      }
      warnings_.push_back(path() + ": ignored " + std::to_string(total) + " lower-dimensional element(s) (" + detail +
                          "); their element data is dropped with them");
    }
    mesh_.points = std::move(points_);
    mesh_.validate(path());

    Block block{base_name(path()), std::move(mesh_), FieldSet{}};
    if (has_physical_ || v4_) {
      block.fields.add(Field(label_name_, Association::Cell, DataArray::from(std::move(labels_), 1)));
    }
    for (PendingField& f : fields_) {
      const uint64_t missing = uint64_t(std::count(f.defined.begin(), f.defined.end(), false));
      if (f.replaced > 0) {
        warnings_.push_back(path() + ": '" + f.name + "' has " + std::to_string(f.replaced + 1) +
                            " time steps; the last one (step " + std::to_string(f.step) + ") is kept");
      }
      if (missing > 0) {
        warnings_.push_back(path() + ": '" + f.name + "' has no value for " + std::to_string(missing) + " " +
                            (f.association == Association::Vertex ? "node(s)" : "cell(s)") + "; they are NaN");
      }
      block.fields.add(Field(f.name, f.association, std::move(f.data)));
    }
    Dataset d = single_block_dataset("Gmsh MSH " + version_ + (in_.binary() ? " binary" : " ASCII"), path(),
                                     std::move(block), std::move(warnings_));
    if (progress_) progress_->finish();
    return d;
  }

  InputFile file_;
  GmshInput in_;
  std::optional<Progress> progress_;
  std::vector<std::string> warnings_;
  std::string version_;
  bool v4_ = false;
  bool nodes_read_ = false, elements_read_ = false, element_map_built_ = false;

  std::vector<uint64_t> node_tags_;  // while $Nodes is read
  std::vector<Vec3f> points_;
  uint64_t nodes_line_ = 0, nodes_offset_ = 0;
  TagMap node_map_;

  std::unordered_map<int64_t, int32_t> volume_physical_;  // 4.1 volume entity -> first physical tag
  std::vector<uint64_t> node_ids_;                        // the node tags of the element being read
  GmshType current_type_;
  uint64_t file_elements_ = 0;
  UnstructuredMesh mesh_;
  std::vector<int32_t> labels_;
  bool has_physical_ = false;
  std::string label_name_ = "gmsh:physical";
  std::vector<std::pair<uint64_t, uint64_t>> elements_;  // (tag, cell index or kDropped) until the map is built
  TagMap element_map_;
  std::map<std::string, uint64_t> dropped_;

  std::vector<PendingField> fields_;
  std::map<std::pair<Association, std::string>, size_t> field_index_;
};

}  // namespace

Dataset read_gmsh(const std::string& path) { return GmshReader(path).read(); }

}  // namespace ugvr
