#include "ugvr/lod/octree_vtu_cells.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <pugixml.hpp>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/vtk_xml_array.h"
#include "ugvr/io/vtk_xml_skeleton.h"

namespace ugvr {

namespace {

constexpr size_t kChunk = size_t(1) << 16;  // cells (or tuples) decoded per step

template <class T>
std::optional<T> parse_number(std::string_view s) {
  T v{};
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  return v;
}

// One selected array of <PointData> or <CellData>.
struct Selected {
  XmlArray array;
  Association association = Association::Vertex;
  int component = kMagnitude;
};

}  // namespace

struct VtuCellSource::Markup {
  std::string path;
  InputFile file;
  XmlSkeleton skeleton;
  pugi::xml_document doc;
  XmlEncoding encoding;
  pugi::xml_node piece;
  std::optional<XmlArray> points, connectivity, offsets, types;
  std::vector<Selected> selected;  // store order

  explicit Markup(std::string p) : path(p), file(std::move(p)) {}

  uint64_t offset(pugi::xml_node n) const {
    const ptrdiff_t o = n.offset_debug();
    return o < 0 ? 0 : skeleton.file_offset(uint64_t(o));
  }
  [[noreturn]] void fail(pugi::xml_node n, const std::string& message) const {
    fail_at_offset(path, offset(n), message);
  }

  uint64_t count(pugi::xml_node n, const char* name) const {
    const auto v = parse_number<uint64_t>(n.attribute(name).value());
    if (!v) fail(n, std::string("<") + n.name() + "> has no valid " + name + " attribute");
    return *v;
  }

  // The layout of one <DataArray> (vtk_xml_array.h describes the formats).
  XmlArray describe(pugi::xml_node n, const std::string& label) const {
    XmlArray a;
    a.element_offset = offset(n);
    a.name = n.attribute("Name").value();
    a.label = label;
    const std::string type = n.attribute("type").value();
    const auto st = parse_scalar_type(type);
    if (!st) fail(n, label + ": unsupported type \"" + type.substr(0, 40) + "\"");
    a.type = *st;
    if (const pugi::xml_attribute c = n.attribute("NumberOfComponents")) {
      const auto v = parse_number<int>(c.value());
      if (!v || *v < 1 || *v > (1 << 20)) fail(n, label + ": bad NumberOfComponents");
      a.components = *v;
    }
    const std::string format = n.attribute("format").value();
    if (format == "appended") {
      if (!encoding.appended_data) fail(n, label + ": format=\"appended\" but the file has no <AppendedData>");
      a.format = XmlArrayFormat::Appended;
      const uint64_t off = count(n, "offset");
      if (off > file.size() - std::min(*encoding.appended_data, file.size())) {
        fail(n, label + ": offset points past the end of the file");
      }
      a.begin = *encoding.appended_data + off;
      a.end = file.size();
      return a;
    }
    if (format == "ascii")
      a.format = XmlArrayFormat::Ascii;
    else if (format == "binary")
      a.format = XmlArrayFormat::Binary;
    else
      fail(n, label + ": format=\"" + format.substr(0, 40) + "\" is not ascii, binary or appended");
    a.begin = a.end = a.element_offset;
    for (pugi::xml_node c : n.children()) {
      if (c.type() != pugi::node_pi || std::string_view(c.name()) != kXmlTextMarker) continue;
      uint64_t begin = 0, length = 0;
      if (std::sscanf(c.value(), "%lu %lu", &begin, &length) != 2) fail(n, label + ": malformed text marker");
      a.begin = begin, a.end = begin + length;
    }
    return a;
  }

  XmlArray required(pugi::xml_node parent, const char* name, const std::string& label) const {
    for (pugi::xml_node c : parent.children("DataArray")) {
      if (!name || std::string_view(name) == c.attribute("Name").value()) return describe(c, label);
    }
    fail(piece, label + " is missing");
  }
};

VtuCellSource::~VtuCellSource() = default;

VtuCellSource::VtuCellSource(std::string path, std::span<const std::string> selectors)
    : path_(path), markup_(std::make_unique<Markup>(std::move(path))) {
  Markup& m = *markup_;
  m.skeleton = scan_xml_skeleton(m.file);
  const pugi::xml_parse_result r = m.doc.load_buffer(m.skeleton.markup.data(), m.skeleton.markup.size(),
                                                     pugi::parse_default | pugi::parse_pi, pugi::encoding_utf8);
  if (!r) fail_in(path_, std::string("malformed XML: ") + r.description());
  const pugi::xml_node root = m.doc.child("VTKFile");
  if (!root || std::string_view(root.attribute("type").value()) != "UnstructuredGrid") {
    fail_in(path_, "not a VTK XML UnstructuredGrid (.vtu) file: the out-of-core build reads only those");
  }
  const std::string order = root.attribute("byte_order").value();
  m.encoding.big_endian = order == "BigEndian";
  m.encoding.header_uint64 = std::string_view(root.attribute("header_type").value()) == "UInt64";
  const std::string compressor = root.attribute("compressor").value();
  if (compressor == "vtkZLibDataCompressor")
    m.encoding.codec = Codec::Zlib;
  else if (compressor == "vtkLZ4DataCompressor")
    m.encoding.codec = Codec::Lz4;
  else if (!compressor.empty())
    m.fail(root, "compressor \"" + compressor.substr(0, 60) + "\" is not supported");
  if (const pugi::xml_node app = root.child("AppendedData")) {
    m.encoding.appended_base64 = std::string_view(app.attribute("encoding").value()) == "base64";
    m.encoding.appended_data = m.skeleton.appended_data;
  }
  const pugi::xml_node grid = root.child("UnstructuredGrid");
  int pieces = 0;
  for (pugi::xml_node p : grid.children("Piece")) m.piece = p, ++pieces;
  if (pieces != 1) fail_in(path_, "has " + std::to_string(pieces) + " pieces; the out-of-core build reads one");
  const uint64_t points = m.count(m.piece, "NumberOfPoints");
  cells_ = m.count(m.piece, "NumberOfCells");
  if (points > UINT32_MAX) m.fail(m.piece, "more than 2^32-1 points");
  m.points = m.required(m.piece.child("Points"), nullptr, "<Points> DataArray");
  if (m.points->components != 3) m.fail(m.piece, "<Points> DataArray must have 3 components");
  const pugi::xml_node cells = m.piece.child("Cells");
  m.connectivity = m.required(cells, "connectivity", "<Cells> DataArray 'connectivity'");
  m.offsets = m.required(cells, "offsets", "<Cells> DataArray 'offsets'");
  m.types = m.required(cells, "types", "<Cells> DataArray 'types'");

  // The fields, as FieldSet::scalar resolves selectors: an exact name, else NAME:COMPONENT; vertex fields first.
  std::vector<std::pair<pugi::xml_node, Association>> arrays;
  for (pugi::xml_node n : m.piece.child("PointData").children("DataArray")) arrays.push_back({n, Association::Vertex});
  for (pugi::xml_node n : m.piece.child("CellData").children("DataArray")) arrays.push_back({n, Association::Cell});
  auto find = [&](std::string_view name) -> const std::pair<pugi::xml_node, Association>* {
    for (const auto& a : arrays)
      if (name == a.first.attribute("Name").value()) return &a;
    return nullptr;
  };
  auto select = [&](const std::pair<pugi::xml_node, Association>& a, int component) {
    Selected s;
    s.association = a.second;
    s.component = component;
    const std::string kind = a.second == Association::Vertex ? "<PointData>" : "<CellData>";
    s.array = m.describe(a.first, kind + " DataArray '" + a.first.attribute("Name").value() + "'");
    if (s.array.components == 1) s.component = kMagnitude;
    if (s.component >= s.array.components)
      m.fail(a.first, s.array.label + " has no component " + std::to_string(s.component));
    m.selected.push_back(std::move(s));
  };
  for (const std::string& selector : selectors) {
    if (const auto* a = find(selector)) {
      select(*a, kMagnitude);
      continue;
    }
    const auto colon = selector.rfind(':');
    const auto* a = colon == std::string::npos ? nullptr : find(std::string_view(selector).substr(0, colon));
    if (!a) fail_in(path_, "no field named '" + selector + "'");
    const std::string comp = selector.substr(colon + 1);
    int k = kMagnitude;
    if (comp == "x" || comp == "X")
      k = 0;
    else if (comp == "y" || comp == "Y")
      k = 1;
    else if (comp == "z" || comp == "Z")
      k = 2;
    else if (comp != "magnitude" && comp != "mag")
      k = parse_number<int>(comp).value_or(-2);
    if (k < kMagnitude) fail_in(path_, "field selector '" + selector + "': unknown component '" + comp + "'");
    select(*a, k);
  }

  // Points and vertex scalars, whole.
  {
    XmlArrayReader reader(m.file, m.encoding, *m.points);
    reader.expect_count(3 * points, "NumberOfPoints=" + std::to_string(points) + " x 3 components");
    points_.resize(points);
    std::vector<float> buf(3 * kChunk);
    for (uint64_t p0 = 0; p0 < points; p0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, points - p0));
      reader.read(std::span(buf.data(), 3 * n));
      for (size_t i = 0; i < n; ++i) {
        points_[p0 + i] = {buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]};
        bounds_.add(to_double(points_[p0 + i]));
      }
    }
    reader.finish();
  }
  auto name_of = [&](const Selected& s) {
    const std::string& n = s.array.name;
    if (s.array.components == 1) return n;
    if (s.component == kMagnitude) return n + ":magnitude";
    if (s.array.components <= 3) return n + ":" + "xyz"[s.component];
    return n + ":" + std::to_string(s.component);
  };
  auto read_scalars = [&](XmlArrayReader& reader, const Selected& s, uint64_t tuples, float* out, double& lo,
                          double& hi) {
    const size_t c = size_t(s.array.components);
    std::vector<double> buf(c * kChunk);
    for (uint64_t t0 = 0; t0 < tuples; t0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, tuples - t0));
      reader.read(std::span(buf.data(), c * n));
      for (size_t i = 0; i < n; ++i) {
        double v = 0;
        if (c == 1) {
          v = buf[i];
        } else if (s.component >= 0) {
          v = buf[i * c + size_t(s.component)];
        } else {
          for (size_t k = 0; k < c; ++k) v += buf[i * c + k] * buf[i * c + k];
          v = std::sqrt(v);
        }
        if (!std::isfinite(v))
          reader.fail("value " + std::to_string(t0 + i) + " is not finite: bricks cannot store it");
        out[t0 + i] = float(v);
        lo = std::min(lo, double(out[t0 + i])), hi = std::max(hi, double(out[t0 + i]));
      }
    }
  };
  if (m.selected.empty()) {  // the default: the first vertex field that is not constant, else the first field
    for (const auto& a : arrays) {
      if (a.second != Association::Vertex) continue;
      select(a, kMagnitude);
      XmlArrayReader reader(m.file, m.encoding, m.selected.back().array);
      std::vector<float> v(points);
      double lo = INFINITY, hi = -INFINITY;
      read_scalars(reader, m.selected.back(), points, v.data(), lo, hi);
      if (hi > lo) break;
      m.selected.pop_back();
    }
    if (m.selected.empty() && !arrays.empty()) select(arrays.front(), kMagnitude);
    if (m.selected.empty()) fail_in(path_, "the dataset has no fields to voxelize");
  }
  for (const Selected& s : m.selected) {
    BrickStoreField f;
    f.name = name_of(s);
    f.association = s.association;
    for (const BrickStoreField& other : fields_) {
      if (other.name == f.name) fail_in(path_, "field '" + f.name + "' is selected twice");
    }
    Slot slot;
    slot.association = s.association;
    if (s.association == Association::Vertex) {
      slot.index = layout_.vertex_fields++;
      XmlArrayReader reader(m.file, m.encoding, s.array);
      reader.expect_count(points * uint64_t(s.array.components), s.array.label);
      std::vector<float>& v = vertex_values_.emplace_back(points);
      double lo = INFINITY, hi = -INFINITY;
      read_scalars(reader, s, points, v.data(), lo, hi);
      reader.finish();
      f.min = lo, f.max = hi;
    } else {
      slot.index = layout_.cell_fields++;
      f.min = INFINITY, f.max = -INFINITY;  // known after write_soup
    }
    slots_.push_back(slot);
    fields_.push_back(std::move(f));
  }
  if (points == 0 || cells_ == 0) fail_in(path_, "the dataset has no cells to voxelize");
}

void VtuCellSource::release() {
  std::vector<Vec3f>().swap(points_);
  std::vector<std::vector<float>>().swap(vertex_values_);
}

uint64_t VtuCellSource::write_soup(SoupWriter& soup, Progress* progress) {
  Markup& m = *markup_;
  XmlArrayReader offsets(m.file, m.encoding, *m.offsets);
  XmlArrayReader types(m.file, m.encoding, *m.types);
  XmlArrayReader conn(m.file, m.encoding, *m.connectivity);
  offsets.expect_count(cells_, "NumberOfCells=" + std::to_string(cells_));
  types.expect_count(cells_, "NumberOfCells=" + std::to_string(cells_));
  std::vector<std::unique_ptr<XmlArrayReader>> cell_readers;
  std::vector<size_t> cell_selected;  // index into m.selected of each cell scalar, in soup order
  for (size_t s = 0; s < m.selected.size(); ++s) {
    if (m.selected[s].association != Association::Cell) continue;
    cell_readers.push_back(std::make_unique<XmlArrayReader>(m.file, m.encoding, m.selected[s].array));
    cell_readers.back()->expect_count(cells_ * uint64_t(m.selected[s].array.components), m.selected[s].array.label);
    cell_selected.push_back(s);
  }
  const uint32_t Fv = layout_.vertex_fields, Fc = layout_.cell_fields;
  std::vector<int64_t> off(kChunk), type(kChunk);
  std::vector<std::vector<double>> cell_buf(Fc);
  std::vector<int64_t> ids;  // connectivity of the chunk
  uint64_t prev = 0, written = 0;
  uint32_t vertices[kMaxCellVertices];
  Vec3f positions[kMaxCellVertices];
  std::vector<float> vvalues(size_t(Fv) * kMaxCellVertices), cvalues(Fc);
  std::vector<double> cell_lo(Fc, INFINITY), cell_hi(Fc, -INFINITY);
  for (uint64_t c0 = 0; c0 < cells_; c0 += kChunk) {
    const size_t n = size_t(std::min<uint64_t>(kChunk, cells_ - c0));
    offsets.read(std::span(off.data(), n));
    types.read(std::span(type.data(), n));
    if (off[n - 1] < 0 || uint64_t(off[n - 1]) < prev) offsets.fail("offsets decrease at cell " + std::to_string(c0));
    ids.resize(size_t(uint64_t(off[n - 1]) - prev));
    conn.read(std::span(ids.data(), ids.size()));
    for (uint32_t k = 0; k < Fc; ++k) {
      const Selected& s = m.selected[cell_selected[k]];
      cell_buf[k].resize(n * size_t(s.array.components));
      cell_readers[k]->read(std::span(cell_buf[k].data(), cell_buf[k].size()));
    }
    uint64_t chunk_begin = prev;
    for (size_t i = 0; i < n; ++i) {
      const uint64_t end = uint64_t(off[i]);
      if (off[i] < 0 || end < prev || off[i] > off[n - 1]) {
        offsets.fail("offsets decrease at cell " + std::to_string(c0 + i));
      }
      const std::span<const int64_t> cell(ids.data() + (prev - chunk_begin), size_t(end - prev));
      prev = end;
      const VtkCellMapping map = map_vtk_cell_type(int(std::clamp<int64_t>(type[i], INT32_MIN, INT32_MAX)));
      if (map.kind == VtkCellMapping::Kind::DropLowerDimension) continue;
      if (map.kind == VtkCellMapping::Kind::Unsupported) {
        types.fail("cell " + std::to_string(c0 + i) + " has VTK type " + std::to_string(type[i]) +
                   ", which the out-of-core build does not take");
      }
      const int corners = map.corner_count;
      if (int64_t(cell.size()) < corners) {
        conn.fail("cell " + std::to_string(c0 + i) + " lists " + std::to_string(cell.size()) + " point ids, " +
                  std::string(map.vtk_name) + " needs " + std::to_string(corners));
      }
      for (int k = 0; k < corners; ++k) {
        int src = k;
        if (map.voxel_order && (k % 4 == 2 || k % 4 == 3)) src = k ^ 1;  // voxel: corners 2<->3, 6<->7
        const int64_t id = cell[size_t(src)];
        if (id < 0 || uint64_t(id) >= points_.size()) {
          conn.fail("cell " + std::to_string(c0 + i) + ": point id " + std::to_string(id) + " is outside [0, " +
                    std::to_string(points_.size()) + ")");
        }
        vertices[k] = uint32_t(id);
        positions[k] = points_[size_t(id)];
        for (uint32_t f = 0; f < Fv; ++f) vvalues[f * size_t(corners) + size_t(k)] = vertex_values_[f][size_t(id)];
      }
      for (uint32_t k = 0; k < Fc; ++k) {
        const Selected& s = m.selected[cell_selected[k]];
        const size_t nc = size_t(s.array.components);
        double v = 0;
        if (nc == 1) {
          v = cell_buf[k][i];
        } else if (s.component >= 0) {
          v = cell_buf[k][i * nc + size_t(s.component)];
        } else {
          for (size_t q = 0; q < nc; ++q) v += cell_buf[k][i * nc + q] * cell_buf[k][i * nc + q];
          v = std::sqrt(v);
        }
        if (!std::isfinite(v)) {
          cell_readers[k]->fail("value " + std::to_string(c0 + i) + " is not finite: bricks cannot store it");
        }
        cvalues[k] = float(v);
        cell_lo[k] = std::min(cell_lo[k], double(cvalues[k]));
        cell_hi[k] = std::max(cell_hi[k], double(cvalues[k]));
      }
      soup.add(c0 + i, map.type, corners, vertices, positions, vvalues.data(), cvalues.data());
      ++written;
    }
    if (progress) progress->add(n);
  }
  offsets.finish();
  types.finish();
  conn.finish();
  for (auto& r : cell_readers) r->finish();
  for (uint32_t k = 0; k < Fc; ++k) {
    BrickStoreField& f = fields_[cell_selected[k]];
    f.min = cell_lo[k], f.max = cell_hi[k];
  }
  if (written == 0) fail_in(path_, "the file has no volume cells");
  return written;
}

}  // namespace ugvr
