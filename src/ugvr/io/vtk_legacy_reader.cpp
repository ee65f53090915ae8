// Legacy VTK reader (.vtk), following vtkDataReader and its subclasses (VTK 9).
//
// Layout of a file:
//   # vtk DataFile Version X.Y              line 1 (any version; 5.0 and later use the OFFSETS/CONNECTIVITY cells)
//   title                                   line 2, kept as the block name
//   ASCII | BINARY                          from here on the file is whitespace-separated words (keywords are
//   DATASET <type>                          matched case-insensitively, as VTK lower-cases them)
//   geometry keywords of <type>             in any order, plus dataset-level FIELD data (read and discarded)
//   POINT_DATA n / CELL_DATA n sections     attributes, in either order, each section until the next one
//
// Geometry by dataset type:
//   UNSTRUCTURED_GRID   POINTS n type; CELLS; CELL_TYPES n. Before 5.0: "CELLS n size" and `size` int32 values,
//                       one list per cell: its point count then its point ids. From 5.0: "CELLS nOffsets nConn" then
//                       "OFFSETS type" (nOffsets = cells + 1 values, the first 0) and "CONNECTIVITY type" (nConn ids).
//                       Cells become UnstructuredMesh cells through VtkCellImporter (linear volume cells kept,
//                       quadratic ones linearised, 2-D ones dropped with a warning, others refused).
//   STRUCTURED_GRID     DIMENSIONS nx ny nz; POINTS n type (n = nx*ny*nz)             -> StructuredGrid
//   STRUCTURED_POINTS   DIMENSIONS; ORIGIN; SPACING or ASPECT_RATIO; DIRECTION (identity only) -> ImageGrid
//   RECTILINEAR_GRID    DIMENSIONS; X_COORDINATES n type; Y_...; Z_...                -> RectilinearGrid
//   POLYDATA and the non-dataset types are refused: they hold no volume. So are 1-D and 2-D structured grids.
// Points are kept as float32 whatever their stored type (a coordinate beyond float range is an error).
//
// Attributes (n tuples each; the count after POINT_DATA / CELL_DATA must equal the grid's points / the file's cells):
//   SCALARS name type [numComp] + LOOKUP_TABLE tableName   numComp components (default 1)
//   VECTORS | NORMALS name type (3)   TENSORS name type (9)   TENSORS6 name type (6)
//   TEXTURE_COORDINATES name dim type (dim 1..3)   GLOBAL_IDS | PEDIGREE_IDS | EDGE_FLAGS name type (1)
//   COLOR_SCALARS name numComp     BINARY: unsigned_char; ASCII: floats in [0, 1], stored as unsigned char
//                                  (round(255 v), as VTK does), so both encodings give the same field
//   LOOKUP_TABLE name size         a colour table, not data: size RGBA entries skipped
//   FIELD name numArrays           then per array "name numComp numTuples type" and its values, or the word
//                                  NULL_ARRAY (5.1) for an empty slot
// Fields keep their stored type (vtkIdType arrays are read as Int64; "bit" arrays as UInt8 0/1). String arrays are
// skipped with a warning. Names decode %XX escapes (VTK writes spaces as %20). Cell fields of an unstructured grid go
// through VtkCellImporter::filter_cell_data so they stay aligned with the cells kept. A second array of the same name
// and association replaces the first, as in vtkFieldData::AddArray, with a warning.
//
// 5.1 writers follow an array by an optional METADATA block (COMPONENT_NAMES / INFORMATION lines ended by a blank
// line); it is skipped (LegacyInput::skip_metadata).
//
// BINARY files: each block of values starts after the newline that ends its keyword line (VTK reads the rest of the
// line and then the bytes), is big-endian, and is followed by a newline that the next keyword read skips as
// whitespace. Errors name the line in ASCII files and the byte offset in BINARY ones.
//
// Streaming: the file is read through a buffered tokenizer, never whole. Arrays are read straight into their final
// DataArray. Cell lists come before the cell types that say how to read them, so the first pass only checks and skips
// them, remembering where they start; once CELL_TYPES has been seen, cursors on the types and the lists (and, in 5.x,
// the offsets) read them together in chunks and feed VtkCellImporter, so nothing but the final mesh is held in memory.
//
// Time steps (io/step_fields.h): a series of legacy files with one mesh is read whole once, then each step's fields
// alone. The geometry key (vtk_legacy_geometry_key) hashes, as they lie in the file, the version line and everything
// from the encoding word to the first POINT_DATA / CELL_DATA (or the end): the encoding, the DATASET line, every
// geometry keyword with its header words and stored values (BINARY bytes or ASCII text, never decoded), less the
// title line and dataset-level FIELD and METADATA blocks, which hold no geometry (writers put the step's TIME in a
// FIELD). The cut-out blocks' places and lengths are hashed with the bytes between them. Every dataset type the reader
// reads as a mesh is keyed the same way. A fields-only read (read_vtk_legacy_fields) passes over POINTS and CELLS
// (BINARY: a seek by their counts; ASCII: their words counted, not parsed), reads CELL_TYPES to know which cells'
// values the mesh keeps, and reads the attributes exactly as the whole read does.
//
// Hostile input: every count is checked against the bytes left before anything is allocated (ASCII values take at
// least 2 bytes, BINARY ones their size), ids and offsets are range-checked, and tokens and header lines are bounded.
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/text_tokenizer.h"
#include "ugvr/io/vtk_cell_import.h"
#include "ugvr/io/vtk_legacy_input.h"

namespace ugvr {

namespace {

using vtk_legacy::DeferredArray;
using vtk_legacy::LegacyInput;
using vtk_legacy::ValueCursor;
using vtk_legacy::ValueType;
using Mark = TextTokenizer::Mark;

constexpr std::string_view kVersionPrefix = "# vtk DataFile Version";
// Structured grids may hold no arrays at all (STRUCTURED_POINTS), so their size is not bounded by the file; this
// bounds it by what could ever be rendered.
constexpr uint64_t kMaxStructuredPoints = uint64_t(1) << 42;

enum class Kind { Unstructured, StructuredGrid, StructuredPoints, Rectilinear };

bool is(std::string_view word, std::string_view keyword) { return equals_ignore_case(word, keyword); }

std::optional<Kind> dataset_kind(std::string_view type) {
  if (is(type, "UNSTRUCTURED_GRID")) return Kind::Unstructured;
  if (is(type, "STRUCTURED_GRID")) return Kind::StructuredGrid;
  if (is(type, "STRUCTURED_POINTS")) return Kind::StructuredPoints;
  if (is(type, "RECTILINEAR_GRID")) return Kind::Rectilinear;
  return std::nullopt;
}

ValueType value_type_named(std::string_view name) { return *vtk_legacy::parse_value_type(name); }

// A POINT_DATA or CELL_DATA section.
struct Section {
  Association association = Association::Vertex;
  uint64_t tuples = 0;
  std::string keyword() const { return association == Association::Vertex ? "POINT_DATA" : "CELL_DATA"; }
};

// The cell lists as the first pass found them (read later, with the cell types).
struct CellLists {
  Mark at;              // the CELLS keyword
  bool count_prefixed;  // before 5.0: each list starts with its point count
  uint64_t cells = 0;
  DeferredArray lists;         // before 5.0
  DeferredArray offsets;       // 5.0 and later
  DeferredArray connectivity;  // 5.0 and later
};

// What a reader makes of a file: the dataset, the geometry key alone, or the fields alone (see the top).
enum class Pass { Whole, GeometryKey, FieldsOnly };

class LegacyReader {
 public:
  explicit LegacyReader(const std::string& path, Pass pass = Pass::Whole)
      : file_(path), in_(file_, false), pass_(pass) {
    if (pass_ != Pass::GeometryKey) start_reading_progress(progress_, file_);
  }

  Dataset read() {
    read_header();
    read_geometry();
    Block block{title_, std::move(grid_), FieldSet{}};
    for (Field& f : fields_) block.fields.add(std::move(f));
    Dataset dataset = single_block_dataset(format_name(), path(), std::move(block), std::move(warnings_));
    if (progress_) progress_->finish();
    return dataset;
  }

  uint64_t geometry_key() {
    read_header();
    key_ = hash_mix(hash_mix(kFnvOffset, 0x6c766b), hash_file_range(file_, 0, version_line_end_));  // "lvk"
    read_geometry();
    return key_;
  }

  FieldSet read_fields(std::string& format, std::vector<std::string>& warnings) {
    read_header();
    read_geometry();
    FieldSet fields;
    for (Field& f : fields_) fields.add(std::move(f));
    format = format_name();
    warnings.insert(warnings.end(), warnings_.begin(), warnings_.end());
    if (progress_) progress_->finish();
    return fields;
  }

 private:
  std::string format_name() const {
    return "legacy VTK " + version_ + (in_.binary() ? " BINARY " : " ASCII ") + kind_name_;
  }
  bool passes_over_mesh() const { return pass_ != Pass::Whole; }

  // The geometry key takes in the bytes from the end of the last cut-out block (or the title line) to `end`.
  void hash_segment(uint64_t end) {
    if (pass_ != Pass::GeometryKey) return;
    key_ = hash_mix(hash_mix(key_, end - segment_begin_), hash_file_range(file_, segment_begin_, end));
  }

  const std::string& path() const { return file_.path(); }
  Mark keyword_mark() { return {in_.tokens().token_offset(), in_.tokens().token_line()}; }

  // --- header --------------------------------------------------------------------------------------------------

  void read_header() {
    TextTokenizer& t = in_.tokens();
    const std::optional<std::string_view> first = t.read_line();
    if (!first || !first->starts_with(kVersionPrefix)) {
      fail_at_line(path(), 1, "not a legacy VTK file: the first line must start with '# vtk DataFile Version'");
    }
    parse_version(first->substr(kVersionPrefix.size()));
    version_line_end_ = t.offset();
    const std::optional<std::string_view> title = t.read_line();
    if (!title) fail_at_line(path(), 2, "unexpected end of file: expected the title line");
    title_ = trim(*title);
    segment_begin_ = t.offset();

    const std::string encoding(in_.word("ASCII or BINARY"));
    // VTK compares the first 5 / 6 letters only.
    if (starts_with_ignore_case(encoding, "ascii")) {
      in_.set_binary(false);
    } else if (starts_with_ignore_case(encoding, "binary")) {
      in_.set_binary(true);
    } else {
      in_.fail("expected ASCII or BINARY, found '" + encoding.substr(0, 40) + "'");
    }
    in_.expect_keyword("DATASET");
    const std::string type(in_.word("the dataset type"));
    if (is(type, "POLYDATA")) in_.fail("DATASET POLYDATA is a surface, not a volume: ugvr renders volumes only");
    const std::optional<Kind> kind = dataset_kind(type);
    if (!kind) {
      in_.fail("unsupported dataset type '" + type.substr(0, 40) +
               "' (expected UNSTRUCTURED_GRID, STRUCTURED_GRID, STRUCTURED_POINTS or RECTILINEAR_GRID)");
    }
    kind_ = *kind;
    kind_name_ = type;
    for (char& c : kind_name_) c = (c >= 'a' && c <= 'z') ? char(c - 'a' + 'A') : c;
  }

  void parse_version(std::string_view text) {
    const std::string v = trim(text);
    const size_t dot = v.find('.');
    if (dot != std::string::npos && parse_number(std::string_view(v).substr(0, dot), major_) &&
        parse_number(std::string_view(v).substr(dot + 1), minor_)) {
      version_ = std::to_string(major_) + "." + std::to_string(minor_);
      return;
    }
    // VTK warns and goes on with version 0.0, which means the pre-5.0 cell layout.
    major_ = minor_ = 0;
    version_ = "(unknown version)";
    warnings_.push_back(path() + ": cannot read the file version in its first line; reading it as a pre-5.0 file");
  }

  static std::string trim(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    return std::string(s);
  }

  // --- geometry ------------------------------------------------------------------------------------------------

  void read_geometry() {
    for (;;) {
      const std::string keyword(in_.tokens().next_token());
      if (progress_) progress_->set(in_.tokens().offset());
      if (keyword.empty()) break;
      if (is(keyword, "POINT_DATA") || is(keyword, "CELL_DATA")) {
        if (pass_ == Pass::GeometryKey) return hash_segment(in_.tokens().token_offset());
        finish_geometry();
        read_attributes(keyword);
        return;
      }
      if (is(keyword, "FIELD") || is(keyword, "METADATA")) {
        // Not geometry: cut out of the key (a step's TIME is often a dataset-level FIELD).
        hash_segment(in_.tokens().token_offset());
        if (is(keyword, "FIELD")) {
          read_field(nullptr);
        } else {
          skip_metadata_keyword();
        }
        segment_begin_ = in_.tokens().offset();
      } else if (!read_geometry_keyword(keyword)) {
        in_.fail("unexpected keyword '" + keyword.substr(0, 40) + "' in " + kind_name_ + " (expected " +
                 expected_geometry_keywords() + ", POINT_DATA or CELL_DATA)");
      }
    }
    if (pass_ == Pass::GeometryKey) return hash_segment(file_.size());
    finish_geometry();
  }

  // Reads one geometry keyword of the dataset's type; false if the keyword is not one.
  bool read_geometry_keyword(const std::string& keyword) {
    if (kind_ == Kind::Unstructured) {
      if (is(keyword, "POINTS")) {
        read_points();
      } else if (is(keyword, "CELLS")) {
        read_cells();
      } else if (is(keyword, "CELL_TYPES")) {
        read_cell_types();
      } else {
        return false;
      }
      return true;
    }
    if (is(keyword, "DIMENSIONS")) {
      read_dimensions();
      return true;
    }
    if (kind_ == Kind::StructuredGrid) {
      if (!is(keyword, "POINTS")) return false;
      read_points();
      return true;
    }
    if (kind_ == Kind::StructuredPoints) {
      if (is(keyword, "ORIGIN")) {
        image_.origin = read_vec3("ORIGIN");
      } else if (is(keyword, "SPACING") || is(keyword, "ASPECT_RATIO")) {
        image_.spacing = read_vec3(keyword);
      } else if (is(keyword, "DIRECTION")) {
        read_direction();
      } else {
        return false;
      }
      return true;
    }
    for (int axis = 0; axis < 3; ++axis) {  // RECTILINEAR_GRID
      if (is(keyword, axis_name(axis) + "_COORDINATES")) {
        read_coordinates(axis);
        return true;
      }
    }
    return false;
  }

  static std::string axis_name(int axis) { return std::string(1, char('X' + axis)); }

  std::string expected_geometry_keywords() const {
    switch (kind_) {
      case Kind::Unstructured: return "POINTS, CELLS, CELL_TYPES, FIELD";
      case Kind::StructuredGrid: return "DIMENSIONS, POINTS, FIELD";
      case Kind::StructuredPoints: return "DIMENSIONS, ORIGIN, SPACING, ASPECT_RATIO, DIRECTION, FIELD";
      case Kind::Rectilinear: return "DIMENSIONS, X_COORDINATES, Y_COORDINATES, Z_COORDINATES, FIELD";
    }
    return {};
  }

  void skip_metadata_keyword() {
    in_.tokens().skip_line();
    in_.skip_metadata_body(0);
  }

  void read_points() {
    if (points_ || passed_points_) in_.fail("POINTS given twice");
    points_at_ = keyword_mark();
    const uint64_t n = in_.count("the number of points");
    if (n > std::numeric_limits<uint32_t>::max()) {
      in_.fail(std::to_string(n) + " points: an in-memory mesh holds at most 2^32-1 vertices");
    }
    const ValueType type = in_.value_type("the POINTS data type");
    if (type.is_bit() || type.is_string) in_.fail("POINTS cannot be of type " + type.name);
    if (passes_over_mesh()) {
      in_.pass_over_array(type, n, 3, "POINTS");
      passed_points_ = n;
      return;
    }
    const uint64_t values = in_.value_count("POINTS", n, 3);
    in_.begin_array(type, values, "POINTS");
    std::vector<Vec3f> points(n);
    in_.read_chunks<double>(type, values, "POINTS", [&](uint64_t first, std::span<const double> chunk) {
      for (size_t i = 0; i < chunk.size(); ++i) {
        const double v = chunk[i];
        if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
          in_.fail_at(points_at_, "POINTS coordinate " + std::to_string(first + i) + " (" + std::to_string(v) +
                                      ") is beyond the float32 range points are kept in");
        }
        points[(first + i) / 3][int((first + i) % 3)] = float(v);
      }
    });
    in_.skip_metadata(3);
    points_ = std::move(points);
  }

  // Integer arrays only: cell offsets, connectivity and types.
  ValueType integer_type(std::string_view what) {
    const ValueType type = in_.value_type(what);
    if (!type.is_integer() || type.is_bit() || type.is_string) in_.fail(std::string(what) + " must be an integer type");
    return type;
  }

  void read_cells() {
    if (cells_) in_.fail("CELLS given twice");
    CellLists c;
    c.at = keyword_mark();
    c.count_prefixed = major_ < 5;
    if (c.count_prefixed) {
      c.cells = in_.count("the number of cells");
      const uint64_t size = in_.count("the size of the cell lists");
      if (c.cells > size) {
        in_.fail("CELLS: " + std::to_string(c.cells) + " cells cannot fit in " + std::to_string(size) +
                 " values (each cell lists its point count first)");
      }
      c.lists = skip_mesh_array(value_type_named("int"), size, "CELLS");
    } else {
      const uint64_t offsets = in_.count("the number of cell offsets");
      const uint64_t connectivity = in_.count("the number of connectivity entries");
      if (offsets > 0) {  // VTK writes "CELLS 0 0" and nothing else for no cells
        c.cells = offsets - 1;
        in_.expect_keyword("OFFSETS");
        c.offsets = skip_mesh_array(integer_type("the OFFSETS data type"), offsets, "OFFSETS");
        in_.expect_keyword("CONNECTIVITY");
        c.connectivity = skip_mesh_array(integer_type("the CONNECTIVITY data type"), connectivity, "CONNECTIVITY");
      }
    }
    cells_ = c;
  }

  void read_cell_types() {
    if (cell_types_) in_.fail("CELL_TYPES given twice");
    cell_types_at_ = keyword_mark();
    const uint64_t n = in_.count("the number of cell types");
    cell_types_ = skip_mesh_array(value_type_named("int"), n, "CELL_TYPES");
  }

  // A cell array's place, for ValueCursors to read later; ASCII values are checked here in a whole read only (the
  // other passes read the types alone, with the same checks, or nothing).
  DeferredArray skip_mesh_array(const ValueType& type, uint64_t values, std::string_view what) {
    return passes_over_mesh() ? in_.pass_over_array(type, values, 1, what) : in_.skip_array(type, values, 1, what);
  }

  void read_dimensions() {
    if (dims_) in_.fail("DIMENSIONS given twice");
    GridDims d;
    uint64_t product = 1;
    for (int axis = 0; axis < 3; ++axis) {
      const uint64_t n = in_.count("DIMENSIONS");
      if (n < 1 || n > std::numeric_limits<uint32_t>::max()) {
        in_.fail("DIMENSIONS must be between 1 and 2^32-1, not " + std::to_string(n));
      }
      d.points[size_t(axis)] = uint32_t(n);
      product = n > kMaxStructuredPoints / product ? kMaxStructuredPoints + 1 : product * n;
    }
    if (product > kMaxStructuredPoints) {
      in_.fail("DIMENSIONS " + dims_text(d) + " describe more than 2^42 points");
    }
    dims_ = d;
    dims_at_ = keyword_mark();
  }

  static std::string dims_text(const GridDims& d) {
    return std::to_string(d.points[0]) + " x " + std::to_string(d.points[1]) + " x " + std::to_string(d.points[2]);
  }

  Vec3d read_vec3(std::string_view what) {
    Vec3d v;
    for (int i = 0; i < 3; ++i) {
      v[i] = in_.real(what);
      if (!std::isfinite(v[i])) in_.fail(std::string(what) + " must be finite");
    }
    return v;
  }

  // vtkImageData's orientation; the model keeps axis-aligned images only.
  void read_direction() {
    for (int i = 0; i < 9; ++i) {
      const double v = in_.real("DIRECTION");
      const double identity = (i % 4 == 0) ? 1.0 : 0.0;
      if (!(std::fabs(v - identity) <= 1e-9)) {
        in_.fail("DIRECTION is not the identity: rotated images are not supported (resample it axis-aligned first)");
      }
    }
  }

  void read_coordinates(int axis) {
    const std::string what = axis_name(axis) + "_COORDINATES";
    if (coords_[size_t(axis)]) in_.fail(what + " given twice");
    coords_at_[size_t(axis)] = keyword_mark();
    const uint64_t n = in_.count("the number of " + what);
    const ValueType type = in_.value_type("the " + what + " data type");
    if (type.is_bit() || type.is_string) in_.fail(what + " cannot be of type " + type.name);
    in_.begin_array(type, n, what);
    std::vector<double> c(n);
    in_.read_chunks<double>(type, n, what, [&](uint64_t first, std::span<const double> chunk) {
      std::copy(chunk.begin(), chunk.end(), c.begin() + ptrdiff_t(first));
    });
    in_.skip_metadata(1);
    coords_[size_t(axis)] = std::move(c);
  }

  // Called when the attributes start (or the file ends): checks the geometry is complete and builds the grid.
  void finish_geometry() {
    if (passes_over_mesh() && (kind_ == Kind::Unstructured || kind_ == Kind::StructuredGrid))
      return count_mesh_passed_over();
    switch (kind_) {
      case Kind::Unstructured: grid_ = build_unstructured(); break;
      case Kind::StructuredGrid: {
        const GridDims d = require_volume_dims();
        if (!points_) in_.fail("STRUCTURED_GRID has no POINTS");
        if (points_->size() != d.point_count()) {
          in_.fail_at(points_at_, "POINTS has " + std::to_string(points_->size()) + " points but DIMENSIONS " +
                                      dims_text(d) + " need " + std::to_string(d.point_count()));
        }
        grid_ = StructuredGrid{d, std::move(*points_), {}};
        break;
      }
      case Kind::StructuredPoints: {
        image_.dims = require_volume_dims();
        grid_ = image_;
        break;
      }
      case Kind::Rectilinear: {
        RectilinearGrid r;
        r.dims = require_volume_dims();
        for (size_t axis = 0; axis < 3; ++axis) {
          const std::string what = axis_name(int(axis)) + "_COORDINATES";
          if (!coords_[axis]) in_.fail("RECTILINEAR_GRID has no " + what);
          if (coords_[axis]->size() != r.dims.points[axis]) {
            in_.fail_at(coords_at_[axis], what + " has " + std::to_string(coords_[axis]->size()) +
                                              " values but DIMENSIONS " + dims_text(r.dims) + " need " +
                                              std::to_string(r.dims.points[axis]));
          }
          r.coords[axis] = std::move(*coords_[axis]);
        }
        grid_ = std::move(r);
        break;
      }
    }
    point_count_ = grid_point_count(grid_);
    if (kind_ != Kind::Unstructured) cell_count_ = grid_cell_count(grid_);
  }

  // A fields-only read's point and cell counts, with the cells the mesh keeps (from their types), for the attributes'
  // checks and the cell data's filter; the points and cell lists themselves were passed over.
  void count_mesh_passed_over() {
    if (kind_ == Kind::StructuredGrid) {
      const GridDims d = require_volume_dims();
      if (!passed_points_) in_.fail("STRUCTURED_GRID has no POINTS");
      point_count_ = d.point_count();
      cell_count_ = d.cell_count();
      return;
    }
    if (!passed_points_) in_.fail("UNSTRUCTURED_GRID has no POINTS");
    check_cells_and_types();
    importer_.emplace(path(), *passed_points_);
    ValueCursor types(file_, in_.binary(), *cell_types_, "CELL_TYPES");
    for (uint64_t c = 0; c < cell_types_->count; ++c) {
      const int type = cell_type_of(types.next());
      at_cell(types, [&] { importer_->add_type_only(type, c); });
    }
    point_count_ = *passed_points_;
    cell_count_ = importer_->file_cell_count();
  }

  void check_cells_and_types() {
    if (!cells_ && !cell_types_) in_.fail("UNSTRUCTURED_GRID has no CELLS: points alone are not a volume");
    if (!cell_types_) in_.fail_at(cells_->at, "CELLS without CELL_TYPES: the file never gives the cell types");
    if (!cells_) in_.fail_at(cell_types_at_, "CELL_TYPES without CELLS: the file never gives the cells' points");
    if (cell_types_->count != cells_->cells) {
      in_.fail_at(cell_types_at_, "CELL_TYPES lists " + std::to_string(cell_types_->count) + " cells but CELLS has " +
                                      std::to_string(cells_->cells));
    }
  }

  GridDims require_volume_dims() {
    if (!dims_) in_.fail(kind_name_ + " has no DIMENSIONS");
    const GridDims d = *dims_;
    if (d.points[0] < 2 || d.points[1] < 2 || d.points[2] < 2) {
      in_.fail_at(dims_at_, "DIMENSIONS " + dims_text(d) + " describe a grid with no volume cells (a dimension of " +
                                "1 makes it 2-D or less): ugvr renders volumes only");
    }
    return d;
  }

  UnstructuredMesh build_unstructured() {
    if (!points_) in_.fail("UNSTRUCTURED_GRID has no POINTS");
    check_cells_and_types();
    importer_.emplace(path(), points_->size());
    if (cells_->count_prefixed) {
      read_count_prefixed_cells();
    } else if (cells_->cells > 0) {
      read_offset_cells();
    }
    UnstructuredMesh mesh;
    mesh.points = std::move(*points_);
    importer_->finish(mesh, warnings_);
    if (mesh.cell_count() == 0) in_.fail("UNSTRUCTURED_GRID has no cells: points alone are not a volume");
    mesh.validate(path());
    cell_count_ = importer_->file_cell_count();
    return mesh;
  }

  // Before 5.0: per cell, its point count then its point ids.
  void read_count_prefixed_cells() {
    ValueCursor types(file_, in_.binary(), *cell_types_, "CELL_TYPES");
    ValueCursor lists(file_, in_.binary(), cells_->lists, "CELLS");
    importer_->reserve(cells_->cells, cells_->lists.count - cells_->cells);
    for (uint64_t c = 0; c < cells_->cells; ++c) {
      const int64_t n = lists.next();
      if (n < 0 || uint64_t(n) > lists.left()) {
        lists.fail("cell " + std::to_string(c) + " lists " + std::to_string(n) + " points but only " +
                   std::to_string(lists.left()) + " values of CELLS are left");
      }
      ids_.resize(size_t(n));
      lists.take(ids_);
      add_cell(lists, types.next(), c);
    }
    if (lists.left() != 0) {
      lists.fail("CELLS declares " + std::to_string(cells_->lists.count) + " values but its " +
                 std::to_string(cells_->cells) + " cells use " + std::to_string(cells_->lists.count - lists.left()));
    }
  }

  // 5.0 and later: cell c uses connectivity[offsets[c] .. offsets[c+1]).
  void read_offset_cells() {
    ValueCursor types(file_, in_.binary(), *cell_types_, "CELL_TYPES");
    ValueCursor offsets(file_, in_.binary(), cells_->offsets, "OFFSETS");
    ValueCursor connectivity(file_, in_.binary(), cells_->connectivity, "CONNECTIVITY");
    const uint64_t total = cells_->connectivity.count;
    importer_->reserve(cells_->cells, total);
    int64_t begin = offsets.next();
    if (begin != 0) offsets.fail("OFFSETS must start at 0, not " + std::to_string(begin));
    for (uint64_t c = 0; c < cells_->cells; ++c) {
      const int64_t end = offsets.next();
      if (end < begin || uint64_t(end) > total) {
        offsets.fail("offset " + std::to_string(c + 1) + " (" + std::to_string(end) + ") is outside [" +
                     std::to_string(begin) + ", " + std::to_string(total) + "]");
      }
      ids_.resize(size_t(end - begin));
      connectivity.take(ids_);
      add_cell(connectivity, types.next(), c);
      begin = end;
    }
    if (uint64_t(begin) != total) {
      offsets.fail("the last offset is " + std::to_string(begin) + " but CONNECTIVITY has " + std::to_string(total) +
                   " values");
    }
  }

  static int cell_type_of(int64_t vtk_type) {
    return (vtk_type >= 0 && vtk_type <= 255) ? int(vtk_type) : -1;  // -1 maps to "unknown cell type"
  }

  void add_cell(const ValueCursor& where, int64_t vtk_type, uint64_t cell) {
    const int type = cell_type_of(vtk_type);
    std::span<const int64_t> ids(ids_);
    at_cell(where, [&] { importer_->add(type, ids, cell); });
  }

  // Runs the importer's `f` on a cell, its error told at `where` in the file.
  template <class F>
  void at_cell(const ValueCursor& where, F&& f) {
    try {
      f();
    } catch (const Error& e) {
      // The importer names the file and cell; add where in the file the cell is.
      std::string_view message = e.what();
      const std::string prefix = path() + ": ";
      if (message.starts_with(prefix)) message.remove_prefix(prefix.size());
      where.fail(message);
    }
  }

  // --- attributes ----------------------------------------------------------------------------------------------

  void read_attributes(const std::string& first_keyword) {
    Section section = open_section(first_keyword);
    for (;;) {
      const std::string keyword(in_.tokens().next_token());
      if (progress_) progress_->set(in_.tokens().offset());
      if (keyword.empty()) return;
      if (is(keyword, "POINT_DATA") || is(keyword, "CELL_DATA")) {
        section = open_section(keyword);
      } else if (is(keyword, "METADATA")) {
        skip_metadata_keyword();
      } else {
        read_attribute(keyword, section);
      }
    }
  }

  Section open_section(const std::string& keyword) {
    Section s;
    s.association = is(keyword, "POINT_DATA") ? Association::Vertex : Association::Cell;
    s.tuples = in_.count("the number of " + s.keyword() + " tuples");
    const bool points = s.association == Association::Vertex;
    const uint64_t want = points ? point_count_ : cell_count_;
    if (s.tuples != want) {
      in_.fail(s.keyword() + " " + std::to_string(s.tuples) + " does not match the " + std::to_string(want) +
               (points ? " points of the grid" : " cells of the file"));
    }
    return s;
  }

  void read_attribute(const std::string& keyword, const Section& s) {
    if (is(keyword, "SCALARS")) return read_scalars(s);
    if (is(keyword, "VECTORS") || is(keyword, "NORMALS")) return read_named_array(keyword, s, 3);
    if (is(keyword, "TENSORS")) return read_named_array(keyword, s, 9);
    if (is(keyword, "TENSORS6")) return read_named_array(keyword, s, 6);
    if (is(keyword, "GLOBAL_IDS") || is(keyword, "PEDIGREE_IDS") || is(keyword, "EDGE_FLAGS")) {
      return read_named_array(keyword, s, 1);
    }
    if (is(keyword, "TEXTURE_COORDINATES")) {
      const std::string name = vtk_legacy::decode_name(in_.word("the TEXTURE_COORDINATES name"));
      const int dim = in_.components("the TEXTURE_COORDINATES dimension");
      if (dim > 3) in_.fail("TEXTURE_COORDINATES dimension must be 1, 2 or 3, not " + std::to_string(dim));
      return read_typed_array(name, keyword, s, dim);
    }
    if (is(keyword, "COLOR_SCALARS")) return read_color_scalars(s);
    if (is(keyword, "LOOKUP_TABLE")) {
      in_.word("the LOOKUP_TABLE name");
      return in_.skip_lookup_table(in_.count("the LOOKUP_TABLE size"));
    }
    if (is(keyword, "FIELD")) return read_field(&s);
    in_.fail("unexpected keyword '" + keyword.substr(0, 40) + "' in " + s.keyword() +
             " (expected SCALARS, VECTORS, NORMALS, TENSORS, TENSORS6, TEXTURE_COORDINATES, COLOR_SCALARS, "
             "GLOBAL_IDS, PEDIGREE_IDS, EDGE_FLAGS, LOOKUP_TABLE, FIELD, POINT_DATA or CELL_DATA)");
  }

  // SCALARS name type [numComp] then LOOKUP_TABLE tableName.
  void read_scalars(const Section& s) {
    const std::string name = vtk_legacy::decode_name(in_.word("the SCALARS name"));
    const ValueType type = in_.value_type("the SCALARS data type");
    int components = 1;
    std::string next(in_.word("LOOKUP_TABLE"));
    if (!is(next, "LOOKUP_TABLE")) {
      uint64_t n = 0;
      if (!parse_number(next, n) || n < 1 || n > uint64_t(LegacyInput::kMaxComponents)) {
        in_.fail("expected a component count or LOOKUP_TABLE after SCALARS " + name + ", found '" + next.substr(0, 40) +
                 "'");
      }
      components = int(n);
      in_.expect_keyword("LOOKUP_TABLE");
    }
    in_.word("the lookup table name");
    add_field(name, s, in_.read_array(type, s.tuples, components, "SCALARS " + name));
  }

  // KEYWORD name type, with a fixed number of components.
  void read_named_array(const std::string& keyword, const Section& s, int components) {
    const std::string name = vtk_legacy::decode_name(in_.word("the " + keyword + " name"));
    read_typed_array(name, keyword, s, components);
  }

  void read_typed_array(const std::string& name, const std::string& keyword, const Section& s, int components) {
    const ValueType type = in_.value_type("the " + keyword + " data type");
    const std::string what = keyword + " " + name;
    if (type.is_string) {
      in_.skip_string_array(in_.value_count(what, s.tuples, components), what);
      warnings_.push_back(path() + ": ignored string array '" + name + "'");
      return;
    }
    add_field(name, s, in_.read_array(type, s.tuples, components, what));
  }

  // COLOR_SCALARS name numComp: unsigned char in BINARY files, floats in [0, 1] in ASCII ones.
  void read_color_scalars(const Section& s) {
    const std::string name = vtk_legacy::decode_name(in_.word("the COLOR_SCALARS name"));
    const int components = in_.components("the COLOR_SCALARS component count");
    const std::string what = "COLOR_SCALARS " + name;
    if (in_.binary()) {
      add_field(name, s, in_.read_array(value_type_named("unsigned_char"), s.tuples, components, what));
      return;
    }
    const DataArray floats = in_.read_array(value_type_named("float"), s.tuples, components, what);
    DataArray bytes(ScalarType::UInt8, components, s.tuples);
    const std::span<const float> in = floats.values<float>();
    const std::span<uint8_t> out = bytes.values<uint8_t>();
    for (size_t i = 0; i < in.size(); ++i) {
      const float v = 255.0f * in[i] + 0.5f;  // as vtkDataReader::ReadCoScalarData, clamped (NaN becomes 0)
      out[i] = v >= 255.0f ? uint8_t(255) : (v >= 0.0f ? uint8_t(v) : uint8_t(0));
    }
    add_field(name, s, std::move(bytes));
  }

  // FIELD name numArrays, then the arrays. `s` is null for dataset-level field data, which is not kept: its arrays
  // belong to neither the points nor the cells.
  void read_field(const Section* s) {
    const std::string field_name = vtk_legacy::decode_name(in_.word("the FIELD name"));
    const uint64_t arrays = in_.count("the number of FIELD arrays");
    for (uint64_t i = 0; i < arrays; ++i) {
      const std::string word(in_.word("a FIELD array name"));
      if (word == "NULL_ARRAY") continue;  // an empty slot (5.1); VTK compares it case-sensitively
      const std::string name = vtk_legacy::decode_name(word);
      const std::string what = "FIELD array " + name;
      const int components = in_.components("the component count of " + what);
      const uint64_t tuples = in_.count("the tuple count of " + what);
      const ValueType type = in_.value_type("the data type of " + what);
      if (type.is_string) {
        in_.skip_string_array(in_.value_count(what, tuples, components), what);
        if (s) warnings_.push_back(path() + ": ignored string array '" + name + "'");
        continue;
      }
      if (!s) {
        in_.skip_array(type, tuples, components, what);
        continue;
      }
      if (tuples != s->tuples) {
        in_.fail(what + " has " + std::to_string(tuples) + " tuples but " + s->keyword() + " has " +
                 std::to_string(s->tuples));
      }
      add_field(name, *s, in_.read_array(type, tuples, components, what));
    }
    if (!s && arrays > 0) {
      warnings_.push_back(path() + ": ignored dataset-level FIELD '" + field_name + "' (" + std::to_string(arrays) +
                          " arrays that belong to neither points nor cells)");
    }
  }

  void add_field(const std::string& name, const Section& s, DataArray data) {
    if (s.association == Association::Cell && importer_) data = importer_->filter_cell_data(std::move(data));
    Field field(name, s.association, std::move(data));
    const auto key = std::make_pair(s.association, name);
    if (const auto it = field_index_.find(key); it != field_index_.end()) {
      // vtkFieldData::AddArray replaces an array of the same name.
      warnings_.push_back(path() + ": " + std::string(association_name(s.association)) + " field '" + name +
                          "' appears twice; the later one is kept");
      fields_[it->second] = std::move(field);
      return;
    }
    field_index_.emplace(key, fields_.size());
    fields_.push_back(std::move(field));
  }

  InputFile file_;
  LegacyInput in_;
  Pass pass_;
  uint64_t version_line_end_ = 0;  // the geometry key's first bytes
  uint64_t segment_begin_ = 0;     // where the geometry key's next bytes start
  uint64_t key_ = 0;
  std::optional<uint64_t> passed_points_;  // POINTS' count where its values were passed over
  std::optional<Progress> progress_;
  std::vector<std::string> warnings_;
  std::string title_, version_, kind_name_;
  int major_ = 0, minor_ = 0;
  Kind kind_ = Kind::Unstructured;

  // Geometry as read.
  std::optional<std::vector<Vec3f>> points_;
  Mark points_at_;
  std::optional<GridDims> dims_;
  Mark dims_at_;
  ImageGrid image_;
  std::array<std::optional<std::vector<double>>, 3> coords_;
  std::array<Mark, 3> coords_at_;
  std::optional<CellLists> cells_;
  std::optional<DeferredArray> cell_types_;
  Mark cell_types_at_;
  std::optional<VtkCellImporter> importer_;
  std::vector<int64_t> ids_;  // the point ids of the cell being read

  // The grid and its fields.
  Grid grid_;
  uint64_t point_count_ = 0, cell_count_ = 0;
  std::vector<Field> fields_;
  std::map<std::pair<Association, std::string>, size_t> field_index_;
};

}  // namespace

Dataset read_vtk_legacy(const std::string& path) { return LegacyReader(path).read(); }

std::optional<uint64_t> vtk_legacy_geometry_key(const std::string& path) {
  if (extension_lower(path) != ".vtk") return std::nullopt;
  return LegacyReader(path, Pass::GeometryKey).geometry_key();
}

FieldSet read_vtk_legacy_fields(const std::string& path, std::string& format, std::vector<std::string>& warnings) {
  return LegacyReader(path, Pass::FieldsOnly).read_fields(format, warnings);
}

}  // namespace ugvr
