// The exact engine against the reference renderer (tests/oracle): real meshes (blunt fin as hexahedra and as
// tetrahedra, the Kiefer bracket's per-cell stress, the notch's hexahedra and wedges, the LOx post's curvilinear grid)
// and a non-convex mesh made here, whose rays leave the mesh and enter it again. The transfer function is rescaled to
// the field and made semi-transparent (unit distance = diagonal / 20) so that every cell along a ray contributes.
// Set UGVR_ORACLE_DUMP=DIR to write both images of each comparison as PNG.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "oracle/reference_renderer.h"
#include "test_data.h"
#include "ugvr/gen/generator.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/exact/exact_engine.h"

namespace ugvr {
namespace {

struct Scene {
  std::string name;
  Camera camera;
  TransferFunction tf;
  RenderSettings settings;
};

RenderSettings oracle_settings(int size = 48) {
  RenderSettings s;
  s.width = s.height = size;
  s.early_termination_opacity = 1;  // the oracle never terminates early; neither may the engine here
  s.lighting = false;
  return s;
}

TransferFunction semi_transparent(double lo, double hi, const Bounds& bounds) {
  TransferFunction tf = builtin_preset("viridis");
  tf.rescale(lo, hi);
  tf.opacity_unit_distance = length(bounds.size()) / 20;
  return tf;
}

// A preset view moved closer by `zoom`: the presets fit the bounding sphere, which leaves elongated meshes small.
Camera view(std::string_view preset, const Bounds& bounds, double zoom = 1.3) {
  Camera c = camera_preset(preset, bounds);
  c.position = c.focal_point - c.direction() * (c.distance() / zoom);
  c.parallel_scale /= zoom;
  return c;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Renders `scene` with the engine and with `reference` (built on the same dataset and field) and returns the RGB
// difference, after checking that the volume is visible at all.
oracle::RgbDifference compare(const Dataset& dataset, std::string_view field, const Scene& scene,
                              const oracle::ReferenceRenderer& reference, ExactRenderStats* stats = nullptr) {
  ExactEngine engine(dataset);
  engine.set_field(dataset, field);
  const Image exact = engine.render(scene.camera, scene.tf, scene.settings, stats);
  const auto start = std::chrono::steady_clock::now();
  const Image expected = reference.render(scene.camera, scene.tf, scene.settings);
  const double oracle_seconds = seconds_since(start);
  const oracle::RgbDifference d = oracle::rgb_difference(exact, expected, 1e-2);
  std::printf("%s: rms %.2e, max %.2e, %llu pixels off by > 1e-2; oracle %.2f s (%llu cells)\n", scene.name.c_str(),
              d.rms, d.max_abs, (unsigned long long)d.pixels_over, oracle_seconds,
              (unsigned long long)reference.cell_count());
  if (const char* dir = std::getenv("UGVR_ORACLE_DUMP"); dir && *dir) {
    write_png(std::string(dir) + "/" + scene.name + "-exact.png", exact);
    write_png(std::string(dir) + "/" + scene.name + "-oracle.png", expected);
  }
  // A comparison against an empty image proves nothing: the volume must cover part of the view.
  uint64_t covered = 0;
  for (int y = 0; y < expected.height; ++y)
    for (int x = 0; x < expected.width; ++x)
      for (int c = 0; c < 3; ++c)
        if (std::abs(expected.pixel(x, y)[c] - float(scene.settings.background[size_t(c)])) > 0.02f) {
          ++covered;
          break;
        }
  EXPECT_GT(covered, uint64_t(expected.width) * uint64_t(expected.height) / 20)
      << scene.name << ": volume barely visible";
  return d;
}

Dataset as_tetrahedra(const Dataset& source, StructuredCellShape shape) {
  Dataset out;
  out.format = source.format;
  for (const Block& b : source.blocks) out.blocks.push_back(to_unstructured_block(b, shape));
  return out;
}

const Dataset& blunt_fin() {
  static const Dataset ds = read_dataset(std::vector<std::string>{test::data_path("blunt-fin/bluntfinxyz.bin"),
                                                                  test::data_path("blunt-fin/bluntfinq.bin")});
  return ds;
}

// Engine and oracle agree to ~1e-5 RMS on these scenes (~3e-4 for trilinear cells, which the engine linearises to a
// tolerance); 1e-3 RMS fails for an opacity ~5% off everywhere, and no pixel may be off by 1e-2 (a local error: one
// cell type or one kind of face handled wrongly).
constexpr double kRmsLimit = 1e-3;

void expect_close(const oracle::RgbDifference& d, const std::string& name) {
  EXPECT_LE(d.rms, kRmsLimit) << name;
  EXPECT_EQ(d.pixels_over, 0u) << name << ": pixels off by more than 1e-2, worst " << d.max_abs;
}

TEST(ExactOracle, BluntFinHexahedra) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinq.bin");
  const Dataset& ds = blunt_fin();
  const oracle::ReferenceRenderer reference(ds, "Density");
  // Density is near 1 in most of the flow: a map over the lower half of the range shows its structure.
  const double lo = reference.field_min(), hi = reference.field_max();
  Scene s{"bluntfin-hex", view("iso", ds.bounds()), semi_transparent(lo, lo + 0.5 * (hi - lo), ds.bounds()),
          oracle_settings()};
  expect_close(compare(ds, "Density", s, reference), s.name);
}

TEST(ExactOracle, BluntFinTetrahedra) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinq.bin");
  const Dataset ds = as_tetrahedra(blunt_fin(), StructuredCellShape::FiveTetrahedra);
  const oracle::ReferenceRenderer reference(ds, "Density");
  const double lo = reference.field_min(), hi = reference.field_max();
  Scene s{"bluntfin-tet", view("+y", ds.bounds(), 1.6), semi_transparent(lo, lo + 0.5 * (hi - lo), ds.bounds()),
          oracle_settings()};
  expect_close(compare(ds, "Density", s, reference), s.name);
}

// MIP with a clip plane through the fin's middle, and the isosurface mode, on the tetrahedra.
TEST(ExactOracle, BluntFinMipAndIsosurfaces) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinq.bin");
  const Dataset ds = as_tetrahedra(blunt_fin(), StructuredCellShape::FiveTetrahedra);
  const oracle::ReferenceRenderer reference(ds, "Density");
  const double lo = reference.field_min(), hi = reference.field_max();
  Scene mip{"bluntfin-mip-clip", view("iso", ds.bounds()), semi_transparent(lo, lo + 0.5 * (hi - lo), ds.bounds()),
            oracle_settings()};
  mip.settings.mode = RenderMode::Mip;
  mip.settings.clip_plane = ClipPlane{ds.bounds().center(), {0.3, -1, 0.2}};
  expect_close(compare(ds, "Density", mip, reference), mip.name);

  Scene iso{"bluntfin-iso", view("iso", ds.bounds()), semi_transparent(lo, hi, ds.bounds()), oracle_settings()};
  iso.settings.mode = RenderMode::Isosurface;
  // Around the free-stream density: the shock in front of the fin and the expansion behind it, nested surfaces.
  iso.settings.iso_values = {lo + 0.15 * (hi - lo), lo + 0.25 * (hi - lo)};
  iso.settings.iso_opacity = 0.5;
  // A ray grazing an isosurface can cross it twice within one oracle step, which the oracle misses; a few such
  // pixels may differ, so this bound is per pixel count rather than the RMS of the volume comparisons.
  const oracle::RgbDifference d = compare(ds, "Density", iso, reference);
  EXPECT_LE(d.pixels_over, uint64_t(iso.settings.width * iso.settings.height / 100));
  EXPECT_LE(d.rms, 1e-2);
}

TEST(ExactOracle, KieferBracketCellData) {
  UGVR_REQUIRE_DATA("fea-kiefer-bracket/dataset.vtu");
  const Dataset ds = read_dataset(std::vector<std::string>{relative_data_path});
  const std::string field = "Equivalent (von-Mises) Stress (psi)";
  const oracle::ReferenceRenderer reference(ds, field);
  // The stress is concentrated in a few cells: a map over the lower part of the range lets most cells show.
  const double lo = reference.field_min(), hi = reference.field_max();
  Scene s{"kiefer", view("iso", ds.bounds()), semi_transparent(lo, lo + 0.4 * (hi - lo), ds.bounds()),
          oracle_settings()};
  expect_close(compare(ds, field, s, reference), s.name);
}

TEST(ExactOracle, NotchHexahedraAndWedges) {
  UGVR_REQUIRE_DATA("notch-stress/notch_stress.vtk");
  const Dataset ds = read_dataset(std::vector<std::string>{relative_data_path});
  const std::string field = "Nodal Stress-normed";
  const oracle::ReferenceRenderer reference(ds, field);
  const double lo = reference.field_min(), hi = reference.field_max();
  Scene s{"notch", view("iso", ds.bounds()), semi_transparent(lo, lo + 0.3 * (hi - lo), ds.bounds()),
          oracle_settings()};
  expect_close(compare(ds, field, s, reference), s.name);
}

// Curvilinear grid read with its IBLANK array (which blanks no point in this file, so all cells exist).
TEST(ExactOracle, LoxPostCurvilinear) {
  UGVR_REQUIRE_DATA("lox-post/postq.bin");
  const Dataset ds = read_dataset(
      std::vector<std::string>{test::data_path("lox-post/postxyz.bin"), test::data_path("lox-post/postq.bin")});
  const oracle::ReferenceRenderer reference(ds, "StagnationEnergy");
  Scene s{"loxpost", view("iso", ds.bounds()),
          semi_transparent(reference.field_min(), reference.field_max(), ds.bounds()), oracle_settings()};
  expect_close(compare(ds, "StagnationEnergy", s, reference), s.name);
}

// All four cell types (the generator's mixed mesh: wedge layers on the wing, tetrahedra, a pyramid transition layer,
// hexahedra), around a hole (the wing), with a vertex and a cell field.
TEST(ExactOracle, GeneratedMixedCells) {
  GenerateOptions options;
  options.cells = 4000;
  options.kind = GenCellKind::Mixed;
  const Dataset ds = generate_in_memory(options);
  const CellTypeCounts counts = std::get<UnstructuredMesh>(ds.blocks.at(0).grid).cell_type_counts();
  ASSERT_GT(counts.pyramid, 0u);
  ASSERT_GT(counts.wedge, 0u);
  // Close to the wing (chord 1 at the origin, in a disc of radius 15 and height 2), where the prism layers, the
  // tetrahedra and the pyramid transition are, seen from above at an angle so rays cross every layer.
  Camera near_wing;
  near_wing.position = {-4, -5, 7};
  near_wing.focal_point = {0.3, 0, 1};
  near_wing.view_up = {0, 0, 1};
  near_wing.view_angle = 15;
  for (const char* field : {"pressure", "wall_distance"}) {
    const oracle::ReferenceRenderer reference(ds, field);
    TransferFunction tf = builtin_preset("viridis");
    tf.rescale(reference.field_min(), field == std::string("wall_distance") ? 0.3 : reference.field_max());
    tf.opacity_unit_distance = 0.5;
    const Scene s{std::string("mixed-") + field, near_wing, tf, oracle_settings()};
    expect_close(compare(ds, field, s, reference), s.name);
  }
}

// A U-shaped block, 10 x 6 x 3 cells with the middle of the top removed (x in [2, 8], y in [2, 6]), bent by a
// smooth warp so its hexahedra are not parallelepipeds, with a smooth vertex field.
Dataset u_shape(StructuredCellShape shape) {
  ImageGrid grid;
  grid.dims.points = {11, 7, 4};
  grid.spacing = {1, 1, 0.5};
  ExplicitCells all = make_explicit_cells(Grid(grid), shape);
  UnstructuredMesh mesh;
  mesh.points = all.mesh.points;
  for (uint64_t c = 0; c < all.mesh.cell_count(); ++c) {
    const uint64_t source = all.source_cell[c];
    const uint64_t i = source % 10, j = (source / 10) % 6;
    if (i >= 2 && i < 8 && j >= 2) continue;
    mesh.add_cell(all.mesh.cell_types[c], all.mesh.cell(c));
  }
  std::vector<double> values;
  for (Vec3f& p : mesh.points) {
    const Vec3d q = to_double(p);
    const Vec3d w{q.x + 0.15 * std::sin(0.7 * q.y), q.y + 0.1 * std::sin(0.5 * q.x), q.z + 0.05 * q.x * q.y / 10};
    p = Vec3f{float(w.x), float(w.y), float(w.z)};
    values.push_back(std::sin(0.9 * q.x) + 0.3 * q.y + std::cos(2 * q.z));
  }
  Block block{"u", std::move(mesh), {}};
  block.fields.add(Field("s", Association::Vertex, DataArray::from(std::move(values), 1)));
  Dataset ds;
  ds.format = "test U shape";
  ds.blocks.push_back(std::move(block));
  return ds;
}

TEST(ExactOracle, NonConvexMeshReentry) {
  for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::SixTetrahedra}) {
    const Dataset ds = u_shape(shape);
    const oracle::ReferenceRenderer reference(ds, "s");
    const TransferFunction tf = semi_transparent(reference.field_min(), reference.field_max(), ds.bounds());
    // Along +x through both arms: the near arm fills the view, so every ray leaves it, crosses the gap and enters
    // the far arm (or leaves through its side).
    Camera side;
    side.position = {-4, 4, 0.75};
    side.focal_point = {5, 4, 0.75};
    side.view_up = {0, 0, 1};
    side.view_angle = 20;
    RenderSettings wide = oracle_settings();
    wide.width = 48;
    wide.height = 24;
    const std::string kind = shape == StructuredCellShape::Hexahedra ? "hex" : "tet";
    for (const Scene& s : {Scene{"u-" + kind + "-side", side, tf, wide},
                           Scene{"u-" + kind + "-iso", view("iso", ds.bounds()), tf, oracle_settings()}}) {
      ExactRenderStats stats;
      expect_close(compare(ds, "s", s, reference, &stats), s.name);
      EXPECT_GT(stats.reentries, 0u) << s.name;
      EXPECT_EQ(stats.lost_rays, 0u) << s.name;
    }
  }
}

}  // namespace
}  // namespace ugvr
