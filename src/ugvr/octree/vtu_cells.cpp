#include "ugvr/octree/vtu_cells.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <pugixml.hpp>
#include <tuple>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/vtk_xml_array.h"
#include "ugvr/io/vtk_xml_document.h"
#include "ugvr/octree/step_values.h"

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

// `count` tuples of a selected array, from tuple `first` on (for messages), as float scalars: the value, a component
// or the magnitude. Fails on values that are not finite.
void read_scalars(XmlArrayReader& reader, const Selected& s, uint64_t first, size_t count, float* out) {
  const size_t c = size_t(s.array.components);
  thread_local std::vector<double> buf;
  buf.resize(c * count);
  reader.read(std::span(buf.data(), buf.size()));
  for (size_t i = 0; i < count; ++i) {
    double v = 0;
    if (c == 1) {
      v = buf[i];
    } else if (s.component >= 0) {
      v = buf[i * c + size_t(s.component)];
    } else {
      for (size_t k = 0; k < c; ++k) v += buf[i * c + k] * buf[i * c + k];
      v = std::sqrt(v);
    }
    if (!std::isfinite(v)) reader.fail("value " + std::to_string(first + i) + " is not finite: bricks cannot store it");
    out[i] = float(v);
  }
}

// FNV-1a over 64-bit words, fed as the data streams by: the hash of a sequence whatever the chunks it came in.
class StreamHash {
 public:
  void add(const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) {
      word_ |= uint64_t(p[i]) << (8 * filled_);
      if (++filled_ == 8) mix_word();
    }
  }
  uint64_t value() {
    if (filled_ > 0) mix_word();
    return h_ ^ (h_ >> 31);
  }

 private:
  void mix_word() {
    h_ = (h_ ^ word_) * 0x100000001b3ull;
    word_ = 0;
    filled_ = 0;
  }
  uint64_t h_ = 0xcbf29ce484222325ull, word_ = 0;
  int filled_ = 0;
};

}  // namespace

struct VtuCellSource::Markup {
  InputFile file;
  std::unique_ptr<vtk_xml::XmlDoc> xml;
  pugi::xml_node piece;
  std::optional<XmlArray> points, connectivity, offsets, types;
  std::vector<Selected> selected;  // store order

  explicit Markup(const std::string& path) : file(path), xml(vtk_xml::load_doc(path)) {}

  const XmlEncoding& encoding() const { return xml->encoding; }
  [[noreturn]] void fail(pugi::xml_node n, const std::string& message) const { xml->fail(n, message); }
  uint64_t count(pugi::xml_node n, const char* name) const { return vtk_xml::count_attribute(*xml, n, name); }
  XmlArray required(pugi::xml_node parent, std::string_view name, const std::string& label) const {
    const pugi::xml_node n = vtk_xml::single_data_array(*xml, parent, name);
    if (!n) fail(piece, label + " is missing");
    return vtk_xml::required_array(*xml, n, label);
  }
};

VtuCellSource::~VtuCellSource() = default;

VtuCellSource::VtuCellSource(std::string path, std::span<const std::string> selectors)
    : path_(path), markup_(std::make_unique<Markup>(std::move(path))) {
  Markup& m = *markup_;
  const pugi::xml_node root = m.xml->root;
  if (m.xml->type != "UnstructuredGrid") {
    fail_in(path_, "not a VTK XML UnstructuredGrid (.vtu) file: the out-of-core build reads only those");
  }
  // Repeated elements are refused as the in-core reader refuses them (a second <Points> would otherwise be ignored).
  const pugi::xml_node grid = vtk_xml::single_child(*m.xml, root, "UnstructuredGrid");
  int pieces = 0;
  for (pugi::xml_node p : grid.children("Piece")) m.piece = p, ++pieces;
  if (pieces != 1) fail_in(path_, "has " + std::to_string(pieces) + " pieces; the out-of-core build reads one");
  const uint64_t points = m.count(m.piece, "NumberOfPoints");
  cells_ = m.count(m.piece, "NumberOfCells");
  if (points > UINT32_MAX) m.fail(m.piece, "more than 2^32-1 points");
  m.points = m.required(vtk_xml::single_child(*m.xml, m.piece, "Points"), {}, "<Points> DataArray");
  if (m.points->components != 3) m.fail(m.piece, "<Points> DataArray must have 3 components");
  const pugi::xml_node cells = vtk_xml::single_child(*m.xml, m.piece, "Cells");
  m.connectivity = m.required(cells, "connectivity", "<Cells> DataArray 'connectivity'");
  m.offsets = m.required(cells, "offsets", "<Cells> DataArray 'offsets'");
  m.types = m.required(cells, "types", "<Cells> DataArray 'types'");

  // The fields, as FieldSet::scalar resolves selectors: an exact name, else NAME:COMPONENT; vertex fields first.
  std::vector<std::pair<pugi::xml_node, Association>> arrays;
  for (pugi::xml_node n : vtk_xml::single_child(*m.xml, m.piece, "PointData").children("DataArray"))
    arrays.push_back({n, Association::Vertex});
  for (pugi::xml_node n : vtk_xml::single_child(*m.xml, m.piece, "CellData").children("DataArray"))
    arrays.push_back({n, Association::Cell});
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
    s.array = vtk_xml::required_array(*m.xml, a.first, kind + " DataArray '" + a.first.attribute("Name").value() + "'");
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

  // One streaming pass over the points and the vertex scalars: bounds, ranges, finiteness.
  {
    XmlArrayReader reader(m.file, m.encoding(), *m.points);
    reader.expect_count(3 * points, "NumberOfPoints=" + std::to_string(points) + " x 3 components");
    std::vector<float> buf(3 * kChunk);
    StreamHash hash;
    hash.add(&points, sizeof points);
    for (uint64_t p0 = 0; p0 < points; p0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, points - p0));
      reader.read(std::span(buf.data(), 3 * n));
      for (size_t i = 0; i < n; ++i) bounds_.add(Vec3d{buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]});
      hash.add(buf.data(), 3 * n * sizeof(float));
    }
    reader.finish();
    points_hash_ = hash.value();
  }
  points_ = points;
  auto name_of = [&](const Selected& s) {
    const std::string& n = s.array.name;
    if (s.array.components == 1) return n;
    if (s.component == kMagnitude) return n + ":magnitude";
    if (s.array.components <= 3) return n + ":" + "xyz"[s.component];
    return n + ":" + std::to_string(s.component);
  };
  auto range_of = [&](const Selected& s) {
    XmlArrayReader reader(m.file, m.encoding(), s.array);
    reader.expect_count(points * uint64_t(s.array.components), s.array.label);
    std::vector<float> v(kChunk);
    double lo = INFINITY, hi = -INFINITY;
    for (uint64_t t0 = 0; t0 < points; t0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, points - t0));
      read_scalars(reader, s, t0, n, v.data());
      for (size_t i = 0; i < n; ++i) lo = std::min(lo, double(v[i])), hi = std::max(hi, double(v[i]));
    }
    reader.finish();
    return std::pair(lo, hi);
  };
  if (m.selected.empty()) {  // the default: the first vertex field that is not constant, else the first field
    for (const auto& a : arrays) {
      if (a.second != Association::Vertex) continue;
      select(a, kMagnitude);
      const auto [lo, hi] = range_of(m.selected.back());
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
      std::tie(f.min, f.max) = range_of(s);
    } else {
      slot.index = layout_.cell_fields++;
      f.min = INFINITY, f.max = -INFINITY;  // known after write_soup
    }
    slots_.push_back(slot);
    fields_.push_back(std::move(f));
  }
  if (points == 0 || cells_ == 0) fail_in(path_, "the dataset has no cells to voxelize");
}

namespace {

// The points [first, first + count) and the vertex scalars there: positions, then values scalar-major.
void read_point_slice(const VtuCellSource::Markup& m, uint64_t first, uint64_t count, std::vector<Vec3f>& positions,
                      std::vector<float>& values) {
  positions.resize(count);
  {
    XmlArrayReader reader(m.file, m.encoding(), *m.points);
    reader.skip(3 * first);
    std::vector<float> buf(3 * kChunk);
    for (uint64_t p0 = 0; p0 < count; p0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, count - p0));
      reader.read(std::span(buf.data(), 3 * n));
      for (size_t i = 0; i < n; ++i) positions[p0 + i] = {buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]};
    }
  }
  values.clear();
  for (const Selected& s : m.selected) {
    if (s.association != Association::Vertex) continue;
    XmlArrayReader reader(m.file, m.encoding(), s.array);
    reader.skip(first * uint64_t(s.array.components));
    const size_t at = values.size();
    values.resize(at + count);
    for (uint64_t t0 = 0; t0 < count; t0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, count - t0));
      read_scalars(reader, s, first + t0, n, values.data() + at + t0);
    }
  }
}

// One pass over the cells: f(file cell index, type, corner count, corner point ids, cell scalar values or null).
// Cell scalars are decoded only when `cell_values` is set.
template <class F>
void stream_cells(const VtuCellSource::Markup& m, uint64_t cells, uint64_t points, bool cell_values, Progress* progress,
                  F&& f) {
  XmlArrayReader offsets(m.file, m.encoding(), *m.offsets);
  XmlArrayReader types(m.file, m.encoding(), *m.types);
  XmlArrayReader conn(m.file, m.encoding(), *m.connectivity);
  offsets.expect_count(cells, "NumberOfCells=" + std::to_string(cells));
  types.expect_count(cells, "NumberOfCells=" + std::to_string(cells));
  std::vector<const Selected*> cell_scalars;
  std::vector<std::unique_ptr<XmlArrayReader>> readers;
  for (const Selected& s : m.selected) {
    if (s.association != Association::Cell || !cell_values) continue;
    cell_scalars.push_back(&s);
    readers.push_back(std::make_unique<XmlArrayReader>(m.file, m.encoding(), s.array));
    readers.back()->expect_count(cells * uint64_t(s.array.components), s.array.label);
  }
  std::vector<int64_t> off(kChunk), type(kChunk), ids;
  std::vector<float> values(cell_scalars.size() * kChunk), cell(cell_scalars.size());
  uint32_t corners[kMaxCellVertices];
  uint64_t prev = 0;
  for (uint64_t c0 = 0; c0 < cells; c0 += kChunk) {
    const size_t n = size_t(std::min<uint64_t>(kChunk, cells - c0));
    offsets.read(std::span(off.data(), n));
    types.read(std::span(type.data(), n));
    if (off[n - 1] < 0 || uint64_t(off[n - 1]) < prev) offsets.fail("offsets decrease at cell " + std::to_string(c0));
    ids.resize(size_t(uint64_t(off[n - 1]) - prev));
    conn.read(std::span(ids.data(), ids.size()));
    for (size_t k = 0; k < cell_scalars.size(); ++k) {
      read_scalars(*readers[k], *cell_scalars[k], c0, n, values.data() + k * kChunk);
    }
    const uint64_t chunk_begin = prev;
    for (size_t i = 0; i < n; ++i) {
      const uint64_t end = uint64_t(off[i]);
      if (off[i] < 0 || end < prev || off[i] > off[n - 1]) {
        offsets.fail("offsets decrease at cell " + std::to_string(c0 + i));
      }
      const std::span<const int64_t> list(ids.data() + (prev - chunk_begin), size_t(end - prev));
      prev = end;
      const VtkCellMapping map = map_vtk_cell_type(int(std::clamp<int64_t>(type[i], INT32_MIN, INT32_MAX)));
      if (map.kind == VtkCellMapping::Kind::DropLowerDimension) continue;
      if (map.kind == VtkCellMapping::Kind::Unsupported) {
        types.fail("cell " + std::to_string(c0 + i) + " has VTK type " + std::to_string(type[i]) +
                   ", which the out-of-core build does not take");
      }
      const int n_corners = map.corner_count;
      if (int64_t(list.size()) < n_corners) {
        conn.fail("cell " + std::to_string(c0 + i) + " lists " + std::to_string(list.size()) + " point ids, " +
                  std::string(map.vtk_name) + " needs " + std::to_string(n_corners));
      }
      for (int k = 0; k < n_corners; ++k) {
        const int src = map.voxel_order && (k % 4 == 2 || k % 4 == 3) ? k ^ 1 : k;  // voxel: 2<->3, 6<->7
        const int64_t id = list[size_t(src)];
        if (id < 0 || uint64_t(id) >= points) {
          conn.fail("cell " + std::to_string(c0 + i) + ": point id " + std::to_string(id) + " is outside [0, " +
                    std::to_string(points) + ")");
        }
        corners[k] = uint32_t(id);
      }
      for (size_t k = 0; k < cell_scalars.size(); ++k) cell[k] = values[k * kChunk + i];
      f(c0 + i, map.type, n_corners, corners, cell_scalars.empty() ? nullptr : cell.data());
    }
    if (progress) progress->add(n);
  }
  offsets.finish();
  types.finish();
  conn.finish();
  for (auto& r : readers) r->finish();
}

// Corner files: per slice of the points, the position and vertex values of each corner in the slice, in cell order.
class CornerFile {
 public:
  CornerFile(std::string path, size_t entry_bytes, bool write)
      : path_(std::move(path)), entry_(entry_bytes), file_(std::fopen(path_.c_str(), write ? "wb" : "rb")) {
    if (!file_) fail_in(path_, "cannot open a temporary corner file");
    buffer_.resize(entry_ * 4096);  // tens of KiB: the last pass has every slice's file open
  }
  ~CornerFile() {
    if (file_) std::fclose(file_);
    std::error_code ec;
    if (!writing_) std::filesystem::remove(path_, ec);  // read once: no longer needed
  }
  void put(const void* entry) {
    writing_ = true;
    std::memcpy(buffer_.data() + used_, entry, entry_);
    if ((used_ += entry_) == buffer_.size()) flush();
  }
  void flush() {
    if (used_ && std::fwrite(buffer_.data(), 1, used_, file_) != used_) fail_in(path_, "cannot write a corner file");
    used_ = 0;
  }
  void close() {
    flush();
    if (std::fclose(file_) != 0) fail_in(path_, "cannot close a corner file");
    file_ = nullptr;
  }
  const std::byte* get() {
    if (pos_ == used_) {
      used_ = std::fread(buffer_.data(), 1, buffer_.size(), file_);
      pos_ = 0;
      if (used_ < entry_) fail_in(path_, "a temporary corner file ends early");
    }
    const std::byte* e = buffer_.data() + pos_;
    pos_ += entry_;
    return e;
  }

 private:
  std::string path_;
  size_t entry_;
  std::FILE* file_;
  std::vector<std::byte> buffer_;
  size_t used_ = 0, pos_ = 0;
  bool writing_ = false;
};

// What every pass that emits the volume cells checks and sums, the same whether it writes a soup or a step's values:
// the geometry's hash (each cell's index, type and corner ids in file order), the cell scalars' finiteness and ranges.
class EmittedCells {
 public:
  EmittedCells(const std::string& path, uint32_t cell_fields)
      : path_(path), lo_(cell_fields, INFINITY), hi_(cell_fields, -INFINITY) {}
  void add(uint64_t c, CellType t, int n, const uint32_t* corners, const float* cell) {
    const auto type = uint8_t(t);
    hash_.add(&c, sizeof c);
    hash_.add(&type, 1);
    hash_.add(corners, size_t(n) * sizeof(uint32_t));
    for (size_t k = 0; k < lo_.size(); ++k) {
      if (!std::isfinite(cell[k])) fail_in(path_, "cell " + std::to_string(c) + ": a value is not finite");
      lo_[k] = std::min(lo_[k], double(cell[k])), hi_[k] = std::max(hi_[k], double(cell[k]));
    }
    ++count_;
  }
  uint64_t count() const { return count_; }
  uint64_t hash() { return hash_.value(); }
  // The cell scalars' ranges into their fields.
  void set_ranges(std::span<const VtuCellSource::Slot> slots, std::vector<BrickStoreField>& fields) const {
    for (size_t f = 0; f < slots.size(); ++f) {
      if (slots[f].association != Association::Cell) continue;
      fields[f].min = lo_[slots[f].index], fields[f].max = hi_[slots[f].index];
    }
  }

 private:
  const std::string& path_;
  StreamHash hash_;
  std::vector<double> lo_, hi_;
  uint64_t count_ = 0;
};

}  // namespace

void VtuCellSource::for_each_point_slice(
    uint64_t slice_bytes,
    const std::function<void(uint64_t, std::span<const Vec3f>, std::span<const float>)>& f) const {
  const uint64_t per_point = 12 + 4 * uint64_t(layout_.vertex_fields);
  const uint64_t slice = std::max<uint64_t>(1, std::min<uint64_t>(points_, slice_bytes / per_point));
  std::vector<Vec3f> pos;
  std::vector<float> val;
  for (uint64_t first = 0; first < points_; first += slice) {
    read_point_slice(*markup_, first, std::min(slice, points_ - first), pos, val);
    f(first, pos, val);
  }
}

uint64_t VtuCellSource::write_soup(SoupWriter& soup, uint64_t point_budget, const std::string& temp_dir,
                                   Progress* progress, const CellFilter& keep) {
  const Markup& m = *markup_;
  const uint32_t Fv = layout_.vertex_fields, Fc = layout_.cell_fields;
  const uint64_t per_point = 12 + 4 * uint64_t(Fv);
  const uint64_t slice = std::max<uint64_t>(1, std::min<uint64_t>(points_, point_budget / per_point));
  passes_ = (points_ + slice - 1) / slice;
  Vec3f positions[kMaxCellVertices];
  std::vector<float> vvalues(size_t(Fv) * kMaxCellVertices);
  EmittedCells emitted(path_, Fc);
  uint64_t written = 0;
  auto emit = [&](uint64_t c, CellType t, int n, const uint32_t* corners, const float* cell) {
    emitted.add(c, t, n, corners, cell);
    if (keep && !keep(StreamedCell{c, t, n, corners, positions, vvalues.data(), cell})) return;
    soup.add(c, t, n, corners, positions, vvalues.data(), cell);
    ++written;
  };
  std::vector<Vec3f> pos;
  std::vector<float> val;
  if (passes_ == 1) {
    read_point_slice(m, 0, points_, pos, val);
    stream_cells(m, cells_, points_, true, progress,
                 [&](uint64_t c, CellType t, int n, const uint32_t* corners, const float* cell) {
                   for (int k = 0; k < n; ++k) {
                     positions[k] = pos[corners[k]];
                     for (uint32_t f = 0; f < Fv; ++f)
                       vvalues[f * size_t(n) + size_t(k)] = val[f * points_ + corners[k]];
                   }
                   emit(c, t, n, corners, cell);
                 });
  } else {
    // One pass per slice writes its corners; the last pass reads them back in step, a corner from its slice's file.
    const size_t entry = 12 + 4 * size_t(Fv);
    std::vector<std::unique_ptr<CornerFile>> files;
    std::vector<std::byte> e(entry);
    for (uint64_t p = 0; p < passes_; ++p) {
      const uint64_t first = p * slice, count = std::min(slice, points_ - first);
      read_point_slice(m, first, count, pos, val);
      CornerFile out(temp_dir + "/corners-" + std::to_string(p), entry, true);
      stream_cells(m, cells_, points_, false, nullptr,
                   [&](uint64_t, CellType, int n, const uint32_t* corners, const float*) {
                     for (int k = 0; k < n; ++k) {
                       if (corners[k] < first || corners[k] - first >= count) continue;
                       const uint64_t local = corners[k] - first;
                       std::memcpy(e.data(), &pos[local], 12);
                       for (uint32_t f = 0; f < Fv; ++f) std::memcpy(e.data() + 12 + 4 * f, &val[f * count + local], 4);
                       out.put(e.data());
                     }
                   });
      out.close();
      if (progress) progress->add(cells_ / (passes_ + 1));
    }
    std::vector<Vec3f>().swap(pos);
    std::vector<float>().swap(val);
    for (uint64_t p = 0; p < passes_; ++p) {
      files.push_back(std::make_unique<CornerFile>(temp_dir + "/corners-" + std::to_string(p), entry, false));
    }
    stream_cells(m, cells_, points_, true, nullptr,
                 [&](uint64_t c, CellType t, int n, const uint32_t* corners, const float* cell) {
                   for (int k = 0; k < n; ++k) {
                     const std::byte* got = files[corners[k] / slice]->get();
                     std::memcpy(&positions[k], got, 12);
                     for (uint32_t f = 0; f < Fv; ++f)
                       std::memcpy(&vvalues[f * size_t(n) + size_t(k)], got + 12 + 4 * f, 4);
                   }
                   emit(c, t, n, corners, cell);
                 });
  }
  emitted.set_ranges(slots_, fields_);
  if (emitted.count() == 0) fail_in(path_, "the file has no volume cells");
  cells_hash_ = emitted.hash();
  return written;
}

uint64_t VtuCellSource::for_each_sampled_cell(
    uint64_t stride, uint64_t point_budget, Progress* progress,
    const std::function<void(uint64_t, CellType, std::span<const Vec3f>)>& f) {
  stride = std::max<uint64_t>(stride, 1);
  EmittedCells emitted(path_, layout_.cell_fields);
  // The sampled cells, flat: their type, first corner and index; the corners' point ids, then their positions.
  struct Sampled {
    uint64_t index;
    CellType type;
    size_t first;
  };
  std::vector<Sampled> sampled;
  std::vector<uint32_t> ids;
  uint64_t volume = 0;
  stream_cells(*markup_, cells_, points_, true, progress,
               [&](uint64_t c, CellType t, int n, const uint32_t* corners, const float* cell) {
                 emitted.add(c, t, n, corners, cell);
                 if (volume++ % stride != 0) return;
                 sampled.push_back({volume - 1, t, ids.size()});
                 ids.insert(ids.end(), corners, corners + n);
               });
  emitted.set_ranges(slots_, fields_);
  if (emitted.count() == 0) fail_in(path_, "the file has no volume cells");
  cells_hash_ = emitted.hash();
  std::vector<Vec3f> positions(ids.size());
  for_each_point_slice(point_budget, [&](uint64_t first, std::span<const Vec3f> pos, std::span<const float>) {
    for (size_t i = 0; i < ids.size(); ++i)
      if (ids[i] >= first && ids[i] - first < pos.size()) positions[i] = pos[ids[i] - first];
  });
  for (size_t s = 0; s < sampled.size(); ++s) {
    const size_t end = s + 1 < sampled.size() ? sampled[s + 1].first : ids.size();
    f(sampled[s].index, sampled[s].type, std::span(positions.data() + sampled[s].first, end - sampled[s].first));
  }
  return emitted.count();
}

uint64_t VtuCellSource::write_values(const std::string& prefix, Progress* progress) {
  const Markup& m = *markup_;
  // The vertex scalars, each streamed on its own: nothing is held but a chunk.
  uint32_t vertex_field = 0;
  std::vector<float> chunk(kChunk);
  for (const Selected& s : m.selected) {
    if (s.association != Association::Vertex) continue;
    ValueFileWriter out(step_vertex_values_path(prefix, vertex_field++));
    XmlArrayReader reader(m.file, m.encoding(), s.array);
    reader.expect_count(points_ * uint64_t(s.array.components), s.array.label);
    for (uint64_t t0 = 0; t0 < points_; t0 += kChunk) {
      const size_t n = size_t(std::min<uint64_t>(kChunk, points_ - t0));
      read_scalars(reader, s, t0, n, chunk.data());
      out.append(chunk.data(), n);
    }
    reader.finish();
    out.close();
  }
  passes_ = 1;
  // The cells, for the geometry's hash and the cell scalars, each to its file at the cell's index.
  const uint32_t Fc = layout_.cell_fields;
  std::vector<std::unique_ptr<ValueFileWriter>> cell_out;
  for (uint32_t k = 0; k < Fc; ++k)
    cell_out.push_back(std::make_unique<ValueFileWriter>(step_cell_values_path(prefix, k)));
  EmittedCells emitted(path_, Fc);
  uint64_t next = 0;  // the next cell index each file is at
  stream_cells(m, cells_, points_, Fc > 0, progress,
               [&](uint64_t c, CellType t, int n, const uint32_t* corners, const float* cell) {
                 emitted.add(c, t, n, corners, cell);
                 for (uint32_t k = 0; k < Fc; ++k) {
                   cell_out[k]->append_zeros(c - next);
                   cell_out[k]->append(cell + k, 1);
                 }
                 next = c + 1;
               });
  for (uint32_t k = 0; k < Fc; ++k) {
    cell_out[k]->append_zeros(cells_ - next);
    cell_out[k]->close();
  }
  emitted.set_ranges(slots_, fields_);
  if (emitted.count() == 0) fail_in(path_, "the file has no volume cells");
  cells_hash_ = emitted.hash();
  return emitted.count();
}

}  // namespace ugvr
