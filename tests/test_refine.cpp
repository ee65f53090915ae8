// Uniform refinement: counts, volume, orientation, conformity, interpolated and copied fields, structured inputs,
// refused requests, and the real lox-post grid.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/gen/generator.h"
#include "ugvr/grid/topology.h"
#include "ugvr/io/reader.h"
#include "ugvr/refine/refine.h"

namespace ugvr {
namespace {

const UnstructuredMesh& mesh_of(const Dataset& ds) { return std::get<UnstructuredMesh>(ds.blocks.at(0).grid); }

Dataset single_block(UnstructuredMesh mesh) {
  Dataset ds;
  ds.blocks.push_back(Block{"test", std::move(mesh), {}});
  return ds;
}

// One positively oriented cell of a type, slightly irregular so no symmetry hides a bug.
UnstructuredMesh one_cell(CellType t) {
  UnstructuredMesh m;
  std::vector<uint32_t> ids;
  auto pt = [&](float x, float y, float z) {
    ids.push_back(uint32_t(m.points.size()));
    m.points.push_back({x, y, z});
  };
  switch (t) {
    case CellType::Tetra: pt(0, 0, 0), pt(1.2f, 0.1f, 0), pt(0.2f, 0.9f, 0.1f), pt(0.1f, 0.2f, 1.1f); break;
    case CellType::Hexahedron:
      pt(0, 0, 0), pt(1, 0, 0.1f), pt(1.1f, 1, 0), pt(0, 0.9f, 0);
      pt(0, 0.1f, 1), pt(1, 0, 1.2f), pt(1, 1, 1), pt(0.1f, 1, 0.9f);
      break;
    case CellType::Wedge:  // bottom triangle clockwise seen from the top one
      pt(0, 0, 0), pt(0, 1, 0.1f), pt(1.1f, 0, 0), pt(0, 0.1f, 1), pt(0.1f, 1, 1.2f), pt(1, 0, 0.9f);
      break;
    case CellType::Pyramid: pt(0, 0, 0), pt(1, 0, 0.1f), pt(1.1f, 1, 0), pt(0, 0.9f, 0), pt(0.4f, 0.5f, 1.1f); break;
  }
  m.add_cell(t, ids);
  return m;
}

double total_volume(const UnstructuredMesh& m, double* min_volume) {
  double sum = 0, lo = INFINITY;
  for (uint64_t c = 0; c < m.cell_count(); ++c) {
    const double v = cell_volume(m, c);
    sum += v;
    lo = std::min(lo, v);
  }
  *min_volume = lo;
  return sum;
}

struct Refined {
  RefineStats stats;
  Dataset ds;
};

Refined refine_and_read(const Dataset& in, int levels, const test::ScratchDir& dir, Codec codec = Codec::None) {
  Progress::set_enabled(false);
  RefineOptions o;
  o.levels = levels;
  o.codec = codec;
  const std::string path = dir.file("out" + std::to_string(levels) + ".vtu");
  Refined r{refine_to_vtu(in, o, path), {}};
  r.ds = read_vtk_xml(path);
  return r;
}

// Cell count, volume, orientation and conformity against the input.
void check_refinement(const Dataset& in, int levels, uint64_t expected_cells, const test::ScratchDir& dir) {
  SCOPED_TRACE("levels " + std::to_string(levels));
  const UnstructuredMesh& a = mesh_of(in);
  const Refined r = refine_and_read(in, levels, dir);
  const UnstructuredMesh& b = mesh_of(r.ds);
  EXPECT_EQ(b.cell_count(), expected_cells);
  EXPECT_EQ(r.stats.plan.cells, expected_cells);
  EXPECT_EQ(b.point_count(), r.stats.plan.points);
  EXPECT_EQ(r.stats.plan.types.total(), expected_cells);
  for (CellType t : kAllCellTypes) EXPECT_EQ(b.cell_type_counts()[t], r.stats.plan.types[t]);
  double min_a = 0, min_b = 0;
  const double va = total_volume(a, &min_a), vb = total_volume(b, &min_b);
  EXPECT_NEAR(vb, va, 1e-6 * std::abs(va));
  EXPECT_GT(min_b, 0.0);
  const MeshTopology ta = build_topology(a), tb = build_topology(b);
  EXPECT_EQ(tb.nonmanifold_faces, 0u);
  EXPECT_EQ(tb.boundary.size(), ta.boundary.size() << (2 * levels));
  // Every output point is used by some cell (the numbering has no holes).
  std::vector<bool> used(b.point_count(), false);
  for (uint32_t v : b.connectivity) used[v] = true;
  EXPECT_EQ(std::count(used.begin(), used.end(), false), 0);
}

TEST(Refine, EachCellType) {
  const test::ScratchDir dir;
  for (CellType t : kAllCellTypes) {
    SCOPED_TRACE(std::string(cell_name(t)));
    const Dataset in = single_block(one_cell(t));
    for (int levels : {1, 2, 3}) {
      const uint64_t pyramids = uint64_t(std::pow(6, levels));
      const uint64_t expected = t == CellType::Pyramid ? (levels == 1   ? 10
                                                          : levels == 2 ? 6 * 10 + 4 * 8
                                                                        : 0)
                                                       : uint64_t(1) << (3 * levels);
      if (expected == 0) {  // pyramid, 3 levels: 6^3 pyramids and the tets of every level, checked through the plan
        const RefinePlan p = plan_refinement(in, {.levels = levels});
        EXPECT_EQ(p.types.pyramid, pyramids);
        EXPECT_EQ(p.types.tetra, 4u * (64 + 6 * 8 + 36));
        check_refinement(in, levels, p.cells, dir);
        continue;
      }
      check_refinement(in, levels, expected, dir);
    }
  }
}

TEST(Refine, MixedMeshConformsAndKeepsFields) {
  const test::ScratchDir dir;
  const Dataset in = generate_in_memory(GenerateOptions{.cells = 2000, .kind = GenCellKind::Mixed});
  const UnstructuredMesh& a = mesh_of(in);
  const CellTypeCounts n = a.cell_type_counts();
  for (int levels : {1, 2}) {
    const uint64_t k = uint64_t(1) << (3 * levels);
    const uint64_t pyr = levels == 1 ? 10 : 92;
    check_refinement(in, levels, (n.tetra + n.wedge + n.hexahedron) * k + n.pyramid * pyr, dir);
  }
  // Cell fields are copied to every child: the children of input cell c are a contiguous run in file order.
  const Refined r = refine_and_read(in, 1, dir, Codec::Zlib);
  const Field* wall = r.ds.blocks[0].fields.find("wall_distance", Association::Cell);
  const Field* wall_in = in.blocks[0].fields.find("wall_distance", Association::Cell);
  ASSERT_NE(wall, nullptr);
  uint64_t out = 0;
  for (uint64_t c = 0; c < a.cell_count(); ++c) {
    const uint64_t children = a.cell_types[c] == CellType::Pyramid ? 10 : 8;
    for (uint64_t i = 0; i < children; ++i, ++out) ASSERT_EQ(wall->data().get(out, 0), wall_in->data().get(c, 0));
  }
  EXPECT_EQ(out, wall->tuples());
  // Vertex fields keep their type and components; original vertices keep their values exactly.
  const Field* vel = r.ds.blocks[0].fields.find("velocity", Association::Vertex);
  const Field* vel_in = in.blocks[0].fields.find("velocity", Association::Vertex);
  ASSERT_NE(vel, nullptr);
  EXPECT_EQ(vel->data().type(), ScalarType::Float32);
  EXPECT_EQ(vel->components(), 3);
  for (uint64_t v = 0; v < a.point_count(); ++v) ASSERT_EQ(vel->data().get(v, 2), vel_in->data().get(v, 2));
}

// A field linear in x, y, z is reproduced at every new vertex of a tet mesh (the interpolation is exact there), and
// an integer field is written rounded, in its own type.
TEST(Refine, LinearFieldReproducedOnTets) {
  const test::ScratchDir dir;
  Dataset in = generate_in_memory(GenerateOptions{.cells = 3000, .kind = GenCellKind::Tet});
  const UnstructuredMesh& a = mesh_of(in);
  auto linear = [](const Vec3f& p) { return 1.0 + 2.0 * p.x - 3.0 * p.y + 0.5 * p.z; };
  std::vector<double> f;
  std::vector<int16_t> g;
  for (const Vec3f& p : a.points) f.push_back(linear(p)), g.push_back(int16_t(std::lround(100 * p.z)));
  in.blocks[0].fields.add(Field("linear", Association::Vertex, DataArray::from(f, 1)));
  in.blocks[0].fields.add(Field("zint", Association::Vertex, DataArray::from(g, 1)));
  const Refined r = refine_and_read(in, 2, dir);
  const UnstructuredMesh& b = mesh_of(r.ds);
  const Field* lin = r.ds.blocks[0].fields.find("linear", Association::Vertex);
  const Field* zint = r.ds.blocks[0].fields.find("zint", Association::Vertex);
  ASSERT_NE(lin, nullptr);
  ASSERT_NE(zint, nullptr);
  EXPECT_EQ(lin->data().type(), ScalarType::Float64);
  EXPECT_EQ(zint->data().type(), ScalarType::Int16);
  double worst = 0;
  for (uint64_t v = 0; v < b.point_count(); ++v) {
    // Positions are stored as float32, the field in float64: the difference is float rounding of the position.
    worst = std::max(worst, std::abs(lin->data().get(v, 0) - linear(b.points[v])));
    // Rounded twice (input and output): within 1 of the exact value.
    ASSERT_LE(std::abs(zint->data().get(v, 0) - 100 * b.points[v].z), 1.0 + 1e-3) << v;
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(b.point_count(), a.point_count() * 30);
}

TEST(Refine, StructuredGridWithIblank) {
  const test::ScratchDir dir;
  StructuredGrid g;
  g.dims.points = {4, 3, 3};
  for (uint32_t k = 0; k < 3; ++k)
    for (uint32_t j = 0; j < 3; ++j)
      for (uint32_t i = 0; i < 4; ++i) g.points.push_back({float(i) + 0.1f * float(j), float(j), float(k) * 1.5f});
  g.iblank.assign(g.points.size(), 1);
  g.iblank[g.dims.point_index(0, 0, 0)] = 0;  // blanks the one cell touching the corner
  Dataset in;
  std::vector<float> q(g.points.size());
  for (size_t i = 0; i < q.size(); ++i) q[i] = float(i);
  in.blocks.push_back(Block{"grid", g, {}});
  in.blocks[0].fields.add(Field("q", Association::Vertex, DataArray::from(q, 1)));
  const uint64_t cells = g.dims.cell_count() - 1;  // 12 - 1
  for (int levels : {1, 2}) {
    const Refined r = refine_and_read(in, levels, dir);
    EXPECT_EQ(mesh_of(r.ds).cell_count(), 5 * cells << (3 * levels));
    EXPECT_EQ(mesh_of(r.ds).cell_type_counts().tetra, 5 * cells << (3 * levels));
    EXPECT_NE(r.ds.blocks[0].fields.find("q"), nullptr);
    EXPECT_EQ(r.ds.blocks[0].fields.find("IBLANK"), nullptr);  // applied, not interpolated
    const MeshTopology t = build_topology(mesh_of(r.ds));
    EXPECT_EQ(t.nonmanifold_faces, 0u);
  }
  RefineOptions six;
  six.levels = 1;
  six.split = StructuredCellShape::SixTetrahedra;
  EXPECT_EQ(plan_refinement(in, six).cells, 6 * cells * 8);
}

TEST(Refine, AbsurdRequestsRefused) {
  const Dataset in = generate_in_memory(GenerateOptions{.cells = 2000, .kind = GenCellKind::Hex});
  EXPECT_THROW(plan_refinement(in, {.levels = kMaxRefineLevels + 1}), Error);
  EXPECT_THROW(plan_refinement(in, {.levels = -1}), Error);
  // 6 levels of 2000 cells: 524 million cells, fine to plan (nothing is allocated for the output).
  const RefinePlan p = plan_refinement(in, {.levels = 6});
  EXPECT_EQ(p.cells, mesh_of(in).cell_count() << 18);
  // Points beyond 2^32 - 1: a mesh of many disjoint hexahedra refined 6 levels has (65^3) points per cell.
  UnstructuredMesh many;
  for (uint32_t c = 0; c < 16000; ++c) {
    const UnstructuredMesh one = one_cell(CellType::Hexahedron);
    std::vector<uint32_t> ids;
    for (const Vec3f& pt : one.points) {
      ids.push_back(uint32_t(many.points.size()));
      many.points.push_back({pt.x + 2.0f * float(c), pt.y, pt.z});
    }
    many.add_cell(CellType::Hexahedron, ids);
  }
  try {
    plan_refinement(single_block(std::move(many)), {.levels = 6});
    ADD_FAILURE() << "expected a refusal";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("32 bits"), std::string::npos) << e.what();
  }
  Dataset two = in;
  two.blocks.push_back(two.blocks[0]);
  EXPECT_THROW(plan_refinement(two, {.levels = 1}), Error);
}

TEST(Refine, LoxPostOneLevel) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const std::vector<std::string> paths = {relative_data_path, test::data_path("lox-post/postq.bin")};
  const Dataset ds = read_dataset(paths);
  const RefinePlan p = plan_refinement(ds, {.levels = 1});
  EXPECT_EQ(p.input_cells, 513'375u);
  EXPECT_EQ(p.cells, 513'375u * 8);
  EXPECT_EQ(p.types.tetra, 513'375u * 8);
  // Euler-style check of the numbering: every input edge gains one midpoint; tets have no face or interior points.
  EXPECT_EQ(p.points, p.input_points + p.edges);
}

}  // namespace
}  // namespace ugvr
