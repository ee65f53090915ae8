// Synthetic dataset generator: sizes, conformity, orientation, fields, determinism and the written file.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

constexpr GenCellKind kKinds[] = {GenCellKind::Hex, GenCellKind::Tet, GenCellKind::Mixed};

GenerateOptions options(uint64_t cells, GenCellKind kind, uint64_t seed = 1) {
  GenerateOptions o;
  o.cells = cells;
  o.kind = kind;
  o.seed = seed;
  return o;
}

const UnstructuredMesh& mesh_of(const Dataset& ds) { return std::get<UnstructuredMesh>(ds.blocks.at(0).grid); }

TEST(Generator, PlanLandsNearTheTarget) {
  for (GenCellKind kind : kKinds) {
    for (uint64_t target : {10'000ull, 55'555ull, 1'000'000ull, 100'000'000ull, 1'000'000'000ull}) {
      SCOPED_TRACE(std::string(gen_cell_kind_name(kind)) + " " + std::to_string(target));
      const GeneratePlan p = plan_generation(options(target, kind));
      EXPECT_LT(std::abs(double(p.cells) - double(target)) / double(target), 0.03);
      EXPECT_EQ(p.tetra + p.pyramid + p.wedge + p.hexahedron, p.cells);
      EXPECT_EQ(p.connectivity, 4 * p.tetra + 5 * p.pyramid + 6 * p.wedge + 8 * p.hexahedron);
      EXPECT_EQ(p.points, uint64_t(p.ni) * (p.nj + 1) * (p.nk + 1));
      // Sensible proportions: around the body about twice the wall-normal and spanwise resolution.
      EXPECT_GT(double(p.ni) / p.nj, 1.2);
      EXPECT_LT(double(p.ni) / p.nj, 3.0);
      if (kind == GenCellKind::Mixed) {
        EXPECT_GE(p.wedge_layers, 1u);
        EXPECT_GE(p.tet_layers, 1u);
        EXPECT_LE(p.wedge_layers + p.tet_layers + 2, p.nj);  // at least one hexahedron layer
        EXPECT_EQ(p.pyramid, uint64_t(p.ni) * p.nk);
        EXPECT_GT(p.hexahedron, 0u);
      }
    }
  }
  EXPECT_THROW(plan_generation(options(10, GenCellKind::Hex)), Error);
}

TEST(Generator, CellKindNames) {
  for (GenCellKind kind : kKinds) EXPECT_EQ(parse_gen_cell_kind(gen_cell_kind_name(kind)), kind);
  EXPECT_FALSE(parse_gen_cell_kind("prism").has_value());
}

// ---------------------------------------------------------------------------------------------------------------
// Conformity and orientation.

using FaceKey = std::array<uint32_t, 4>;  // sorted vertex ids; a triangle's 4th entry is UINT32_MAX

struct FaceCount {
  uint64_t boundary = 0;
  uint64_t interior = 0;
  uint64_t over_shared = 0;  // faces found 3 or more times: never in a valid mesh
};

FaceCount count_faces(const UnstructuredMesh& m) {
  std::vector<FaceKey> keys;
  for (uint64_t c = 0; c < m.cell_count(); ++c) {
    const CellInfo info = cell_info(m.cell_types[c]);
    const auto v = m.cell(c);
    for (int f = 0; f < info.face_count; ++f) {
      const CellFace& face = info.faces[size_t(f)];
      FaceKey key = {UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX};
      for (int q = 0; q < face.size; ++q) key[size_t(q)] = v[face.v[size_t(q)]];
      std::sort(key.begin(), key.end());
      keys.push_back(key);
    }
  }
  std::sort(keys.begin(), keys.end());
  FaceCount n;
  for (size_t a = 0; a < keys.size();) {
    size_t b = a;
    while (b < keys.size() && keys[b] == keys[a]) ++b;
    if (b - a == 1)
      ++n.boundary;
    else if (b - a == 2)
      ++n.interior;
    else
      ++n.over_shared;
    a = b;
  }
  return n;
}

// Boundary faces the geometry predicts: the wing (j = 0), the far field (j = nj), the floor and the top (k = 0, nk);
// none at the periodic seam in i.
uint64_t expected_boundary_faces(const GeneratePlan& p) {
  const uint64_t ni = p.ni, nj = p.nj, nk = p.nk;
  switch (p.kind) {
    case GenCellKind::Hex: return 2 * ni * nk + 2 * ni * nj;
    case GenCellKind::Tet: return 2 * (2 * ni * nk) + 2 * (2 * ni * nj);
    case GenCellKind::Mixed: {
      // Wall: prism triangles; far field: hexahedron quads; floor and top per layer: prisms and hexahedra one quad,
      // tetrahedra and the transition layer two triangles.
      const uint64_t layers_with_two = p.tet_layers + 1;
      const uint64_t per_k_face = ni * (p.wedge_layers + 2 * layers_with_two + (nj - p.wedge_layers - layers_with_two));
      return 2 * ni * nk + ni * nk + 2 * per_k_face;
    }
  }
  return 0;
}

double tet_volume(Vec3d a, Vec3d b, Vec3d c, Vec3d d) { return dot(cross(b - a, c - a), d - a) / 6.0; }

// The smallest volume of the tetrahedra the cell splits into (all positive for a valid, untangled cell).
double min_subtet_volume(const UnstructuredMesh& m, uint64_t cell) {
  const auto v = m.cell(cell);
  auto P = [&](int q) { return to_double(m.points[v[size_t(q)]]); };
  double lo = INFINITY;
  auto tet = [&](int a, int b, int c, int d) { lo = std::min(lo, tet_volume(P(a), P(b), P(c), P(d))); };
  switch (m.cell_types[cell]) {
    case CellType::Tetra: tet(0, 1, 2, 3); break;
    case CellType::Pyramid:  // base (0,1,2,3) counter-clockwise seen from the apex 4
      tet(0, 1, 2, 4), tet(0, 2, 3, 4), tet(0, 1, 3, 4), tet(1, 2, 3, 4);
      break;
    case CellType::Wedge:  // base (0,1,2) clockwise seen from the top (3,4,5): swap two base vertices
      tet(0, 2, 1, 3), tet(1, 3, 2, 4), tet(2, 4, 3, 5);
      break;
    case CellType::Hexahedron: {
      // The 6 Kuhn tetrahedra of the diagonal 0-6, written with VTK hexahedron numbering.
      static constexpr int kTets[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                          {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
      for (const auto& t : kTets) tet(t[0], t[1], t[2], t[3]);
      break;
    }
  }
  return lo;
}

TEST(Generator, SubTetVolumesOfReferenceCellsArePositive) {
  // Guards the decompositions above against sign mistakes, on VTK's reference cells.
  UnstructuredMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}, {0.5f, 0.5f, 1}};
  const uint32_t hex[] = {0, 1, 2, 3, 4, 5, 6, 7}, pyr[] = {0, 1, 2, 3, 8}, tet[] = {0, 1, 3, 4};
  const uint32_t wedge[] = {0, 3, 1, 4, 7, 5};  // base normal (0,3,1) points to -z, away from the top
  m.add_cell(CellType::Hexahedron, hex);
  m.add_cell(CellType::Pyramid, pyr);
  m.add_cell(CellType::Tetra, tet);
  m.add_cell(CellType::Wedge, wedge);
  for (uint64_t c = 0; c < m.cell_count(); ++c) {
    EXPECT_GT(min_subtet_volume(m, c), 0) << c;
    EXPECT_GT(cell_volume(m, c), 0) << c;
  }
}

class GeneratorKind : public ::testing::TestWithParam<GenCellKind> {};

TEST_P(GeneratorKind, MeshIsConformingAndPositivelyOriented) {
  Progress::set_enabled(false);
  const GenerateOptions o = options(12'000, GetParam());
  const GeneratePlan p = plan_generation(o);
  const Dataset ds = generate_in_memory(o);
  const UnstructuredMesh& m = mesh_of(ds);
  m.validate("generated");
  ASSERT_EQ(m.cell_count(), p.cells);
  ASSERT_EQ(m.point_count(), p.points);
  const CellTypeCounts counts = m.cell_type_counts();
  EXPECT_EQ(counts.tetra, p.tetra);
  EXPECT_EQ(counts.pyramid, p.pyramid);
  EXPECT_EQ(counts.wedge, p.wedge);
  EXPECT_EQ(counts.hexahedron, p.hexahedron);

  const FaceCount faces = count_faces(m);
  EXPECT_EQ(faces.over_shared, 0u);
  EXPECT_EQ(faces.boundary, expected_boundary_faces(p));
  EXPECT_GT(faces.interior, 0u);

  double smallest = INFINITY, total = 0;
  uint64_t bad = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) {
    const double v = cell_volume(m, c);
    total += v;
    smallest = std::min(smallest, v);
    bad += min_subtet_volume(m, c) <= 0;
  }
  EXPECT_GT(smallest, 0);
  EXPECT_EQ(bad, 0u);
  // The domain: a cylinder of radius 15 and height 2 minus the wing (float rounding and the faceted far field aside).
  const double cylinder = std::numbers::pi * 15 * 15 * 2;
  EXPECT_GT(total, 0.9 * cylinder);
  EXPECT_LT(total, cylinder);
}

TEST_P(GeneratorKind, FieldsAreFiniteVariedAndPhysical) {
  Progress::set_enabled(false);
  const GenerateOptions o = options(12'000, GetParam());
  const GeneratePlan p = plan_generation(o);
  const Dataset ds = generate_in_memory(o);
  const FieldSet& fields = ds.blocks[0].fields;
  ASSERT_EQ(fields.size(), 3u);
  const Field* pressure = fields.find("pressure", Association::Vertex);
  const Field* velocity = fields.find("velocity", Association::Vertex);
  const Field* wall = fields.find("wall_distance", Association::Cell);
  ASSERT_TRUE(pressure && velocity && wall);
  EXPECT_EQ(pressure->data().type(), ScalarType::Float32);
  EXPECT_EQ(velocity->components(), 3);
  EXPECT_EQ(wall->tuples(), p.cells);

  for (const Field* f : {pressure, velocity, wall}) {
    for (int c = f->components() == 1 ? kMagnitude : 0; c < f->components(); ++c) {
      const Range r = f->range(c);
      EXPECT_EQ(r.nan_count, 0u) << f->name();
      EXPECT_TRUE(std::isfinite(r.min) && std::isfinite(r.max)) << f->name();
      EXPECT_GT(r.max - r.min, 1e-3) << f->name() << " component " << c;
    }
  }
  // Pressure coefficient: stagnation near 1, suction on the wing and in the vortex cores.
  EXPECT_GT(pressure->range().max, 0.8);
  EXPECT_LT(pressure->range().max, 1.5);
  EXPECT_LT(pressure->range().min, -0.3);
  EXPECT_GT(pressure->range().min, -5.0);
  EXPECT_LT(velocity->range().max, 3.0);
  EXPECT_GT(wall->range().min, 0);
  EXPECT_LT(wall->range().max, 16);

  // No slip: zero velocity on the wing (j = 0) and the floor (k = 0); free stream at 6 degrees far upstream.
  const uint64_t ni = p.ni, nj1 = p.nj + 1;
  for (uint64_t k = 0; k <= p.nk; ++k) {
    for (uint64_t i = 0; i < ni; ++i) EXPECT_EQ(velocity->scalar(i + ni * nj1 * k, kMagnitude), 0.0);
  }
  for (uint64_t j = 0; j < nj1; ++j) {
    for (uint64_t i = 0; i < ni; ++i) EXPECT_EQ(velocity->scalar(i + ni * j, kMagnitude), 0.0);
  }
  // Far-field point upstream: theta = pi, i = ni/2 (ni is even or the point is close to it), j = nj, mid-span.
  const uint64_t far_upstream = ni / 2 + ni * (p.nj + nj1 * (p.nk / 2));
  EXPECT_NEAR(velocity->scalar(far_upstream, 0), std::cos(6 * std::numbers::pi / 180), 0.05);
  EXPECT_NEAR(velocity->scalar(far_upstream, 1), std::sin(6 * std::numbers::pi / 180), 0.05);
}

INSTANTIATE_TEST_SUITE_P(Kinds, GeneratorKind, ::testing::ValuesIn(kKinds),
                         [](const auto& param_info) { return std::string(gen_cell_kind_name(param_info.param)); });

TEST(Generator, DeterministicPerSeed) {
  Progress::set_enabled(false);
  const Dataset a = generate_in_memory(options(5'000, GenCellKind::Mixed, 7));
  const Dataset b = generate_in_memory(options(5'000, GenCellKind::Mixed, 7));
  const Dataset c = generate_in_memory(options(5'000, GenCellKind::Mixed, 8));
  EXPECT_EQ(mesh_of(a), mesh_of(b));
  EXPECT_EQ(a.blocks[0].fields, b.blocks[0].fields);
  EXPECT_EQ(mesh_of(a), mesh_of(c));  // the seed changes the flow, not the grid
  EXPECT_FALSE(a.blocks[0].fields.find("pressure")->data() == c.blocks[0].fields.find("pressure")->data());
}

// ---------------------------------------------------------------------------------------------------------------
// The file.

TEST(Generator, WritesTheDatasetToAVtuFile) {
  Progress::set_enabled(false);
  test::ScratchDir dir;
  for (Codec codec : {Codec::None, Codec::Zlib, Codec::Lz4}) {
    GenerateOptions o = options(8'000, GenCellKind::Mixed);
    o.codec = codec;
    const std::string path = dir.file("gen.vtu");
    const GenerateStats s = generate_dataset(o, path);
    EXPECT_EQ(s.cells, s.plan.cells);
    EXPECT_EQ(s.points, s.plan.points);
    EXPECT_EQ(s.bytes, std::filesystem::file_size(path));
    EXPECT_GT(s.seconds, 0);
    const std::string head = InputFile(path).read_all().substr(0, 2000);
    EXPECT_NE(head.find("<Piece NumberOfPoints=\"" + std::to_string(s.points) + "\" NumberOfCells=\"" +
                        std::to_string(s.cells) + "\">"),
              std::string::npos);
    for (const char* name : {"Name=\"pressure\"", "Name=\"velocity\" NumberOfComponents=\"3\"",
                             "Name=\"wall_distance\"", "Name=\"connectivity\"", "Name=\"offsets\"", "Name=\"types\""}) {
      EXPECT_NE(head.find(name), std::string::npos) << name;
    }
    if (codec == Codec::None) {
      // Raw: the size is fully determined by the arrays (8-byte length prefix each).
      const uint64_t data = 12 * s.points + 4 * s.plan.connectivity + 8 * s.cells + s.cells + 4 * s.points +
                            12 * s.points + 4 * s.cells + 7 * 8;
      EXPECT_EQ(s.bytes, head.find('_', head.find("<AppendedData")) + 1 + data + 30);
    }

    // Read back with the project's reader once it exists; it must equal the in-memory generation.
    try {
      const Dataset back = read_vtk_xml(path);
      const Dataset mem = generate_in_memory(o);
      ASSERT_EQ(back.blocks.size(), 1u);
      EXPECT_EQ(std::get<UnstructuredMesh>(back.blocks[0].grid), mesh_of(mem));
      for (const Field& f : mem.blocks[0].fields) {
        const Field* g = back.blocks[0].fields.find(f.name(), f.association());
        ASSERT_NE(g, nullptr) << f.name();
        EXPECT_EQ(g->data(), f.data()) << f.name();
      }
    } catch (const Error& e) {
      if (std::string(e.what()).find("not yet implemented") == std::string::npos) throw;
    }
  }
  EXPECT_THROW(generate_dataset(options(8'000, GenCellKind::Hex), dir.file("missing-dir/gen.vtu")), Error);
  EXPECT_FALSE(std::filesystem::exists(dir.file("missing-dir")));
}

}  // namespace
}  // namespace ugvr
