// The octree builder, end to end through the brick store: every sample of every node (leaves and the interior nodes
// subsampled from them) against an independent point location over all cells, shared border samples bit for bit,
// the validity mask against point-in-mesh (with IBLANK holes in the oxygen post), the node table as an octree that
// covers the cells, monotone errors, and the split criterion, padding and the command line on their own.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "store_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/cell_box_overlap.h"
#include "ugvr/octree/data_points.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/octree/soup_boundary.h"
#include "ugvr/octree/split.h"
#include "ugvr/octree/vtu_cells.h"
#include "ugvr/store/brick_pad.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// ---- inputs ---------------------------------------------------------------------------------------------------------

// A sheared, bent, jittered structured grid (the boundary is not a box) with a wavy and a linear vertex field and a
// per-cell field.
Dataset synthetic_dataset(uint32_t n, uint32_t seed) {
  StructuredGrid g;
  g.dims = GridDims{{n + 1, n + 2, n}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  std::vector<float> wave, lin;
  for (uint32_t k = 0; k < g.dims.points[2]; ++k)
    for (uint32_t j = 0; j < g.dims.points[1]; ++j)
      for (uint32_t i = 0; i < g.dims.points[0]; ++i) {
        const double x = i + u(rng), y = j + u(rng), z = k + u(rng);
        const Vec3f p{float(x + 0.3 * y), float(y + 0.05 * x * x), float(z - 0.2 * x)};
        g.points.push_back(p);
        wave.push_back(float(std::sin(0.9 * p.x) * std::cos(0.7 * p.y) + 0.3 * p.z));
        lin.push_back(float(0.3 * p.x - 1.7 * p.y + 0.9 * p.z + 2.0));
      }
  const uint64_t cells = uint64_t(n) * (n + 1) * (n - 1);
  std::vector<float> cellid(cells);
  for (uint64_t c = 0; c < cells; ++c) cellid[c] = float(c % 13);
  Dataset ds;
  ds.sources = {"synthetic"};
  Block b;
  b.name = "synthetic";
  b.grid = std::move(g);
  b.fields.add(Field("wave", Association::Vertex, DataArray::from(std::move(wave), 1)));
  b.fields.add(Field("lin", Association::Vertex, DataArray::from(std::move(lin), 1)));
  b.fields.add(Field("cellid", Association::Cell, DataArray::from(std::move(cellid), 1)));
  ds.blocks.push_back(std::move(b));
  return ds;
}

// A structured block cut into cells of `shape` (the builder itself always takes hexahedra), as a one-block dataset.
Dataset with_cells(const Dataset& ds, StructuredCellShape shape) {
  Dataset out;
  out.sources = ds.sources;
  out.blocks.push_back(to_unstructured_block(ds.blocks.at(0), shape));
  return out;
}

OctreeBuildOptions small_options(uint32_t resolution, int max_depth, double error) {
  OctreeBuildOptions o;
  o.resolution = resolution;
  o.max_depth = max_depth;
  o.error = error;
  o.encoding.samples = SampleEncoding::Float32;  // lossless: shared samples must stay bit-identical
  return o;
}

// ---- independent point location
// --------------------------------------------------------------------------------------

// The exact field at a node's lattice points, cell by cell: every cell tests the lattice points in its bounding box
// with the inverse map of cell_interpolation.h (Newton from the parametric centre; the sampler uses its own prepared
// forms). Points on shared faces follow the sampler's documented rule (octree/brick_sampler.h): a cell holding the
// point well inside wins, else the lowest cell id within tolerance.
struct ExactBrick {
  std::vector<uint8_t> inside;
  std::vector<double> values;  // field-major
};

class BruteForce {
 public:
  BruteForce(const UnstructuredMesh& mesh, std::vector<ScalarRef> scalars) : mesh_(mesh), scalars_(std::move(scalars)) {
    boxes_.resize(mesh.cell_count());
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      Vec3d v[kMaxCellVertices];
      const int n = gather_cell_vertices(mesh, c, v);
      for (int i = 0; i < n; ++i) boxes_[c].add(v[i]);
    }
  }

  ExactBrick brick(const BrickLattice& lattice, int level, std::array<uint32_t, 3> ijk) const {
    const uint32_t R = lattice.resolution;
    const size_t n = size_t(R) * R * R;
    ExactBrick e;
    e.inside.assign(n, 0);
    e.values.assign(scalars_.size() * n, 0.0);
    std::vector<double> margin(n, -INFINITY);
    std::vector<uint64_t> owner(n, UINT64_MAX);
    const BrickSamplerOptions o;
    std::array<std::vector<double>, 3> coords;
    for (int a = 0; a < 3; ++a)
      for (uint32_t x = 0; x < R; ++x)
        coords[size_t(a)].push_back(lattice.coordinate(a, level, uint64_t(ijk[size_t(a)]) * (R - 1) + x));
    for (uint64_t c = 0; c < mesh_.cell_count(); ++c) {
      const Bounds& bb = boxes_[c];
      const double slack = 1e-6 * length(bb.size());
      uint32_t first[3], last[3];
      bool outside = false;
      for (int a = 0; a < 3; ++a) {
        const auto& cs = coords[size_t(a)];
        first[a] = uint32_t(std::lower_bound(cs.begin(), cs.end(), bb.lo[a] - slack) - cs.begin());
        last[a] = uint32_t(std::upper_bound(cs.begin(), cs.end(), bb.hi[a] + slack) - cs.begin());
        if (first[a] >= last[a]) outside = true;
      }
      if (outside) continue;
      const CellType type = mesh_.cell_types[c];
      Vec3d v[kMaxCellVertices];
      gather_cell_vertices(mesh_, c, v);
      for (uint32_t z = first[2]; z < last[2]; ++z)
        for (uint32_t y = first[1]; y < last[1]; ++y)
          for (uint32_t x = first[0]; x < last[0]; ++x) {
            const Vec3d p{coords[0][x], coords[1][y], coords[2][z]};
            Vec3d rst;
            if (!inverse_map(type, v, p, parametric_center(type), rst)) continue;
            const double m = parametric_margin(type, rst);
            if (m < -o.tolerance) continue;
            const size_t s = x + size_t(R) * (y + size_t(R) * z);
            const bool better = owner[s] == UINT64_MAX || (m >= o.interior_margin && margin[s] < o.interior_margin) ||
                                (margin[s] < o.interior_margin && m < o.interior_margin && c < owner[s]);
            if (!better) continue;
            owner[s] = c, margin[s] = m, e.inside[s] = 1;
            const auto ids = mesh_.cell(c);
            for (size_t f = 0; f < scalars_.size(); ++f) {
              const Field& field = *scalars_[f].field;
              if (field.association() == Association::Cell) {
                e.values[f * n + s] = field.scalar(c, scalars_[f].component);
              } else {
                double vals[kMaxCellVertices];
                for (size_t i = 0; i < ids.size(); ++i) vals[i] = field.scalar(ids[i], scalars_[f].component);
                e.values[f * n + s] = interpolate(type, rst, vals);
              }
            }
          }
    }
    return e;
  }

 private:
  const UnstructuredMesh& mesh_;
  std::vector<ScalarRef> scalars_;
  std::vector<Bounds> boxes_;
};

// ---- checks on a built store
// ------------------------------------------------------------------------------------------

struct SampleCheck {
  uint64_t nodes = 0, samples = 0, valid = 0, mask_mismatches = 0, shared_mismatches = 0, shared = 0;
  std::vector<double> max_error;  // per field, relative to the field's range
};

// Every node's samples against brute force (leaves only with leaves_only) and shared border samples across the nodes
// of each level.
SampleCheck check_samples(const BrickStoreReader& store, const OctreeInput& in, bool leaves_only) {
  const BruteForce brute(*in.mesh, in.scalars);
  BrickLattice lattice;
  lattice.root = store.layout().root;
  lattice.resolution = store.resolution();
  const uint32_t R = store.resolution(), F = store.field_count();
  const size_t n = size_t(R) * R * R;
  SampleCheck c;
  c.max_error.assign(F, 0.0);
  std::vector<float> values(n);
  std::vector<uint8_t> mask(n);
  // (level, global lattice point) -> first node's bits for each field and its mask
  std::unordered_map<uint64_t, std::pair<std::vector<uint32_t>, uint8_t>> border;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& node = store.node(id);
    if (leaves_only && !node.is_leaf()) continue;
    ++c.nodes;
    const ExactBrick exact = brute.brick(lattice, node.level, {node.i, node.j, node.k});
    std::vector<std::vector<float>> got(F, std::vector<float>(n, 0.0f));
    if (node.has_brick()) {
      for (uint32_t f = 0; f < F; ++f) store.read_brick(id, f, got[f].data(), mask.data());
    } else {
      std::fill(mask.begin(), mask.end(), 0);
    }
    for (uint32_t z = 0; z < R; ++z)
      for (uint32_t y = 0; y < R; ++y)
        for (uint32_t x = 0; x < R; ++x) {
          const size_t s = x + size_t(R) * (y + size_t(R) * z);
          ++c.samples;
          c.valid += mask[s];
          if (bool(mask[s]) != bool(exact.inside[s])) ++c.mask_mismatches;
          if (mask[s] && exact.inside[s]) {
            for (uint32_t f = 0; f < F; ++f) {
              const double range = std::max(in.fields[f].max - in.fields[f].min, 1e-300);
              c.max_error[f] = std::max(c.max_error[f], std::abs(got[f][s] - exact.values[f * n + s]) / range);
            }
          }
          const bool on_border = x == 0 || y == 0 || z == 0 || x == R - 1 || y == R - 1 || z == R - 1;
          if (!on_border) continue;
          const uint64_t gx = uint64_t(node.i) * (R - 1) + x, gy = uint64_t(node.j) * (R - 1) + y,
                         gz = uint64_t(node.k) * (R - 1) + z;
          const uint64_t key = (uint64_t(node.level) << 57) | (gx << 38) | (gy << 19) | gz;
          std::vector<uint32_t> bits(F);
          for (uint32_t f = 0; f < F; ++f) std::memcpy(&bits[f], &got[f][s], 4);
          if (!mask[s]) std::fill(bits.begin(), bits.end(), 0u);
          auto [it, fresh] = border.try_emplace(key, bits, mask[s]);
          if (!fresh) {
            ++c.shared;
            if (it->second.first != bits || it->second.second != mask[s]) ++c.shared_mismatches;
          }
        }
  }
  return c;
}

void expect_exact(const SampleCheck& c, const std::string& what) {
  SCOPED_TRACE(what);
  std::printf(
      "%s: %llu nodes, %llu samples, %llu valid, %llu mask mismatches, %llu of %llu shared samples differ, "
      "max error/range:",
      what.c_str(), (unsigned long long)c.nodes, (unsigned long long)c.samples, (unsigned long long)c.valid,
      (unsigned long long)c.mask_mismatches, (unsigned long long)c.shared_mismatches, (unsigned long long)c.shared);
  for (double e : c.max_error) std::printf(" %.3g", e);
  std::printf("\n");
  EXPECT_GT(c.valid, 0u);
  EXPECT_EQ(c.mask_mismatches, 0u);
  EXPECT_EQ(c.shared_mismatches, 0u);
  for (double e : c.max_error) EXPECT_LE(e, 1e-5);
}

bool box_inside(const Bounds& inner, const Bounds& outer) {
  return inner.lo.x >= outer.lo.x && inner.lo.y >= outer.lo.y && inner.lo.z >= outer.lo.z && inner.hi.x <= outer.hi.x &&
         inner.hi.y <= outer.hi.y && inner.hi.z <= outer.hi.z;
}

// The node table as an octree over the mesh: a cubic root around the data, children inside their parents, every cell
// that overlaps an interior node overlapping one of its existing children (so the leaves cover every cell), every
// vertex in some leaf, and errors that never grow when refining.
void check_tree(const BrickStoreReader& store, const OctreeInput& in, bool check_overlaps = true) {
  const UnstructuredMesh& mesh = *in.mesh;
  const Bounds root = store.layout().root;
  const Vec3d size = root.size();
  EXPECT_EQ(size.x, size.y);
  EXPECT_EQ(size.x, size.z);
  EXPECT_TRUE(box_inside(in.bounds, root));
  const uint32_t F = store.field_count();
  for (uint64_t id = 1; id < store.node_count(); ++id) {
    const BrickNode& node = store.node(id);
    const BrickNode& parent = store.node(node.parent);
    ASSERT_EQ(node.level, parent.level + 1);
    EXPECT_TRUE(box_inside(store.bounds(id), store.bounds(node.parent))) << "node " << id;
    for (uint32_t f = 0; f < F; ++f) {
      EXPECT_GE(store.stats(node.parent, f).error_max, store.stats(id, f).error_max) << "node " << id;
      EXPECT_GE(store.stats(node.parent, f).error_rms, store.stats(id, f).error_rms) << "node " << id;
    }
  }
  if (check_overlaps) {
    for (uint64_t id = 0; id < store.node_count(); ++id) {
      const BrickNode& node = store.node(id);
      if (node.is_leaf()) continue;
      for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
        Vec3d v[kMaxCellVertices];
        gather_cell_vertices(mesh, c, v);
        if (!cell_box_overlap(mesh.cell_types[c], v, store.bounds(id))) continue;
        bool in_child = false;
        for (int o = 0; o < 8 && !in_child; ++o) {
          const uint64_t child = node.child(o);
          in_child = child != kNoNode && cell_box_overlap(mesh.cell_types[c], v, store.bounds(child));
        }
        ASSERT_TRUE(in_child) << "cell " << c << " overlaps node " << id << " but none of its children";
      }
    }
  }
  // Every vertex of a cell descends to a leaf holding it.
  for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
    for (uint32_t vid : mesh.cell(c)) {
      const Vec3d p = to_double(mesh.points[vid]);
      uint64_t id = 0;
      while (!store.node(id).is_leaf()) {
        uint64_t next = kNoNode;
        for (int o = 0; o < 8 && next == kNoNode; ++o) {
          const uint64_t child = store.node(id).child(o);
          if (child != kNoNode && box_contains(store.bounds(child), p)) next = child;
        }
        ASSERT_NE(next, kNoNode) << "vertex " << vid << " of cell " << c << " is in node " << id
                                 << " but in none of its children";
        id = next;
      }
    }
  }
}

// ---- synthetic meshes
// ---------------------------------------------------------------------------------------------------

class OctreeSynthetic : public ::testing::TestWithParam<StructuredCellShape> {};

TEST_P(OctreeSynthetic, SamplesBordersTreeAndErrors) {
  ScratchDir dir;
  const Dataset ds = with_cells(synthetic_dataset(6, 3), GetParam());
  const std::vector<std::string> fields = {"wave", "lin", "cellid"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  const std::string path = dir.file("syn.ugvr");
  const OctreeBuildStats stats = build_octree(in, small_options(5, 3, 0.02), path);
  const BrickStoreReader store(path);
  EXPECT_EQ(store.node_count(), stats.nodes);
  EXPECT_GT(stats.nodes, 9u);  // it refined
  EXPECT_GT(stats.max_level, 1);
  check_tree(store, in);
  expect_exact(check_samples(store, in, /*leaves_only=*/false), "synthetic, every node");
  EXPECT_GT(store.stats(0, 0).error_max, 0.0f);  // the root cannot hold the wave exactly
  // The default 16-bit store: every block of a field on one grid, so shared samples still decode bit for bit alike,
  // each within 7.63e-6 of the range (the linear field's bricks differ in range, the per-cell field has plateaus).
  OctreeBuildOptions quant16 = small_options(5, 3, 0.02);
  quant16.encoding = {};
  build_octree(in, quant16, dir.file("q16.ugvr"));
  const BrickStoreReader q16(dir.file("q16.ugvr"));
  EXPECT_EQ(q16.layout().encoding.samples, SampleEncoding::Quant16);
  EXPECT_EQ(q16.node_count(), store.node_count());
  expect_exact(check_samples(q16, in, /*leaves_only=*/false), "synthetic quant16, every node");
}

INSTANTIATE_TEST_SUITE_P(Shapes, OctreeSynthetic,
                         ::testing::Values(StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra),
                         [](const auto& param_info) {
                           return param_info.param == StructuredCellShape::Hexahedra ? std::string("hexahedra")
                                                                                     : std::string("five_tets");
                         });

TEST(OctreeBuilder, StructuredInputIsBuiltFromHexahedraAndDefaultsToTheFirstField) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(5, 8);
  const OctreeInput in = prepare_octree_input(ds, {});
  ASSERT_EQ(in.fields.size(), 1u);
  EXPECT_EQ(in.fields[0].name, "wave");
  EXPECT_EQ(in.mesh->cell_type_counts().hexahedron, in.mesh->cell_count());
  const std::string path = dir.file("a.ugvr");
  build_octree(in, small_options(5, 2, 0.05), path);
  const BrickStoreReader store(path);
  EXPECT_EQ(store.layout().fields.at(0).name, "wave");
  check_tree(store, in);
  expect_exact(check_samples(store, in, false), "structured");
}

TEST(OctreeBuilder, BlocksAreMergedIntoOneMesh) {
  ScratchDir dir;
  const Dataset one = with_cells(synthetic_dataset(4, 2), StructuredCellShape::FiveTetrahedra);
  Dataset two = one;
  Block shifted = one.blocks[0];
  shifted.name = "shifted";
  for (Vec3f& p : std::get<UnstructuredMesh>(shifted.grid).points)
    p.x += 30.0f;  // beside the first block (overlapping blocks would make values ambiguous)
  FieldSet fields;
  for (const Field& f : shifted.fields) {
    DataArray data = f.data();
    for (uint64_t t = 0; t < data.tuples(); ++t) data.set(t, 0, data.get(t, 0) + 10.0);
    fields.add(Field(f.name(), f.association(), std::move(data)));
  }
  shifted.fields = std::move(fields);
  two.blocks.push_back(std::move(shifted));
  const std::vector<std::string> selectors = {"wave", "cellid"};
  const OctreeInput in = prepare_octree_input(two, selectors);
  const auto& first = std::get<UnstructuredMesh>(one.blocks[0].grid);
  EXPECT_EQ(in.mesh->cell_count(), 2 * first.cell_count());
  EXPECT_EQ(in.mesh->point_count(), 2 * first.point_count());
  ASSERT_EQ(in.fields.size(), 2u);
  EXPECT_EQ(in.fields[0].name, "wave");
  EXPECT_EQ(in.fields[1].association, Association::Cell);
  const Range wave = one.blocks[0].fields.scalar("wave").field->range();
  EXPECT_DOUBLE_EQ(in.fields[0].min, wave.min);
  EXPECT_NEAR(in.fields[0].max, wave.max + 10.0, 1e-5);
  const std::string path = dir.file("two.ugvr");
  build_octree(in, small_options(5, 5, 0.02), path);
  const BrickStoreReader store(path);
  check_tree(store, in);
  expect_exact(check_samples(store, in, false), "two blocks");
}

TEST(OctreeBuilder, SmallerErrorRefinesAtLeastAsMuchAndDepthIsBounded) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(7, 4);
  const std::vector<std::string> fields = {"wave"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  // Above 0 a smaller threshold never refines less. 0 is the geometric rule (no two data points per voxel, two voxels
  // per cell edge) rather than the limit of the thresholds: the interpolant check of a small threshold may ask for
  // more where cells are double sampled but their interpolant still bends between the voxels.
  uint64_t previous = UINT64_MAX;
  for (double error : {0.01, 0.05, 0.5}) {
    const OctreeBuildStats s = build_octree(in, small_options(5, 4, error), dir.file("e.ugvr"));
    std::printf("error %g: %llu nodes, %llu leaves, depth %.2f / %d\n", error, (unsigned long long)s.nodes,
                (unsigned long long)s.leaves, s.mean_leaf_level, s.max_level);
    EXPECT_LE(s.nodes, previous) << "error " << error;
    EXPECT_LE(s.max_level, 4);
    previous = s.nodes;
  }
  const OctreeBuildStats zero = build_octree(in, small_options(5, 4, 0.0), dir.file("z.ugvr"));
  const OctreeBuildStats coarse = build_octree(in, small_options(5, 4, 0.05), dir.file("c.ugvr"));
  EXPECT_GT(zero.nodes, coarse.nodes);
  const OctreeBuildStats root_only = build_octree(in, small_options(5, 0, 0.0), dir.file("r.ugvr"));
  EXPECT_EQ(root_only.nodes, 1u);
}

TEST(OctreeBuilder, SameTreeForAnyThreadCount) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(6, 5);
  const std::vector<std::string> fields = {"wave"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  OctreeBuildOptions o = small_options(5, 3, 0.01);
  o.threads = 1;
  build_octree(in, o, dir.file("1.ugvr"));
  o.threads = 0;
  build_octree(in, o, dir.file("n.ugvr"));
  const BrickStoreReader a(dir.file("1.ugvr")), b(dir.file("n.ugvr"));
  ASSERT_EQ(a.node_count(), b.node_count());
  std::vector<float> va(125), vb(125);
  for (uint64_t id = 0; id < a.node_count(); ++id) {
    EXPECT_EQ(a.node(id).child_mask, b.node(id).child_mask);
    EXPECT_EQ(a.node(id).first_child, b.node(id).first_child);
    EXPECT_EQ(a.stats(id, 0).error_max, b.stats(id, 0).error_max);
    ASSERT_EQ(a.node(id).has_brick(), b.node(id).has_brick());
    if (!a.node(id).has_brick()) continue;
    a.read_brick(id, 0, va.data(), nullptr);
    b.read_brick(id, 0, vb.data(), nullptr);
    EXPECT_EQ(va, vb);
  }
}

TEST(OctreeBuilder, RejectsBadOptionsAndFields) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(3, 1);
  const std::vector<std::string> missing = {"nope"};
  try {
    prepare_octree_input(ds, missing);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("synthetic"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nope"), std::string::npos) << e.what();
  }
  const OctreeInput in = prepare_octree_input(ds, {});
  OctreeBuildOptions o;
  o.resolution = 1;
  EXPECT_THROW(build_octree(in, o, dir.file("x.ugvr")), Error);
  o = {};
  o.error = -1;
  EXPECT_THROW(build_octree(in, o, dir.file("x.ugvr")), Error);
  o = {};
  o.max_depth = 40;
  EXPECT_THROW(build_octree(in, o, dir.file("x.ugvr")), Error);
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.ugvr")));
}

// ---- out of core
// ------------------------------------------------------------------------------------------------------

// The same tree, the same bricks bit for bit, the same leaf errors (max, rms and transfer-function error entry: a
// leaf sampled in pieces measures the same points, each once); interior errors can only be lower out of core
// (measured at the children's samples, not at the data points too).
void expect_same_store(const BrickStoreReader& in_core, const BrickStoreReader& ooc) {
  ASSERT_EQ(in_core.node_count(), ooc.node_count());
  test::expect_same_nodes_and_bricks(in_core, ooc, [&](uint64_t ia, uint64_t ib, uint32_t f) {
    ASSERT_TRUE(in_core.has_tf_errors() && ooc.has_tf_errors());
    EXPECT_EQ(in_core.stats(ia, f).error_rms, ooc.stats(ib, f).error_rms) << "node " << ia;
    const auto& ta = in_core.tf_errors()[ia * in_core.field_count() + f];
    const auto& tb = ooc.tf_errors()[ib * ooc.field_count() + f];
    EXPECT_EQ(std::memcmp(&ta, &tb, sizeof ta), 0) << "node " << ia;
  });
}

// The same boundary section: the same triangles in the same order, and each node (by place) listing the same ones,
// its virtual nodes (numbered in another order out of core) compared by octant.
void expect_same_boundary(const BrickStoreReader& in_core, const BrickStoreReader& ooc) {
  const StoreBoundary &a = in_core.boundary(), &b = ooc.boundary();
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  ASSERT_FALSE(a.triangles.empty());
  EXPECT_EQ(std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(a.triangles[0])), 0);
  EXPECT_EQ(a.refs.size(), b.refs.size());
  EXPECT_EQ(a.nodes.size(), b.nodes.size());
  EXPECT_EQ(a.max_per_node, b.max_per_node);
  auto same_entry = [&](auto& self, uint64_t ea, uint64_t eb, bool leaf) -> void {
    const store_format::BoundaryNodeEntry &x = a.nodes[ea], &y = b.nodes[eb];
    ASSERT_EQ(x.count, y.count) << "entry " << ea;
    if (x.count == store_format::kBoundaryOverflow) {
      if (leaf)
        for (uint32_t o = 0; o < 8; ++o) self(self, x.first + o, y.first + o, true);
      return;
    }
    for (uint32_t r = 0; r < x.count; ++r) EXPECT_EQ(a.refs[x.first + r], b.refs[y.first + r]) << "entry " << ea;
  };
  const auto pa = test::nodes_by_place(in_core), pb = test::nodes_by_place(ooc);
  for (const auto& [place, ia] : pa) same_entry(same_entry, ia, pb.at(place), in_core.node(ia).is_leaf());
}

TEST(OctreeOutOfCore, SameStoreAsInCore) {
  ScratchDir dir;
  const std::string vtu = dir.file("syn.vtu");
  write_vtu(with_cells(synthetic_dataset(12, 6), StructuredCellShape::FiveTetrahedra), vtu);
  const Dataset ds = read_dataset(std::vector<std::string>{vtu});
  const std::vector<std::string> fields = {"wave", "cellid"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  for (const auto& [error, depth] : {std::pair(0.0, 4), std::pair(0.02, 4), std::pair(0.02, 1), std::pair(0.0, 0)}) {
    SCOPED_TRACE("error " + std::to_string(error) + " max depth " + std::to_string(depth));
    const OctreeBuildOptions o = small_options(5, depth, error);
    const OctreeBuildStats a = build_octree(in, o, dir.file("in.ugvr"));
    // A budget so small (64 KiB of records per worker) that the larger leaves are sampled in pieces.
    const OctreeBuildStats b = build_octree_out_of_core(vtu, fields, o, 1, dir.file("ooc.ugvr"));
    std::printf("error %g: %llu nodes, %llu leaves sampled in pieces\n", error, (unsigned long long)b.nodes,
                (unsigned long long)b.leaves_in_pieces);
    EXPECT_EQ(a.nodes, b.nodes);
    EXPECT_EQ(a.leaves, b.leaves);
    EXPECT_EQ(a.cells, b.cells);
    EXPECT_EQ(a.valid_samples, b.valid_samples);
    if (depth <= 1) {
      EXPECT_GT(b.leaves_in_pieces, 0u);  // leaves of ~1000 cells or more: over 100 KB of records
    }
    EXPECT_EQ(a.leaf_samples, b.leaf_samples);
    const BrickStoreReader store(dir.file("ooc.ugvr"));
    expect_same_store(BrickStoreReader(dir.file("in.ugvr")), store);
    check_tree(store, in, /*check_overlaps=*/false);
    expect_exact(check_samples(store, in, false), "out of core");
    // A budget this small cannot hold the boundary's triangles: the store keeps the stencil's boundary and says why.
    EXPECT_FALSE(store.has_boundary());
    EXPECT_NE(b.boundary_note.find("memory budget"), std::string::npos) << b.boundary_note;
    // With room, the same boundary section as in core; and, beside the boundary, the same store as at the small
    // budget: every node's errors and transfer-function entries too (its leaves were not sampled in pieces).
    const OctreeBuildStats c = build_octree_out_of_core(vtu, fields, o, uint64_t(256) << 20, dir.file("roomy.ugvr"));
    EXPECT_TRUE(c.boundary_note.empty()) << c.boundary_note;
    EXPECT_EQ(c.leaves_in_pieces, 0u);
    EXPECT_EQ(c.boundary_triangles, a.boundary_triangles);
    EXPECT_EQ(c.boundary_bytes, a.boundary_bytes);
    const BrickStoreReader roomy(dir.file("roomy.ugvr"));
    expect_same_store(BrickStoreReader(dir.file("in.ugvr")), roomy);
    expect_same_boundary(BrickStoreReader(dir.file("in.ugvr")), roomy);
    test::expect_same_store_at_any_budget(roomy, store);
  }
  // Nothing is left beside the output.
  size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(vtu).parent_path())) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 4u);  // syn.vtu, in.ugvr, ooc.ugvr, roomy.ugvr
}

TEST(OctreeOutOfCore, PointsInSlicesGiveTheSameCells) {
  ScratchDir dir;
  const std::string vtu = dir.file("syn.vtu");
  write_vtu(with_cells(synthetic_dataset(6, 2), StructuredCellShape::SixTetrahedra), vtu);
  const std::vector<std::string> fields = {"wave", "cellid", "lin"};
  std::string bytes[2];
  uint64_t passes[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    VtuCellSource source(vtu, fields);
    const uint64_t budget = k == 0 ? uint64_t(1) << 30 : 100 * (12 + 4 * 2);  // all points, or 100 at a time
    const std::string soup = dir.file("soup" + std::to_string(k));
    {
      SoupWriter w(soup, source.layout());
      EXPECT_EQ(source.write_soup(w, budget, dir.file("")), 6u * 6 * 7 * 5);
      w.close();
    }
    passes[k] = source.passes();
    bytes[k] = InputFile(soup).read_all();
    EXPECT_EQ(source.fields().at(1).name, "cellid");
    EXPECT_EQ(source.fields().at(1).min, 0.0);
    EXPECT_EQ(source.fields().at(1).max, 12.0);
  }
  EXPECT_EQ(passes[0], 1u);
  EXPECT_EQ(passes[1], (7u * 8 * 6 + 99) / 100);
  EXPECT_EQ(bytes[0], bytes[1]);
  // The corner files are gone.
  EXPECT_FALSE(std::filesystem::exists(dir.file("corners-0")));
}

// The boundary found from a soup equals the one found from the mesh in memory (grid/topology.h), triangle for
// triangle: quadrilaterals split alike, faces met more than twice counted as boundary, with faces in many buckets.
TEST(OctreeOutOfCore, SoupBoundaryEqualsTheMeshBoundary) {
  ScratchDir dir;
  Dataset hexes = with_cells(synthetic_dataset(10, 4), StructuredCellShape::Hexahedra);
  Dataset dup;  // two hexahedra and a copy of the first: its shared face is met three times
  {
    Block b;
    b.name = "dup";
    UnstructuredMesh m;
    for (int z = 0; z < 2; ++z)
      for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) m.points.push_back({float(x), float(y), float(z)});
    auto id = [](int x, int y, int z) { return uint32_t(x + 3 * (y + 2 * z)); };
    for (int c : {0, 1, 0}) {
      const uint32_t v[8] = {id(c, 0, 0), id(c + 1, 0, 0), id(c + 1, 1, 0), id(c, 1, 0),
                             id(c, 0, 1), id(c + 1, 0, 1), id(c + 1, 1, 1), id(c, 1, 1)};
      m.add_cell(CellType::Hexahedron, v);
    }
    std::vector<float> values(12);
    for (size_t i = 0; i < values.size(); ++i) values[i] = float(i);
    b.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(values), 1)));
    b.grid = std::move(m);
    dup.sources = {"dup"};
    dup.blocks.push_back(std::move(b));
  }
  int k = 0;
  for (const Dataset* ds : {&hexes, &dup}) {
    SCOPED_TRACE("dataset " + std::to_string(k));
    const std::string vtu = dir.file("m" + std::to_string(k++) + ".vtu");
    write_vtu(*ds, vtu);
    const Dataset back = read_dataset(std::vector<std::string>{vtu});
    const auto& mesh = std::get<UnstructuredMesh>(back.blocks.at(0).grid);
    const std::vector<MeshFaceTriangle> expected = mesh_boundary_triangles(mesh);
    VtuCellSource source(vtu, {});
    const std::string soup = dir.file("soup");
    uint64_t cells = 0;
    {
      SoupWriter w(soup, source.layout());
      cells = source.write_soup(w, uint64_t(1) << 30, dir.file(""));
      w.close();
    }
    SoupBoundaryStats st;
    // Budget 1: buckets of the 64 KiB minimum, so the 990 hexahedra's 5,940 faces spread over several.
    const std::vector<MeshFaceTriangle> got =
        soup_boundary_triangles(soup, source.layout(), cells, 1, dir.file(""), {}, &st);
    ASSERT_EQ(got.size(), expected.size());
    EXPECT_EQ(std::memcmp(got.data(), expected.data(), got.size() * sizeof(got[0])), 0);
    EXPECT_EQ(st.faces, 6 * cells);
    if (ds == &hexes) {
      EXPECT_GT(st.buckets, 1u);
      EXPECT_EQ(st.nonmanifold_faces, 0u);
      EXPECT_EQ(got.size(), 2u * 2 * (10 * 11 + 11 * 9 + 10 * 9));  // a 10 x 11 x 9 block: 2 triangles a quad
    } else {
      EXPECT_EQ(st.nonmanifold_faces, 3u);
      EXPECT_EQ(st.boundary_faces, 5u + 3);  // cell 1's five outer faces, and the shared one three times
    }
    for (const auto& e : std::filesystem::directory_iterator(dir.file("")))
      EXPECT_EQ(e.path().filename().string().rfind("faces-", 0), std::string::npos) << e.path();
  }
}

TEST(OctreeOutOfCore, RejectsWhatItCannotRead) {
  ScratchDir dir;
  const std::string vtu = dir.file("syn.vtu");
  write_vtu(synthetic_dataset(3, 1), vtu);
  const std::vector<std::string> missing = {"nope"};
  try {
    build_octree_out_of_core(vtu, missing, small_options(5, 2, 0.01), 1 << 30, dir.file("x.ugvr"));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("syn.vtu"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nope"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.ugvr")));
  const auto r = test::run_ugvr("build " + vtu + " -o " + dir.file("y.ugvr") + " --out-of-core --brick 5 --json");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("\"out_of_core\":true"), std::string::npos) << r.out;
  // A .vtu larger than 40% of --memory is built out of core by itself.
  const auto small = test::run_ugvr("build " + vtu + " -o " + dir.file("s.ugvr") + " --memory 1KiB --brick 5 --json");
  EXPECT_EQ(small.status, 0) << small.out;
  EXPECT_NE(small.out.find("\"out_of_core\":true"), std::string::npos) << small.out;
  const auto roomy = test::run_ugvr("build " + vtu + " -o " + dir.file("s.ugvr") + " --brick 5 --json");
  EXPECT_NE(roomy.out.find("\"out_of_core\":false"), std::string::npos) << roomy.out;
  const auto bad = test::run_ugvr("build " + vtu + " " + vtu + " -o " + dir.file("z.ugvr") + " --out-of-core");
  EXPECT_NE(bad.status, 0) << bad.out;
}

// ---- the split criterion and the pad on their own -------------------------------------------------------------------

// Two unit hexahedra side by side along x; vertex values given.
struct TwoHexes {
  UnstructuredMesh mesh;
  FieldSet fields;
};
TwoHexes two_hexes(std::vector<float> values) {
  TwoHexes t;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) t.mesh.points.push_back({float(x), float(y), float(z)});
  auto id = [](int x, int y, int z) { return uint32_t(x + 3 * (y + 2 * z)); };
  for (int c = 0; c < 2; ++c) {
    const uint32_t v[8] = {id(c, 0, 0), id(c + 1, 0, 0), id(c + 1, 1, 0), id(c, 1, 0),
                           id(c, 0, 1), id(c + 1, 0, 1), id(c + 1, 1, 1), id(c, 1, 1)};
    t.mesh.add_cell(CellType::Hexahedron, v);
  }
  t.fields.add(Field("f", Association::Vertex, DataArray::from(std::move(values), 1)));
  return t;
}

TEST(OctreeSplit, VerticesSharingAVoxelSplitWhenTheyDiffer) {
  // R = 2 over x in [0, 2]: the voxels are the halves nearest x = 0 and x = 2; the vertices at x = 1 round into the
  // x = 2 voxel with those at x = 2.
  Bounds box;
  box.lo = {0, 0, 0}, box.hi = {2, 2, 2};
  const std::vector<uint64_t> cells = {0, 1};
  auto split = [&](std::vector<float> values, double error) {
    const TwoHexes t = two_hexes(std::move(values));
    const std::vector<ScalarRef> refs = {t.fields.scalar("f")};
    const OctreeDataPoints points(t.mesh, refs);
    BrickStoreField f;
    f.min = 0, f.max = 10;
    VoxelSpread scratch;
    return SplitTest(points, std::span(&f, 1), error, 2).needs_split(box, cells, scratch);
  };
  std::vector<float> flat(12, 1.0f);
  EXPECT_FALSE(split(flat, 0.01));
  EXPECT_TRUE(split(flat, 0.0));  // geometric: two positions in one voxel
  std::vector<float> step = flat;
  step[1] = 1.5f;  // vertex (1, 0, 0): differs from (2, 0, 0) by 0.05 of the range
  EXPECT_TRUE(split(step, 0.01));
  EXPECT_FALSE(split(step, 0.1));
  std::vector<float> far = flat;
  far[0] = 9.0f;  // vertex (0, 0, 0) has its own voxel: no matter how different
  EXPECT_FALSE(split(far, 0.01));
}

TEST(OctreeSplit, CoincidentVerticesAndFlatCellsDoNotForceSplits) {
  // One hexahedron and, sharing no vertex, a flat one whose vertices nearly coincide in pairs.
  UnstructuredMesh mesh;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) mesh.points.push_back({float(x), float(y), float(z)});
  const uint32_t hex[8] = {0, 1, 3, 2, 4, 5, 7, 6};
  mesh.add_cell(CellType::Hexahedron, hex);
  // Duplicates of the hexahedron's vertices: positions coincide, so they never count twice.
  for (int i = 0; i < 8; ++i) mesh.points.push_back(mesh.points[size_t(i)]);
  const uint32_t dup[8] = {8, 9, 11, 10, 12, 13, 15, 14};
  mesh.add_cell(CellType::Hexahedron, dup);
  // A sliver tetrahedron far from both.
  const uint32_t base = uint32_t(mesh.points.size());
  mesh.points.push_back({5, 5, 5});
  mesh.points.push_back({5.001f, 5, 5});
  mesh.points.push_back({5, 5.001f, 5});
  mesh.points.push_back({5.0005f, 5.0005f, 5.0f});
  const uint32_t tet[4] = {base, base + 1, base + 2, base + 3};
  mesh.add_cell(CellType::Tetra, tet);
  std::vector<float> values(mesh.point_count(), 2.0f);
  FieldSet fs;
  fs.add(Field("f", Association::Vertex, DataArray::from(std::move(values), 1)));
  const std::vector<ScalarRef> refs = {fs.scalar("f")};
  const OctreeDataPoints points(mesh, refs);
  EXPECT_FALSE(points.splits(base));
  EXPECT_TRUE(points.splits(0));
  BrickStoreField f;
  f.min = 0, f.max = 1;
  VoxelSpread scratch;
  // R = 3: the unit hexahedron's edges span two voxels (h = 0.5), as the double-sampling rule asks.
  const SplitTest test(points, std::span(&f, 1), 0.0, 3);
  Bounds unit;
  unit.lo = {0, 0, 0}, unit.hi = {1, 1, 1};
  EXPECT_FALSE(test.needs_split(unit, std::vector<uint64_t>{0, 1}, scratch));
  Bounds far;
  far.lo = {4, 4, 4}, far.hi = {6, 6, 6};
  EXPECT_FALSE(test.needs_split(far, std::vector<uint64_t>{2}, scratch));
}

TEST(OctreeSplit, CellEdgesSpanTwoVoxelsAtZeroError) {
  // One unit hexahedron filling the box [0, 1]³: with R samples per axis a voxel is h = 1 / (R - 1).
  const TwoHexes t = two_hexes(std::vector<float>(12, 1.0f));
  Vec3d corners[8];
  for (int i = 0; i < 8; ++i) corners[i] = to_double(t.mesh.points[t.mesh.cell(0)[size_t(i)]]);
  Bounds box;
  box.lo = {0, 0, 0}, box.hi = {1, 1, 1};
  const double threshold = 0;
  VoxelSpread table;
  auto splits = [&](uint32_t R, bool geometric, const Bounds& b) {
    table.begin(b, R, std::span(&threshold, 1), geometric);
    return table.add_cell_edges(CellType::Hexahedron, corners);
  };
  EXPECT_TRUE(splits(2, true, box));    // one voxel per edge
  EXPECT_FALSE(splits(3, true, box));   // two
  EXPECT_FALSE(splits(5, true, box));   // four
  EXPECT_FALSE(splits(2, false, box));  // only at --error 0
  Bounds far;
  far.lo = {3, 3, 3}, far.hi = {4, 4, 4};
  EXPECT_FALSE(splits(2, true, far));  // no edge has an end in the node
  // A collapsed edge (two vertices at one position) never counts; the other edges still do.
  corners[1] = corners[0];
  EXPECT_FALSE(splits(3, true, box));
  // Through the split test: the same answer with the two hexahedra (R = 3 over [0, 2]: h = 1, one voxel per edge).
  const std::vector<ScalarRef> refs = {t.fields.scalar("f")};
  const OctreeDataPoints points(t.mesh, refs);
  BrickStoreField f;
  f.min = 0, f.max = 10;
  Bounds two;
  two.lo = {0, 0, 0}, two.hi = {2, 2, 2};
  const std::vector<uint64_t> cells = {0, 1};
  EXPECT_TRUE(SplitTest(points, std::span(&f, 1), 0.0, 3).needs_split(two, cells, table));
  EXPECT_FALSE(SplitTest(points, std::span(&f, 1), 0.0, 5).needs_split(two, cells, table));
}

// At --error 0 every leaf (above the depth limit) holds at least two voxels per edge of each cell that reaches into it:
// LaMar's double-sampling rule. A coarse grid (about one data point per voxel under the point rule alone) gets it.
TEST(OctreeBuilder, CoarseGridLeavesDoubleSampleEveryCellEdge) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(5, 9);
  const std::vector<std::string> fields = {"wave"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  const int max_depth = 6;
  build_octree(in, small_options(5, max_depth, 0.0), dir.file("z.ugvr"));
  const BrickStoreReader store(dir.file("z.ugvr"));
  const UnstructuredMesh& mesh = *in.mesh;
  const OctreeDataPoints data(mesh, in.scalars);
  uint64_t checked = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& n = store.node(id);
    if (!n.is_leaf() || n.level >= max_depth) continue;
    const Bounds b = store.bounds(id);
    const double h = (b.hi.x - b.lo.x) / (store.resolution() - 1);
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (data.cell_flat(c)) continue;
      const auto v = mesh.cell(c);
      for (const auto& e : cell_edges(mesh.cell_types[c])) {
        const Vec3d p = to_double(mesh.points[v[e[0]]]), q = to_double(mesh.points[v[e[1]]]);
        const double len = length(q - p);
        if (len == 0 || !(box_contains(b, p) || box_contains(b, q))) continue;
        EXPECT_GE(len, 2 * h * (1 - 1e-12)) << "leaf " << id << " cell " << c;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100u);
}

// At --error E > 0 every leaf above the depth limit reads, trilinearly from its stored brick (float32, padded as a
// renderer pads it), within E × range of the mesh's own interpolant at every vertex, edge midpoint and centre of the
// cells reaching into it, wherever the 8 surrounding samples all hold data. Computed here independently of the
// builder's check, with the cells' interpolant at those points in closed form (vertex means).
TEST(OctreeBuilder, LeavesFollowTheInterpolantWithinTheThreshold) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(5, 11);
  const std::vector<std::string> fields = {"wave"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  const double error = 0.02;
  const int max_depth = 6;
  const OctreeBuildStats stats = build_octree(in, small_options(5, max_depth, error), dir.file("i.ugvr"));
  const BrickStoreReader store(dir.file("i.ugvr"));
  const double threshold = error * (in.fields[0].max - in.fields[0].min);
  const UnstructuredMesh& mesh = *in.mesh;
  const OctreeDataPoints data(mesh, in.scalars);
  const uint32_t R = store.resolution();
  std::vector<float> values(size_t(R) * R * R);
  std::vector<uint8_t> mask(values.size());
  uint64_t checked = 0, leaves = 0;
  double worst = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& n = store.node(id);
    if (!n.is_leaf() || n.level >= max_depth || !n.has_brick()) continue;
    ++leaves;
    store.read_brick(id, 0, values.data(), mask.data());
    pad_brick(R, 1, values.data(), mask.data());
    // The lattice box: the node's cell (the lattice spans it, border samples on its faces).
    const Bounds b = store.bounds(id);
    auto trilinear = [&](Vec3d p, double& out) {
      double u[3];
      uint32_t i0[3];
      for (int a = 0; a < 3; ++a) {
        const double c = std::clamp((p[a] - b.lo[a]) / (b.hi[a] - b.lo[a]) * (R - 1), 0.0, double(R - 1));
        i0[a] = std::min(uint32_t(c), R - 2);
        u[a] = c - i0[a];
      }
      out = 0;
      for (int q = 0; q < 8; ++q) {
        const uint32_t dx = q & 1, dy = q >> 1 & 1, dz = q >> 2 & 1;
        const size_t s = (i0[0] + dx) + size_t(R) * ((i0[1] + dy) + size_t(R) * (i0[2] + dz));
        if (!mask[s]) return false;
        out += (dx ? u[0] : 1 - u[0]) * (dy ? u[1] : 1 - u[1]) * (dz ? u[2] : 1 - u[2]) * values[s];
      }
      return true;
    };
    for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
      if (data.cell_flat(c)) continue;
      const auto v = mesh.cell(c);
      auto check = [&](std::initializer_list<size_t> corners) {
        Vec3d p{0, 0, 0};
        double exact = 0;
        for (size_t i : corners) p = p + to_double(mesh.points[v[i]]), exact += data.value(v[i], 0);
        p = p * (1.0 / double(corners.size()));
        exact /= double(corners.size());
        double voxel = 0;
        if (!box_contains(b, p) || !trilinear(p, voxel)) return;
        worst = std::max(worst, std::abs(voxel - exact));
        EXPECT_LE(std::abs(voxel - exact), threshold * (1 + 1e-6)) << "leaf " << id << " cell " << c;
        ++checked;
      };
      for (size_t i = 0; i < v.size(); ++i) check({i});
      for (const auto& e : cell_edges(mesh.cell_types[c])) check({e[0], e[1]});
      ASSERT_EQ(v.size(), 8u);  // hexahedra: the centre is the mean of the 8
      check({0, 1, 2, 3, 4, 5, 6, 7});
    }
  }
  std::printf("error %g: %llu nodes, %llu leaves checked at %llu points, worst %.3g of the threshold\n", error,
              (unsigned long long)stats.nodes, (unsigned long long)leaves, (unsigned long long)checked,
              worst / threshold);
  EXPECT_GT(checked, 1000u);
}

// The transfer-function error table (store/brick_store_format.h, TfErrorEntry) as the builder writes it: every node
// with data has one entry per field, its group weights summing to 255, its groups in ascending order, each group's
// rms within the node's error_max; the wavy field's root has a spread.
TEST(OctreeBuilder, TfErrorTableFromThePairs) {
  ScratchDir dir;
  const Dataset ds = synthetic_dataset(6, 3);
  const std::vector<std::string> fields = {"wave", "lin"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  build_octree(in, small_options(5, 4, 0.01), dir.file("t.ugvr"));
  const BrickStoreReader store(dir.file("t.ugvr"));
  ASSERT_TRUE(store.has_tf_errors());
  const auto entries = store.tf_errors();
  double root_wave = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    for (uint32_t f = 0; f < 2; ++f) {
      const store_format::TfErrorEntry& e = entries[id * 2 + f];
      const BrickStoreField& field = store.layout().fields[f];
      int weight = 0, spread = 0;
      for (int g = 0; g < store_format::kTfErrorGroups; ++g) {
        EXPECT_LE(e.bound[g], e.bound[g + 1]) << id;
        weight += e.weight[g];
        spread = std::max(spread, int(e.spread[g]));
      }
      if (!store.node(id).has_brick()) continue;
      // No pair (no measured point had a data sample among its 8 neighbours): all zero, "unknown".
      EXPECT_TRUE(weight == 0 || std::abs(weight - 255) <= 8) << "node " << id << " field " << f << ": " << weight;
      if (weight == 0) {
        EXPECT_EQ(spread, 0) << id;
      }
      const double code = 65535 / (field.max - field.min);
      if (f == 0 && id == 0) root_wave = spread / code;
      // Never beyond the node's stored error_max (rms <= max), up to the code's rounding.
      EXPECT_LE(spread / code, store.stats(id, f).error_max + 2 / code) << "node " << id << " field " << f;
    }
  }
  EXPECT_GT(root_wave, 0.0);
}

TEST(OctreePad, OneLayerOfMeansOfDataNeighbours) {
  const uint32_t R = 4;
  std::vector<float> values(2 * 64, -99.0f);
  std::vector<uint8_t> mask(64, 0);
  auto at = [](uint32_t x, uint32_t y, uint32_t z) { return size_t(x + 4 * (y + 4 * z)); };
  mask[at(1, 1, 1)] = 1, values[at(1, 1, 1)] = 5, values[64 + at(1, 1, 1)] = -5;
  mask[at(2, 1, 1)] = 1, values[at(2, 1, 1)] = 7, values[64 + at(2, 1, 1)] = -7;
  pad_brick(R, 2, values.data(), mask.data());
  EXPECT_EQ(values[at(0, 0, 0)], 5.0f);  // touches (1, 1, 1) only
  EXPECT_EQ(values[at(3, 2, 2)], 7.0f);  // touches (2, 1, 1) only
  EXPECT_EQ(values[at(1, 2, 1)], 6.0f);  // touches both
  EXPECT_EQ(values[64 + at(1, 2, 1)], -6.0f);
  EXPECT_EQ(values[at(1, 1, 1)], 5.0f);    // data stays
  EXPECT_EQ(values[at(3, 3, 3)], -99.0f);  // no data neighbour: one layer only
  EXPECT_EQ(values[at(0, 3, 3)], -99.0f);
}

// ---- real data
// -------------------------------------------------------------------------------------------------------

TEST(OctreeRealData, SpxTetrahedra) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  ScratchDir dir;
  const Dataset ds = read_dataset(std::vector<std::string>{relative_data_path});
  const std::vector<std::string> fields = {"density"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  const OctreeBuildStats s = build_octree(in, small_options(9, 4, 0.01), dir.file("spx.ugvr"));
  const BrickStoreReader store(dir.file("spx.ugvr"));
  std::printf("spx: %llu nodes, %llu leaves, depth %.2f / %d\n", (unsigned long long)s.nodes,
              (unsigned long long)s.leaves, s.mean_leaf_level, s.max_level);
  check_tree(store, in);
  expect_exact(check_samples(store, in, false), "spx");
  // The default 16-bit store keeps every sample within 7.63e-6 of the range (brick-store.md), and its field-wide
  // quantization grid keeps shared samples identical.
  OctreeBuildOptions quant16 = small_options(9, 4, 0.01);
  quant16.encoding = {};
  build_octree(in, quant16, dir.file("q16.ugvr"));
  expect_exact(check_samples(BrickStoreReader(dir.file("q16.ugvr")), in, false), "spx quant16");
  const OctreeBuildStats zero = build_octree(in, small_options(9, 4, 0.0), dir.file("spx0.ugvr"));
  const OctreeBuildStats coarse = build_octree(in, small_options(9, 4, 0.05), dir.file("spx5.ugvr"));
  EXPECT_GE(zero.nodes, coarse.nodes);
  EXPECT_GE(zero.nodes, s.nodes);
}

TEST(OctreeRealData, BluntFinLeaves) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  ScratchDir dir;
  const Dataset ds =
      read_dataset(std::vector<std::string>{relative_data_path, test::data_path("blunt-fin/bluntfinq.bin")});
  const std::vector<std::string> fields = {"Density", "Momentum"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  EXPECT_EQ(in.fields[1].name, "Momentum:magnitude");
  const OctreeBuildStats s = build_octree(in, small_options(9, 3, 0.05), dir.file("fin.ugvr"));
  const BrickStoreReader store(dir.file("fin.ugvr"));
  std::printf("blunt fin: %llu nodes, %llu leaves, depth %.2f / %d\n", (unsigned long long)s.nodes,
              (unsigned long long)s.leaves, s.mean_leaf_level, s.max_level);
  check_tree(store, in, /*check_overlaps=*/false);
  expect_exact(check_samples(store, in, /*leaves_only=*/true), "blunt fin leaves");
}

TEST(OctreeRealData, LoxPostMaskFollowsIblankHoles) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  ScratchDir dir;
  Dataset ds = read_dataset(std::vector<std::string>{relative_data_path, test::data_path("lox-post/postq.bin")});
  auto& grid = std::get<StructuredGrid>(ds.blocks.at(0).grid);
  ASSERT_TRUE(grid.has_iblank());
  // The file blanks no point (its IBLANK holds only fringe markers): cut holes as a flow solver would, a block of
  // the grid and a scatter of single points.
  StructuredGrid unblanked = grid;
  unblanked.iblank.clear();
  const GridDims d = grid.dims;
  for (uint32_t k = 0; k < d.points[2]; ++k)
    for (uint32_t j = 0; j < d.points[1]; ++j)
      for (uint32_t i = 0; i < d.points[0]; ++i) {
        const bool block = i >= 12 && i < 24 && j >= 30 && j < 50 && k >= 8 && k < 20;
        const bool scatter = (i * 7 + j * 13 + k * 5) % 97 == 0;
        if (block || scatter) grid.iblank[d.point_index(i, j, k)] = 0;
      }
  const std::vector<std::string> fields = {"StagnationEnergy"};
  const OctreeInput in = prepare_octree_input(ds, fields);
  ASSERT_LT(in.mesh->cell_count(), uint64_t(d.points[0] - 1) * (d.points[1] - 1) * (d.points[2] - 1));
  const OctreeBuildStats s = build_octree(in, small_options(9, 2, 0.05), dir.file("lox.ugvr"));
  const BrickStoreReader store(dir.file("lox.ugvr"));
  std::printf("lox post with holes: %llu nodes, %llu leaves\n", (unsigned long long)s.nodes,
              (unsigned long long)s.leaves);
  expect_exact(check_samples(store, in, /*leaves_only=*/true), "lox post leaves");
  // The leaves' lattices do reach into the holes: points in the unblanked mesh that the blanked one lacks, masked out.
  const UnstructuredMesh whole = make_explicit_cells(unblanked, StructuredCellShape::Hexahedra).mesh;
  const BruteForce with_holes(*in.mesh, {}), without(whole, {});
  BrickLattice lattice;
  lattice.root = store.layout().root;
  lattice.resolution = store.resolution();
  uint64_t in_holes = 0;
  std::vector<uint8_t> mask(size_t(9 * 9 * 9));
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    const BrickNode& node = store.node(id);
    if (!node.is_leaf()) continue;
    const ExactBrick a = with_holes.brick(lattice, node.level, {node.i, node.j, node.k});
    const ExactBrick b = without.brick(lattice, node.level, {node.i, node.j, node.k});
    std::fill(mask.begin(), mask.end(), 0);
    if (node.has_brick()) store.read_brick(id, 0, std::vector<float>(mask.size()).data(), mask.data());
    for (size_t s2 = 0; s2 < mask.size(); ++s2) {
      if (b.inside[s2] && !a.inside[s2]) {
        ++in_holes;
        EXPECT_EQ(mask[s2], 0) << "node " << id << " sample " << s2 << " lies in a hole";
      }
    }
  }
  std::printf("lox post: %llu leaf samples in the holes\n", (unsigned long long)in_holes);
  EXPECT_GT(in_holes, 20u);
}

// ---- command line
// ----------------------------------------------------------------------------------------------------

TEST(CliBuild, SpxStoreAndErrors) {
  UGVR_REQUIRE_DATA("spx/spx.inp");
  ScratchDir dir;
  const std::string out = dir.file("spx.ugvr");
  const auto r = test::run_ugvr("build " + relative_data_path + " -o " + out + " --brick 9 --max-depth 3 --threads 2");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("nodes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("peak RSS"), std::string::npos) << r.out;
  const BrickStoreReader store(out);
  EXPECT_EQ(store.field_index("density"), 0);
  EXPECT_EQ(store.resolution(), 9u);

  const auto bad = test::run_ugvr("build " + relative_data_path + " -o " + dir.file("b.ugvr") + " --fields nope");
  EXPECT_EQ(bad.status, 1) << bad.out;
  EXPECT_NE(bad.out.find("spx.inp"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("nope"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("b.ugvr")));
  const auto ext = test::run_ugvr("build " + relative_data_path + " -o " + dir.file("b.vtu"));
  EXPECT_EQ(ext.status, 1) << ext.out;
}

}  // namespace
}  // namespace ugvr
