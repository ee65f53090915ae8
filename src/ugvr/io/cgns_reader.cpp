// CGNS (.cgns, ADF or HDF5 files) through libcgns's mid-level library.
//
// What is read: every base of cell dimension 3 and every zone in it, one Block per zone named "BASE/ZONE".
//  - Structured zones become curvilinear grids (StructuredGrid); unstructured zones meshes.
//  - Unstructured sections: TETRA_4, PYRA_5, PENTA_6, HEXA_8 and their quadratic forms (corner nodes kept, as the
//    other readers do), MIXED, and NGON_n + NFACE_n polyhedra (through grid/polyhedra.h: native shapes recognised,
//    the rest split around cell and face centres). Sections of lower dimension (boundary faces, edges, nodes) are
//    skipped with a note. Volume cells are kept in element-number order, which is the order a CellCenter solution
//    lists them in.
//  - Orientation: CGNS's PENTA_6 lists its first triangle with the opposite orientation to VTK's wedge, so every cell
//    type whose cells are mostly inverted in the file is flipped as a whole (the other types agree with VTK and are
//    left as they are; one flip rule covers writers that disagree with the standard too).
//  - FlowSolution_t at Vertex and CellCenter; other locations skipped with a note. Rind layers are read with the
//    array and cut away. Fields named BASE + X/Y/Z (MomentumX, MomentumY, MomentumZ) become one 3-component field
//    BASE, as VTK's CGNS reader makes them.
//  - Iterative data: with a ZoneIterativeData's FlowSolutionPointers, `time_step` picks the solution of that step
//    (default the last); otherwise every FlowSolution_t is read (a name found in two of them gets the solution's name
//    as prefix).
// Reading goes through the library's "array" calls (cg_goto + cg_array_read_as), which return a node's data as
// stored, rind included: their index ranges need no interpretation.
#include <cgnslib.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/grid/polyhedra.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/cgns_fields.h"
#include "ugvr/io/header_counts.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/saturating_size.h"
#include "ugvr/io/step_lists.h"

namespace ugvr {

namespace {

// libcgns asserts (aborting the process) on some files that are neither of its formats: a 2-byte file made its ADF
// layer fail `ADF_file[file_index].format != UNDEFINED_FORMAT` (fuzz_cgns, fuzz/regression/fuzz_cgns). So the file
// must carry one of the two headers before cg_open sees it: ADF's "@(#)ADF Database Version" (the first four bytes
// with their high bit set) within its 186-byte file header, or HDF5's signature at offset 0, 512, 1024, 2048, ...
// (the HDF5 user block sizes).
void check_cgns_header(const std::string& path, uint64_t size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail_in(path, "cannot open");
  constexpr char kAdf[] =
      "\xc0\xa8\xa3\xa9"
      "ADF Database Version";
  constexpr size_t kAdfMagic = sizeof kAdf - 1, kAdfHeader = 186;
  constexpr char kHdf5[] = "\x89HDF\r\n\x1a\n";
  constexpr size_t kHdf5Magic = sizeof kHdf5 - 1;
  char head[kAdfMagic] = {};
  in.read(head, kAdfMagic);
  if (size >= kAdfHeader && std::string_view(head, kAdfMagic) == std::string_view(kAdf, kAdfMagic)) return;
  for (uint64_t at = 0; at + kHdf5Magic <= size; at = at ? at * 2 : 512) {
    char sig[kHdf5Magic] = {};
    in.clear();
    in.seekg(std::streamoff(at));
    if (!in.read(sig, kHdf5Magic)) break;
    if (std::string_view(sig, kHdf5Magic) == std::string_view(kHdf5, kHdf5Magic)) return;
  }
  fail_in(path, "not a CGNS file: neither an ADF header (\"ADF Database Version\" in the first " +
                    std::to_string(kAdfHeader) + " bytes) nor an HDF5 signature, in " + std::to_string(size) +
                    " bytes");
}

// libcgns keeps global state (its open files, the cg_goto position): one file in use at a time in the process. A
// series' step read ahead on another thread (ExactScene::prefetch) and a key taken meanwhile would otherwise
// interleave.
std::mutex& cgns_library_mutex() {
  static std::mutex m;
  return m;
}

class CgnsFile {
 public:
  explicit CgnsFile(std::string path) : lock_(cgns_library_mutex()), path_(std::move(path)) {
    std::error_code ec;
    file_size_ = std::filesystem::file_size(path_, ec);
    if (ec) fail_in(path_, "cannot open: " + ec.message());
    check_cgns_header(path_, file_size_);
    if (cg_open(path_.c_str(), CG_MODE_READ, &fn_) != CG_OK) {
      fn_ = -1;
      fail_in(path_, std::string("cannot open as CGNS: ") + cg_get_error());
    }
  }
  ~CgnsFile() {
    if (fn_ >= 0) cg_close(fn_);
  }
  CgnsFile(const CgnsFile&) = delete;
  CgnsFile& operator=(const CgnsFile&) = delete;

  int fn() const { return fn_; }
  const std::string& path() const { return path_; }
  // Throws with the library's message and `where` (the node being read) when a call failed.
  void check(int status, const std::string& where) const {
    if (status != CG_OK) fail_in(path_, where + ": " + cg_get_error());
  }
  // The file's bases in order: index (1-based), name, cell dimension, and for a base of volume cells (dimension 3,
  // the only ones read) its zone count.
  struct Base {
    int index = 0;
    std::string name;
    int cell_dim = 0, zones = 0;
  };
  std::vector<Base> bases() const {
    int n = 0;
    check(cg_nbases(fn_, &n), "bases");
    std::vector<Base> out;
    for (int B = 1; B <= n; ++B) {
      char name[33] = {};
      int cell_dim = 0, phys_dim = 0, zones = 0;
      check(cg_base_read(fn_, B, name, &cell_dim, &phys_dim), "base " + std::to_string(B));
      if (cell_dim == 3) check(cg_nzones(fn_, B, &zones), name);
      out.push_back({B, name, cell_dim, zones});
    }
    return out;
  }
  // Zone Z of a base: its name, sizes (vertices, cells, boundary vertices per index direction: one direction for an
  // unstructured zone, three for a structured one) and type.
  struct Zone {
    std::string name;
    std::array<cgsize_t, 9> size{};
    ZoneType_t type = ZoneTypeNull;
  };
  Zone zone(const Base& base, int Z) const {
    Zone z;
    char name[33] = {};
    check(cg_zone_read(fn_, base.index, Z, name, z.size.data()), base.name + ": zone " + std::to_string(Z));
    z.name = name;
    check(cg_zone_type(fn_, base.index, Z, &z.type), z.name);
    return z;
  }
  // A count of stored values the file cannot hold (even compressed 16 to 1) is refused before anything is allocated.
  void check_plausible(uint64_t values, const std::string& what) const {
    if (values / 16 > file_size_)
      fail_in(path_,
              what + ": " + std::to_string(values) + " values in a file of " + std::to_string(file_size_) + " bytes");
  }

 private:
  std::lock_guard<std::mutex> lock_;
  std::string path_;
  uint64_t file_size_ = 0;
  int fn_ = -1;
};

struct ArrayNode {
  std::string name;
  DataType_t type;
  int dim = 0;
  std::array<cgsize_t, 12> extent{};
  uint64_t count() const {
    uint64_t n = 1;
    for (int d = 0; d < dim; ++d) n *= uint64_t(extent[size_t(d)]);
    return n;
  }
};

// The DataArray_t children of the node cg_goto went to last.
std::vector<ArrayNode> list_arrays(const CgnsFile& f, const std::string& where) {
  int n = 0;
  f.check(cg_narrays(&n), where);
  std::vector<ArrayNode> out;
  for (int a = 1; a <= n; ++a) {
    ArrayNode node;
    char name[33] = {};
    f.check(cg_array_info(a, name, &node.type, &node.dim, node.extent.data()), where);
    if (node.dim < 1 || node.dim > 12)
      fail_in(f.path(), where + ": array " + name + " has dimension " + std::to_string(node.dim));
    for (int d = 0; d < node.dim; ++d)
      if (node.extent[size_t(d)] < 0) fail_in(f.path(), where + ": array " + name + " has a negative extent");
    node.name = name;
    out.push_back(node);
  }
  return out;
}

// Rind planes of the current node (zeros when it has none): low and high per index direction.
std::array<int, 6> read_rind(int index_dim) {
  std::array<int, 6> rind{};
  if (cg_rind_read(rind.data()) != CG_OK) rind.fill(0);  // CG_NODE_NOT_FOUND: no rind
  for (int d = index_dim; d < 3; ++d) rind[size_t(2 * d)] = rind[size_t(2 * d + 1)] = 0;
  return rind;
}

// Reads array `a` (1-based, of the current node) as doubles and keeps the core (rind cut away) of a grid whose core
// has `core` points/cells per index direction (unstructured: one direction).
std::vector<double> read_core(const CgnsFile& f, int a, const ArrayNode& node, const std::array<uint64_t, 3>& core,
                              int index_dim, const std::array<int, 6>& rind, const std::string& where) {
  std::array<uint64_t, 3> full{1, 1, 1};
  uint64_t want = 1;
  for (int d = 0; d < index_dim; ++d) {
    full[size_t(d)] = core[size_t(d)] + uint64_t(rind[size_t(2 * d)]) + uint64_t(rind[size_t(2 * d + 1)]);
    want *= full[size_t(d)];
  }
  if (node.count() != want)
    fail_in(f.path(), where + ": array " + node.name + " has " + std::to_string(node.count()) + " values, " +
                          std::to_string(want) + " expected (grid size with rind)");
  f.check_plausible(node.count(), where + ": array " + node.name);
  std::vector<double> all(node.count());
  f.check(cg_array_read_as(a, RealDouble, all.data()), where + ": array " + node.name);
  if (rind == std::array<int, 6>{}) return all;
  std::vector<double> out;
  out.reserve(core[0] * core[1] * core[2]);
  for (uint64_t k = 0; k < core[2]; ++k)
    for (uint64_t j = 0; j < core[1]; ++j)
      for (uint64_t i = 0; i < core[0]; ++i)
        out.push_back(
            all[(i + uint64_t(rind[0])) + full[0] * ((j + uint64_t(rind[2])) + full[1] * (k + uint64_t(rind[4])))]);
  return out;
}

// "MomentumX" -> "Momentum" for axis 'X'.
std::optional<std::string> vector_base(const std::string& name, char axis) {
  if (name.size() < 2 || std::toupper(static_cast<unsigned char>(name.back())) != axis) return std::nullopt;
  std::string base = name.substr(0, name.size() - 1);
  if (!base.empty() && base.back() == '_') base.pop_back();
  if (base.empty()) return std::nullopt;
  return base;
}

struct NamedValues {
  std::string name;
  Association association;
  std::vector<double> values;
};

// Groups BASE X, Y, Z triples (consecutive or not) into vectors; keeps everything else as scalars.
FieldSet make_fields(std::vector<NamedValues> values) {
  FieldSet fields;
  std::vector<bool> used(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    if (used[i]) continue;
    if (auto base = vector_base(values[i].name, 'X')) {
      auto find = [&](char axis) -> size_t {
        for (size_t k = 0; k < values.size(); ++k)
          if (!used[k] && k != i && values[k].association == values[i].association &&
              vector_base(values[k].name, axis) == base && values[k].values.size() == values[i].values.size())
            return k;
        return values.size();
      };
      const size_t y = find('Y'), z = find('Z');
      if (y < values.size() && z < values.size()) {
        std::vector<double> v(values[i].values.size() * 3);
        for (size_t t = 0; t < values[i].values.size(); ++t) {
          v[3 * t] = values[i].values[t];
          v[3 * t + 1] = values[y].values[t];
          v[3 * t + 2] = values[z].values[t];
        }
        used[i] = used[y] = used[z] = true;
        fields.add(Field(*base, values[i].association, DataArray::from(std::move(v), 3)));
        continue;
      }
    }
    used[i] = true;
    fields.add(Field(values[i].name, values[i].association, DataArray::from(std::move(values[i].values), 1)));
  }
  return fields;
}

struct ZoneShape {
  ZoneType_t type;
  std::array<uint64_t, 3> points{1, 1, 1};  // structured: per direction; unstructured: [0] = vertices
  std::array<uint64_t, 3> cells{1, 1, 1};
  int index_dim = 1;
};

std::array<std::vector<double>, 3> read_coordinates(const CgnsFile& f, int B, int Z, const ZoneShape& shape,
                                                    const std::string& where) {
  f.check(cg_goto(f.fn(), B, "Zone_t", Z, "GridCoordinates_t", 1, "end"), where + ": GridCoordinates");
  const auto rind = read_rind(shape.index_dim);
  const auto arrays = list_arrays(f, where + "/GridCoordinates");
  std::array<std::vector<double>, 3> xyz;
  const char* names[3] = {"CoordinateX", "CoordinateY", "CoordinateZ"};
  for (int c = 0; c < 3; ++c) {
    int a = 0;
    for (size_t k = 0; k < arrays.size(); ++k)
      if (arrays[k].name == names[c]) a = int(k) + 1;
    if (a == 0)
      fail_in(f.path(),
              where + ": no " + names[c] + " (only Cartesian coordinates are read; cylindrical and spherical are not)");
    xyz[size_t(c)] =
        read_core(f, a, arrays[size_t(a - 1)], shape.points, shape.index_dim, rind, where + "/GridCoordinates");
  }
  return xyz;
}

// The FlowSolution_t nodes to read: those the zone's iterative data names for `time_step`, or all of them.
std::vector<int> solutions_to_read(const CgnsFile& f, int B, int Z, int64_t time_step, const std::string& where,
                                   std::vector<std::string>& notes) {
  int nsols = 0;
  f.check(cg_nsols(f.fn(), B, Z, &nsols), where);
  std::vector<int> all;
  for (int s = 1; s <= nsols; ++s) all.push_back(s);
  char iter_name[33] = {};
  if (nsols == 0 || cg_ziter_read(f.fn(), B, Z, iter_name) != CG_OK) return all;
  if (cg_goto(f.fn(), B, "Zone_t", Z, "ZoneIterativeData_t", 1, "end") != CG_OK) return all;
  int narrays = 0;
  if (cg_narrays(&narrays) != CG_OK) return all;
  for (int a = 1; a <= narrays; ++a) {
    char name[33] = {};
    DataType_t type;
    int dim = 0;
    cgsize_t extent[12] = {};
    if (cg_array_info(a, name, &type, &dim, extent) != CG_OK) continue;
    if (std::string(name) != "FlowSolutionPointers" || type != Character || dim != 2 || extent[0] <= 0 ||
        extent[1] <= 0)
      continue;
    f.check_plausible(uint64_t(extent[0]) * uint64_t(extent[1]), where + "/ZoneIterativeData/FlowSolutionPointers");
    std::vector<char> text(static_cast<size_t>(extent[0]) * static_cast<size_t>(extent[1]));
    f.check(cg_array_read(a, text.data()), where + "/ZoneIterativeData/FlowSolutionPointers");
    const int64_t steps = extent[1];
    if (time_step >= steps)
      fail_in(f.path(), where + ": time step " + std::to_string(time_step) + " asked for, the zone has " +
                            std::to_string(steps) + " (0 to " + std::to_string(steps - 1) + ")");
    const int64_t step = time_step < 0 ? steps - 1 : time_step;
    std::string wanted(text.data() + size_t(step) * size_t(extent[0]), size_t(extent[0]));
    wanted.erase(wanted.find_last_not_of(" \0", std::string::npos, 2) + 1);
    for (int s = 1; s <= nsols; ++s) {
      char sol_name[33] = {};
      GridLocation_t location;
      f.check(cg_sol_info(f.fn(), B, Z, s, sol_name, &location), where);
      if (wanted == sol_name) {
        notes.push_back(where + ": time step " + std::to_string(step) + " of " + std::to_string(steps) +
                        " (FlowSolution " + wanted + ")");
        return {s};
      }
    }
    fail_in(f.path(), where + ": FlowSolutionPointers names '" + wanted + "', which the zone does not have");
  }
  return all;
}

std::vector<NamedValues> read_solutions(const CgnsFile& f, int B, int Z, const ZoneShape& shape, int64_t time_step,
                                        const std::string& where, std::vector<std::string>& notes) {
  std::vector<NamedValues> values;
  std::map<std::string, int> name_uses;
  const std::vector<int> sols = solutions_to_read(f, B, Z, time_step, where, notes);
  for (int s : sols) {
    char sol_name[33] = {};
    GridLocation_t location;
    f.check(cg_sol_info(f.fn(), B, Z, s, sol_name, &location), where);
    const std::string sol_where = where + "/" + sol_name;
    if (location != Vertex && location != CellCenter) {
      notes.push_back(sol_where + ": skipped (GridLocation " + cg_GridLocationName(location) +
                      "; Vertex and CellCenter are read)");
      continue;
    }
    const Association assoc = location == Vertex ? Association::Vertex : Association::Cell;
    f.check(cg_goto(f.fn(), B, "Zone_t", Z, "FlowSolution_t", s, "end"), sol_where);
    const auto rind = read_rind(shape.index_dim);
    const auto arrays = list_arrays(f, sol_where);
    const auto& core = location == Vertex ? shape.points : shape.cells;
    for (size_t a = 0; a < arrays.size(); ++a) {
      if (arrays[a].type == Character) continue;
      NamedValues v{arrays[a].name, assoc, {}};
      v.values = read_core(f, int(a) + 1, arrays[a], core, shape.index_dim, rind, sol_where);
      ++name_uses[v.name];
      values.push_back(std::move(v));
      values.back().name = std::string(sol_name) + "\x1f" + values.back().name;
    }
  }
  // Names as stored unless two solutions share one (then "SOLUTION/NAME").
  for (auto& v : values) {
    const size_t sep = v.name.find('\x1f');
    const std::string plain = v.name.substr(sep + 1);
    v.name = name_uses[plain] > 1 ? v.name.substr(0, sep) + "/" + plain : plain;
  }
  return values;
}

// What a zone's solutions need of its mesh, kept from its read (cgns_fields.h).
struct ZoneLayout {
  int base = 0, zone = 0;  // B, Z
  std::string where;
  ZoneShape shape{Structured, {}, {}, 3};  // the shape its solutions are read with
  std::optional<CellExpansion> expansion;  // unstructured zones: the polyhedra decomposition's
  size_t notes_at = 0;                     // the mesh's notes before this zone's solutions' (CgnsLayout::notes)
};

// The zone's fields: its solutions read with `shape`, expanded over the polyhedra decomposition where there is one.
FieldSet zone_fields(const CgnsFile& f, int B, int Z, const ZoneShape& shape, const CellExpansion* expansion,
                     int64_t time_step, const std::string& where, std::vector<std::string>& notes) {
  FieldSet raw = make_fields(read_solutions(f, B, Z, shape, time_step, where, notes));
  if (!expansion) return raw;
  FieldSet out;
  for (const Field& field : raw)
    out.add(field.association() == Association::Vertex ? expansion->expand_point_field(field)
                                                       : expansion->expand_cell_field(field));
  return out;
}

// Where `kept` is given, records what zone_fields needs, and in `notes_at` where the zone's solutions' notes start
// among the dataset's notes (read_cgns_file makes it a position among the mesh's notes alone).
void keep_zone(ZoneLayout* kept, int B, int Z, const std::string& where, const ZoneShape& shape,
               const CellExpansion* expansion, size_t notes_at) {
  if (!kept) return;
  kept->base = B;
  kept->zone = Z;
  kept->where = where;
  kept->shape = shape;
  if (expansion) kept->expansion = *expansion;
  kept->notes_at = notes_at;
}

Block read_structured_zone(const CgnsFile& f, int B, int Z, const std::string& where, const cgsize_t* size,
                           int64_t time_step, std::vector<std::string>& notes, ZoneLayout* kept) {
  ZoneShape shape{Structured, {}, {}, 3};
  for (int d = 0; d < 3; ++d) {
    if (size[d] < 1 || uint64_t(size[d]) > uint64_t(UINT32_MAX))
      fail_in(f.path(), where + ": structured zone size " + std::to_string(size[d]));
    shape.points[size_t(d)] = uint64_t(size[d]);
    shape.cells[size_t(d)] = uint64_t(size[3 + d]);
    if (shape.cells[size_t(d)] + 1 != shape.points[size_t(d)])
      fail_in(f.path(), where + ": " + std::to_string(size[3 + d]) + " cells along index " + std::to_string(d + 1) +
                            " for " + std::to_string(size[d]) + " vertices");
  }
  const auto xyz = read_coordinates(f, B, Z, shape, where);
  StructuredGrid grid;
  grid.dims.points = {uint32_t(shape.points[0]), uint32_t(shape.points[1]), uint32_t(shape.points[2])};
  grid.points.resize(grid.dims.point_count());
  for (size_t i = 0; i < grid.points.size(); ++i)
    grid.points[i] = Vec3f{float(xyz[0][i]), float(xyz[1][i]), float(xyz[2][i])};
  Block block;
  block.name = where;
  block.grid = std::move(grid);
  keep_zone(kept, B, Z, where, shape, nullptr, notes.size());
  block.fields = zone_fields(f, B, Z, shape, nullptr, time_step, where, notes);
  return block;
}

struct VolumeType {
  CellType type;
  int corners;
};

std::optional<VolumeType> volume_type(ElementType_t t) {
  switch (t) {
    case TETRA_4:
    case TETRA_10: return VolumeType{CellType::Tetra, 4};
    case PYRA_5:
    case PYRA_13:
    case PYRA_14: return VolumeType{CellType::Pyramid, 5};
    case PENTA_6:
    case PENTA_15:
    case PENTA_18: return VolumeType{CellType::Wedge, 6};
    case HEXA_8:
    case HEXA_20:
    case HEXA_27: return VolumeType{CellType::Hexahedron, 8};
    default: return std::nullopt;
  }
}

// A volume element found in a section, by element number (the order CellCenter data uses).
struct PendingCell {
  cgsize_t number;
  CellType type;  // unused for polyhedra
  bool polyhedron;
  uint64_t at;  // into the section's stream
  uint32_t section;
};

Block read_unstructured_zone(const CgnsFile& f, int B, int Z, const std::string& where, const cgsize_t* size,
                             int64_t time_step, std::vector<std::string>& notes, ZoneLayout* kept) {
  ZoneShape shape{Unstructured, {uint64_t(size[0]), 1, 1}, {uint64_t(size[1]), 1, 1}, 1};
  if (size[0] < 1 || uint64_t(size[0]) >= uint64_t(UINT32_MAX))
    fail_in(f.path(), where + ": " + std::to_string(size[0]) + " vertices");
  const auto xyz = read_coordinates(f, B, Z, shape, where);
  UnstructuredMesh mesh;
  mesh.points.resize(shape.points[0]);
  for (size_t i = 0; i < mesh.points.size(); ++i)
    mesh.points[i] = Vec3f{float(xyz[0][i]), float(xyz[1][i]), float(xyz[2][i])};

  // Read every section's stream; note the volume elements; keep NGON faces by element number.
  int nsections = 0;
  f.check(cg_nsections(f.fn(), B, Z, &nsections), where);
  struct Section {
    ElementType_t type;
    cgsize_t start, end;
    std::vector<cgsize_t> elements, offsets;  // offsets: per element, into elements (MIXED, NGON, NFACE)
  };
  std::vector<Section> sections;
  std::vector<PendingCell> cells;
  uint64_t skipped_lower = 0;
  const Section* ngon = nullptr;
  for (int s = 1; s <= nsections; ++s) {
    char name[33] = {};
    Section sec;
    int nbndry = 0, parent_flag = 0;
    f.check(cg_section_read(f.fn(), B, Z, s, name, &sec.type, &sec.start, &sec.end, &nbndry, &parent_flag),
            where + ": section " + std::to_string(s));
    const std::string swhere = where + "/" + name;
    if (sec.end < sec.start)
      fail_in(f.path(), swhere + ": element range " + std::to_string(sec.start) + ".." + std::to_string(sec.end));
    const uint64_t count = uint64_t(sec.end - sec.start + 1);
    cgsize_t data_size = 0;
    f.check(cg_ElementDataSize(f.fn(), B, Z, s, &data_size), swhere);
    if (data_size < 0 || uint64_t(data_size) > (uint64_t(1) << 34))
      fail_in(f.path(), swhere + ": element data size " + std::to_string(data_size));
    f.check_plausible(uint64_t(data_size), swhere + ": element data");
    f.check_plausible(count, swhere + ": element range");
    const bool poly = sec.type == MIXED || sec.type == NGON_n || sec.type == NFACE_n;
    const auto vt = volume_type(sec.type);
    if (!poly && !vt) {  // faces, edges, nodes: boundary sections
      skipped_lower += count;
      sections.push_back(std::move(sec));
      continue;
    }
    sec.elements.resize(size_t(data_size));
    if (poly) {
      sec.offsets.resize(count + 1);
      f.check(cg_poly_elements_read(f.fn(), B, Z, s, sec.elements.data(), sec.offsets.data(), nullptr), swhere);
      if (sec.offsets[0] != 0 || sec.offsets[count] != data_size ||
          !std::is_sorted(sec.offsets.begin(), sec.offsets.end()))
        fail_in(f.path(), swhere + ": element offsets do not run from 0 to the data size");
    } else {
      int npe = 0;
      f.check(cg_npe(sec.type, &npe), swhere);
      if (uint64_t(data_size) != count * uint64_t(npe))
        fail_in(f.path(), swhere + ": " + std::to_string(data_size) + " node indices for " + std::to_string(count) +
                              " elements of " + std::to_string(npe) + " nodes");
      f.check(cg_elements_read(f.fn(), B, Z, s, sec.elements.data(), nullptr), swhere);
    }
    const uint32_t si = uint32_t(sections.size());
    for (uint64_t e = 0; e < count; ++e) {
      const cgsize_t number = sec.start + cgsize_t(e);
      if (sec.type == NGON_n) break;  // faces: used by NFACE_n
      if (sec.type == NFACE_n) {
        cells.push_back({number, CellType::Tetra, true, uint64_t(sec.offsets[e]), si});
      } else if (sec.type == MIXED) {
        const auto mixed_type = ElementType_t(sec.elements[size_t(sec.offsets[e])]);
        if (auto t = volume_type(mixed_type))
          cells.push_back({number, t->type, false, uint64_t(sec.offsets[e]) + 1, si});
        else
          ++skipped_lower;
      } else {
        int npe = 0;
        cg_npe(sec.type, &npe);
        cells.push_back({number, vt->type, false, e * uint64_t(npe), si});
      }
    }
    sections.push_back(std::move(sec));
  }
  for (const auto& sec : sections)
    if (sec.type == NGON_n) {
      if (ngon) fail_in(f.path(), where + ": more than one NGON_n section (one is supported)");
      ngon = &sec;
    }
  std::stable_sort(cells.begin(), cells.end(),
                   [](const PendingCell& a, const PendingCell& b) { return a.number < b.number; });
  if (cells.empty())
    fail_in(f.path(), where + ": no volume cells (sections of tetra, pyramid, penta, hexa, MIXED or NFACE_n)");
  if (uint64_t(size[1]) != cells.size())
    notes.push_back(where + ": the zone declares " + std::to_string(size[1]) + " cells, its sections hold " +
                    std::to_string(cells.size()) + " volume elements");

  const uint64_t nverts = mesh.points.size();
  auto vertex = [&](cgsize_t v, const std::string& what) -> uint32_t {
    if (v < 1 || uint64_t(v) > nverts)
      fail_in(f.path(), where + ": " + what + " uses vertex " + std::to_string(v) + " of 1.." + std::to_string(nverts));
    return uint32_t(v - 1);
  };
  PolyhedronDecomposer decomposer(mesh, f.path() + ": " + where);
  std::vector<uint32_t> v(8), face_sizes, face_vertices;
  std::vector<bool> from_file;  // per output cell: a native cell as the file lists it (not oriented by us)
  std::array<uint64_t, 15> type_cells{}, type_inverted{};
  for (const PendingCell& c : cells) {
    const Section& sec = sections[c.section];
    const std::string what = "element " + std::to_string(c.number);
    if (!c.polyhedron) {
      const int n = cell_vertex_count(c.type);
      if (c.at + uint64_t(n) > sec.elements.size()) fail_in(f.path(), where + ": " + what + " runs past its section");
      for (int k = 0; k < n; ++k) v[size_t(k)] = vertex(sec.elements[size_t(c.at) + size_t(k)], what);
      decomposer.add_native(c.type, std::span(v.data(), size_t(n)));
      from_file.resize(mesh.cell_count());
      from_file.back() = true;
      ++type_cells[size_t(c.type)];
      type_inverted[size_t(c.type)] += cell_volume(mesh, mesh.cell_count() - 1) < 0;
      continue;
    }
    if (!ngon) fail_in(f.path(), where + ": NFACE_n without an NGON_n section");
    const uint64_t e = uint64_t(c.number - sec.start);
    face_sizes.clear();
    face_vertices.clear();
    for (cgsize_t k = sec.offsets[e]; k < sec.offsets[e + 1]; ++k) {
      const cgsize_t face = sec.elements[size_t(k)];
      const cgsize_t fnum = face < 0 ? -face : face;
      if (fnum < ngon->start || fnum > ngon->end)
        fail_in(f.path(), where + ": " + what + " names face " + std::to_string(face) + ", outside NGON_n's " +
                              std::to_string(ngon->start) + ".." + std::to_string(ngon->end));
      const uint64_t fi = uint64_t(fnum - ngon->start);
      const cgsize_t b = ngon->offsets[fi], end = ngon->offsets[fi + 1];
      face_sizes.push_back(uint32_t(end - b));
      for (cgsize_t q = b; q < end; ++q) face_vertices.push_back(vertex(ngon->elements[size_t(q)], what));
    }
    decomposer.add_polyhedron(face_sizes, face_vertices);
  }
  if (skipped_lower > 0)
    notes.push_back(where + ": " + std::to_string(skipped_lower) +
                    " elements of lower dimension (boundary faces, edges, nodes) skipped");
  if (const std::string s = decomposer.summary(); !s.empty()) notes.push_back(where + ": " + s);

  // One flip per cell type when most of the file's cells of that type are inverted (PENTA_6 against VTK's wedge).
  from_file.resize(mesh.cell_count());
  for (CellType t : kAllCellTypes) {
    const uint64_t total = type_cells[size_t(t)], inverted = type_inverted[size_t(t)];
    if (total == 0 || 2 * inverted <= total) continue;
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (mesh.cell_types[c] != t || !from_file[c]) continue;
      uint32_t* p = mesh.connectivity.data() + mesh.cell_offsets[c];
      switch (t) {
        case CellType::Tetra: std::swap(p[1], p[2]); break;
        case CellType::Wedge:
          std::swap(p[1], p[2]);
          std::swap(p[4], p[5]);
          break;
        case CellType::Pyramid: std::swap(p[1], p[3]); break;
        case CellType::Hexahedron:
          std::swap(p[1], p[3]);
          std::swap(p[5], p[7]);
          break;
      }
    }
  }

  Block block;
  block.name = where;
  ZoneShape field_shape = shape;
  field_shape.cells = {decomposer.input_cells(), 1, 1};
  keep_zone(kept, B, Z, where, field_shape, &decomposer.expansion(), notes.size());
  block.fields = zone_fields(f, B, Z, field_shape, &decomposer.expansion(), time_step, where, notes);
  block.grid = std::move(mesh);
  return block;
}

}  // namespace

std::vector<double> list_cgns_times(const std::string& path) {
  CgnsFile f(path);
  for (const CgnsFile::Base& base : f.bases()) {
    if (base.cell_dim != 3) continue;
    const int B = base.index, nzones = base.zones;
    const std::string& base_name = base.name;
    // The steps time_step indexes: the first zone's FlowSolutionPointers (solutions_to_read).
    char iter_name[33] = {};
    if (nzones < 1 || cg_ziter_read(f.fn(), B, 1, iter_name) != CG_OK) return {};
    if (cg_goto(f.fn(), B, "Zone_t", 1, "ZoneIterativeData_t", 1, "end") != CG_OK) return {};
    int narrays = 0;
    if (cg_narrays(&narrays) != CG_OK) return {};
    int64_t steps = 0;
    for (int a = 1; a <= narrays && steps == 0; ++a) {
      char name[33] = {};
      DataType_t type;
      int dim = 0;
      cgsize_t extent[12] = {};
      if (cg_array_info(a, name, &type, &dim, extent) == CG_OK && std::string(name) == "FlowSolutionPointers" &&
          dim == 2 && extent[1] > 0)
        steps = extent[1];
    }
    if (steps == 0) return {};
    f.check_plausible(uint64_t(steps), std::string(base_name) + "/ZoneIterativeData/FlowSolutionPointers");
    std::vector<double> times(static_cast<size_t>(steps));
    for (size_t i = 0; i < times.size(); ++i) times[i] = double(i);
    // The times: BaseIterativeData's TimeValues when it holds one per step, else the step index.
    int nsteps = 0;
    if (cg_biter_read(f.fn(), B, iter_name, &nsteps) == CG_OK && nsteps == steps &&
        cg_goto(f.fn(), B, "BaseIterativeData_t", 1, "end") == CG_OK && cg_narrays(&narrays) == CG_OK) {
      for (int a = 1; a <= narrays; ++a) {
        char name[33] = {};
        DataType_t type;
        int dim = 0;
        cgsize_t extent[12] = {};
        if (cg_array_info(a, name, &type, &dim, extent) == CG_OK && std::string(name) == "TimeValues" && dim == 1 &&
            extent[0] == steps && cg_array_read_as(a, RealDouble, times.data()) == CG_OK)
          break;
      }
    }
    return times;
  }
  return {};
}

std::optional<GridCounts> cgns_header_counts(const std::string& path) {
  CgnsFile f(path);
  GridCounts counts;
  bool any = false;
  for (const CgnsFile::Base& base : f.bases()) {
    if (base.cell_dim != 3) continue;  // as read_cgns: volume cells only
    for (int Z = 1; Z <= base.zones; ++Z) {
      const CgnsFile::Zone zone = f.zone(base, Z);
      const int dirs = zone.type == Structured ? 3 : zone.type == Unstructured ? 1 : 0;
      if (dirs == 0) continue;
      uint64_t points = 1, cells = 1;
      for (int d = 0; d < dirs; ++d) {
        if (zone.size[d] < 0 || zone.size[dirs + d] < 0)
          fail_in(path, base.name + "/" + zone.name + ": a negative size");
        points = sat_mul(points, uint64_t(zone.size[d]));
        cells = sat_mul(cells, uint64_t(zone.size[dirs + d]));
      }
      counts.points = sat_add(counts.points, points);
      counts.cells = sat_add(counts.cells, cells);
      any = true;
    }
  }
  if (!any) return std::nullopt;
  return counts;
}

// What a step's solutions need of the mesh, kept from its read (cgns_fields.h).
struct CgnsLayout {
  std::optional<uint64_t> mesh_key;  // cgns_mesh_key of the file when read
  std::string format;
  std::vector<std::string> notes;  // the whole read's notes but the solutions' (which each step reads again)
  std::vector<ZoneLayout> zones;   // one per block, in block order
};

namespace {

// The whole read; where `kept` is given, the layout of its mesh.
Dataset read_cgns_file(const std::string& path, int64_t time_step, CgnsLayout* kept) {
  CgnsFile f(path);
  Dataset ds;
  int file_type = 0;
  cg_get_file_type(f.fn(), &file_type);
  ds.format = std::string("CGNS (") + (file_type == CG_FILE_HDF5 ? "HDF5" : "ADF") + ")";
  ds.sources = {path};
  size_t solution_notes = 0;  // the solutions' notes so far (not kept in the layout)
  for (const CgnsFile::Base& base : f.bases()) {
    if (base.cell_dim != 3) {
      ds.warnings.push_back("base " + base.name + ": cell dimension " + std::to_string(base.cell_dim) +
                            " skipped (volume cells are read)");
      continue;
    }
    for (int Z = 1; Z <= base.zones; ++Z) {
      const CgnsFile::Zone zone = f.zone(base, Z);
      const std::string where = base.name + "/" + zone.name;
      ZoneLayout layout;
      ZoneLayout* keep = kept ? &layout : nullptr;
      if (zone.type == Structured) {
        ds.blocks.push_back(
            read_structured_zone(f, base.index, Z, where, zone.size.data(), time_step, ds.warnings, keep));
      } else if (zone.type == Unstructured) {
        ds.blocks.push_back(
            read_unstructured_zone(f, base.index, Z, where, zone.size.data(), time_step, ds.warnings, keep));
      } else {
        ds.warnings.push_back(where + ": zone type not structured nor unstructured, skipped");
        continue;
      }
      if (!kept) continue;
      // The notes from the solutions' start to the zone's end are the solutions' (read_solutions is the zone's last
      // step): the mesh's notes before them are kept, theirs are not.
      const size_t solutions_from = layout.notes_at;
      kept->notes.insert(kept->notes.end(), ds.warnings.begin() + std::ptrdiff_t(kept->notes.size() + solution_notes),
                         ds.warnings.begin() + std::ptrdiff_t(solutions_from));
      layout.notes_at = kept->notes.size();
      solution_notes += ds.warnings.size() - solutions_from;
      kept->zones.push_back(std::move(layout));
    }
  }
  if (ds.blocks.empty()) fail_in(path, "no zone with volume cells (bases of cell dimension 3)");
  for (const Block& b : ds.blocks) b.validate_fields(path);
  if (kept) {
    kept->notes.insert(kept->notes.end(), ds.warnings.begin() + std::ptrdiff_t(kept->notes.size() + solution_notes),
                       ds.warnings.end());
    kept->format = ds.format;
  }
  return ds;
}

// Whether a zone's grid moves from step to step: several GridCoordinates_t, grid motion nodes, or
// GridCoordinatesPointers in its iterative data.
bool zone_grid_moves(const CgnsFile& f, int B, int Z) {
  int grids = 0, rigid = 0, arbitrary = 0;
  f.check(cg_ngrids(f.fn(), B, Z, &grids), "zone " + std::to_string(Z));
  f.check(cg_n_rigid_motions(f.fn(), B, Z, &rigid), "zone " + std::to_string(Z));
  f.check(cg_n_arbitrary_motions(f.fn(), B, Z, &arbitrary), "zone " + std::to_string(Z));
  if (grids > 1 || rigid > 0 || arbitrary > 0) return true;
  char iter_name[33] = {};
  if (cg_ziter_read(f.fn(), B, Z, iter_name) != CG_OK) return false;
  if (cg_goto(f.fn(), B, "Zone_t", Z, "ZoneIterativeData_t", 1, "end") != CG_OK) return false;
  int narrays = 0;
  if (cg_narrays(&narrays) != CG_OK) return false;
  for (int a = 1; a <= narrays; ++a) {
    char name[33] = {};
    DataType_t type;
    int dim = 0;
    cgsize_t extent[12] = {};
    if (cg_array_info(a, name, &type, &dim, extent) == CG_OK && std::string(name) == "GridCoordinatesPointers")
      return true;
  }
  return false;
}

}  // namespace

Dataset read_cgns(const std::string& path, int64_t time_step) { return read_cgns_file(path, time_step, nullptr); }

std::optional<uint64_t> cgns_mesh_key(const std::string& path) {
  {
    const CgnsFile f(path);
    for (const CgnsFile::Base& base : f.bases())
      for (int Z = 1; Z <= base.zones; ++Z)
        if (zone_grid_moves(f, base.index, Z)) return std::nullopt;
  }
  return hash_file_stamp(hash_mix(kFnvOffset, 0x63676e73), path);  // "cgns"
}

Dataset read_cgns(const std::string& path, int64_t time_step, std::shared_ptr<const CgnsLayout>* kept) {
  if (!kept) return read_cgns(path, time_step);
  // Taken before the mesh is read: a file rewritten during the read gives another key than the one kept.
  const std::optional<uint64_t> key = cgns_mesh_key(path);
  auto layout = std::make_shared<CgnsLayout>();
  Dataset ds = read_cgns_file(path, time_step, layout.get());
  layout->mesh_key = key;
  *kept = std::move(layout);
  return ds;
}

const std::optional<uint64_t>& cgns_layout_mesh_key(const CgnsLayout& layout) { return layout.mesh_key; }

std::vector<FieldSet> read_cgns_fields(const CgnsLayout& layout, const std::string& path, int64_t time_step,
                                       std::string& format, std::vector<std::string>& sources,
                                       std::vector<std::string>& warnings) {
  const CgnsFile f(path);
  format = layout.format;
  sources = {path};
  std::vector<FieldSet> blocks;
  size_t note = 0;
  for (const ZoneLayout& z : layout.zones) {
    warnings.insert(warnings.end(), layout.notes.begin() + std::ptrdiff_t(note),
                    layout.notes.begin() + std::ptrdiff_t(z.notes_at));
    note = z.notes_at;
    blocks.push_back(
        zone_fields(f, z.base, z.zone, z.shape, z.expansion ? &*z.expansion : nullptr, time_step, z.where, warnings));
  }
  warnings.insert(warnings.end(), layout.notes.begin() + std::ptrdiff_t(note), layout.notes.end());
  return blocks;
}

}  // namespace ugvr
