// AVS UCD reader (.inp, ASCII), after the AVS/Express "UCD file format" and VTK's vtkAVSucdReader.
//
// Layout (whitespace-separated; '#' lines at the top are comments):
//   nnodes ncells nnodedata ncelldata nmodeldata     header; n*data = total values per node / cell
//   id x y z                                          nnodes lines; ids arbitrary (usually 1-based), mapped
//   id material type n1 .. nk                         ncells lines; type pt line tri quad tet pyr prism hex
//   ncomp size1 .. sizeN                              node data (if nnodedata > 0): component groups, sizes summing
//   label, units                                      to nnodedata; one "label, units" line per group
//   id v1 .. v(nnodedata)                             nnodes lines, in any node order
//   (the same for cell data if ncelldata > 0; model data after it is ignored)
// Each group becomes a Float64 field of `size` components named by its label; the material becomes the Int32 cell
// field "material". pt/line/tri/quad cells are dropped with a warning (VtkCellImporter's policy).
//
// Node orderings. AVS numbers volume cells with the first face turned the other way from VTK's:
//   tet   n1 n2 n3 n4         -> VTK n1 n3 n2 n4   (verified on spx.inp: 12,924 of its 12,936 tets have negative
//                                                   volume read in file order; swapped, all but 12 are positive)
//   pyr   apex n1, base n2..n5 -> VTK n2 n3 n4 n5 n1 (the apex moves last, as vtkAVSucdReader does; the base turns
//                                                   towards the apex as the tet's first face does)
//   prism n1 n2 n3 / n4 n5 n6 -> VTK unchanged     (AVS draws the prism like the hex; with the first face turned
//                                                   outwards that is VTK's wedge, whose base normal points outwards)
//   hex   n1..n4 / n5..n8     -> VTK n5..n8 n1..n4 (AVS's hex is deal.II's old "UCD numbering", whose first face
//                                                   turns away from the second)
// No real file with pyramids, prisms or hexahedra was at hand: a file whose cells come out inverted anyway is read as
// it is, with a warning counting the inverted cells per type, so a writer with another convention shows up.
//
// Variants: binary UCD (first byte 7) and multi-step files (a step count alone on the first line) are refused with
// a message saying so.
//
// Streaming: read through TextTokenizer; counts from the header are checked against the bytes left before anything
// is reserved (ASCII values take at least 2 bytes each).
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/file_dataset.h"
#include "ugvr/io/id_map.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/text_tokenizer.h"
#include "ugvr/io/vtk_cell_import.h"

namespace ugvr {

namespace {

struct AvsCellType {
  std::string_view name;
  int vtk_type;
  uint8_t nodes;
  std::array<uint8_t, 8> to_vtk;  // VTK vertex k is AVS node to_vtk[k]
};

constexpr std::array<AvsCellType, 8> kCellTypes = {{
    {"pt", 1, 1, {0}},
    {"line", 3, 2, {0, 1}},
    {"tri", 5, 3, {0, 1, 2}},
    {"quad", 9, 4, {0, 1, 2, 3}},
    {"tet", 10, 4, {0, 2, 1, 3}},
    {"pyr", 14, 5, {1, 2, 3, 4, 0}},
    {"prism", 13, 6, {0, 1, 2, 3, 4, 5}},
    {"hex", 12, 8, {4, 5, 6, 7, 0, 1, 2, 3}},
}};

const AvsCellType* cell_type_named(std::string_view name) {
  for (const AvsCellType& t : kCellTypes) {
    if (equals_ignore_case(name, t.name)) return &t;
  }
  return nullptr;
}

std::string trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return std::string(s);
}

class AvsUcdReader {
 public:
  explicit AvsUcdReader(const std::string& path) : file_(path), t_(file_) {}

  Dataset read() {
    reject_binary();
    skip_comments();
    read_header();
    read_nodes();
    read_cells();
    Block block{file_.name(), UnstructuredMesh{}, FieldSet{}};
    auto& mesh = std::get<UnstructuredMesh>(block.grid);
    mesh.points = std::move(points_);
    importer_->finish(mesh, warnings_);
    warn_inverted(mesh);
    block.fields.add(
        Field("material", Association::Cell, importer_->filter_cell_data(DataArray::from(std::move(materials_), 1))));
    if (node_values_ > 0) read_data(Association::Vertex, block.fields);
    if (cell_values_ > 0) read_data(Association::Cell, block.fields);
    mesh.validate(path());
    return single_block_dataset("AVS UCD ASCII (.inp)", path(), std::move(block), std::move(warnings_));
  }

 private:
  const std::string& path() const { return file_.path(); }

  void reject_binary() {
    char first = 0;
    if (file_.read_some_at(0, &first, 1) == 1 && first == 7) {
      fail_in(path(), "binary AVS UCD files are not supported (first byte 7); write the file as ASCII UCD");
    }
  }

  void skip_comments() {
    while (t_.peek_token().starts_with("#")) t_.skip_line();
  }

  uint64_t count(std::string_view what) { return t_.next_number<uint64_t>(what); }

  void read_header() {
    nnodes_ = count("the number of nodes");
    if (t_.at_line_end()) {
      t_.fail_at_token_line(
          "a single number on the first line: this is a multi-step AVS UCD file, which is not supported (expected "
          "\"nnodes ncells nnodedata ncelldata nmodeldata\")");
    }
    ncells_ = count("the number of cells");
    node_values_ = count("the number of node data values");
    cell_values_ = count("the number of cell data values");
    count("the number of model data values");
    if (nnodes_ > std::numeric_limits<uint32_t>::max()) {
      t_.fail_at_token_line(std::to_string(nnodes_) + " nodes: an in-memory mesh holds at most 2^32-1 vertices");
    }
    // A node line holds 4 values, a cell line at least 4.
    check_count_fits(path(), t_.offset(), "node", nnodes_, 8, t_.bytes_left());
    check_count_fits(path(), t_.offset(), "cell", ncells_, 8, t_.bytes_left() - nnodes_ * 8);
    check_count_fits(path(), t_.offset(), "node data value", node_values_, 2, t_.bytes_left());
    check_count_fits(path(), t_.offset(), "cell data value", cell_values_, 2, t_.bytes_left());
  }

  void read_nodes() {
    points_.resize(nnodes_);
    for (uint64_t i = 0; i < nnodes_; ++i) {
      const int64_t id = t_.next_number<int64_t>("a node id");
      if (!node_ids_.add(id)) t_.fail_at_token_line("node id " + std::to_string(id) + " defined twice");
      for (int c = 0; c < 3; ++c) {
        const double v = t_.next_number<double>("a node coordinate");
        if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
          t_.fail_at_token_line("coordinate " + std::to_string(v) + " is beyond the float32 range points are kept in");
        }
        points_[i][c] = float(v);
      }
    }
  }

  void read_cells() {
    importer_.emplace(path(), nnodes_);
    importer_->reserve(ncells_, ncells_ * 4);
    materials_.reserve(ncells_);
    std::array<uint32_t, 8> nodes{}, vtk{};
    for (uint64_t c = 0; c < ncells_; ++c) {
      const int64_t id = t_.next_number<int64_t>("a cell id");
      if (!cell_ids_.add(id)) t_.fail_at_token_line("cell id " + std::to_string(id) + " defined twice");
      materials_.push_back(t_.next_number<int32_t>("the cell's material id"));
      const std::string_view type_name = t_.next_token();
      const AvsCellType* type = cell_type_named(type_name);
      if (!type) {
        if (type_name.empty()) t_.fail_at_token_line("unexpected end of file: expected a cell type");
        t_.fail_at_token_line("unknown cell type '" + std::string(type_name.substr(0, 40)) +
                              "' (expected pt, line, tri, quad, tet, pyr, prism or hex)");
      }
      for (uint8_t k = 0; k < type->nodes; ++k) {
        const int64_t node = t_.next_number<int64_t>("a node id of cell " + std::to_string(id));
        const std::optional<uint32_t> index = node_ids_.find(node);
        if (!index)
          t_.fail_at_token_line("cell " + std::to_string(id) + " uses undefined node " + std::to_string(node));
        nodes[k] = *index;
      }
      // A cell line must end after its nodes: more numbers there means the type and the node count disagree.
      if (!t_.at_line_end()) {
        t_.next_token();
        t_.fail_at_token_line("cell " + std::to_string(id) + " of type " + std::string(type->name) + " has more than " +
                              std::to_string(type->nodes) + " node ids");
      }
      for (uint8_t k = 0; k < type->nodes; ++k) vtk[k] = nodes[type->to_vtk[k]];
      importer_->add<uint32_t>(type->vtk_type, std::span<const uint32_t>(vtk.data(), type->nodes), c);
    }
  }

  void warn_inverted(const UnstructuredMesh& mesh) {
    CellTypeCounts inverted;
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (cell_volume(mesh, c) < 0) ++inverted[mesh.cell_types[c]];
    }
    if (inverted.total() == 0) return;
    std::string detail;
    for (CellType type : kAllCellTypes) {
      if (inverted[type] == 0) continue;
      detail += (detail.empty() ? "" : ", ") + std::to_string(inverted[type]) + " " + std::string(cell_name(type));
    }
    warnings_.push_back(path() + ": " + std::to_string(inverted.total()) + " cell(s) have negative volume (" + detail +
                        "): inverted or degenerate in the file");
  }

  // A node or cell data section: component groups, their labels, then one line of values per node / cell.
  void read_data(Association association, FieldSet& fields) {
    const bool vertex = association == Association::Vertex;
    const std::string what = vertex ? "node data" : "cell data";
    const uint64_t total = vertex ? node_values_ : cell_values_;
    const uint64_t tuples = vertex ? nnodes_ : ncells_;
    const uint64_t groups = count("the number of " + what + " components");
    if (groups == 0 || groups > total) {
      t_.fail_at_token_line(what + ": " + std::to_string(groups) + " components for " + std::to_string(total) +
                            " values per " + (vertex ? "node" : "cell") + " given in the header");
    }
    std::vector<int> sizes;
    uint64_t sum = 0;
    for (uint64_t g = 0; g < groups; ++g) {
      const uint64_t size = count("the size of a " + what + " component");
      if (size == 0 || size > total - sum) {
        t_.fail_at_token_line(what + " component sizes must be positive and sum to " + std::to_string(total) +
                              " (the header's count)");
      }
      sum += size;
      sizes.push_back(int(size));
    }
    if (sum != total) {
      t_.fail_at_token_line(what + " component sizes sum to " + std::to_string(sum) + ", the header says " +
                            std::to_string(total));
    }
    t_.skip_line();
    std::vector<std::string> names;
    for (uint64_t g = 0; g < groups; ++g) {
      const std::optional<std::string_view> line = t_.read_line();
      if (!line) t_.fail_at_token_line("unexpected end of file: expected the label line of a " + what + " component");
      std::string name = trim(line->substr(0, line->find(',')));
      if (name.empty()) name = (vertex ? "node_data_" : "cell_data_") + std::to_string(g);
      names.push_back(std::move(name));
    }
    check_count_fits(path(), t_.offset(), what + " line", tuples, 2 * (total + 1), t_.bytes_left());
    std::vector<std::vector<double>> values(groups);
    for (uint64_t g = 0; g < groups; ++g) values[g].assign(tuples * uint64_t(sizes[g]), 0.0);
    std::vector<uint8_t> seen(tuples, 0);
    const IdMap& ids = vertex ? node_ids_ : cell_ids_;
    for (uint64_t i = 0; i < tuples; ++i) {
      const int64_t id = t_.next_number<int64_t>(std::string("a ") + (vertex ? "node" : "cell") + " id");
      const std::optional<uint32_t> index = ids.find(id);
      if (!index) t_.fail_at_token_line(what + " for undefined " + (vertex ? "node " : "cell ") + std::to_string(id));
      if (seen[*index]++) t_.fail_at_token_line(what + " given twice for id " + std::to_string(id));
      for (uint64_t g = 0; g < groups; ++g) {
        for (int k = 0; k < sizes[g]; ++k) {
          values[g][*index * uint64_t(sizes[g]) + uint64_t(k)] = t_.next_number<double>(what + " value");
        }
      }
    }
    for (uint64_t g = 0; g < groups; ++g) {
      DataArray data = DataArray::from(std::move(values[g]), sizes[g]);
      if (!vertex) data = importer_->filter_cell_data(std::move(data));
      fields.add(Field(names[g], association, std::move(data)));
    }
  }

  InputFile file_;
  TextTokenizer t_;
  uint64_t nnodes_ = 0, ncells_ = 0, node_values_ = 0, cell_values_ = 0;
  std::vector<Vec3f> points_;
  IdMap node_ids_, cell_ids_;
  std::optional<VtkCellImporter> importer_;
  std::vector<int32_t> materials_;
  std::vector<std::string> warnings_;
};

}  // namespace

Dataset read_avs_ucd(const std::string& path) { return AvsUcdReader(path).read(); }

}  // namespace ugvr
