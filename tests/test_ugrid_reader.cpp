// UGRID reader: one mixed mesh (a tetrahedron, a pyramid, a prism and a hexahedron written in the UGRID / AFLR3
// orderings, plus boundary faces) in every variant (ASCII, C binary b8/lb8/b4/lb4/b8l/lb8l, Fortran r8/lr8/r4/lr4),
// named by suffix and detected by size, must read identically with positive cell volumes; malformed files must fail
// with the file name and the line (ASCII) or byte offset (binary).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

struct UgridModel {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<int64_t>> tris, quads;
  std::array<std::vector<std::vector<int64_t>>, 4> cells;  // tets, pyramids, prisms, hexes (1-based, UGRID order)
};

// Cells in the UGRID convention: a first face whose normal points into the cell (right-hand rule). The pyramid's
// apex is its third node and its base loop is 1-4-5-2.
UgridModel make_model() {
  UgridModel m;
  auto add = [&](std::vector<std::array<double, 3>> ps) {
    std::vector<int64_t> ids;
    for (const auto& p : ps) {
      m.points.push_back(p);
      ids.push_back(int64_t(m.points.size()));
    }
    return ids;
  };
  m.cells[0].push_back(add({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
  // Pyramid: base A(2,0,0) B(3,0,0) C(3,1,0) D(2,1,0) counter-clockwise from the apex E above; nodes 1,4,5,2 = A,B,C,D.
  m.cells[1].push_back(add({{2, 0, 0}, {2, 1, 0}, {2.5, 0.5, 1}, {3, 0, 0}, {3, 1, 0}}));
  m.cells[2].push_back(add({{4, 0, 0}, {5, 0, 0}, {4, 1, 0}, {4, 0, 1}, {5, 0, 1}, {4, 1, 1}}));
  m.cells[3].push_back(add({{6, 0, 0}, {7, 0, 0}, {7, 1, 0}, {6, 1, 0}, {6, 0, 1}, {7, 0, 1}, {7, 1, 1}, {6, 1, 1}}));
  m.tris = {{1, 2, 3}, {1, 2, 4}};
  m.quads = {{16, 17, 18, 19}};
  return m;
}

struct Layout {
  std::string suffix;  // "" = ASCII
  bool big;
  int real_bytes, int_bytes;
  bool fortran;
};

const std::vector<Layout> kLayouts = {
    {"", false, 8, 4, false},    {"b8", true, 8, 4, false},  {"lb8", false, 8, 4, false},  {"b4", true, 4, 4, false},
    {"lb4", false, 4, 4, false}, {"b8l", true, 8, 8, false}, {"lb8l", false, 8, 8, false}, {"r8", true, 8, 4, true},
    {"lr8", false, 8, 4, true},  {"r4", true, 4, 4, true},   {"lr4", false, 4, 4, true},
};

class UgridWriter {
 public:
  explicit UgridWriter(const Layout& l) : l_(l) {}

  std::string write(const UgridModel& m) {
    const std::vector<int64_t> header = {
        int64_t(m.points.size()),   int64_t(m.tris.size()),     int64_t(m.quads.size()),   int64_t(m.cells[0].size()),
        int64_t(m.cells[1].size()), int64_t(m.cells[2].size()), int64_t(m.cells[3].size())};
    record_begin(7 * l_.int_bytes);
    for (int64_t h : header) integer(h);
    record_end(7 * l_.int_bytes);
    newline();
    const size_t data_start = out_.size();
    record_begin(0);  // patched below
    for (const auto& p : m.points) {
      for (double v : p) real(v);
      newline();
    }
    for (const auto* list : {&m.tris, &m.quads}) {
      for (const auto& f : *list) {
        for (int64_t id : f) integer(id);
        newline();
      }
    }
    for (size_t k = 0; k < m.tris.size() + m.quads.size(); ++k) integer(int64_t(k % 3 + 1)), newline();
    for (const auto& kind : m.cells) {
      for (const auto& c : kind) {
        for (int64_t id : c) integer(id);
        newline();
      }
    }
    if (l_.fortran) {
      const int64_t bytes = int64_t(out_.size() - data_start - 4);
      std::string marker;
      std::swap(marker, out_);
      raw(int32_t(bytes));
      std::memcpy(marker.data() + data_start, out_.data(), 4);
      std::swap(marker, out_);
      record_end(bytes);
    }
    return out_;
  }

 private:
  template <class T>
  void raw(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof v);
    if (l_.big) std::reverse(b, b + sizeof b);
    out_.append(b, sizeof b);
  }
  void integer(int64_t v) {
    if (l_.suffix.empty()) {
      out_ += std::to_string(v) + " ";
    } else if (l_.int_bytes == 4) {
      raw(int32_t(v));
    } else {
      raw(v);
    }
  }
  void real(double v) {
    if (l_.suffix.empty()) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g ", v);
      out_ += buf;
    } else if (l_.real_bytes == 4) {
      raw(float(v));
    } else {
      raw(v);
    }
  }
  void newline() {
    if (l_.suffix.empty()) out_ += "\n";
  }
  void record_begin(int64_t bytes) {
    if (l_.fortran) raw(int32_t(bytes));
  }
  void record_end(int64_t bytes) {
    if (l_.fortran) raw(int32_t(bytes));
  }

  Layout l_;
  std::string out_;
};

std::string write_file(const test::ScratchDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir.file(name);
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

std::string file_name(const Layout& l) { return l.suffix.empty() ? "mesh.ugrid" : "mesh." + l.suffix + ".ugrid"; }

std::string error_of(const std::string& path) {
  try {
    read_ugrid(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

const UnstructuredMesh& mesh_of(const Dataset& d) { return std::get<UnstructuredMesh>(d.blocks.at(0).grid); }

TEST(UgridReader, AsciiMixedMeshIsPositivelyOriented) {
  test::ScratchDir dir;
  const Dataset d = read_ugrid(write_file(dir, "mesh.ugrid", UgridWriter(kLayouts[0]).write(make_model())));
  EXPECT_EQ(d.format, "UGRID ASCII");
  const UnstructuredMesh& mesh = mesh_of(d);
  EXPECT_EQ(mesh.point_count(), 23u);
  ASSERT_EQ(mesh.cell_count(), 4u);
  EXPECT_EQ(mesh.cell_types,
            (std::vector<CellType>{CellType::Tetra, CellType::Pyramid, CellType::Wedge, CellType::Hexahedron}));
  const double expected[] = {1.0 / 6.0, 1.0 / 3.0, 0.5, 1.0};
  for (uint64_t c = 0; c < 4; ++c) EXPECT_NEAR(cell_volume(mesh, c), expected[c], 1e-6) << "cell " << c;
  // The pyramid's apex (UGRID node 3 of the cell, point index 6) is VTK's vertex 4.
  EXPECT_EQ(mesh.cell(1)[4], 6u);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_NE(d.warnings[0].find("2 triangles, 1 quadrilaterals"), std::string::npos) << d.warnings[0];
}

TEST(UgridReader, EveryVariantByNameAndBySize) {
  test::ScratchDir dir;
  const UgridModel m = make_model();
  const Dataset reference = read_ugrid(write_file(dir, "ref.ugrid", UgridWriter(kLayouts[0]).write(m)));
  for (const Layout& l : kLayouts) {
    SCOPED_TRACE(file_name(l));
    const std::string bytes = UgridWriter(l).write(m);
    const Dataset named = read_ugrid(write_file(dir, file_name(l), bytes));
    EXPECT_EQ(mesh_of(named), mesh_of(reference));
    if (!l.suffix.empty()) {
      EXPECT_NE(named.format.find("." + l.suffix + " ("), std::string::npos) << named.format;
      // The same bytes under a name without the variant: found from the size.
      const Dataset detected = read_ugrid(write_file(dir, "plain_" + l.suffix + ".ugrid", bytes));
      EXPECT_EQ(detected.format, named.format);
      EXPECT_EQ(mesh_of(detected), mesh_of(reference));
    }
  }
}

TEST(UgridReader, DispatchedByExtension) {
  test::ScratchDir dir;
  const std::string path = write_file(dir, "wing.lb8.ugrid", UgridWriter(kLayouts[2]).write(make_model()));
  EXPECT_EQ(detect_format(std::vector<std::string>{path}), InputFormat::Ugrid);
  EXPECT_EQ(read_dataset(std::vector<std::string>{path}).cell_count(), 4u);
}

TEST(UgridReader, TrailingRecordsAllowedWhenNamed) {
  test::ScratchDir dir;
  const std::string bytes = UgridWriter(kLayouts[2]).write(make_model()) + std::string(8, '\0');
  const Dataset d = read_ugrid(write_file(dir, "t.lb8.ugrid", bytes));
  EXPECT_EQ(d.cell_count(), 4u);
  EXPECT_TRUE(std::any_of(d.warnings.begin(), d.warnings.end(),
                          [](const std::string& w) { return w.find("ignored 8 bytes") != std::string::npos; }));
  const std::string e = error_of(write_file(dir, "t.ugrid", bytes));
  EXPECT_NE(e.find("t.ugrid: not ASCII, and no binary UGRID layout fits"), std::string::npos) << e;
}

TEST(UgridReader, MalformedAsciiNamesLine) {
  test::ScratchDir dir;
  const std::string good = UgridWriter(kLayouts[0]).write(make_model());
  struct Case {
    std::string text, expect;
  };
  std::string bad_id = good;
  bad_id.replace(bad_id.rfind("\n16 17 18 19 20"), 15, "\n16 17 18 19 99");  // the hexahedron's 5th node
  std::string bad_token = good;
  bad_token.replace(bad_token.find("2.5"), 3, "2,5");
  const std::vector<Case> cases = {
      {bad_id, "bad.ugrid:34: hexahedron 1 uses node 99, outside [1, 23]"},
      {bad_token, "bad.ugrid:8: expected a number for a node coordinate, found '2,5'"},
      {"23 2 1 -1 1 1 1\n", "bad.ugrid:1: the number of tetrahedra is negative (-1)"},
      {"99999999 0 0 0 0 0 1\n1 2 3\n", "bad.ugrid: byte 20: value count 300000005 needs at least 2 bytes"},
      {good.substr(0, good.size() - 10), "bad.ugrid:34: unexpected end of file: expected a node index of a hexahedron"},
      {"", "bad.ugrid:1: unexpected end of file: expected the number of nodes"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of(write_file(dir, "bad.ugrid", c.text));
    EXPECT_NE(e.find(c.expect), std::string::npos) << "expected '" << c.expect << "' in: " << e;
  }
}

TEST(UgridReader, MalformedBinaryNamesByteOffset) {
  test::ScratchDir dir;
  const Layout& lb8 = kLayouts[2];
  const std::string good = UgridWriter(lb8).write(make_model());
  std::string bad = good;
  bad[good.size() - 4] = 50;  // the hexahedron's last node
  std::string e = error_of(write_file(dir, "bad.lb8.ugrid", bad));
  EXPECT_NE(e.find("bad.lb8.ugrid: byte " + std::to_string(good.size() - 4) + ": hexahedron 1 uses node 50"),
            std::string::npos)
      << e;
  e = error_of(write_file(dir, "bad.lb8.ugrid", good.substr(0, good.size() - 1)));
  EXPECT_NE(e.find("bad.lb8.ugrid: byte 28: the header announces 23 nodes"), std::string::npos) << e;
  // Fortran: a wrong record marker.
  std::string fortran = UgridWriter(kLayouts[8]).write(make_model());
  fortran[36] = 1;
  e = error_of(write_file(dir, "bad.lr8.ugrid", fortran));
  EXPECT_NE(e.find("bad.lr8.ugrid: byte 36: Fortran record marker is"), std::string::npos) << e;
  // An absurd header.
  std::string absurd = good;
  absurd[3] = 0x7f;
  e = error_of(write_file(dir, "bad.lb8.ugrid", absurd));
  EXPECT_NE(e.find("bad.lb8.ugrid: byte 28: the header announces"), std::string::npos) << e;
}

TEST(UgridReader, EveryTruncationFailsCleanly) {
  test::ScratchDir dir;
  for (const Layout& l : kLayouts) {
    const std::string bytes = UgridWriter(l).write(make_model());
    // An ASCII file cut within its last number still reads (as a smaller node index); any other cut must fail.
    const size_t last_line = l.suffix.empty() ? bytes.rfind('\n', bytes.size() - 2) : bytes.size();
    for (size_t n = 0; n < bytes.size(); n += 5) {
      const std::string e = error_of(write_file(dir, file_name(l), bytes.substr(0, n)));
      if (n > last_line && e == "(no error)") continue;
      EXPECT_NE(e.find(file_name(l)), std::string::npos) << "cut at " << n << ": " << e;
    }
  }
}

}  // namespace
}  // namespace ugvr
