// Gmsh reader: one mixed mesh (every volume type, a higher-order tetrahedron, dropped surface and line elements,
// sparse tags, node and element data, two time steps) written by a small test-side writer as MSH 2.2 and 4.1, ASCII
// and binary (both byte orders), must read identically with positive cell volumes; malformed files must fail with
// the file name and the line (ASCII) or byte offset (binary).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

struct Node {
  uint64_t tag;
  double x, y, z;
};
struct Element {
  uint64_t tag;
  int type;
  int dim;
  int entity;
  int physical;
  std::vector<uint64_t> nodes;
};

// The mesh of every test, in Gmsh node orderings: a unit hexahedron, a prism, a pyramid, a tetrahedron and a
// 10-node tetrahedron, each with its own nodes, plus a triangle and a line that the reader drops.
struct Model {
  std::vector<Node> nodes;
  std::vector<Element> elements;
};

Model make_model() {
  Model m;
  auto node = [&](double x, double y, double z) {
    const uint64_t tag = 10 * m.nodes.size() + 7;  // sparse, arbitrary tags
    m.nodes.push_back({tag, x, y, z});
    return tag;
  };
  auto nodes = [&](std::vector<std::array<double, 3>> ps) {
    std::vector<uint64_t> tags;
    for (const auto& p : ps) tags.push_back(node(p[0], p[1], p[2]));
    return tags;
  };
  uint64_t etag = 1000;
  auto element = [&](int type, int dim, int entity, int physical, std::vector<uint64_t> ns) {
    m.elements.push_back({etag, type, dim, entity, physical, std::move(ns)});
    etag += 7;
  };
  element(5, 3, 1, 100,
          nodes({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}));
  element(6, 3, 1, 100, nodes({{2, 0, 0}, {3, 0, 0}, {2, 1, 0}, {2, 0, 1}, {3, 0, 1}, {2, 1, 1}}));
  element(7, 3, 2, 200, nodes({{4, 0, 0}, {5, 0, 0}, {5, 1, 0}, {4, 1, 0}, {4.5, 0.5, 1}}));
  element(4, 3, 2, 200, nodes({{6, 0, 0}, {7, 0, 0}, {6, 1, 0}, {6, 0, 1}}));
  element(11, 3, 2, 200,
          nodes({{8, 0, 0},
                 {9, 0, 0},
                 {8, 1, 0},
                 {8, 0, 1},
                 {8.5, 0, 0},
                 {8.5, 0.5, 0},
                 {8, 0.5, 0},
                 {8, 0, 0.5},
                 {8, 0.5, 0.5},
                 {8.5, 0, 0.5}}));
  element(2, 2, 5, 300, {m.nodes[0].tag, m.nodes[1].tag, m.nodes[2].tag});
  element(1, 1, 7, 400, {m.nodes[0].tag, m.nodes[1].tag});
  return m;
}

struct Options {
  int version = 41;  // 22 or 41
  bool binary = false;
  bool big_endian = false;
  bool entities = true;  // 4.1: write $Entities (physical groups)
  bool data = true;
};

// Writes a model in one MSH variant.
class MshWriter {
 public:
  explicit MshWriter(Options o) : o_(o) {}

  std::string write(const Model& m) {
    text("$MeshFormat\n");
    text(o_.version == 22 ? "2.2 " : "4.1 ");
    text(o_.binary ? "1 8\n" : "0 8\n");
    if (o_.binary) {
      bin(int32_t(1));
      text("\n");
    }
    text("$EndMeshFormat\n");
    text("$PhysicalNames\n2\n3 100 \"solid one\"\n3 200 \"solid two\"\n$EndPhysicalNames\n");
    text("$Comments\nanything $Nodes here\n$EndComments\n");
    if (o_.version == 41 && o_.entities) entities();
    o_.version == 22 ? nodes22(m) : nodes41(m);
    o_.version == 22 ? elements22(m) : elements41(m);
    if (o_.data) data(m);
    return out_;
  }

 private:
  void text(std::string_view s) { out_ += s; }
  template <class T>
  void bin(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof v);
    if (o_.big_endian) std::reverse(b, b + sizeof b);
    out_.append(b, sizeof b);
  }
  void i(int32_t v) { o_.binary ? bin(v) : text(std::to_string(v) + " "); }
  void sz(uint64_t v) { o_.binary ? bin(v) : text(std::to_string(v) + " "); }
  void d(double v) {
    if (o_.binary) return bin(v);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g ", v);
    text(buf);
  }
  void nl() {
    if (!o_.binary) text("\n");
  }
  void end(std::string_view name) {
    if (o_.binary) text("\n");
    text("$End");
    text(name);
    text("\n");
  }

  void entities() {
    text("$Entities\n");
    for (uint64_t n : {0, 1, 1, 2}) sz(n);
    nl();
    auto entity = [&](int tag, std::vector<int> physical, std::vector<int> bounding) {
      i(tag);
      for (int k = 0; k < 6; ++k) d(k * 0.5);
      sz(physical.size());
      for (int p : physical) i(p);
      sz(bounding.size());
      for (int b : bounding) i(b);
      nl();
    };
    entity(7, {400}, {1, -2});
    entity(5, {300}, {7});
    entity(1, {100, 101}, {5});
    entity(2, {200}, {5, 6});
    end("Entities");
  }

  void nodes22(const Model& m) {
    text("$Nodes\n" + std::to_string(m.nodes.size()) + "\n");
    for (const Node& n : m.nodes) {
      i(int32_t(n.tag));
      d(n.x), d(n.y), d(n.z);
      nl();
    }
    end("Nodes");
  }

  // Two blocks: the first 20 nodes plain, the rest with (skipped) parametric coordinates of a surface.
  void nodes41(const Model& m) {
    text("$Nodes\n");
    sz(2), sz(m.nodes.size()), sz(7), sz(m.nodes.back().tag);
    nl();
    const size_t split = 20;
    for (int b = 0; b < 2; ++b) {
      const size_t first = b == 0 ? 0 : split, last = b == 0 ? split : m.nodes.size();
      i(b == 0 ? 3 : 2), i(b == 0 ? 1 : 5), i(b), sz(last - first);
      nl();
      for (size_t k = first; k < last; ++k) sz(m.nodes[k].tag), nl();
      for (size_t k = first; k < last; ++k) {
        d(m.nodes[k].x), d(m.nodes[k].y), d(m.nodes[k].z);
        if (b == 1) d(0.25), d(0.75);
        nl();
      }
    }
    end("Nodes");
  }

  void elements22(const Model& m) {
    text("$Elements\n" + std::to_string(m.elements.size()) + "\n");
    for (size_t k = 0; k < m.elements.size();) {
      // Binary groups consecutive elements of one type under one header.
      size_t n = 1;
      while (k + n < m.elements.size() && m.elements[k + n].type == m.elements[k].type) ++n;
      if (o_.binary) i(m.elements[k].type), i(int32_t(n)), i(2);
      for (size_t e = k; e < k + n; ++e) {
        const Element& el = m.elements[e];
        i(int32_t(el.tag));
        if (!o_.binary) i(el.type), i(2);
        i(el.physical), i(el.entity);
        for (uint64_t t : el.nodes) i(int32_t(t));
        nl();
      }
      k += n;
    }
    end("Elements");
  }

  void elements41(const Model& m) {
    text("$Elements\n");
    // Each element is its own block (entity and type per block).
    sz(m.elements.size()), sz(m.elements.size()), sz(m.elements.front().tag), sz(m.elements.back().tag);
    nl();
    for (const Element& el : m.elements) {
      i(el.dim), i(el.entity), i(el.type), sz(1);
      nl();
      sz(el.tag);
      for (uint64_t t : el.nodes) sz(t);
      nl();
    }
    end("Elements");
  }

  // temperature = x + 2y + 3z on nodes; pressure with two time steps (the last is tag); cellid on all elements.
  void data(const Model& m) {
    auto header = [&](std::string_view section, std::string_view name, int step, int ncomp, size_t count) {
      text("$" + std::string(section) + "\n1\n\"" + std::string(name) + "\"\n1\n" + std::to_string(step * 0.5) +
           "\n3\n" + std::to_string(step) + "\n" + std::to_string(ncomp) + "\n" + std::to_string(count) + "\n");
    };
    auto tag = [&](uint64_t t) { o_.binary ? bin(int32_t(t)) : text(std::to_string(t) + " "); };
    header("NodeData", "temperature", 0, 1, m.nodes.size());
    for (const Node& n : m.nodes) tag(n.tag), d(n.x + 2 * n.y + 3 * n.z), nl();
    end("NodeData");
    for (int step = 0; step < 2; ++step) {
      header("NodeData", "pressure", step, 1, m.nodes.size());
      for (const Node& n : m.nodes) tag(n.tag), d(step == 0 ? -1.0 : double(n.tag)), nl();
      end("NodeData");
    }
    header("ElementData", "cellid", 0, 3, m.elements.size());
    for (const Element& el : m.elements) tag(el.tag), d(double(el.tag)), d(1), d(2), nl();
    end("ElementData");
    text("$ElementNodeData\n1\n\"corner\"\n0\n3\n0\n1\n1\n");
    tag(m.elements[3].tag);
    o_.binary ? bin(int32_t(4)) : text("4 ");
    d(1), d(2), d(3), d(4), nl();
    end("ElementNodeData");
  }

  Options o_;
  std::string out_;
};

std::string write_file(const test::ScratchDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir.file(name);
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

std::string msh(Options o) { return MshWriter(o).write(make_model()); }

std::string error_of(const std::string& path) {
  try {
    read_gmsh(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

bool has_warning(const Dataset& d, std::string_view text) {
  return std::any_of(d.warnings.begin(), d.warnings.end(),
                     [&](const std::string& w) { return w.find(text) != std::string::npos; });
}

const UnstructuredMesh& mesh_of(const Dataset& d) { return std::get<UnstructuredMesh>(d.blocks.at(0).grid); }

// --- well-formed files -------------------------------------------------------------------------------------------

TEST(GmshReader, AsciiMeshTypesOrientationAndFields) {
  test::ScratchDir dir;
  const Dataset d = read_gmsh(write_file(dir, "mixed.msh", msh({})));
  EXPECT_EQ(d.format, "Gmsh MSH 4.1 ASCII");
  const UnstructuredMesh& mesh = mesh_of(d);
  EXPECT_EQ(mesh.point_count(), 33u);
  ASSERT_EQ(mesh.cell_count(), 5u);
  const CellTypeCounts counts = mesh.cell_type_counts();
  EXPECT_EQ(counts.hexahedron, 1u);
  EXPECT_EQ(counts.wedge, 1u);
  EXPECT_EQ(counts.pyramid, 1u);
  EXPECT_EQ(counts.tetra, 2u);
  const double expected[] = {1.0, 0.5, 1.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0};
  for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
    EXPECT_NEAR(cell_volume(mesh, c), expected[c], 1e-6) << "cell " << c;
  }
  EXPECT_EQ(mesh.cell(4).size(), 4u) << "the 10-node tetrahedron is linearised to its corners";
  EXPECT_TRUE(has_warning(d, "ignored 2 lower-dimensional element(s)"));
  EXPECT_TRUE(has_warning(d, "ElementNodeData"));
  EXPECT_TRUE(has_warning(d, "'pressure' has 2 time steps; the last one (step 1) is kept"));

  const FieldSet& f = d.blocks[0].fields;
  const Field* physical = f.find("gmsh:physical", Association::Cell);
  ASSERT_NE(physical, nullptr);
  EXPECT_EQ(physical->data().type(), ScalarType::Int32);
  const auto labels = physical->data().values<int32_t>();
  EXPECT_EQ(std::vector<int32_t>(labels.begin(), labels.end()), (std::vector<int32_t>{100, 100, 200, 200, 200}));

  const Model m = make_model();
  const Field* temperature = f.find("temperature", Association::Vertex);
  ASSERT_NE(temperature, nullptr);
  EXPECT_EQ(temperature->data().type(), ScalarType::Float64);
  for (size_t k = 0; k < m.nodes.size(); ++k) {
    EXPECT_DOUBLE_EQ(temperature->data().get(k, 0), m.nodes[k].x + 2 * m.nodes[k].y + 3 * m.nodes[k].z);
    EXPECT_DOUBLE_EQ(f.find("pressure", Association::Vertex)->data().get(k, 0), double(m.nodes[k].tag));
  }
  const Field* cellid = f.find("cellid", Association::Cell);
  ASSERT_NE(cellid, nullptr);
  EXPECT_EQ(cellid->components(), 3);
  for (size_t c = 0; c < 5; ++c) {
    EXPECT_DOUBLE_EQ(cellid->data().get(c, 0), double(m.elements[c].tag));
    EXPECT_DOUBLE_EQ(cellid->data().get(c, 2), 2.0);
  }
}

TEST(GmshReader, EveryVariantReadsTheSame) {
  test::ScratchDir dir;
  const Dataset reference = read_gmsh(write_file(dir, "ref.msh", msh({})));
  int k = 0;
  for (const int version : {22, 41}) {
    for (const bool binary : {false, true}) {
      for (const bool big : {false, true}) {
        if (big && !binary) continue;
        Options o;
        o.version = version;
        o.binary = binary;
        o.big_endian = big;
        const Dataset d = read_gmsh(write_file(dir, "v" + std::to_string(k++) + ".msh", msh(o)));
        SCOPED_TRACE(d.format + (big ? " big-endian" : ""));
        EXPECT_EQ(d.format,
                  std::string("Gmsh MSH ") + (version == 22 ? "2.2" : "4.1") + (binary ? " binary" : " ASCII"));
        EXPECT_EQ(mesh_of(d), mesh_of(reference));
        EXPECT_EQ(d.blocks[0].fields, reference.blocks[0].fields);
        EXPECT_EQ(d.warnings.size(), reference.warnings.size());
      }
    }
  }
}

TEST(GmshReader, EntityLabelsWithoutEntitiesSection) {
  test::ScratchDir dir;
  Options o;
  o.entities = false;
  o.data = false;
  const Dataset d = read_gmsh(write_file(dir, "noent.msh", msh(o)));
  EXPECT_EQ(d.blocks[0].fields.find("gmsh:physical"), nullptr);
  const Field* entity = d.blocks[0].fields.find("gmsh:entity", Association::Cell);
  ASSERT_NE(entity, nullptr);
  EXPECT_EQ(entity->data().get(0, 0), 1);
  EXPECT_EQ(entity->data().get(4, 0), 2);
}

TEST(GmshReader, DispatchedByContent) {
  test::ScratchDir dir;
  const std::string path = write_file(dir, "mesh.data", msh({}));
  EXPECT_EQ(detect_format(std::vector<std::string>{path}), InputFormat::Gmsh);
  EXPECT_EQ(read_dataset(std::vector<std::string>{path}).cell_count(), 5u);
}

// --- malformed files ---------------------------------------------------------------------------------------------

// Replaces the first `from` after `anchor`.
std::string replace(std::string s, std::string_view from, std::string_view to, std::string_view anchor = "") {
  const size_t at = s.find(from, s.find(anchor));
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

TEST(GmshReader, MalformedAsciiNamesFileAndLine) {
  test::ScratchDir dir;
  Options o22;
  o22.version = 22;
  const std::string good = msh(o22);
  struct Case {
    std::string text, expect;
  };
  const std::vector<Case> cases = {
      {replace(good, "2.2 0 8", "3.0 0 8"), "bad.msh:2: unsupported MSH version '3.0'"},
      {replace(good, "\n17 1 0 0", "\n17 1 zero 0"), "expected a number for a node coordinate, found 'zero'"},
      {replace(good, "1000 5 2", "1000 99 2"), "unsupported Gmsh element type 99"},
      {replace(good, "1000 5 2 100 1 7 ", "1000 5 2 100 1 8 "), "uses node tag 8, which $Nodes does not define"},
      {replace(good, "$Nodes\n33", "$Nodes\n33000000"), "node count 33000000 needs at least"},
      {replace(good, "$EndNodes", "$EndNode"), "expected $EndNodes, found '$EndNode'"},
      {replace(good, "\n17 ", "\n27 "), "node tag 27 is defined twice"},
      {replace(good, "\n33\n7 ", "\n33\n8 ", "temperature"),
       "gives a value for node 8, which the mesh does not define"},
      {replace(good, "\n3\n0\n3\n", "\n3\n0\n0\n", "cellid"), "component count 0"},
      {good.substr(0, good.find("$EndElements")), "expected $EndElements, found the end of the file"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of(write_file(dir, "bad.msh", c.text));
    EXPECT_NE(e.find("bad.msh:"), std::string::npos) << e;
    EXPECT_NE(e.find(c.expect), std::string::npos) << "expected '" << c.expect << "' in: " << e;
  }
}

// Issue 23: every stored node tag is checked, also a second-order tetrahedron's mid-edge ones (linearised away) and
// a dropped triangle's.
TEST(GmshReader, NodeTagsInDroppedSlotsAreChecked) {
  test::ScratchDir dir;
  Options o22;
  o22.version = 22;
  const std::string good = msh(o22);
  // The last node tag on the element line that starts with `prefix`, replaced by 99999.
  auto bad_last_tag = [&](const std::string& prefix) {
    const size_t line = good.find("\n" + prefix);
    EXPECT_NE(line, std::string::npos) << prefix;
    size_t end = good.find('\n', line + 1);
    while (good[end - 1] == ' ') --end;  // the writer ends lines with a space
    const size_t last = good.rfind(' ', end - 1) + 1;
    std::string text = good;
    text.replace(last, end - last, "99999");
    return text;
  };
  for (const std::string prefix : {"1028 11 ", "1035 2 "}) {  // the tet10, the triangle
    SCOPED_TRACE(prefix);
    const std::string e = error_of(write_file(dir, "bad.msh", bad_last_tag(prefix)));
    EXPECT_NE(e.find("bad.msh:"), std::string::npos) << e;
    EXPECT_NE(e.find("uses node tag 99999, which $Nodes does not define"), std::string::npos) << e;
  }
}

TEST(GmshReader, SurfaceOnlyIsRefused) {
  test::ScratchDir dir;
  Model m = make_model();
  m.elements.erase(m.elements.begin(), m.elements.begin() + 5);
  Options o;
  o.data = false;
  const std::string e = error_of(write_file(dir, "surf.msh", MshWriter(o).write(m)));
  EXPECT_NE(e.find("surf.msh: none of its 2 elements is a volume element"), std::string::npos) << e;
}

TEST(GmshReader, MalformedBinaryNamesByteOffset) {
  test::ScratchDir dir;
  Options o;
  o.binary = true;
  std::string bytes = msh(o);
  // Element type 4 (the tetrahedron's block header) becomes 99.
  const size_t at = bytes.find("$Elements\n") + 10 + 4 * 8;  // past the section header
  std::string bad = bytes;
  // The tetrahedron's block header: dim 3, entity 2, type 4, one element.
  const std::string needle = std::string("\x03\0\0\0\x02\0\0\0\x04\0\0\0\x01\0\0\0\0\0\0\0", 20);
  const size_t tet = bytes.find(needle, at);
  ASSERT_NE(tet, std::string::npos);
  bad[tet + 8] = 99;
  std::string e = error_of(write_file(dir, "bad.msh", bad));
  EXPECT_NE(e.find("bad.msh: byte " + std::to_string(tet + 8) + ": unsupported Gmsh element type 99"),
            std::string::npos)
      << e;
  // The byte-order marker.
  bad = bytes;
  const size_t one = bytes.find("4.1 1 8\n") + 8;
  bad[one] = 2;
  e = error_of(write_file(dir, "bad.msh", bad));
  EXPECT_NE(e.find("bad.msh: byte " + std::to_string(one) + ": expected the int 1"), std::string::npos) << e;
}

// Every prefix of every variant must be rejected (or read) cleanly: with file and position, never a crash.
TEST(GmshReader, EveryTruncationFailsCleanly) {
  test::ScratchDir dir;
  for (const int version : {22, 41}) {
    for (const bool binary : {false, true}) {
      Options o;
      o.version = version;
      o.binary = binary;
      const std::string bytes = msh(o);
      const size_t cut_at_data = bytes.find("$NodeData");
      for (size_t n = 0; n < bytes.size(); n += (n < cut_at_data ? 5 : 17)) {
        const std::string path = write_file(dir, "cut.msh", bytes.substr(0, n));
        try {
          read_gmsh(path);
          EXPECT_GE(n, bytes.find("$EndElements")) << "a cut at " << n << " read as complete";
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("cut.msh"), std::string::npos) << e.what();
        }
      }
    }
  }
}

}  // namespace
}  // namespace ugvr
