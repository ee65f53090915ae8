// VTK XML reader: .vtu, .pvtu, .vts, .vti, .vtr, .pvts, .pvti, .pvtr.
//
// How a file is read (see vtk_xml_skeleton.h and vtk_xml_array.h for the byte-level layouts):
//  1. The file is scanned once for its markup (scan_xml_skeleton): tags are kept, array text is replaced by its file
//     range, and scanning stops at the appended data. pugixml parses only that skeleton.
//  2. Every array a piece needs is described (type, components, encoding, where its bytes are) and probed: its header
//     is read and its size checked against the counts of the markup (NumberOfPoints, NumberOfCells, extents) before
//     anything is allocated. The cell types are counted in a first streaming pass so the mesh is reserved exactly
//     (quadratic cells keep only their corners; lower-dimensional cells are dropped).
//  3. Arrays are decoded chunk by chunk straight into their final place: points into the mesh (converted to float32),
//     fields into their DataArray in the stored type, cells by reading offsets, types and connectivity in lockstep
//     and handing each cell to VtkCellImporter. No array is ever held whole in another form beside the result.
//
// Pieces: the <Piece>s of an UnstructuredGrid (in one .vtu or in the files a .pvtu lists) are concatenated into one
// mesh, point ids offset by the points of the pieces before; fields are concatenated by name, so every piece must
// have the same point and cell arrays (same type and components). Pieces of structured files are placed into the
// WholeExtent by their Extent and must cover it; so are the piece files of a .pvts / .pvti / .pvtr (each read as a
// .vts / .vti / .vtr of its <Piece Extent>, placed by that Extent, points shared between pieces written by each).
//
// Fields: PointData becomes vertex fields, CellData cell fields (filtered like the cells when some are dropped).
// Arrays of a type the model has no place for (String, Bit) are skipped with a warning. VTK's own arrays such as
// vtkGhostType are ordinary numeric arrays and are kept as fields (a warning says when duplicate ghost cells are
// present). FieldData (global values) is ignored.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <pugixml.hpp>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/pvtu_pieces.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/vtk_cell_import.h"
#include "ugvr/io/vtk_xml_array.h"
#include "ugvr/io/vtk_xml_document.h"
#include "ugvr/io/vtk_xml_skeleton.h"
#include "ugvr/io/vtu_pieces.h"

namespace ugvr {

namespace {

using vtk_xml::count_attribute;
using vtk_xml::data_array;
using vtk_xml::describe_array;
using vtk_xml::element_name;
using vtk_xml::kMaxComponents;
using vtk_xml::load_doc;
using vtk_xml::parse_number;
using vtk_xml::parse_numbers;
using vtk_xml::required_array;
using vtk_xml::single_child;
using vtk_xml::single_data_array;
using vtk_xml::Unsupported;
using vtk_xml::XmlDoc;

constexpr size_t kChunkValues = size_t(1) << 16;  // cells or ids decoded per step
constexpr uint64_t kMaxPoints = uint64_t(UINT32_MAX);

struct FieldSpec {
  std::string name;
  Association association;
  ScalarType type;
  int components;
  bool operator==(const FieldSpec&) const = default;
};

// The arrays of a <PointData> or <CellData> element. Unnamed arrays are named "array<k>"; arrays of unsupported
// types and repeated names are skipped with a warning.
std::vector<XmlArray> field_arrays(const XmlDoc& d, pugi::xml_node parent, Association assoc,
                                   const std::string& piece_label, std::vector<std::string>& warnings) {
  std::vector<XmlArray> out;
  if (!parent) return out;
  const std::string where = piece_label + (assoc == Association::Vertex ? "<PointData>" : "<CellData>");
  std::set<std::string> names;
  int k = 0;
  for (pugi::xml_node n : parent.children("DataArray")) {
    std::string name = n.attribute("Name").value();
    if (name.empty()) name = "array" + std::to_string(k);
    ++k;
    const std::string label = where + " DataArray '" + name + "'";
    auto v = describe_array(d, n, label);
    if (auto* u = std::get_if<Unsupported>(&v)) {
      warnings.push_back(base_name(d.path) + ": " + label + " skipped: " + u->reason + " is not a numeric type");
      continue;
    }
    if (!names.insert(name).second) {
      warnings.push_back(base_name(d.path) + ": " + label + " skipped: a field of that name was read already");
      continue;
    }
    XmlArray a = std::get<XmlArray>(std::move(v));
    a.name = name;
    out.push_back(std::move(a));
  }
  return out;
}

// Pieces agree on their fields: the same names with the same type and components, in any order.
void check_same_fields(const XmlDoc& d, pugi::xml_node piece, const std::vector<FieldSpec>& expected,
                       const std::vector<XmlArray>& got, Association assoc, const std::string& piece_label) {
  const std::string kind = assoc == Association::Vertex ? "point" : "cell";
  for (const XmlArray& a : got) {
    const auto it = std::find_if(expected.begin(), expected.end(),
                                 [&](const FieldSpec& s) { return s.name == a.name && s.association == assoc; });
    if (it == expected.end()) {
      d.fail(piece, piece_label + "has " + kind + " array '" + a.name + "' which the first piece does not have");
    }
    if (it->type != a.type || it->components != a.components) {
      d.fail(piece, piece_label + kind + " array '" + a.name + "' is " + std::string(scalar_type_name(a.type)) + " x " +
                        std::to_string(a.components) + " but " + std::string(scalar_type_name(it->type)) + " x " +
                        std::to_string(it->components) + " in the first piece");
    }
  }
  for (const FieldSpec& s : expected) {
    if (s.association != assoc) continue;
    if (std::none_of(got.begin(), got.end(), [&](const XmlArray& a) { return a.name == s.name; })) {
      d.fail(piece, piece_label + "lacks " + kind + " array '" + s.name + "' which the first piece has");
    }
  }
}

std::string tuples_text(uint64_t tuples, int components, const char* what) {
  return std::string(what) + "=" + std::to_string(tuples) + " x " + std::to_string(components) + " components";
}

uint64_t checked_product(uint64_t a, uint64_t b, const XmlDoc& d, pugi::xml_node n) {
  if (b != 0 && a > UINT64_MAX / b) d.fail(n, "array size overflows 64 bits");
  return a * b;
}

// Reads the next `tuples` tuples of `reader` into data's tuples [first, first + tuples), in the stored type.
void read_field_slice(XmlArrayReader& reader, DataArray& data, uint64_t first, uint64_t tuples) {
  const uint64_t nc = uint64_t(data.components());
  data.visit([&](auto values) { reader.read_native(values.subspan(size_t(first * nc), size_t(tuples * nc))); });
}

DataArray make_field_data(const FieldSpec& s, uint64_t tuples) { return DataArray(s.type, s.components, tuples); }

// ---------------------------------------------------------------------------------------------------------------
// UnstructuredGrid (.vtu, .pvtu)

struct UgPiece {
  size_t doc = 0;
  pugi::xml_node node;
  std::string label;  // "Piece 2 " in files with several pieces, else ""
  uint64_t points = 0, cells = 0;
  std::optional<XmlArray> points_array, connectivity, offsets, types;
  std::vector<XmlArray> point_data, cell_data;

  bool empty() const { return points == 0 && cells == 0; }
};

UgPiece describe_ug_piece(const XmlDoc& d, size_t doc_index, pugi::xml_node piece, const std::string& label,
                          std::vector<std::string>& warnings) {
  UgPiece p;
  p.doc = doc_index;
  p.node = piece;
  p.label = label;
  p.points = count_attribute(d, piece, "NumberOfPoints");
  p.cells = count_attribute(d, piece, "NumberOfCells");
  // Each of these may appear once: with two, which one is meant is a guess.
  const pugi::xml_node points = single_child(d, piece, "Points");
  const pugi::xml_node cells = single_child(d, piece, "Cells");
  const pugi::xml_node point_data = single_child(d, piece, "PointData");
  const pugi::xml_node cell_data = single_child(d, piece, "CellData");
  if (p.points > 0) {
    const pugi::xml_node pa = single_data_array(d, points);
    if (!pa) d.fail(piece, label + "<Piece> has " + std::to_string(p.points) + " points but no <Points> DataArray");
    p.points_array = required_array(d, pa, label + "<Points> DataArray");
    if (p.points_array->components != 3) {
      d.fail(pa, label + "<Points> DataArray has " + std::to_string(p.points_array->components) +
                     " components, expected 3");
    }
  }
  if (p.cells > 0) {
    for (const char* name : {"connectivity", "offsets", "types"}) {
      const pugi::xml_node n = single_data_array(d, cells, name);
      if (!n) d.fail(piece, label + "<Cells> has no DataArray named '" + name + "'");
      XmlArray a = required_array(d, n, label + "<Cells> DataArray '" + name + "'");
      if (a.type == ScalarType::Float32 || a.type == ScalarType::Float64) {
        d.fail(n, a.label + " must hold integers, not " + std::string(scalar_type_name(a.type)));
      }
      if (a.components != 1) d.fail(n, a.label + " must have 1 component");
      const std::string_view which = name;
      if (which == "connectivity")
        p.connectivity = std::move(a);
      else if (which == "offsets")
        p.offsets = std::move(a);
      else
        p.types = std::move(a);
    }
  }
  p.point_data = field_arrays(d, point_data, Association::Vertex, label, warnings);
  p.cell_data = field_arrays(d, cell_data, Association::Cell, label, warnings);
  return p;
}

// A <Piece> whose points and connectivity are the same bytes as another piece's of the same file is a copy of it (a
// duplicated element, or appended offsets pointing twice at the same arrays): read, it would double the mesh with
// coincident cells, so it is refused. Appended arrays are the same bytes when they start at the same offset; inline
// arrays (ascii, binary) when their text is equal, compared by length and a 64-bit FNV-1a hash, read only in files
// with several pieces.
using ArrayIdentity = std::tuple<bool, uint64_t, uint64_t>;  // (inline, begin or hash, 0 or length)

ArrayIdentity array_identity(const InputFile& file, const XmlArray& a) {
  if (a.format == XmlArrayFormat::Appended) return {false, a.begin, 0};
  uint64_t hash = 0xcbf29ce484222325u;
  std::vector<unsigned char> buf(size_t(1) << 20);
  for (uint64_t at = a.begin; at < a.end;) {
    const size_t n = size_t(std::min<uint64_t>(buf.size(), a.end - at));
    file.read_at(at, buf.data(), n);
    for (size_t i = 0; i < n; ++i) hash = (hash ^ buf[i]) * 0x100000001b3u;
    at += n;
  }
  return {true, hash, a.end - a.begin};
}

void refuse_duplicate_pieces(const std::vector<std::unique_ptr<XmlDoc>>& docs, const std::vector<UgPiece>& pieces) {
  std::vector<size_t> per_doc(docs.size());
  for (const UgPiece& p : pieces) ++per_doc[p.doc];
  std::map<std::tuple<size_t, ArrayIdentity, ArrayIdentity>, size_t> seen;  // (doc, points, connectivity) -> piece
  std::unique_ptr<InputFile> file;
  size_t file_doc = SIZE_MAX;
  for (size_t i = 0; i < pieces.size(); ++i) {
    const UgPiece& p = pieces[i];
    if (per_doc[p.doc] < 2 || !p.points_array || !p.connectivity) continue;
    if (file_doc != p.doc) {
      file = std::make_unique<InputFile>(docs[p.doc]->path);
      file_doc = p.doc;
    }
    const auto key = std::tuple{p.doc, array_identity(*file, *p.points_array), array_identity(*file, *p.connectivity)};
    const auto [it, fresh] = seen.emplace(key, i);
    if (fresh) continue;
    docs[p.doc]->fail(p.node, p.label + "<Piece> is a duplicate of " + pieces[it->second].label +
                                  "<Piece>: its points and connectivity are the same bytes");
  }
}

struct KeptCounts {
  uint64_t cells = 0, indices = 0;
};

int clamp_cell_type(int64_t t) { return int(std::clamp<int64_t>(t, INT32_MIN, INT32_MAX)); }

// Streams the types array once to count the cells and corner indices the mesh will keep.
void count_kept_cells(XmlArrayReader& types, uint64_t cells, KeptCounts& kept) {
  std::vector<int64_t> buf(size_t(std::min<uint64_t>(cells, kChunkValues)));
  for (uint64_t c = 0; c < cells;) {
    const size_t n = size_t(std::min<uint64_t>(kChunkValues, cells - c));
    types.read(std::span(buf.data(), n));
    for (size_t i = 0; i < n; ++i) {
      const VtkCellMapping m = map_vtk_cell_type(clamp_cell_type(buf[i]));
      if (m.kind == VtkCellMapping::Kind::Keep) {
        ++kept.cells;
        kept.indices += m.corner_count;
      }
    }
    c += n;
  }
}

// A window over the connectivity array: hands out each cell's ids as one contiguous span, reading ahead in chunks
// (up to the count the array's header gives; ascii arrays exactly what is asked).
class IdWindow {
 public:
  static constexpr size_t kCapacity = kChunkValues;

  explicit IdWindow(XmlArrayReader& reader)
      : reader_(reader),
        total_(reader.value_count()),
        buf_(size_t(std::min<uint64_t>(kCapacity, total_ ? *total_ : 64))) {}

  // `count` is at most kCapacity.
  std::span<const int64_t> take(size_t count) {
    if (len_ - pos_ < count) {
      const size_t rest = len_ - pos_;
      std::copy(buf_.begin() + ptrdiff_t(pos_), buf_.begin() + ptrdiff_t(len_), buf_.begin());
      if (buf_.size() < count) buf_.resize(count);
      size_t want = count - rest;
      if (total_) want = size_t(std::min<uint64_t>(buf_.size() - rest, *total_ - read_));
      if (want < count - rest) reader_.fail("connectivity ends before the cells the offsets describe");
      reader_.read(std::span(buf_.data() + rest, want));
      read_ += want;
      pos_ = 0;
      len_ = rest + want;
    }
    const std::span<const int64_t> ids(buf_.data() + pos_, count);
    pos_ += count;
    return ids;
  }

  // Passes over `count` ids nobody looks at (a huge polygon or poly-vertex that is dropped anyway).
  void skip(uint64_t count) {
    const uint64_t buffered = std::min<uint64_t>(count, len_ - pos_);
    pos_ += size_t(buffered);
    count -= buffered;
    if (total_ && count > *total_ - read_) reader_.fail("connectivity ends before the cells the offsets describe");
    reader_.skip(count);
    read_ += count;
  }

 private:
  XmlArrayReader& reader_;
  std::optional<uint64_t> total_;
  uint64_t read_ = 0;
  std::vector<int64_t> buf_;
  size_t pos_ = 0, len_ = 0;
};

// Reads one piece's cells into the importer. `point_base` is the index of the piece's first point in the mesh.
void read_ug_cells(const InputFile& file, const XmlDoc& d, const UgPiece& p, VtkCellImporter& importer,
                   uint64_t point_base, uint64_t cell_base, bool offset_ids, Progress& progress) {
  XmlArrayReader offsets(file, d.encoding, *p.offsets);
  XmlArrayReader types(file, d.encoding, *p.types);
  XmlArrayReader conn(file, d.encoding, *p.connectivity);
  offsets.expect_count(p.cells, "NumberOfCells=" + std::to_string(p.cells));
  types.expect_count(p.cells, "NumberOfCells=" + std::to_string(p.cells));
  const std::optional<uint64_t> conn_total = conn.value_count();
  IdWindow window(conn);
  const size_t chunk = size_t(std::min<uint64_t>(p.cells, kChunkValues));
  std::vector<int64_t> off_buf(chunk), type_buf(chunk);
  std::array<int64_t, 32> shifted{};
  uint64_t prev = 0;
  for (uint64_t c0 = 0; c0 < p.cells;) {
    const size_t n = size_t(std::min<uint64_t>(kChunkValues, p.cells - c0));
    offsets.read(std::span(off_buf.data(), n));
    types.read(std::span(type_buf.data(), n));
    for (size_t i = 0; i < n; ++i) {
      const uint64_t c = c0 + i;
      const int64_t end = off_buf[i];
      if (end < 0 || uint64_t(end) < prev) {
        offsets.fail("offset " + std::to_string(end) + " of cell " + std::to_string(c) +
                     " is smaller than the previous offset " + std::to_string(prev));
      }
      if (conn_total && uint64_t(end) > *conn_total) {
        offsets.fail("offset " + std::to_string(end) + " of cell " + std::to_string(c) +
                     " is beyond the connectivity array's " + std::to_string(*conn_total) + " ids");
      }
      const uint64_t count = uint64_t(end) - prev;
      prev = uint64_t(end);
      const int type = clamp_cell_type(type_buf[i]);
      const VtkCellMapping m = map_vtk_cell_type(type);
      if (count > IdWindow::kCapacity) {
        // Only a variable-size lower-dimensional cell can be this long legitimately; it is dropped unseen.
        if (m.kind == VtkCellMapping::Kind::Unsupported) importer.add(type, std::span<const int64_t>(), cell_base + c);
        if (m.kind == VtkCellMapping::Kind::Keep || m.expected_points >= 0) {
          offsets.fail("cell " + std::to_string(c) + " (" + std::string(m.vtk_name) + ") lists " +
                       std::to_string(count) + " point ids");
        }
        window.skip(count);
        importer.add(type, std::span<const int64_t>(), cell_base + c);
        continue;
      }
      std::span<const int64_t> ids = window.take(size_t(count));
      if (offset_ids && m.kind == VtkCellMapping::Kind::Keep && ids.size() == size_t(m.expected_points)) {
        // Ids index the piece's own points; the mesh holds all pieces' points one after the other.
        for (size_t k = 0; k < ids.size(); ++k) {
          if (ids[k] < 0 || uint64_t(ids[k]) >= p.points) {
            conn.fail("cell " + std::to_string(c) + ": point id " + std::to_string(ids[k]) + " is outside [0, " +
                      std::to_string(p.points) + ") of its piece");
          }
          shifted[k] = ids[k] + int64_t(point_base);
        }
        ids = std::span<const int64_t>(shifted.data(), ids.size());
      }
      importer.add(type, ids, cell_base + c);
    }
    c0 += n;
    progress.add(n);
  }
  if (conn_total && prev != *conn_total) {
    conn.fail("holds " + std::to_string(*conn_total) + " ids but the offsets use " + std::to_string(prev));
  }
  offsets.finish();
  types.finish();
  conn.finish();
}

std::vector<FieldSpec> field_specs(const UgPiece& p) {
  std::vector<FieldSpec> s;
  for (const XmlArray& a : p.point_data) s.push_back({a.name, Association::Vertex, a.type, a.components});
  for (const XmlArray& a : p.cell_data) s.push_back({a.name, Association::Cell, a.type, a.components});
  return s;
}

const XmlArray& find_field(const std::vector<XmlArray>& point_data, const std::vector<XmlArray>& cell_data,
                           const FieldSpec& s) {
  const auto& list = s.association == Association::Vertex ? point_data : cell_data;
  return *std::find_if(list.begin(), list.end(), [&](const XmlArray& a) { return a.name == s.name; });
}

void warn_ghost_cells(const Block& block, const std::string& source, std::vector<std::string>& warnings) {
  const Field* ghost = block.fields.find("vtkGhostType", Association::Cell);
  if (!ghost || ghost->data().type() != ScalarType::UInt8) return;
  const auto v = ghost->data().values<uint8_t>();
  // vtkDataSetAttributes::DUPLICATECELL = 1: a copy of a cell owned by another piece.
  const auto dup = std::count_if(v.begin(), v.end(), [](uint8_t g) { return (g & 1) != 0; });
  if (dup > 0) {
    warnings.push_back(source + ": " + std::to_string(dup) +
                       " duplicate ghost cells kept (marked in cell field vtkGhostType)");
  }
}

// Every <Piece> of UnstructuredGrid files, described; arrays skipped (unsupported types, repeated names) are warned
// about in `warnings`.
std::vector<UgPiece> describe_ug_pieces(const std::vector<std::unique_ptr<XmlDoc>>& docs,
                                        std::vector<std::string>& warnings) {
  std::vector<UgPiece> pieces;
  for (size_t di = 0; di < docs.size(); ++di) {
    const XmlDoc& d = *docs[di];
    if (d.type != "UnstructuredGrid") {
      fail_in(d.path, "VTKFile type \"" + d.type.substr(0, 40) + "\", expected UnstructuredGrid");
    }
    const pugi::xml_node grid = single_child(d, d.root, "UnstructuredGrid");
    if (!grid) d.fail(d.root, "no <UnstructuredGrid> element");
    const size_t count = size_t(std::distance(grid.children("Piece").begin(), grid.children("Piece").end()));
    size_t k = 0;
    for (pugi::xml_node piece : grid.children("Piece")) {
      const std::string label = count > 1 ? "Piece " + std::to_string(k) + " " : "";
      pieces.push_back(describe_ug_piece(d, di, piece, label, warnings));
      ++k;
    }
  }
  return pieces;
}

// The fields: those of the first piece with data; every other non-empty piece must agree.
std::vector<FieldSpec> agreed_field_specs(const std::vector<std::unique_ptr<XmlDoc>>& docs,
                                          const std::vector<UgPiece>& pieces) {
  std::vector<FieldSpec> specs;
  const auto first = std::find_if(pieces.begin(), pieces.end(), [](const UgPiece& p) { return !p.empty(); });
  if (first != pieces.end()) specs = field_specs(*first);
  for (const UgPiece& p : pieces) {
    if (p.empty()) continue;
    check_same_fields(*docs[p.doc], p.node, specs, p.point_data, Association::Vertex, p.label);
    check_same_fields(*docs[p.doc], p.node, specs, p.cell_data, Association::Cell, p.label);
  }
  return specs;
}

// Checks that every field array of a piece holds one tuple per point or cell, before anything is allocated for it.
void expect_field_counts(const InputFile& file, const XmlDoc& d, const UgPiece& p) {
  for (const XmlArray& a : p.point_data) {
    XmlArrayReader(file, d.encoding, a)
        .expect_count(checked_product(p.points, uint64_t(a.components), d, p.node),
                      tuples_text(p.points, a.components, "NumberOfPoints"));
  }
  for (const XmlArray& a : p.cell_data) {
    XmlArrayReader(file, d.encoding, a)
        .expect_count(checked_product(p.cells, uint64_t(a.components), d, p.node),
                      tuples_text(p.cells, a.components, "NumberOfCells"));
  }
}

// Reads a piece's fields into `field_data` (one array per spec, sized for every piece) at the piece's first point and
// cell.
void read_piece_fields(const InputFile& file, const XmlDoc& d, const UgPiece& p, const std::vector<FieldSpec>& specs,
                       std::vector<DataArray>& field_data, uint64_t point_base, uint64_t cell_base) {
  for (size_t f = 0; f < specs.size(); ++f) {
    const bool vertex = specs[f].association == Association::Vertex;
    XmlArrayReader r(file, d.encoding, find_field(p.point_data, p.cell_data, specs[f]));
    const uint64_t tuples = vertex ? p.points : p.cells;
    r.expect_count(tuples * uint64_t(specs[f].components),
                   tuples_text(tuples, specs[f].components, vertex ? "NumberOfPoints" : "NumberOfCells"));
    read_field_slice(r, field_data[f], vertex ? point_base : cell_base, tuples);
    r.finish();
  }
}

// The arrays a .pvtu declares (<PPointData>, <PCellData>) must be in its pieces with the declared type and components
// (pieces without points or cells aside); nothing is checked for a .vtu (`declared` empty).
void check_declared_fields(const std::vector<UgPiece>& pieces, const std::vector<FieldSpec>& specs,
                           const std::vector<FieldSpec>& declared, pugi::xml_node declared_at, const XmlDoc* pdoc) {
  const bool any_data = std::any_of(pieces.begin(), pieces.end(), [](const UgPiece& p) { return !p.empty(); });
  for (const FieldSpec& s : declared) {
    const auto it = std::find_if(specs.begin(), specs.end(), [&](const FieldSpec& f) {
      return f.name == s.name && f.association == s.association;
    });
    if (any_data && (it == specs.end() || it->type != s.type || it->components != s.components)) {
      pdoc->fail(declared_at, std::string(s.association == Association::Vertex ? "point" : "cell") + " array '" +
                                  s.name + "' declared as " + std::string(scalar_type_name(s.type)) + " x " +
                                  std::to_string(s.components) + " is not in the pieces as declared");
    }
  }
}

// `only_piece`: read that <Piece> of the documents' pieces alone (read_vtu_piece), with the fields every piece agrees
// on.
Dataset read_unstructured(const std::string& path, std::vector<std::unique_ptr<XmlDoc>> docs, std::string format,
                          const std::vector<FieldSpec>& declared, pugi::xml_node declared_at, const XmlDoc* pdoc,
                          std::optional<size_t> only_piece = std::nullopt) {
  Dataset ds;
  ds.format = std::move(format);
  ds.sources.push_back(path);
  for (const auto& d : docs) {
    if (d->path != path) ds.sources.push_back(d->path);
  }

  std::vector<UgPiece> pieces = describe_ug_pieces(docs, ds.warnings);
  refuse_duplicate_pieces(docs, pieces);
  const std::vector<FieldSpec> specs = agreed_field_specs(docs, pieces);
  check_declared_fields(pieces, specs, declared, declared_at, pdoc);
  const bool several = pieces.size() > 1;
  if (only_piece) {
    if (*only_piece >= pieces.size())
      fail_in(path,
              "<Piece> " + std::to_string(*only_piece) + " asked for, the file has " + std::to_string(pieces.size()));
    UgPiece one = std::move(pieces[*only_piece]);
    pieces.clear();
    pieces.push_back(std::move(one));
  }

  // Probe every array's size and count the kept cells before allocating anything.
  uint64_t total_points = 0, total_cells = 0;
  KeptCounts kept;
  for (size_t di = 0; di < docs.size(); ++di) {
    const XmlDoc& d = *docs[di];
    const InputFile file(d.path);
    for (const UgPiece& p : pieces) {
      if (p.doc != di || p.empty()) continue;
      if (p.points_array) {
        XmlArrayReader(file, d.encoding, *p.points_array)
            .expect_count(checked_product(p.points, 3, d, p.node), tuples_text(p.points, 3, "NumberOfPoints"));
      }
      expect_field_counts(file, d, p);
      if (p.cells > 0) {
        XmlArrayReader types(file, d.encoding, *p.types);
        types.expect_count(p.cells, "NumberOfCells=" + std::to_string(p.cells));
        count_kept_cells(types, p.cells, kept);
      }
      total_points += p.points;
      total_cells += p.cells;
      if (total_points > kMaxPoints) {
        d.fail(p.node, "more than 2^32-1 points in total; ugvr meshes index vertices with 32 bits");
      }
    }
  }

  // Allocate the result at its final size, then read every piece into place.
  UnstructuredMesh mesh;
  mesh.points.resize(size_t(total_points));
  VtkCellImporter importer(base_name(path), total_points);
  importer.reserve(kept.cells, kept.indices);
  std::vector<DataArray> field_data;
  for (const FieldSpec& s : specs) {
    field_data.push_back(make_field_data(s, s.association == Association::Vertex ? total_points : total_cells));
  }
  uint64_t point_base = 0, cell_base = 0;
  Progress progress("reading " + base_name(path), total_points + total_cells);
  for (size_t di = 0; di < docs.size(); ++di) {
    const XmlDoc& d = *docs[di];
    const InputFile file(d.path);
    for (const UgPiece& p : pieces) {
      if (p.doc != di || p.empty()) continue;
      if (p.points > 0) {
        XmlArrayReader r(file, d.encoding, *p.points_array);
        r.expect_count(p.points * 3, tuples_text(p.points, 3, "NumberOfPoints"));
        float* xyz = &mesh.points[size_t(point_base)].x;
        r.read(std::span<float>(xyz, size_t(p.points * 3)));
        r.finish();
        progress.add(p.points);
      }
      if (p.cells > 0) read_ug_cells(file, d, p, importer, point_base, cell_base, several, progress);
      read_piece_fields(file, d, p, specs, field_data, point_base, cell_base);
      point_base += p.points;
      cell_base += p.cells;
    }
  }

  progress.finish();
  importer.finish(mesh, ds.warnings);
  Block block;
  for (size_t f = 0; f < specs.size(); ++f) {
    DataArray data = std::move(field_data[f]);
    if (specs[f].association == Association::Cell) data = importer.filter_cell_data(std::move(data));
    block.fields.add(Field(specs[f].name, specs[f].association, std::move(data)));
  }
  mesh.validate(base_name(path));
  block.grid = std::move(mesh);
  block.validate_fields(base_name(path));
  warn_ghost_cells(block, base_name(path), ds.warnings);
  ds.blocks.push_back(std::move(block));
  return ds;
}

// The file cells the mesh keeps (the importer's policy: volume cells), in file order (the pieces of every document one
// after the other, as read_unstructured numbers them); nullopt when it keeps them all, so that cell data read without
// the mesh lines up with the mesh's cells. Reads the types arrays only.
std::optional<std::vector<uint64_t>> kept_file_cells(const std::vector<std::unique_ptr<XmlDoc>>& docs,
                                                     const std::vector<UgPiece>& pieces) {
  std::vector<uint64_t> kept;
  bool dropped = false, keep = true;
  uint64_t base = 0;
  std::vector<int64_t> buf;
  std::unique_ptr<InputFile> file;
  size_t file_doc = SIZE_MAX;
  for (const UgPiece& p : pieces) {
    if (p.empty()) continue;
    if (p.cells > 0) {
      const XmlDoc& d = *docs[p.doc];
      if (file_doc != p.doc) {
        file = std::make_unique<InputFile>(d.path);
        file_doc = p.doc;
      }
      XmlArrayReader types(*file, d.encoding, *p.types);
      types.expect_count(p.cells, "NumberOfCells=" + std::to_string(p.cells));
      buf.resize(size_t(std::min<uint64_t>(p.cells, kChunkValues)));
      for (uint64_t c = 0; c < p.cells;) {
        const size_t n = size_t(std::min<uint64_t>(kChunkValues, p.cells - c));
        types.read(std::span(buf.data(), n));
        for (size_t i = 0; i < n; ++i) {
          // Runs of one type are the rule (a hexahedral mesh has one): the mapping is looked up once a run.
          if (i == 0 || buf[i] != buf[i - 1])
            keep = map_vtk_cell_type(clamp_cell_type(buf[i])).kind == VtkCellMapping::Kind::Keep;
          if (keep && dropped) {
            kept.push_back(base + c + i);
          } else if (!keep && !dropped) {
            // From here on kept cells are listed; those before were all kept.
            dropped = true;
            kept.resize(size_t(base + c + i));
            std::iota(kept.begin(), kept.end(), uint64_t(0));
          }
        }
        c += n;
      }
    }
    base += p.cells;
  }
  if (!dropped) return std::nullopt;
  return kept;
}

// The arrays a .pvtu declares in <PPointData> / <PCellData>.
std::vector<FieldSpec> declared_fields(const XmlDoc& d, pugi::xml_node grid) {
  std::vector<FieldSpec> out;
  for (const auto& [tag, assoc] :
       {std::pair{"PPointData", Association::Vertex}, std::pair{"PCellData", Association::Cell}}) {
    int k = 0;
    for (pugi::xml_node n : grid.child(tag).children("PDataArray")) {
      std::string name = n.attribute("Name").value();
      if (name.empty()) name = "array" + std::to_string(k);
      ++k;
      const auto type = parse_scalar_type(n.attribute("type").value());
      if (!type) continue;  // skipped in the pieces too
      int components = 1;
      if (const pugi::xml_attribute c = n.attribute("NumberOfComponents")) {
        const auto v = parse_number<int64_t>(c.value());
        if (!v || *v < 1 || *v > kMaxComponents) d.fail(n, "<PDataArray> has a bad NumberOfComponents");
        components = int(*v);
      }
      out.push_back({name, assoc, *type, components});
    }
  }
  return out;
}

// More piece files than this in one .pvtu are refused before any is opened (large MPI runs write one per rank; each
// open piece keeps its parsed markup while the mesh is assembled).
constexpr size_t kMaxPvtuPieces = size_t(1) << 16;

// The memory budget a .pvtu's pieces are checked against before reading: the machine's physical memory. The mesh
// read from a piece takes about as much memory as the piece's file (float64 points become float32, base64 shrinks
// by 3/4, compressed arrays grow), so pieces whose files add up to more than the memory cannot be read.
uint64_t pvtu_memory_budget() { return physical_memory_bytes(); }

// The piece files a .pvtu lists, checked before any is read: a sane count, no file listed twice (it would be read
// twice into one mesh, with coincident cells), and their total size within the memory budget. Without this, a .pvtu
// listing one 1.1 MB piece 20,000 times ran to 5.9 GB before anything failed.
std::vector<std::string> pvtu_piece_paths(const XmlDoc& pdoc, pugi::xml_node grid) {
  const std::string tag = std::string("<") + grid.name() + ">";
  const size_t count = size_t(std::distance(grid.children("Piece").begin(), grid.children("Piece").end()));
  if (count > kMaxPvtuPieces) {
    pdoc.fail(grid, tag + " lists " + std::to_string(count) + " pieces, more than the " +
                        std::to_string(kMaxPvtuPieces) + " this reader accepts");
  }
  std::vector<std::string> paths;
  std::map<std::string, pugi::xml_node> seen;  // file identity -> its first <Piece>
  uint64_t total = 0;
  for (pugi::xml_node piece : grid.children("Piece")) {
    const std::string source = piece.attribute("Source").value();
    if (source.empty()) pdoc.fail(piece, "<Piece> has no Source attribute");
    // Sources are relative to the .pvtu's directory.
    const std::string path = source.front() == '/' ? source : dir_name(pdoc.path) + source;
    // One file however it is named (another spelling, a symbolic or a hard link): its device and inode; a file
    // that cannot be stat'ed fails in load_doc, with its own message, so its path stands in for it here.
    struct stat st {};
    const bool found = ::stat(path.c_str(), &st) == 0;
    const std::string key = found ? std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino) : "path:" + path;
    if (!seen.emplace(key, piece).second) {
      pdoc.fail(piece, "<Piece Source=\"" + source.substr(0, 200) + "\"> lists a piece file already listed");
    }
    if (found && S_ISREG(st.st_mode)) {
      const uint64_t size = uint64_t(st.st_size);
      total = size > UINT64_MAX - total ? UINT64_MAX : total + size;
    }
    paths.push_back(path);
  }
  if (const uint64_t budget = pvtu_memory_budget(); total > budget) {
    pdoc.fail(grid, "the " + std::to_string(count) + " piece files add up to " + format_bytes(total) + " (" +
                        std::to_string(total) + " bytes), more than the memory budget of " + format_bytes(budget) +
                        " (physical memory)");
  }
  return paths;
}

Dataset read_pvtu(std::unique_ptr<XmlDoc> pdoc) {
  const pugi::xml_node grid = single_child(*pdoc, pdoc->root, "PUnstructuredGrid");
  if (!grid) pdoc->fail(pdoc->root, "no <PUnstructuredGrid> element");
  std::vector<std::unique_ptr<XmlDoc>> docs;
  for (const std::string& piece_path : pvtu_piece_paths(*pdoc, grid)) docs.push_back(load_doc(piece_path));
  if (docs.empty()) pdoc->fail(grid, "<PUnstructuredGrid> lists no <Piece Source=...>");
  const std::vector<FieldSpec> declared = declared_fields(*pdoc, grid);
  return read_unstructured(pdoc->path, std::move(docs), "VTK XML PUnstructuredGrid (.pvtu)", declared, grid,
                           pdoc.get());
}

// ---------------------------------------------------------------------------------------------------------------
// Structured grids (.vts, .vti, .vtr)

// Inclusive point index ranges [lo, hi] per axis, as in VTK's Extent attributes.
struct Extent {
  std::array<int64_t, 3> lo{}, hi{};

  uint64_t points(int axis) const { return uint64_t(hi[axis] - lo[axis]) + 1; }
  uint64_t point_count() const { return points(0) * points(1) * points(2); }
  uint64_t cells(int axis) const { return uint64_t(hi[axis] - lo[axis]); }
  uint64_t cell_count() const { return cells(0) * cells(1) * cells(2); }
  bool operator==(const Extent&) const = default;
};

Extent parse_extent(const XmlDoc& d, pugi::xml_node n, const char* name) {
  const pugi::xml_attribute a = n.attribute(name);
  if (a.empty()) d.fail(n, element_name(n) + " has no " + name + " attribute");
  const auto v = parse_numbers<int64_t>(a.value(), 6);
  Extent e;
  bool ok = v.has_value();
  for (int i = 0; ok && i < 3; ++i) {
    e.lo[i] = (*v)[size_t(2 * i)];
    e.hi[i] = (*v)[size_t(2 * i + 1)];
    // Bounded so sizes and index arithmetic cannot overflow.
    ok = e.lo[i] >= -(int64_t(1) << 40) && e.hi[i] < (int64_t(1) << 40) && e.hi[i] >= e.lo[i] &&
         e.hi[i] - e.lo[i] < int64_t(kMaxPoints);
  }
  if (!ok) {
    d.fail(n, element_name(n) + " " + name + "=\"" + std::string(a.value()).substr(0, 80) +
                  "\" is not six integers x0 x1 y0 y1 z0 z1 with x0 <= x1 < x0 + 2^32 (and so on)");
  }
  return e;
}

bool inside(const Extent& inner, const Extent& outer) {
  for (int i = 0; i < 3; ++i) {
    if (inner.lo[i] < outer.lo[i] || inner.hi[i] > outer.hi[i]) return false;
  }
  return true;
}

// Calls run(first_tuple, tuple_count) in order for the runs of consecutive tuples (i fastest) that a piece's
// values occupy in the whole grid; rows that follow each other in the whole grid are merged into one run.
void for_each_run(const Extent& piece, const Extent& whole, bool cells,
                  const std::function<void(uint64_t, uint64_t)>& run) {
  std::array<uint64_t, 3> n{}, wn{}, off{};
  for (int i = 0; i < 3; ++i) {
    n[i] = cells ? piece.cells(i) : piece.points(i);
    wn[i] = cells ? whole.cells(i) : whole.points(i);
    off[i] = uint64_t(piece.lo[i] - whole.lo[i]);
  }
  if (n[0] == 0 || n[1] == 0 || n[2] == 0) return;
  uint64_t start = 0, length = 0;
  for (uint64_t k = 0; k < n[2]; ++k) {
    for (uint64_t j = 0; j < n[1]; ++j) {
      const uint64_t first = off[0] + wn[0] * ((off[1] + j) + wn[1] * (off[2] + k));
      if (length > 0 && first == start + length) {
        length += n[0];
        continue;
      }
      if (length > 0) run(start, length);
      start = first;
      length = n[0];
    }
  }
  if (length > 0) run(start, length);
}

// Tracks which tuples of the whole grid the pieces' extents cover, when there are several pieces. Only used for
// arrays the pieces really hold, so its size is backed by data in the file.
class Coverage {
 public:
  Coverage(uint64_t size, bool active) : seen_(active ? size_t(size) : 0) {}
  bool active() const { return !seen_.empty(); }
  void mark(uint64_t first, uint64_t count) {
    std::fill(seen_.begin() + ptrdiff_t(first), seen_.begin() + ptrdiff_t(first + count), true);
  }
  bool complete() const {
    return std::all_of(seen_.begin(), seen_.end(), [](bool b) { return b; });
  }

 private:
  std::vector<bool> seen_;
};

enum class StructuredKind { Curvilinear, Image, Rectilinear };

struct StPiece {
  pugi::xml_node node;
  std::string label;
  Extent extent;
  uint64_t points = 0, cells = 0;  // cells: 0 unless the grid is 3-D
  std::optional<XmlArray> points_array;
  std::array<std::optional<XmlArray>, 3> coords;
  std::vector<XmlArray> point_data, cell_data;
};

ImageGrid parse_image_geometry(const XmlDoc& d, pugi::xml_node image, const Extent& whole) {
  ImageGrid g;
  std::array<double, 3> origin{0, 0, 0}, spacing{1, 1, 1};
  for (const auto& [attr, dst] : {std::pair{"Origin", &origin}, std::pair{"Spacing", &spacing}}) {
    if (const pugi::xml_attribute a = image.attribute(attr)) {
      const auto v = parse_numbers<double>(a.value(), 3);
      if (!v || !std::all_of(v->begin(), v->end(), [](double x) { return std::isfinite(x); })) {
        d.fail(image, std::string("<ImageData> ") + attr + "=\"" + std::string(a.value()).substr(0, 80) +
                          "\" is not three finite numbers");
      }
      std::copy(v->begin(), v->end(), dst->begin());
    }
  }
  for (int i = 0; i < 3; ++i) {
    if (!(spacing[size_t(i)] > 0) && whole.points(i) > 1) {
      d.fail(image, "<ImageData> Spacing must be positive along every axis with more than one point");
    }
  }
  if (const pugi::xml_attribute a = image.attribute("Direction")) {
    const auto v = parse_numbers<double>(a.value(), 9);
    const std::array<double, 9> identity{1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (!v || !std::equal(v->begin(), v->end(), identity.begin())) {
      d.fail(image, "<ImageData> Direction=\"" + std::string(a.value()).substr(0, 80) +
                        "\" is not the identity; rotated images are not supported (resample to an axis-aligned grid)");
    }
  }
  // VTK places point (i, j, k) of the extent at Origin + (i, j, k) * Spacing; ugvr counts from the extent's corner.
  g.origin = {origin[0] + double(whole.lo[0]) * spacing[0], origin[1] + double(whole.lo[1]) * spacing[1],
              origin[2] + double(whole.lo[2]) * spacing[2]};
  g.spacing = {spacing[0], spacing[1], spacing[2]};
  return g;
}

// Point count of an extent, refused above 2^48 so that counts times components stay far from overflow.
uint64_t checked_point_count(const XmlDoc& d, pugi::xml_node n, const Extent& e) {
  const uint64_t a = e.points(0), b = e.points(1), c = e.points(2);
  constexpr uint64_t kMax = uint64_t(1) << 48;
  if (a * b > kMax || c > kMax / (a * b)) d.fail(n, element_name(n) + " extent has more than 2^48 points");
  return a * b * c;
}

StPiece describe_st_piece(const XmlDoc& d, pugi::xml_node pn, StructuredKind kind, const std::string& label,
                          bool volume, std::vector<std::string>& warnings) {
  StPiece p;
  p.node = pn;
  p.label = label;
  p.extent = parse_extent(d, pn, "Extent");
  p.points = checked_point_count(d, pn, p.extent);
  p.cells = volume ? p.extent.cell_count() : 0;
  const pugi::xml_node point_data = single_child(d, pn, "PointData");
  const pugi::xml_node cell_data = single_child(d, pn, "CellData");
  if (kind == StructuredKind::Curvilinear) {
    const pugi::xml_node pa = single_data_array(d, single_child(d, pn, "Points"));
    if (!pa) d.fail(pn, label + "<Piece> has no <Points> DataArray");
    p.points_array = required_array(d, pa, label + "<Points> DataArray");
    if (p.points_array->components != 3) d.fail(pa, label + "<Points> DataArray must have 3 components");
  } else if (kind == StructuredKind::Rectilinear) {
    int axis = 0;
    for (pugi::xml_node a : single_child(d, pn, "Coordinates").children("DataArray")) {
      if (axis == 3) d.fail(a, label + "<Coordinates> holds more than three DataArrays");
      p.coords[size_t(axis)] = required_array(d, a, label + "<Coordinates> DataArray " + std::to_string(axis));
      if (p.coords[size_t(axis)]->components != 1) d.fail(a, "<Coordinates> arrays must have 1 component");
      ++axis;
    }
    if (axis != 3) d.fail(pn, label + "<Coordinates> must hold three DataArrays (x, y, z)");
  }
  p.point_data = field_arrays(d, point_data, Association::Vertex, label, warnings);
  p.cell_data = field_arrays(d, cell_data, Association::Cell, label, warnings);
  return p;
}

// Opens the reader of a structured piece's field and checks its size.
std::unique_ptr<XmlArrayReader> open_st_field(const InputFile& file, const XmlDoc& d, const StPiece& p,
                                              const FieldSpec& s) {
  auto r = std::make_unique<XmlArrayReader>(file, d.encoding, find_field(p.point_data, p.cell_data, s));
  const bool vertex = s.association == Association::Vertex;
  r->expect_count(checked_product(vertex ? p.points : p.cells, uint64_t(s.components), d, p.node),
                  tuples_text(vertex ? p.points : p.cells, s.components, vertex ? "Extent points" : "Extent cells"));
  return r;
}

Dataset read_structured(std::unique_ptr<XmlDoc> doc, StructuredKind kind) {
  const XmlDoc& d = *doc;
  const char* tag = kind == StructuredKind::Curvilinear ? "StructuredGrid"
                    : kind == StructuredKind::Image     ? "ImageData"
                                                        : "RectilinearGrid";
  Dataset ds;
  ds.format = kind == StructuredKind::Curvilinear ? "VTK XML StructuredGrid (.vts)"
              : kind == StructuredKind::Image     ? "VTK XML ImageData (.vti)"
                                                  : "VTK XML RectilinearGrid (.vtr)";
  ds.sources.push_back(d.path);
  const pugi::xml_node grid = single_child(d, d.root, tag);
  if (!grid) d.fail(d.root, std::string("no <") + tag + "> element");
  const Extent whole = parse_extent(d, grid, "WholeExtent");
  const uint64_t whole_points = checked_point_count(d, grid, whole);
  GridDims dims;
  for (int i = 0; i < 3; ++i) dims.points[size_t(i)] = uint32_t(whole.points(i));
  // ugvr's structured grids have cells only when they are 3-D; VTK's 2-D cells carry no volume.
  const bool volume = whole.points(0) > 1 && whole.points(1) > 1 && whole.points(2) > 1;

  std::vector<StPiece> pieces;
  const size_t count = size_t(std::distance(grid.children("Piece").begin(), grid.children("Piece").end()));
  for (pugi::xml_node pn : grid.children("Piece")) {
    const std::string label = count > 1 ? "Piece " + std::to_string(pieces.size()) + " " : "";
    pieces.push_back(describe_st_piece(d, pn, kind, label, volume, ds.warnings));
    if (!inside(pieces.back().extent, whole)) d.fail(pn, label + "<Piece> Extent is outside the WholeExtent");
  }
  if (pieces.empty()) d.fail(grid, std::string("<") + tag + "> has no <Piece>");
  if (pieces.size() == 1 && !(pieces[0].extent == whole)) {
    d.fail(pieces[0].node, "the only <Piece>'s Extent does not cover the WholeExtent");
  }

  std::vector<FieldSpec> specs;
  for (const XmlArray& a : pieces[0].point_data) specs.push_back({a.name, Association::Vertex, a.type, a.components});
  for (const XmlArray& a : pieces[0].cell_data) specs.push_back({a.name, Association::Cell, a.type, a.components});
  for (const StPiece& p : pieces) {
    check_same_fields(d, p.node, specs, p.point_data, Association::Vertex, p.label);
    check_same_fields(d, p.node, specs, p.cell_data, Association::Cell, p.label);
  }
  const auto is_cell = [](const FieldSpec& s) { return s.association == Association::Cell; };
  if (!volume && std::any_of(specs.begin(), specs.end(), is_cell)) {
    ds.warnings.push_back(base_name(d.path) + ": cell data ignored: the grid is not 3-D, so it has no volume cells");
    std::erase_if(specs, is_cell);
  }

  // Probe every array before allocating; the pieces' data must add up to at least the whole grid.
  const InputFile file(d.path);
  uint64_t piece_points = 0, piece_cells = 0;
  for (const StPiece& p : pieces) {
    if (p.points_array) {
      XmlArrayReader(file, d.encoding, *p.points_array)
          .expect_count(p.points * 3, tuples_text(p.points, 3, "Extent points"));
    }
    for (int i = 0; i < 3; ++i) {
      if (p.coords[size_t(i)]) {
        XmlArrayReader(file, d.encoding, *p.coords[size_t(i)])
            .expect_count(p.extent.points(i), "the Extent's points along axis " + std::to_string(i));
      }
    }
    for (const FieldSpec& s : specs) open_st_field(file, d, p, s);
    piece_points += p.points;
    piece_cells += p.cells;
  }
  if (piece_points < whole_points || (volume && piece_cells < dims.cell_count())) {
    d.fail(grid, "the pieces' Extents do not cover the WholeExtent");
  }

  // Coverage is checked for what is read: points (positions or point fields), cells, rectilinear axes.
  const bool several = pieces.size() > 1;
  const bool point_arrays = kind == StructuredKind::Curvilinear || !std::all_of(specs.begin(), specs.end(), is_cell);
  const bool cell_arrays = std::any_of(specs.begin(), specs.end(), is_cell);
  Coverage point_cover(whole_points, several && point_arrays), cell_cover(dims.cell_count(), several && cell_arrays);
  std::array<Coverage, 3> axis_cover{Coverage(dims.points[0], several && kind == StructuredKind::Rectilinear),
                                     Coverage(dims.points[1], several && kind == StructuredKind::Rectilinear),
                                     Coverage(dims.points[2], several && kind == StructuredKind::Rectilinear)};

  StructuredGrid sgrid;
  RectilinearGrid rgrid;
  sgrid.dims = rgrid.dims = dims;
  if (kind == StructuredKind::Curvilinear) sgrid.points.resize(size_t(whole_points));
  if (kind == StructuredKind::Rectilinear) {
    for (int i = 0; i < 3; ++i) rgrid.coords[size_t(i)].resize(dims.points[size_t(i)]);
  }
  std::vector<DataArray> field_data;
  for (const FieldSpec& s : specs) {
    field_data.push_back(make_field_data(s, s.association == Association::Vertex ? whole_points : dims.cell_count()));
  }

  for (const StPiece& p : pieces) {
    if (point_cover.active()) {
      for_each_run(p.extent, whole, false, [&](uint64_t first, uint64_t n) { point_cover.mark(first, n); });
    }
    if (cell_cover.active()) {
      for_each_run(p.extent, whole, true, [&](uint64_t first, uint64_t n) { cell_cover.mark(first, n); });
    }
    if (p.points_array) {
      XmlArrayReader r(file, d.encoding, *p.points_array);
      r.expect_count(p.points * 3, tuples_text(p.points, 3, "Extent points"));
      for_each_run(p.extent, whole, false, [&](uint64_t first, uint64_t n) {
        r.read(std::span<float>(&sgrid.points[size_t(first)].x, size_t(n * 3)));
      });
      r.finish();
    }
    for (int i = 0; i < 3; ++i) {
      if (!p.coords[size_t(i)]) continue;
      XmlArrayReader r(file, d.encoding, *p.coords[size_t(i)]);
      r.expect_count(p.extent.points(i), "the Extent's points along axis " + std::to_string(i));
      const uint64_t first = uint64_t(p.extent.lo[i] - whole.lo[i]);
      r.read(std::span<double>(rgrid.coords[size_t(i)].data() + first, size_t(p.extent.points(i))));
      if (axis_cover[size_t(i)].active()) axis_cover[size_t(i)].mark(first, p.extent.points(i));
      r.finish();
    }
    for (size_t f = 0; f < specs.size(); ++f) {
      const auto r = open_st_field(file, d, p, specs[f]);
      for_each_run(p.extent, whole, specs[f].association == Association::Cell,
                   [&](uint64_t first, uint64_t n) { read_field_slice(*r, field_data[f], first, n); });
      r->finish();
    }
  }
  bool covered = point_cover.complete() && cell_cover.complete();
  for (const Coverage& c : axis_cover) covered = covered && c.complete();
  if (!covered) d.fail(grid, "the pieces' Extents leave parts of the WholeExtent without data");

  Block block;
  switch (kind) {
    case StructuredKind::Curvilinear: block.grid = std::move(sgrid); break;
    case StructuredKind::Rectilinear: block.grid = std::move(rgrid); break;
    case StructuredKind::Image: {
      ImageGrid g = parse_image_geometry(d, grid, whole);
      g.dims = dims;
      block.grid = g;
      break;
    }
  }
  for (size_t f = 0; f < specs.size(); ++f) {
    block.fields.add(Field(specs[f].name, specs[f].association, std::move(field_data[f])));
  }
  block.validate_fields(base_name(d.path));
  ds.blocks.push_back(std::move(block));
  return ds;
}

// A parallel structured file (.pvts, .pvti, .pvtr): its piece files are read whole, each must be the serial kind of
// the size of its <Piece Extent>, and are placed into the WholeExtent, which they must cover. The first piece's
// arrays are the fields; every piece must have them with the same type and components (extra arrays are ignored).
Dataset read_pstructured(std::unique_ptr<XmlDoc> pdoc, StructuredKind kind);

}  // namespace

bool is_pvtu_path(const std::string& path) { return extension_lower(path) == ".pvtu"; }

std::vector<std::string> pvtu_piece_files(const std::string& path) {
  const std::unique_ptr<XmlDoc> doc = load_doc(path);
  if (doc->type != "PUnstructuredGrid")
    fail_in(path, "VTKFile type \"" + doc->type.substr(0, 40) + "\", expected PUnstructuredGrid");
  const pugi::xml_node grid = single_child(*doc, doc->root, "PUnstructuredGrid");
  if (!grid) doc->fail(doc->root, "no <PUnstructuredGrid> element");
  std::vector<std::string> paths = pvtu_piece_paths(*doc, grid);
  if (paths.empty()) doc->fail(grid, "<PUnstructuredGrid> lists no <Piece Source=...>");
  return paths;
}

size_t vtu_piece_count(const std::string& path) {
  const std::unique_ptr<XmlDoc> doc = load_doc(path);
  if (doc->type != "UnstructuredGrid")
    fail_in(path, "VTKFile type \"" + doc->type.substr(0, 40) + "\", expected UnstructuredGrid");
  const pugi::xml_node grid = single_child(*doc, doc->root, "UnstructuredGrid");
  if (!grid) doc->fail(doc->root, "no <UnstructuredGrid> element");
  return size_t(std::distance(grid.children("Piece").begin(), grid.children("Piece").end()));
}

Dataset read_vtu_piece(const std::string& path, size_t piece) {
  std::unique_ptr<XmlDoc> doc = load_doc(path);
  if (doc->type != "UnstructuredGrid")
    fail_in(path, "VTKFile type \"" + doc->type.substr(0, 40) + "\", expected UnstructuredGrid");
  std::vector<std::unique_ptr<XmlDoc>> docs;
  docs.push_back(std::move(doc));
  return read_unstructured(path, std::move(docs), "VTK XML UnstructuredGrid (.vtu)", {}, {}, nullptr, piece);
}

namespace {

// The one <Piece> of a .vtu read by cell ranges, described, and the fields.
struct SinglePiece {
  std::unique_ptr<XmlDoc> doc;
  UgPiece piece;
  std::vector<FieldSpec> specs;
};

SinglePiece describe_single_piece(const std::string& path, std::vector<std::string>& warnings) {
  SinglePiece out;
  std::vector<std::unique_ptr<XmlDoc>> docs;
  docs.push_back(load_doc(path));
  if (docs[0]->type != "UnstructuredGrid")
    fail_in(path, "VTKFile type \"" + docs[0]->type.substr(0, 40) + "\", expected UnstructuredGrid");
  std::vector<UgPiece> pieces = describe_ug_pieces(docs, warnings);
  if (pieces.size() != 1) fail_in(path, "a cell range is read from a .vtu of one <Piece>");
  out.specs = agreed_field_specs(docs, pieces);
  out.piece = std::move(pieces[0]);
  out.doc = std::move(docs[0]);
  return out;
}

}  // namespace

bool vtu_reads_by_cell_ranges(const std::string& path) {
  std::vector<std::string> warnings;
  const SinglePiece one = [&] {
    try {
      return describe_single_piece(path, warnings);
    } catch (const Error&) {
      return SinglePiece{};  // read whole, which says what is wrong
    }
  }();
  if (!one.doc || one.piece.cells == 0 || one.doc->encoding.codec != Codec::None || one.doc->encoding.appended_base64)
    return false;
  const UgPiece& p = one.piece;
  std::vector<const XmlArray*> arrays{&*p.connectivity, &*p.offsets, &*p.types};
  if (p.points_array) arrays.push_back(&*p.points_array);
  for (const XmlArray& a : p.point_data) arrays.push_back(&a);
  for (const XmlArray& a : p.cell_data) arrays.push_back(&a);
  return std::all_of(arrays.begin(), arrays.end(),
                     [](const XmlArray* a) { return a->format == XmlArrayFormat::Appended; });
}

Dataset read_vtu_cells(const std::string& path, uint64_t first, uint64_t count, uint64_t* first_point) {
  Dataset ds;
  ds.format = "VTK XML UnstructuredGrid (.vtu), cells " + std::to_string(first) + "+" + std::to_string(count);
  ds.sources.push_back(path);
  const SinglePiece one = describe_single_piece(path, ds.warnings);
  const XmlDoc& d = *one.doc;
  const UgPiece& p = one.piece;
  if (first > p.cells || count > p.cells - first)
    d.fail(p.node, "cells " + std::to_string(first) + "+" + std::to_string(count) + " asked for, the <Piece> has " +
                       std::to_string(p.cells));
  const InputFile file(path);
  // The range's offsets (the end of the cell before it too), types and connectivity: each array's reader seeks to
  // the range (XmlArrayReader::skip) and reads it alone.
  XmlArrayReader offsets(file, d.encoding, *p.offsets), types(file, d.encoding, *p.types);
  offsets.expect_count(p.cells, "NumberOfCells=" + std::to_string(p.cells));
  types.expect_count(p.cells, "NumberOfCells=" + std::to_string(p.cells));
  std::vector<int64_t> ends(size_t(count) + 1, 0);
  std::vector<int64_t> type_of(static_cast<size_t>(count));
  if (first > 0) offsets.skip(first - 1), offsets.read(std::span(ends.data(), 1));
  offsets.read(std::span(ends.data() + 1, size_t(count)));
  types.skip(first);
  types.read(std::span(type_of));
  XmlArrayReader conn(file, d.encoding, *p.connectivity);
  const std::optional<uint64_t> conn_total = conn.value_count();
  for (size_t i = 0; i < count; ++i) {
    if (ends[i + 1] < ends[i] || ends[i] < 0)
      offsets.fail("offset " + std::to_string(ends[i + 1]) + " of cell " + std::to_string(first + i) +
                   " is smaller than the previous offset " + std::to_string(ends[i]));
  }
  if (conn_total && uint64_t(ends.back()) > *conn_total)
    offsets.fail("offset " + std::to_string(ends.back()) + " of cell " + std::to_string(first + count - 1) +
                 " is beyond the connectivity array's " + std::to_string(*conn_total) + " ids");
  std::vector<int64_t> ids(size_t(ends.back() - ends.front()));
  conn.skip(uint64_t(ends.front()));
  conn.read(std::span(ids));
  // The points from the least to the greatest id the range uses (one slab per array; a solver's or generator's cells
  // use points numbered near their own).
  int64_t lo = std::numeric_limits<int64_t>::max(), hi = -1;
  for (const int64_t id : ids) {
    if (id < 0 || uint64_t(id) >= p.points)
      conn.fail("point id " + std::to_string(id) + " is outside [0, " + std::to_string(p.points) + ")");
    lo = std::min(lo, id), hi = std::max(hi, id);
  }
  if (ids.empty()) lo = 0, hi = -1;
  const uint64_t slab = uint64_t(hi - lo + 1);
  if (first_point) *first_point = uint64_t(lo);
  UnstructuredMesh mesh;
  mesh.points.resize(size_t(slab));
  if (slab > 0) {
    XmlArrayReader r(file, d.encoding, *p.points_array);
    r.expect_count(p.points * 3, tuples_text(p.points, 3, "NumberOfPoints"));
    r.skip(uint64_t(lo) * 3);
    r.read(std::span<float>(&mesh.points[0].x, size_t(slab * 3)));
  }
  VtkCellImporter importer(base_name(path), slab);
  std::vector<int64_t> local;
  for (size_t i = 0; i < count; ++i) {
    local.assign(ids.begin() + (ends[i] - ends[0]), ids.begin() + (ends[i + 1] - ends[0]));
    for (int64_t& id : local) id -= lo;
    importer.add(clamp_cell_type(type_of[i]), std::span<const int64_t>(local), first + i);
  }
  const bool any_kept = std::any_of(type_of.begin(), type_of.end(), [](int64_t t) {
    return map_vtk_cell_type(clamp_cell_type(t)).kind == VtkCellMapping::Kind::Keep;
  });
  if (any_kept) importer.finish(mesh, ds.warnings);  // a range of lower-dimensional cells alone has no cells here
  Block block;
  for (const FieldSpec& spec : one.specs) {
    const bool vertex = spec.association == Association::Vertex;
    XmlArrayReader r(file, d.encoding, find_field(p.point_data, p.cell_data, spec));
    const uint64_t tuples = vertex ? p.points : p.cells;
    r.expect_count(tuples * uint64_t(spec.components),
                   tuples_text(tuples, spec.components, vertex ? "NumberOfPoints" : "NumberOfCells"));
    DataArray data = make_field_data(spec, vertex ? slab : count);
    r.skip((vertex ? uint64_t(lo) : first) * uint64_t(spec.components));
    read_field_slice(r, data, 0, vertex ? slab : count);
    if (!vertex) data = any_kept ? importer.filter_cell_data(std::move(data)) : make_field_data(spec, 0);
    block.fields.add(Field(spec.name, spec.association, std::move(data)));
  }
  mesh.validate(base_name(path));
  block.grid = std::move(mesh);
  block.validate_fields(base_name(path));
  ds.blocks.push_back(std::move(block));
  return ds;
}

Dataset read_vtk_xml(const std::string& path) {
  std::unique_ptr<XmlDoc> doc = load_doc(path);
  const std::string type = doc->type;
  if (type == "UnstructuredGrid") {
    std::vector<std::unique_ptr<XmlDoc>> docs;
    docs.push_back(std::move(doc));
    return read_unstructured(path, std::move(docs), "VTK XML UnstructuredGrid (.vtu)", {}, {}, nullptr);
  }
  if (type == "PUnstructuredGrid") return read_pvtu(std::move(doc));
  if (type == "StructuredGrid") return read_structured(std::move(doc), StructuredKind::Curvilinear);
  if (type == "ImageData") return read_structured(std::move(doc), StructuredKind::Image);
  if (type == "RectilinearGrid") return read_structured(std::move(doc), StructuredKind::Rectilinear);
  if (type == "PStructuredGrid") return read_pstructured(std::move(doc), StructuredKind::Curvilinear);
  if (type == "PImageData") return read_pstructured(std::move(doc), StructuredKind::Image);
  if (type == "PRectilinearGrid") return read_pstructured(std::move(doc), StructuredKind::Rectilinear);
  fail_in(path, "VTKFile type \"" + type.substr(0, 40) +
                    "\" is not supported: ugvr reads UnstructuredGrid (.vtu, .pvtu), StructuredGrid (.vts, .pvts), "
                    "ImageData (.vti, .pvti) and RectilinearGrid (.vtr, .pvtr)");
}

}  // namespace ugvr

namespace ugvr {
namespace {

Dataset read_pstructured(std::unique_ptr<XmlDoc> pdoc, StructuredKind kind) {
  const XmlDoc& d = *pdoc;
  const char* tag = kind == StructuredKind::Curvilinear ? "PStructuredGrid"
                    : kind == StructuredKind::Image     ? "PImageData"
                                                        : "PRectilinearGrid";
  const pugi::xml_node grid = single_child(d, d.root, tag);
  if (!grid) d.fail(d.root, std::string("no <") + tag + "> element");
  const Extent whole = parse_extent(d, grid, "WholeExtent");
  const uint64_t whole_points = checked_point_count(d, grid, whole);
  GridDims dims;
  for (int i = 0; i < 3; ++i) dims.points[size_t(i)] = uint32_t(whole.points(i));
  const bool volume = whole.points(0) > 1 && whole.points(1) > 1 && whole.points(2) > 1;
  const std::vector<std::string> paths = pvtu_piece_paths(d, grid);
  if (paths.empty()) d.fail(grid, std::string("<") + tag + "> lists no <Piece Source=...>");

  Dataset ds;
  ds.format = kind == StructuredKind::Curvilinear ? "VTK XML PStructuredGrid (.pvts)"
              : kind == StructuredKind::Image     ? "VTK XML PImageData (.pvti)"
                                                  : "VTK XML PRectilinearGrid (.pvtr)";
  ds.sources.push_back(d.path);
  StructuredGrid sgrid;
  RectilinearGrid rgrid;
  ImageGrid image;
  sgrid.dims = rgrid.dims = image.dims = dims;
  if (kind == StructuredKind::Curvilinear) sgrid.points.resize(size_t(whole_points));
  for (int i = 0; i < 3; ++i) {
    if (kind == StructuredKind::Rectilinear) rgrid.coords[size_t(i)].resize(dims.points[size_t(i)]);
  }
  std::vector<Field> fields;
  Coverage point_cover(whole_points, true), cell_cover(dims.cell_count(), volume);
  size_t k = 0;
  for (pugi::xml_node pn : grid.children("Piece")) {
    const std::string& path = paths[k];
    const std::string label = "piece " + std::to_string(k) + " (" + base_name(path) + ")";
    ++k;
    const Extent e = parse_extent(d, pn, "Extent");
    if (!inside(e, whole)) d.fail(pn, label + ": <Piece> Extent is outside the WholeExtent");
    std::unique_ptr<XmlDoc> piece_doc = load_doc(path);
    const char* serial = tag + 1;  // "StructuredGrid", "ImageData", "RectilinearGrid"
    if (piece_doc->type != serial) {
      d.fail(pn, label + " is a " + piece_doc->type.substr(0, 40) + " file, expected " + serial);
    }
    Dataset piece = read_structured(std::move(piece_doc), kind);
    for (auto& w : piece.warnings) ds.warnings.push_back(std::move(w));
    ds.sources.push_back(path);
    Block& b = piece.blocks.at(0);
    GridDims want;
    for (int i = 0; i < 3; ++i) want.points[size_t(i)] = uint32_t(e.points(i));
    const GridDims got = std::visit(
        [](const auto& g) {
          if constexpr (std::is_same_v<std::decay_t<decltype(g)>, UnstructuredMesh>) {
            return GridDims{};
          } else {
            return g.dims;
          }
        },
        b.grid);
    if (!(got == want)) d.fail(pn, label + " does not have the point dimensions of its <Piece> Extent");
    // Geometry.
    uint64_t src = 0;
    if (const auto* g = std::get_if<StructuredGrid>(&b.grid)) {
      for_each_run(e, whole, false, [&](uint64_t first, uint64_t n) {
        std::copy_n(g->points.begin() + ptrdiff_t(src), n, sgrid.points.begin() + ptrdiff_t(first));
        src += n;
      });
    } else if (const auto* r = std::get_if<RectilinearGrid>(&b.grid)) {
      for (int i = 0; i < 3; ++i) {
        std::copy(r->coords[size_t(i)].begin(), r->coords[size_t(i)].end(),
                  rgrid.coords[size_t(i)].begin() + ptrdiff_t(e.lo[i] - whole.lo[i]));
      }
    } else if (const auto* im = std::get_if<ImageGrid>(&b.grid)) {
      // The piece's origin is its first point; the whole grid's is that minus the offset of the piece.
      Vec3d origin = im->origin;
      for (int i = 0; i < 3; ++i) (&origin.x)[i] -= double(e.lo[i] - whole.lo[i]) * (&im->spacing.x)[i];
      if (k == 1) {
        image.origin = origin;
        image.spacing = im->spacing;
      } else if (!(im->spacing == image.spacing) ||
                 length(origin - image.origin) > 1e-9 * (1 + length(image.origin) + length(image.spacing))) {
        d.fail(pn, label + " has another origin or spacing than the first piece");
      }
    }
    // Fields, by name, placed run by run.
    if (k == 1) {
      for (const Field& f : b.fields) {
        const uint64_t n = f.association() == Association::Vertex ? whole_points : dims.cell_count();
        fields.emplace_back(f.name(), f.association(), DataArray(f.data().type(), f.components(), n));
      }
    }
    for (Field& w : fields) {
      const Field* f = b.fields.find(w.name(), w.association());
      if (!f || f->data().type() != w.data().type() || f->components() != w.components()) {
        d.fail(pn, label + " lacks the array '" + w.name() + "' of the first piece (or has it in another type)");
      }
      const size_t tuple_bytes = scalar_size(w.data().type()) * size_t(w.components());
      std::byte* dst = w.mutable_data().bytes();
      const std::byte* from = f->data().bytes();
      uint64_t at = 0;
      for_each_run(e, whole, w.association() == Association::Cell, [&](uint64_t first, uint64_t n) {
        std::memcpy(dst + first * tuple_bytes, from + at * tuple_bytes, size_t(n) * tuple_bytes);
        at += n;
      });
    }
    for_each_run(e, whole, false, [&](uint64_t first, uint64_t n) { point_cover.mark(first, n); });
    if (cell_cover.active()) {
      for_each_run(e, whole, true, [&](uint64_t first, uint64_t n) { cell_cover.mark(first, n); });
    }
  }
  if (!point_cover.complete() || !cell_cover.complete()) {
    d.fail(grid, "the pieces' Extents leave parts of the WholeExtent without data");
  }
  Block block;
  switch (kind) {
    case StructuredKind::Curvilinear: block.grid = std::move(sgrid); break;
    case StructuredKind::Rectilinear: block.grid = std::move(rgrid); break;
    case StructuredKind::Image: block.grid = image; break;
  }
  for (Field& f : fields) block.fields.add(std::move(f));
  block.validate_fields(base_name(d.path));
  ds.blocks.push_back(std::move(block));
  return ds;
}

}  // namespace
}  // namespace ugvr

// ---------------------------------------------------------------------------------------------------------------
// Fields-only reads of a .vtu time step (io/step_fields.h)

namespace ugvr {
namespace {

std::unique_ptr<XmlDoc> load_vtu_doc(const std::string& path) {
  std::unique_ptr<XmlDoc> doc = load_doc(path);
  if (doc->type != "UnstructuredGrid")
    fail_in(path, "VTKFile type \"" + doc->type.substr(0, 40) + "\", expected UnstructuredGrid");
  return doc;
}

// What decides how an array's stored bytes decode, beside the bytes themselves.
uint64_t hash_array_layout(uint64_t h, const XmlArray& a) {
  h = hash_mix(h, uint64_t(a.type));
  h = hash_mix(h, uint64_t(a.components));
  return hash_mix(h, uint64_t(a.format));
}

// The fields of UnstructuredGrid documents read as one mesh (a .vtu, or the pieces a .pvtu lists, in its order), as
// read_unstructured gives them: the same field specs agreed over every piece, each piece's values at its first point
// and cell, cell data restricted to the cells the mesh keeps; nothing of the points or connectivity read.
FieldSet read_ug_fields(const std::vector<std::unique_ptr<XmlDoc>>& docs, const std::vector<FieldSpec>& declared,
                        pugi::xml_node declared_at, const XmlDoc* pdoc, std::vector<std::string>& warnings) {
  const std::vector<UgPiece> pieces = describe_ug_pieces(docs, warnings);
  const std::vector<FieldSpec> specs = agreed_field_specs(docs, pieces);
  check_declared_fields(pieces, specs, declared, declared_at, pdoc);
  uint64_t total_points = 0, total_cells = 0;
  for (size_t di = 0; di < docs.size(); ++di) {
    const InputFile file(docs[di]->path);
    for (const UgPiece& p : pieces) {
      if (p.doc != di || p.empty()) continue;
      expect_field_counts(file, *docs[di], p);
      total_points += p.points;
      total_cells += p.cells;
    }
  }
  std::vector<DataArray> field_data;
  for (const FieldSpec& s : specs)
    field_data.push_back(make_field_data(s, s.association == Association::Vertex ? total_points : total_cells));
  uint64_t point_base = 0, cell_base = 0;
  for (size_t di = 0; di < docs.size(); ++di) {
    const InputFile file(docs[di]->path);
    for (const UgPiece& p : pieces) {
      if (p.doc != di || p.empty()) continue;
      read_piece_fields(file, *docs[di], p, specs, field_data, point_base, cell_base);
      point_base += p.points;
      cell_base += p.cells;
    }
  }
  const bool cell_fields =
      std::any_of(specs.begin(), specs.end(), [](const FieldSpec& s) { return s.association == Association::Cell; });
  const std::optional<std::vector<uint64_t>> kept =
      cell_fields ? kept_file_cells(docs, pieces) : std::optional<std::vector<uint64_t>>();
  FieldSet fields;
  for (size_t f = 0; f < specs.size(); ++f) {
    DataArray data = std::move(field_data[f]);
    if (specs[f].association == Association::Cell && kept) data = data.gather(*kept);
    fields.add(Field(specs[f].name, specs[f].association, std::move(data)));
  }
  return fields;
}

}  // namespace

std::optional<uint64_t> vtu_geometry_key(const std::string& path) {
  if (extension_lower(path) != ".vtu") return std::nullopt;
  std::vector<std::unique_ptr<XmlDoc>> docs;
  docs.push_back(load_doc(path));
  const XmlDoc& d = *docs[0];
  if (d.type != "UnstructuredGrid") return std::nullopt;
  std::vector<std::string> ignored;  // the field arrays' warnings: not geometry
  const std::vector<UgPiece> pieces = describe_ug_pieces(docs, ignored);
  const InputFile file(path);
  uint64_t h = hash_mix(kFnvOffset, pieces.size());
  h = hash_mix(h, uint64_t(d.encoding.big_endian) | uint64_t(d.encoding.header_uint64) << 1);
  h = hash_mix(h, uint64_t(d.encoding.codec));
  for (const UgPiece& p : pieces) {
    h = hash_mix(hash_mix(h, p.points), p.cells);
    for (const std::optional<XmlArray>* a : {&p.points_array, &p.connectivity, &p.offsets, &p.types}) {
      if (!*a) {
        h = hash_mix(h, 0);
        continue;
      }
      const XmlArrayReader reader(file, d.encoding, **a);  // reads and checks the header
      const std::optional<std::pair<uint64_t, uint64_t>> extent = reader.stored_extent();
      if (!extent) return std::nullopt;
      h = hash_array_layout(h, **a);
      h = hash_mix(h, hash_file_range(file, extent->first, extent->second));
    }
  }
  return h;
}

FieldSet read_vtu_fields(const std::string& path, std::vector<std::string>& warnings) {
  std::vector<std::unique_ptr<XmlDoc>> docs;
  docs.push_back(load_vtu_doc(path));
  return read_ug_fields(docs, {}, {}, nullptr, warnings);
}

FieldSet read_pvtu_fields(const std::string& path, std::vector<std::string>& sources,
                          std::vector<std::string>& warnings) {
  const std::unique_ptr<XmlDoc> pdoc = load_doc(path);
  if (pdoc->type != "PUnstructuredGrid")
    fail_in(path, "VTKFile type \"" + pdoc->type.substr(0, 40) + "\", expected PUnstructuredGrid");
  const pugi::xml_node grid = single_child(*pdoc, pdoc->root, "PUnstructuredGrid");
  if (!grid) pdoc->fail(pdoc->root, "no <PUnstructuredGrid> element");
  std::vector<std::unique_ptr<XmlDoc>> docs;
  for (const std::string& piece_path : pvtu_piece_paths(*pdoc, grid)) docs.push_back(load_doc(piece_path));
  if (docs.empty()) pdoc->fail(grid, "<PUnstructuredGrid> lists no <Piece Source=...>");
  FieldSet fields = read_ug_fields(docs, declared_fields(*pdoc, grid), grid, pdoc.get(), warnings);
  // As read_unstructured names them: the .pvtu, then its pieces.
  sources.push_back(path);
  for (const auto& d : docs)
    if (d->path != path) sources.push_back(d->path);
  return fields;
}

}  // namespace ugvr
