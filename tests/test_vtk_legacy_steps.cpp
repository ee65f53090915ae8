// Legacy VTK (.vtk) time steps read fields only (io/step_fields.h): a step whose stored geometry equals the mesh's
// (the same vtk_legacy_geometry_key, though its title and its dataset-level TIME differ) has its fields read without
// its points or cell lists, bit for bit as the whole read gives them (BINARY and ASCII, the 5.x OFFSETS/CONNECTIVITY
// and the older count-prefixed cells, a dropped lower-dimensional cell); a moved point or other connectivity gives
// another key and a whole read that rebuilds the walk mesh; a truncated file is an error naming it, the scene unharmed.
#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "hex_fixtures.h"
#include "test_data.h"
#include "ugvr/core/file.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/render/exact/exact_renderer.h"

namespace ugvr {
namespace {

using test::bytes_read_so_far;
using test::ScratchDir;
using test::step_cube_block;

struct Layout {
  bool binary = true;
  bool v5 = true;         // "5.1": OFFSETS / CONNECTIVITY; else "4.2": count-prefixed cell lists
  bool triangle = false;  // a VTK_TRIANGLE as file cell 1, which the reader drops (and its cell data)
  bool flipped = false;   // cell 0's corners listed from its other end: the same points, other connectivity
};

// Writes values as a legacy file stores them: big-endian bytes in BINARY files, shortest round-trip text in ASCII ones.
class LegacyText {
 public:
  explicit LegacyText(bool binary) : binary_(binary) {}
  std::string str() const { return out_; }
  void line(const std::string& s) { out_ += s + "\n"; }

  template <class T>
  void values(const std::vector<T>& v) {
    for (size_t i = 0; i < v.size(); ++i) {
      if (binary_) {
        char b[sizeof(T)];
        std::memcpy(b, &v[i], sizeof(T));
        for (size_t k = sizeof(T); k-- > 0;) out_ += b[k];  // little-endian machine: reversed
      } else {
        char t[64];
        out_.append(t, size_t(std::to_chars(t, t + sizeof t, v[i]).ptr - t));
        out_ += (i + 1 == v.size() || i % 9 == 8) ? '\n' : ' ';
      }
    }
    if (binary_) out_ += '\n';
  }

 private:
  bool binary_;
  std::string out_;
};

// `b` (step_cube_block's: hexahedra, float fields f, g, c) as a legacy UNSTRUCTURED_GRID at time `t`: its title and a
// dataset-level FIELD hold t (as writers do), then POINT_DATA f, g and CELL_DATA c and an int FIELD array "id".
std::string legacy_vtk(const Block& b, const Layout& o, double t) {
  static_assert(std::endian::native == std::endian::little);
  const auto& m = std::get<UnstructuredMesh>(b.grid);
  LegacyText w(o.binary);
  w.line(o.v5 ? "# vtk DataFile Version 5.1" : "# vtk DataFile Version 4.2");
  w.line("flow at t = " + std::to_string(t));
  w.line(o.binary ? "BINARY" : "ASCII");
  w.line("DATASET UNSTRUCTURED_GRID");
  w.line("FIELD FieldData 1");
  w.line("TIME 1 1 double");
  w.values(std::vector<double>{t});
  std::vector<float> points;
  for (const Vec3f& p : m.points)
    for (int a = 0; a < 3; ++a) points.push_back(p[a]);
  w.line("POINTS " + std::to_string(m.points.size()) + " float");
  w.values(points);
  // File cells: the hexahedra, with the triangle after the first.
  std::vector<std::vector<int64_t>> cells;
  std::vector<int32_t> types;
  for (uint64_t c = 0; c < m.cell_count(); ++c) {
    std::vector<int64_t> ids(m.connectivity.begin() + m.cell_offsets[c],
                             m.connectivity.begin() + m.cell_offsets[c + 1]);
    if (c == 0 && o.flipped) ids = {ids[4], ids[7], ids[6], ids[5], ids[0], ids[3], ids[2], ids[1]};
    cells.push_back(ids);
    types.push_back(12);  // VTK_HEXAHEDRON
    if (c == 0 && o.triangle) {
      cells.push_back({0, 1, 2});
      types.push_back(5);  // VTK_TRIANGLE
    }
  }
  std::vector<int64_t> offsets{0}, connectivity;
  std::vector<int32_t> lists;
  for (const auto& ids : cells) {
    connectivity.insert(connectivity.end(), ids.begin(), ids.end());
    offsets.push_back(int64_t(connectivity.size()));
    lists.push_back(int32_t(ids.size()));
    lists.insert(lists.end(), ids.begin(), ids.end());
  }
  const std::string n_cells = std::to_string(cells.size());
  if (o.v5) {
    w.line("CELLS " + std::to_string(offsets.size()) + " " + std::to_string(connectivity.size()));
    w.line("OFFSETS vtktypeint64");
    w.values(offsets);
    w.line("CONNECTIVITY vtktypeint64");
    w.values(connectivity);
  } else {
    w.line("CELLS " + n_cells + " " + std::to_string(lists.size()));
    w.values(lists);
  }
  w.line("CELL_TYPES " + n_cells);
  w.values(types);

  auto floats = [&](const char* name) {
    const auto v = b.fields.find(name)->data().values<float>();
    return std::vector<float>(v.begin(), v.end());
  };
  w.line("POINT_DATA " + std::to_string(m.points.size()));
  w.line("SCALARS f float 1");
  w.line("LOOKUP_TABLE default");
  w.values(floats("f"));
  w.line("VECTORS g float");
  w.values(floats("g"));
  std::vector<float> c = floats("c");
  std::vector<int32_t> id(c.size());
  for (size_t i = 0; i < id.size(); ++i) id[i] = int32_t(i * 7 + size_t(t));
  if (o.triangle) {
    c.insert(c.begin() + 1, -1.0f);
    id.insert(id.begin() + 1, 999);
  }
  w.line("CELL_DATA " + n_cells);
  w.line("SCALARS c float 1");
  w.line("LOOKUP_TABLE default");
  w.values(c);
  w.line("FIELD FieldData 1");
  w.line("id 1 " + n_cells + " int");
  w.values(id);
  return w.str();
}

void write_file(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

std::shared_ptr<const TimeSeries> series_of(const std::string& path) {
  return std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
}

// Steps 0..count-1 as flow_000k.vtk (step_cube_block(n, 10 k) unless `step` says otherwise) and a .pvd.
std::string write_series(const ScratchDir& dir, int n, int count, const std::function<Layout(int)>& layout,
                         const std::function<Block(int)>& step = {}) {
  std::vector<std::pair<double, std::string>> steps;
  for (int k = 0; k < count; ++k) {
    const std::string name = "flow_000" + std::to_string(k) + ".vtk";
    write_file(dir.file(name), legacy_vtk(step ? step(k) : step_cube_block(n, 10.0 * k), layout(k), 0.5 * k));
    steps.emplace_back(0.5 * k, name);
  }
  write_pvd(dir.file("flow.pvd"), steps);
  return dir.file("flow.pvd");
}

// The values the engine holds for `field` on a scene built from step `k` alone.
std::vector<float> fresh_values(const TimeSeries& series, uint32_t k, const std::string& field) {
  ExactScene fresh(std::make_shared<const Dataset>(read_time_step(series, k)));
  fresh.bind(field);
  return fresh.engine.bound_values();
}

// Step `k`'s fields-only read equals its whole read: fields bit for bit, format and sources.
void expect_fields_of_whole_read(StepFieldReader& reader, const TimeSeries& series, size_t k) {
  const StepFields fields = reader.read(k);
  const Dataset full = read_time_step(series, k);
  ASSERT_EQ(fields.blocks.size(), 1u);
  EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
  EXPECT_EQ(fields.blocks[0].size(), 4u) << "f, g, c, id";
  EXPECT_EQ(fields.format, full.format);
  EXPECT_EQ(fields.sources, full.sources);
}

TEST(VtkLegacySteps, BinaryAndAsciiStepsReadFieldsOnlyEqualTheWholeRead) {
  for (const bool binary : {true, false})
    for (const bool v5 : {true, false}) {
      SCOPED_TRACE(std::string(binary ? "BINARY " : "ASCII ") + (v5 ? "5.1" : "4.2"));
      ScratchDir dir;
      const auto series = series_of(write_series(dir, 4, 3, [&](int) { return Layout{binary, v5}; }));
      StepFieldReader reader(series);
      const auto k0 = reader.geometry_keys(0);
      ASSERT_TRUE(k0.has_value());
      EXPECT_EQ(reader.geometry_keys(1), k0) << "another title and TIME, the same stored mesh";
      EXPECT_EQ(reader.geometry_keys(2), k0);
      EXPECT_EQ(vtk_legacy_geometry_key(series->steps[1].files[0]), k0->front()) << "the cached key is the uncached";
      expect_fields_of_whole_read(reader, *series, 2);

      ExactScene scene(series, 0);
      for (const char* field : {"f", "c", "g:1", "id"}) {
        SCOPED_TRACE(field);
        scene.bind(field);
        scene.set_step(scene.step == 1 ? 2 : 1);
        EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, scene.step, field));
        EXPECT_TRUE(scene.dataset->blocks[0].fields == read_time_step(*series, scene.step).blocks[0].fields);
      }
      EXPECT_EQ(scene.fields_only, 4u);
      EXPECT_EQ(scene.rebuilds, 0u);
    }
}

TEST(VtkLegacySteps, ANumberedSeriesOfVtkFilesSwitchesFieldsOnly) {
  ScratchDir dir;
  write_series(dir, 3, 3, [](int) { return Layout{}; });
  const auto series = series_of(dir.file("flow_*.vtk"));
  ASSERT_EQ(series->kind, SeriesKind::Numbered);
  ExactScene scene(series, 0);
  scene.bind("f");
  scene.set_step(2);
  EXPECT_EQ(scene.fields_only, 1u);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "f"));
}

TEST(VtkLegacySteps, AMovedPointOrOtherConnectivityIsAnotherKeyAndRebuilds) {
  for (const bool binary : {true, false}) {
    SCOPED_TRACE(binary ? "BINARY" : "ASCII");
    ScratchDir dir;
    // Step 2 moves point 0; step 3 lists cell 0's corners in another order (the same points, counts and sizes).
    const auto series = series_of(write_series(
        dir, 3, 4,
        [&](int k) {
          return Layout{binary, true, false, k == 3};
        },
        [](int k) { return step_cube_block(3, 10.0 * k, k == 2); }));
    StepFieldReader reader(series);
    const auto k0 = reader.geometry_keys(0);
    EXPECT_EQ(reader.geometry_keys(1), k0);
    EXPECT_NE(reader.geometry_keys(2), k0);
    EXPECT_NE(reader.geometry_keys(3), k0);
    EXPECT_NE(reader.geometry_keys(3), reader.geometry_keys(2));

    ExactScene scene(series, 0);
    scene.bind("f");
    scene.set_step(2);
    EXPECT_EQ(scene.rebuilds, 1u);
    EXPECT_EQ(std::get<UnstructuredMesh>(scene.dataset->blocks[0].grid).points[0].x, 0.25f);
    EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "f"));
    scene.set_step(1);
    EXPECT_EQ(scene.rebuilds, 2u) << "step 1 has step 0's mesh, not step 2's";
    scene.set_step(0);
    EXPECT_EQ(scene.fields_only, 1u);
    scene.set_step(3);
    EXPECT_EQ(scene.rebuilds, 3u) << "the same points, other connectivity";
    EXPECT_EQ(std::get<UnstructuredMesh>(scene.dataset->blocks[0].grid).connectivity,
              std::get<UnstructuredMesh>(read_time_step(*series, 3).blocks[0].grid).connectivity);
    EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 3, "f"));
  }
}

TEST(VtkLegacySteps, CellDataOfADroppedTriangleIsDroppedAsTheWholeReadDropsIt) {
  for (const bool binary : {true, false})
    for (const bool v5 : {true, false}) {
      SCOPED_TRACE(std::string(binary ? "BINARY " : "ASCII ") + (v5 ? "5.1" : "4.2"));
      ScratchDir dir;
      const auto series = series_of(write_series(dir, 3, 2, [&](int) { return Layout{binary, v5, true}; }));
      StepFieldReader reader(series);
      ASSERT_TRUE(reader.has_mesh_of(1, 0));
      expect_fields_of_whole_read(reader, *series, 1);
      const StepFields fields = reader.read(1);
      const auto c = fields.blocks[0].find("c")->data().values<float>();
      ASSERT_EQ(c.size(), 27u) << "the triangle's value is not among the hexahedra's";
      EXPECT_EQ(c[0], 10.0f);
      EXPECT_EQ(c[1], 10.5f);

      ExactScene scene(series, 0);
      scene.bind("id");
      scene.set_step(1);
      EXPECT_EQ(scene.fields_only, 1u);
      EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 1, "id"));
    }
}

// A structured legacy file of 3 x 3 x 3 points at time t: STRUCTURED_GRID (POINTS, shifted by `shift` in x),
// STRUCTURED_POINTS (ORIGIN x = shift) or RECTILINEAR_GRID (X_COORDINATES from shift), with POINT_DATA p and
// CELL_DATA q that change with t.
std::string structured_vtk(const std::string& type, bool binary, double t, float shift) {
  LegacyText w(binary);
  w.line("# vtk DataFile Version 3.0");
  w.line("structured at t = " + std::to_string(t));
  w.line(binary ? "BINARY" : "ASCII");
  w.line("DATASET " + type);
  w.line("DIMENSIONS 3 3 3");
  if (type == "STRUCTURED_GRID") {
    std::vector<float> points;
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i)
          for (float v : {float(i) + shift, float(j), float(k)}) points.push_back(v);
    w.line("POINTS 27 float");
    w.values(points);
  } else if (type == "STRUCTURED_POINTS") {
    w.line("ORIGIN " + std::to_string(shift) + " 0 0");
    w.line("SPACING 1 1 1");
  } else {
    for (const char* axis : {"X", "Y", "Z"}) {
      w.line(std::string(axis) + "_COORDINATES 3 double");
      w.values(std::vector<double>{0.0 + (axis[0] == 'X' ? shift : 0.0f), 1.0, 2.0});
    }
  }
  std::vector<float> p(27), q(8);
  for (size_t i = 0; i < p.size(); ++i) p[i] = float(double(i) + t);
  for (size_t i = 0; i < q.size(); ++i) q[i] = float(double(i) * 0.25 - t);
  w.line("POINT_DATA 27");
  w.line("SCALARS p float 1");
  w.line("LOOKUP_TABLE default");
  w.values(p);
  w.line("CELL_DATA 8");
  w.line("SCALARS q float");
  w.line("LOOKUP_TABLE default");
  w.values(q);
  return w.str();
}

TEST(VtkLegacySteps, StructuredTypesAreKeyedAndReadFieldsOnlyToo) {
  for (const std::string type : {"STRUCTURED_GRID", "STRUCTURED_POINTS", "RECTILINEAR_GRID"})
    for (const bool binary : {true, false}) {
      SCOPED_TRACE(type + (binary ? " BINARY" : " ASCII"));
      ScratchDir dir;
      std::vector<std::pair<double, std::string>> steps;
      for (int k = 0; k < 3; ++k) {
        const std::string name = "s_" + std::to_string(k) + ".vtk";
        write_file(dir.file(name), structured_vtk(type, binary, double(k), k == 2 ? 0.5f : 0.0f));
        steps.emplace_back(double(k), name);
      }
      write_pvd(dir.file("s.pvd"), steps);
      const auto series = series_of(dir.file("s.pvd"));
      StepFieldReader reader(series);
      ASSERT_TRUE(reader.geometry_keys(0).has_value());
      EXPECT_EQ(reader.geometry_keys(1), reader.geometry_keys(0));
      EXPECT_NE(reader.geometry_keys(2), reader.geometry_keys(0)) << "the grid moved by half a cell";
      const StepFields fields = reader.read(1);
      const Dataset full = read_time_step(*series, 1);
      EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
      EXPECT_EQ(fields.blocks[0].size(), 2u);
      EXPECT_EQ(fields.format, full.format);

      ExactScene scene(series, 0);
      scene.bind("p");
      scene.set_step(1);
      EXPECT_EQ(scene.fields_only, 1u);
      EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 1, "p"));
      scene.set_step(2);
      EXPECT_EQ(scene.rebuilds, 1u);
      EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "p"));
    }
}

TEST(VtkLegacySteps, AFieldsOnlyReadPassesOverThePointsAndCellLists) {
  if (bytes_read_so_far() == 0) GTEST_SKIP() << "no /proc/self/io";
  ScratchDir dir;
  // Large enough that the tokenizers' 1 MiB buffers (filled after each seek) are small beside the mesh.
  const uint64_t n = 64, points = (n + 1) * (n + 1) * (n + 1), cells = n * n * n;
  const auto series = series_of(write_series(dir, int(n), 2, [](int) { return Layout{}; }));
  const uint64_t file = InputFile(series->steps[1].files[0]).size();
  // f, c and id: 4 bytes a point or cell; g: 12 bytes a point. The mesh: POINTS 12 bytes a point, OFFSETS 8 and
  // CONNECTIVITY 64 bytes a cell (vtktypeint64), CELL_TYPES 4.
  const uint64_t field_bytes = 16 * points + 8 * cells, connectivity_bytes = 64 * cells;
  StepFieldReader reader(series);
  uint64_t before = bytes_read_so_far();
  const StepFields fields = reader.read(1);
  const uint64_t fields_only = bytes_read_so_far() - before;
  before = bytes_read_so_far();
  const Dataset full = read_time_step(*series, 1);
  const uint64_t whole = bytes_read_so_far() - before;
  EXPECT_GE(whole, file) << "the counter sees the full read";
  EXPECT_GE(fields_only, field_bytes);
  // Beside them: CELL_TYPES (read by its cursor) and the 1 MiB buffers filled before each seek is known (after the
  // header, POINTS, OFFSETS, CONNECTIVITY, CELL_TYPES): at most five.
  EXPECT_LT(fields_only, field_bytes + 4 * cells + (5 << 20)) << "the fields and the cell types, not the mesh";
  EXPECT_LT(fields_only, file - connectivity_bytes) << "the connectivity was passed over";
  EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
}

TEST(VtkLegacySteps, ATruncatedStepIsAnErrorNamingItAndTheSceneStaysOnItsStep) {
  for (const bool binary : {true, false}) {
    SCOPED_TRACE(binary ? "BINARY" : "ASCII");
    ScratchDir dir;
    const auto series = series_of(write_series(dir, 6, 3, [&](int) { return Layout{binary}; }));
    const std::string step2 = series->steps[2].files[0];
    ExactScene scene(series, 0);
    scene.bind("f");
    scene.set_step(2);  // its key cached in the scene's reader
    scene.set_step(1);
    // Cut in the middle of the connectivity: the key's hashing runs short.
    const std::string bytes = legacy_vtk(step_cube_block(6, 20.0), Layout{binary}, 1.0);
    const size_t cut = bytes.find("CONNECTIVITY") + 400;
    std::filesystem::resize_file(step2, cut);
    const std::string e = test::error_of([&] { vtk_legacy_geometry_key(step2); });
    EXPECT_NE(e.find(step2 + (binary ? ": byte " : ":")), std::string::npos) << e;
    StepFieldReader reader(series);
    EXPECT_NE(test::error_of([&] { reader.geometry_keys(2); }).find(step2), std::string::npos);
    const std::string switched = test::error_of([&] { scene.set_step(2); });
    EXPECT_NE(switched.find(step2), std::string::npos) << switched;
    EXPECT_EQ(scene.step, 1u) << "a failed switch leaves the scene on its step";
    write_file(step2, bytes);
    scene.set_step(2);
    EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "f"));
    EXPECT_EQ(scene.fields_only, 3u);
  }
}

}  // namespace
}  // namespace ugvr
