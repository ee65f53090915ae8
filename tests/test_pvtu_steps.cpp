// .pvtu time steps read fields only (io/step_fields.h): a step whose pieces hold the mesh shown (equal stored geometry
// keys, piece by piece) has its fields read piece by piece and concatenated, bit for bit as the whole .pvtu read gives
// them (cells dropped and ghost cells across pieces, an empty piece); one piece with a moved point makes the step a
// whole read that rebuilds the walk mesh; a piece with appended base64 data has no key and makes its step a whole read.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include "hex_fixtures.h"
#include "test_data.h"
#include "ugvr/io/base64.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/mpi/mesh_part.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/exact/exact_renderer.h"
#include "ugvr/render/image.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

using test::ScratchDir;
using test::step_cube_block;

std::shared_ptr<const TimeSeries> series_of(const std::string& path) {
  return std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
}

// Steps 0..count-1 of `step(k)` as step_k.pvtu, each of 4 pieces (step_k_0.vtu ...: the boxes of a kd-tree over the
// first step's cells, the same cells in the same piece every step, as a solver's output), and a .pvd.
std::string write_pvtu_series(const ScratchDir& dir, int count, const std::function<Block(int)>& step) {
  const std::vector<uint32_t> piece_of_cell = kd_pieces(step(0), 4);
  std::vector<std::pair<double, std::string>> steps;
  for (int k = 0; k < count; ++k) {
    const std::string name = "step_" + std::to_string(k) + ".pvtu";
    write_pvtu(step(k), dir.file(name), piece_of_cell, 4);
    steps.emplace_back(double(k), name);
  }
  write_pvd(dir.file("flow.pvd"), steps);
  return dir.file("flow.pvd");
}

// One 48 x 48 frame of `field` over the bounds of the unit cubes' block (fixed, so that images of two scenes compare).
Image render_step(const std::shared_ptr<ExactScene>& scene, const std::string& field, std::optional<uint32_t> step) {
  ExactRenderer r(scene);
  FrameRequest req;
  req.settings.width = req.settings.height = 48;
  req.settings.field = field;
  const Bounds b{{0, 0, 0}, {4, 4, 4}};
  req.camera = default_camera(b);
  req.tf = default_transfer_function(0, 32, b);
  req.time_step = step;
  return r.render(req).image;
}

TEST(PvtuSteps, StepsWithTheSamePiecesReadFieldsOnlyEqualTheWholeRead) {
  ScratchDir dir;
  const auto series = series_of(write_pvtu_series(dir, 3, [](int k) { return step_cube_block(4, 10.0 * k); }));
  StepFieldReader reader(series);
  const auto k0 = reader.geometry_keys(0);
  ASSERT_TRUE(k0.has_value()) << "every piece has a key, so the .pvtu has one";
  ASSERT_EQ(k0->size(), 1u);
  EXPECT_EQ(reader.geometry_keys(1), k0);
  EXPECT_EQ(reader.geometry_keys(2), k0);
  EXPECT_EQ(pvtu_geometry_key(series->steps[1].files[0]), k0->front()) << "the cached key is the uncached one";
  EXPECT_TRUE(reader.has_mesh_of(2, 0));

  const StepFields fields = reader.read(1);
  const Dataset full = read_time_step(*series, 1);
  ASSERT_EQ(fields.blocks.size(), 1u);
  EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
  EXPECT_EQ(fields.format, full.format);
  EXPECT_EQ(fields.sources, full.sources) << "the .pvtu and its 4 pieces";
  EXPECT_EQ(fields.sources.size(), 5u);
  EXPECT_TRUE(reader.read_values(2, 0).blocks[0] == read_time_step(*series, 2).blocks[0].fields);

  // Through the scene: the switch is fields-only and draws the image a scene made from that step alone draws.
  auto scene = std::make_shared<ExactScene>(series, 0);
  for (const char* field : {"f", "c", "g:1"}) {
    SCOPED_TRACE(field);
    const uint32_t next = scene->step == 1 ? 2 : 1;
    const Image switched = render_step(scene, field, next);
    auto fresh = std::make_shared<ExactScene>(std::make_shared<const Dataset>(read_time_step(*series, next)));
    const Image alone = render_step(fresh, field, std::nullopt);
    EXPECT_EQ(switched.rgba, alone.rgba);
    EXPECT_EQ(scene->engine.bound_values(), fresh->engine.bound_values());
    EXPECT_TRUE(scene->dataset->blocks[0].fields == read_time_step(*series, next).blocks[0].fields);
  }
  EXPECT_EQ(scene->fields_only, 3u);
  EXPECT_EQ(scene->rebuilds, 0u);
}

TEST(PvtuSteps, APieceWithAMovedPointIsReadWholeAndRebuilds) {
  ScratchDir dir;
  // Step 2 moves point 0 (in one piece; the other pieces' files are those of every other step).
  const auto series = series_of(write_pvtu_series(dir, 3, [](int k) { return step_cube_block(3, 10.0 * k, k == 2); }));
  StepFieldReader reader(series);
  const auto k0 = reader.geometry_keys(0);
  ASSERT_TRUE(k0.has_value());
  EXPECT_EQ(reader.geometry_keys(1), k0);
  EXPECT_NE(reader.geometry_keys(2), k0);
  int same_pieces = 0;
  for (int piece = 0; piece < 4; ++piece) {
    const std::string name = "_" + std::to_string(piece) + ".vtu";
    same_pieces += vtu_geometry_key(dir.file("step_0" + name)) == vtu_geometry_key(dir.file("step_2" + name));
  }
  EXPECT_EQ(same_pieces, 3) << "one piece of four holds the moved point";

  auto scene = std::make_shared<ExactScene>(series, 0);
  scene->bind("f");
  scene->set_step(2);
  EXPECT_EQ(scene->rebuilds, 1u);
  EXPECT_EQ(scene->fields_only, 0u);
  EXPECT_EQ(scene->engine.bounds().lo.x, 0.0f);
  const auto& mesh = std::get<UnstructuredMesh>(scene->dataset->blocks[0].grid);
  EXPECT_NE(std::find_if(mesh.points.begin(), mesh.points.end(), [](const Vec3f& q) { return q.x == 0.25f; }),
            mesh.points.end());
  scene->set_step(1);
  EXPECT_EQ(scene->rebuilds, 2u) << "step 1 has step 0's mesh, not step 2's";
  scene->set_step(0);
  EXPECT_EQ(scene->fields_only, 1u);
  EXPECT_EQ(scene->rebuilds, 2u);
}

// Pieces written by hand, for what the project's writer never writes: lower-dimensional cells among the volume
// cells (dropped by the reader, their cell values with them), an empty piece, ascii arrays and appended base64.
class PieceWriter {
 public:
  explicit PieceWriter(bool base64) : base64_(base64) {}

  template <class T>
  std::string array(const char* type, const std::string& name, int components, const std::vector<T>& values) {
    const std::string head = std::string("<DataArray type=\"") + type + "\" Name=\"" + name +
                             "\" NumberOfComponents=\"" + std::to_string(components) + "\"";
    if (!base64_) {
      std::string text;
      for (T v : values) {
        if constexpr (std::is_integral_v<T>)
          text += std::to_string(int64_t(v)) + " ";
        else
          text += std::to_string(double(v)) + " ";
      }
      return head + " format=\"ascii\">" + text + "</DataArray>\n";
    }
    // As VTK writes appended base64: the UInt32 byte count and the values, each its own padded base64 stream.
    const uint32_t bytes = uint32_t(values.size() * sizeof(T));
    const std::string offset = std::to_string(appended_.size());
    appended_ += base64_encode(std::as_bytes(std::span(&bytes, 1)));
    appended_ += base64_encode(std::as_bytes(std::span(values)));
    return head + " format=\"appended\" offset=\"" + offset + "\"/>\n";
  }
  std::string appended() const {
    return base64_ ? "<AppendedData encoding=\"base64\">_" + appended_ + "\n</AppendedData>\n" : "";
  }

 private:
  bool base64_;
  std::string appended_;
};

// A row of `hexes` unit hexahedra along x from x0 (a triangle after every other one when `triangles`), point field p,
// cell fields c (a triangle's: 1000) and vtkGhostType (every third hexahedron a ghost); `hexes` 0: an empty piece.
void write_row_piece(const std::string& path, int hexes, int x0, float scale, bool triangles, bool base64) {
  PieceWriter w(base64);
  std::vector<float> xyz, p, c;
  std::vector<int64_t> conn, offsets;
  std::vector<uint8_t> types, ghost;
  const int points = hexes ? 4 * (hexes + 1) : 0;
  for (int i = 0; i < points / 4; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) {
        for (float v : {float(x0 + i), float(j), float(k)}) xyz.push_back(v);
        p.push_back(scale * (float(x0 + i) + 0.5f * float(j) + 0.25f * float(k)));
      }
  auto id = [](int i, int j, int k) { return int64_t(4 * i + 2 * j + k); };
  for (int i = 0; i < hexes; ++i) {
    for (int64_t v : {id(i, 0, 0), id(i + 1, 0, 0), id(i + 1, 1, 0), id(i, 1, 0), id(i, 0, 1), id(i + 1, 0, 1),
                      id(i + 1, 1, 1), id(i, 1, 1)})
      conn.push_back(v);
    offsets.push_back(int64_t(conn.size()));
    types.push_back(12);
    c.push_back(scale * float(x0 + i));
    ghost.push_back(i % 3 == 2 ? 1 : 0);
    if (triangles && i % 2 == 0) {
      for (int64_t v : {id(i, 0, 0), id(i + 1, 0, 0), id(i, 1, 0)}) conn.push_back(v);
      offsets.push_back(int64_t(conn.size()));
      types.push_back(5);
      c.push_back(1000.0f);
      ghost.push_back(0);
    }
  }
  std::ofstream f(path);
  f << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
    << "<UnstructuredGrid>\n<Piece NumberOfPoints=\"" << points << "\" NumberOfCells=\"" << types.size() << "\">\n";
  if (hexes > 0) {
    f << "<PointData>\n" << w.array("Float32", "p", 1, p) << "</PointData>\n<CellData>\n";
    f << w.array("Float32", "c", 1, c) << w.array("UInt8", "vtkGhostType", 1, ghost) << "</CellData>\n";
    f << "<Points>\n" << w.array("Float32", "Points", 3, xyz) << "</Points>\n<Cells>\n";
    f << w.array("Int64", "connectivity", 1, conn) << w.array("Int64", "offsets", 1, offsets);
    f << w.array("UInt8", "types", 1, types) << "</Cells>\n";
  }
  f << "</Piece>\n</UnstructuredGrid>\n" << w.appended() << "</VTKFile>\n";
}

// Step k: rows of 5, 0 and 4 hexahedra (triangles among the first row's), p and c scaled by k + 1; the last row's
// piece in appended base64 when `base64_step` is k.
void write_row_steps(const ScratchDir& dir, int count, int base64_step = -1) {
  std::vector<std::pair<double, std::string>> steps;
  for (int k = 0; k < count; ++k) {
    const std::string s = "row_" + std::to_string(k);
    write_row_piece(dir.file(s + "_a.vtu"), 5, 0, float(k + 1), true, false);
    write_row_piece(dir.file(s + "_b.vtu"), 0, 0, float(k + 1), false, false);
    write_row_piece(dir.file(s + "_c.vtu"), 4, 5, float(k + 1), false, k == base64_step);
    std::ofstream(dir.file(s + ".pvtu"))
        << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\">\n"
        << "<PUnstructuredGrid GhostLevel=\"1\">\n<PPointData><PDataArray type=\"Float32\" Name=\"p\"/></PPointData>\n"
        << "<PCellData><PDataArray type=\"Float32\" Name=\"c\"/><PDataArray type=\"UInt8\" Name=\"vtkGhostType\"/>"
        << "</PCellData>\n<PPoints><PDataArray type=\"Float32\" NumberOfComponents=\"3\"/></PPoints>\n"
        << "<Piece Source=\"" << s << "_a.vtu\"/>\n<Piece Source=\"" << s << "_b.vtu\"/>\n<Piece Source=\"" << s
        << "_c.vtu\"/>\n</PUnstructuredGrid>\n</VTKFile>\n";
    steps.emplace_back(double(k), s + ".pvtu");
  }
  write_pvd(dir.file("rows.pvd"), steps);
}

TEST(PvtuSteps, DroppedCellsGhostCellsAndAnEmptyPieceAsTheWholeRead) {
  ScratchDir dir;
  write_row_steps(dir, 2);
  const auto series = series_of(dir.file("rows.pvd"));
  const Dataset full = read_time_step(*series, 1);
  const auto& mesh = std::get<UnstructuredMesh>(full.blocks[0].grid);
  ASSERT_EQ(mesh.cell_count(), 9u) << "the whole read keeps the 9 hexahedra, drops the 3 triangles";
  const Field* ghost = full.blocks[0].fields.find("vtkGhostType", Association::Cell);
  ASSERT_NE(ghost, nullptr) << "ghost cells are kept, marked in vtkGhostType";

  StepFieldReader reader(series);
  ASSERT_TRUE(reader.geometry_keys(0).has_value());
  EXPECT_EQ(reader.geometry_keys(1), reader.geometry_keys(0));
  const StepFields fields = reader.read(1);
  ASSERT_EQ(fields.blocks.size(), 1u);
  EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
  EXPECT_EQ(fields.sources, full.sources);
  const Field* c = fields.blocks[0].find("c", Association::Cell);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->data().tuples(), 9u);
  for (float v : c->data().values<float>()) EXPECT_LT(v, 1000.0f) << "no triangle's value among the cells'";

  auto scene = std::make_shared<ExactScene>(series, 0);
  scene->bind("c");
  scene->set_step(1);
  EXPECT_EQ(scene->fields_only, 1u);
  ExactScene fresh(std::make_shared<const Dataset>(read_time_step(*series, 1)));
  fresh.bind("c");
  EXPECT_EQ(scene->engine.bound_values(), fresh.engine.bound_values());
}

TEST(PvtuSteps, APieceInAppendedBase64MakesItsStepAWholeRead) {
  ScratchDir dir;
  write_row_steps(dir, 3, 2);
  const auto series = series_of(dir.file("rows.pvd"));
  EXPECT_FALSE(vtu_geometry_key(dir.file("row_2_c.vtu")).has_value());
  EXPECT_FALSE(pvtu_geometry_key(dir.file("row_2.pvtu")).has_value());
  StepFieldReader reader(series);
  EXPECT_TRUE(reader.geometry_keys(1).has_value());
  EXPECT_FALSE(reader.geometry_keys(2).has_value());
  EXPECT_FALSE(reader.has_mesh_of(2, 0));
  EXPECT_TRUE(reader.read_values(2, 0).blocks[0] == read_time_step(*series, 2).blocks[0].fields);

  auto scene = std::make_shared<ExactScene>(series, 0);
  scene->bind("p");
  scene->set_step(2);
  EXPECT_EQ(scene->fields_only, 0u) << "read whole";
  EXPECT_EQ(scene->rebuilds, 0u) << "the same mesh by fingerprint";
  scene->set_step(1);
  EXPECT_EQ(scene->fields_only, 1u);
}

}  // namespace
}  // namespace ugvr
