// TetGen reader: a .node file and the .ele file beside it (either may be named; the other is found by swapping the
// extension), after the TetGen 1.6 manual (wias-berlin.de/software/tetgen/fformats.html).
//
//   x.node   npoints dim nattr nmarker       dim must be 3; nmarker 0 or 1
//            id x y z a1..a(nattr) [marker]  npoints lines; ids consecutive from 0 or 1 (the first id decides)
//   x.ele    ntets nodes_per_tet nattr       nodes_per_tet 4 or 10
//            id n1..nk a1..a(nattr)          ntets lines; node ids in the .node file's numbering
// '#' starts a comment anywhere, up to the end of its line. Point attributes become Float64 vertex fields
// "attribute_k", the boundary marker the Int32 vertex field "boundary_marker", element (region) attributes Float64
// cell fields "attribute_k". 10-node tetrahedra are linearised to their 4 corners (the first four nodes).
//
// Orientation: TetGen orders a tetrahedron by its own orient3d sign convention, which is opposite to VTK's in some
// TetGen versions and writers. The reader measures the signed volume of every tetrahedron as listed; when most are
// negative the file uses the opposite convention and every tetrahedron gets its vertices 1 and 2 swapped (which turns
// it into VTK's orientation without moving any vertex). Tetrahedra still inverted after that are counted in a warning.
//
// Streaming: TextTokenizer over each file; counts are checked against the bytes left before anything is reserved.
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {

namespace {

// TextTokenizer with TetGen's '#' comments removed.
class TetGenInput {
 public:
  explicit TetGenInput(const InputFile& file) : t_(file) {}
  TextTokenizer& tokens() { return t_; }
  const std::string& path() const { return t_.file().path(); }

  std::string_view token() {
    for (;;) {
      if (comment_pending_) {
        t_.skip_line();
        comment_pending_ = false;
      }
      std::string_view tok = t_.next_token();
      const size_t hash = tok.find('#');
      if (hash == std::string_view::npos) return tok;
      comment_pending_ = true;  // the rest of the line is skipped before the next token
      if (hash > 0) return tok.substr(0, hash);
    }
  }

  template <class T>
  T number(std::string_view what) {
    const std::string_view tok = token();
    if (tok.empty()) t_.fail_at_token_line("unexpected end of file: expected " + std::string(what));
    T value{};
    if (!parse_number(tok, value)) {
      t_.fail_at_token_line("expected " + std::string(std::is_integral_v<T> ? "an integer" : "a number") + " for " +
                            std::string(what) + ", found '" + std::string(tok.substr(0, 40)) + "'");
    }
    return value;
  }

  [[noreturn]] void fail(std::string_view message) const { t_.fail_at_token_line(message); }

 private:
  TextTokenizer t_;
  bool comment_pending_ = false;
};

std::string sibling(const std::string& path, std::string_view want_ext) {
  const std::string ext = extension_lower(path);
  if (ext != ".node" && ext != ".ele") {
    fail_in(path, "a TetGen mesh is named by its .node or .ele file, not '" + ext + "'");
  }
  return path.substr(0, path.size() - ext.size()) + std::string(want_ext);
}

struct Nodes {
  std::vector<Vec3f> points;
  int64_t first_id = 0;
  std::vector<std::vector<double>> attributes;
  std::vector<int32_t> markers;
  bool has_markers = false;
};

Nodes read_node_file(const InputFile& file) {
  TetGenInput in(file);
  Nodes n;
  const uint64_t count = in.number<uint64_t>("the number of points");
  const uint64_t dim = in.number<uint64_t>("the dimension");
  if (dim != 3) in.fail("dimension " + std::to_string(dim) + ": only 3-D TetGen meshes are volumes");
  const uint64_t nattr = in.number<uint64_t>("the number of point attributes");
  const uint64_t nmarker = in.number<uint64_t>("the boundary marker flag (0 or 1)");
  if (nmarker > 1) in.fail("the boundary marker flag must be 0 or 1, not " + std::to_string(nmarker));
  if (count > std::numeric_limits<uint32_t>::max()) {
    in.fail(std::to_string(count) + " points: an in-memory mesh holds at most 2^32-1 vertices");
  }
  const uint64_t per_line = 4 + nattr + nmarker;
  check_count_fits(file.path(), in.tokens().offset(), "point attribute", nattr, 2, in.tokens().bytes_left());
  check_count_fits(file.path(), in.tokens().offset(), "point", count, 2 * per_line, in.tokens().bytes_left());
  n.points.resize(count);
  n.attributes.assign(nattr, std::vector<double>(count));
  n.has_markers = nmarker == 1;
  if (n.has_markers) n.markers.resize(count);
  for (uint64_t i = 0; i < count; ++i) {
    const int64_t id = in.number<int64_t>("a point id");
    if (i == 0) {
      if (id != 0 && id != 1)
        in.fail("the first point id must be 0 or 1 (the numbering base), not " + std::to_string(id));
      n.first_id = id;
    } else if (id != n.first_id + int64_t(i)) {
      in.fail("point id " + std::to_string(id) + " out of sequence: expected " +
              std::to_string(n.first_id + int64_t(i)));
    }
    for (int c = 0; c < 3; ++c) {
      const double v = in.number<double>("a point coordinate");
      if (std::isfinite(v) && std::fabs(v) > double(std::numeric_limits<float>::max())) {
        in.fail("coordinate " + std::to_string(v) + " is beyond the float32 range points are kept in");
      }
      n.points[i][c] = float(v);
    }
    for (uint64_t a = 0; a < nattr; ++a) n.attributes[a][i] = in.number<double>("a point attribute");
    if (n.has_markers) n.markers[i] = in.number<int32_t>("a boundary marker");
  }
  return n;
}

struct Elements {
  UnstructuredMesh cells;  // without points
  std::vector<std::vector<double>> attributes;
  uint64_t nodes_per_tet = 4;
};

Elements read_ele_file(const InputFile& file, const Nodes& nodes) {
  TetGenInput in(file);
  Elements e;
  const uint64_t count = in.number<uint64_t>("the number of tetrahedra");
  e.nodes_per_tet = in.number<uint64_t>("the number of nodes per tetrahedron (4 or 10)");
  if (e.nodes_per_tet != 4 && e.nodes_per_tet != 10) {
    in.fail("nodes per tetrahedron must be 4 or 10, not " + std::to_string(e.nodes_per_tet));
  }
  const uint64_t nattr = in.number<uint64_t>("the number of element attributes");
  check_count_fits(file.path(), in.tokens().offset(), "element attribute", nattr, 2, in.tokens().bytes_left());
  check_count_fits(file.path(), in.tokens().offset(), "tetrahedron", count, 2 * (1 + e.nodes_per_tet + nattr),
                   in.tokens().bytes_left());
  e.cells.reserve(count, count * 4);
  e.attributes.assign(nattr, std::vector<double>(count));
  const uint64_t npoints = nodes.points.size();
  std::array<uint32_t, 4> v{};
  for (uint64_t c = 0; c < count; ++c) {
    in.number<int64_t>("a tetrahedron id");
    for (uint64_t k = 0; k < e.nodes_per_tet; ++k) {
      const int64_t id = in.number<int64_t>("a node id of a tetrahedron");
      const uint64_t index = uint64_t(id) - uint64_t(nodes.first_id);
      if (id < nodes.first_id || index >= npoints) {
        in.fail("node id " + std::to_string(id) + " is outside the .node file's ids [" +
                std::to_string(nodes.first_id) + ", " + std::to_string(nodes.first_id + int64_t(npoints) - 1) + "]");
      }
      if (k < 4) v[k] = uint32_t(index);
    }
    for (uint64_t a = 0; a < nattr; ++a) e.attributes[a][c] = in.number<double>("an element attribute");
    e.cells.add_cell(CellType::Tetra, v);
  }
  return e;
}

}  // namespace

Dataset read_tetgen(const std::string& path) {
  const InputFile node_file(sibling(path, ".node"));
  const InputFile ele_file(sibling(path, ".ele"));
  Nodes nodes = read_node_file(node_file);
  Elements elements = read_ele_file(ele_file, nodes);

  Block block{base_name(node_file.path().substr(0, node_file.path().size() - 5)), UnstructuredMesh{}, FieldSet{}};
  auto& mesh = std::get<UnstructuredMesh>(block.grid);
  mesh = std::move(elements.cells);
  mesh.points = std::move(nodes.points);
  Dataset d;
  bool flipped = false;
  const uint64_t inverted = orient_tetrahedra_by_majority(mesh, flipped);
  if (inverted > 0) {
    d.warnings.push_back(ele_file.path() + ": " + std::to_string(inverted) +
                         " tetrahedra have negative volume after orientation (inverted in the file)");
  }
  for (size_t a = 0; a < nodes.attributes.size(); ++a) {
    block.fields.add(Field("attribute_" + std::to_string(a), Association::Vertex,
                           DataArray::from(std::move(nodes.attributes[a]), 1)));
  }
  if (nodes.has_markers) {
    block.fields.add(Field("boundary_marker", Association::Vertex, DataArray::from(std::move(nodes.markers), 1)));
  }
  for (size_t a = 0; a < elements.attributes.size(); ++a) {
    block.fields.add(Field("attribute_" + std::to_string(a), Association::Cell,
                           DataArray::from(std::move(elements.attributes[a]), 1)));
  }
  mesh.validate(ele_file.path());
  block.validate_fields(ele_file.path());
  d.format = "TetGen .node/.ele (" + std::to_string(nodes.first_id) + "-based, " +
             std::to_string(elements.nodes_per_tet) + "-node tetrahedra" +
             (flipped ? ", reoriented to VTK's convention)" : ")");
  d.sources = {node_file.path(), ele_file.path()};
  d.blocks.push_back(std::move(block));
  return d;
}

}  // namespace ugvr
