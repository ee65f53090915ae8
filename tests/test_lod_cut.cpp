// LOD cut selection (render/lod/lod_cut.h) on small synthetic brick stores: the leaves cut, the exact-once coverage
// of the visible data on random cameras (checked against pixel rays and the opacity sampled densely, independently of
// the module's own tests), the error and pixel criteria and their monotonicity, the budget, frustum and transfer
// function culling, nodes without bricks, transparency of intervals, and cut spec parsing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "octree_shapes.h"
#include "ugvr/core/error.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/lod/tf_error.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------------------------
// Synthetic stores

struct StoreOptions {
  uint32_t r = 4;
  int depth = 4;
  bool root_without_brick = false;  // an inner node without brick: must be refined regardless
  bool last_leaf_without_brick = false;
  // A transfer-function error table (store_format::TfErrorEntry) for field 0: per node its x range in 8 equal
  // groups, each with an rms difference of 0.02 × 2^-level of the range (inner nodes; leaves 0).
  bool tf_table = false;
};

// Root [0,1]³. A node exists where its box meets the ball of radius 0.5 around the centre, except in the root's
// octant 7 (x, y, z > 0.5: a missing child); nodes with x <= 0.25 stop at level 2, the rest at `depth`. Field 0 is
// x (range [0, 1]), field 1 is 10 x + 3 (range [3, 13]); error_max is 2^-level times a pseudo-random weight in
// [0.5, 1] for inner nodes (field 1: ten times that), 0 for leaves. Nodes are numbered breadth first.
std::unique_ptr<BrickStoreReader> make_store(const std::string& path, const StoreOptions& o = {}) {
  const Bounds root{{0, 0, 0}, {1, 1, 1}};
  std::vector<OctreeNode> nodes = test::ball_octree(o.depth);

  BrickStoreLayout layout;
  layout.resolution = o.r;
  layout.fields = {{"x", Association::Vertex, 0, 1}, {"x10", Association::Vertex, 3, 13}};
  layout.root = root;
  layout.data = root;
  layout.encoding = {SampleEncoding::Float32, Predictor::None, false, BrickCodec::Stored, 0};
  layout.tolerance = 0;
  BrickStoreWriter writer(path, layout);
  std::vector<FieldError> errors(nodes.size() * 2);
  const size_t n3 = size_t(o.r) * o.r * o.r;
  std::vector<float> f0(n3), f1(n3);
  for (uint64_t id = 0; id < nodes.size(); ++id) {
    const OctreeNode& n = nodes[id];
    if (!n.is_leaf()) {
      const double w = 0.5 + 0.5 * std::fmod(std::abs(std::sin(double(id) * 12.9898) * 43758.5453), 1.0);
      const double e = std::ldexp(w, -int(n.level));
      errors[id * 2] = {float(e), float(e / 2)};
      errors[id * 2 + 1] = {float(10 * e), float(5 * e)};
    }
    if ((id == 0 && o.root_without_brick) || (id + 1 == nodes.size() && o.last_leaf_without_brick)) continue;
    const Bounds b = node_bounds(root, n);
    size_t s = 0;
    for (uint32_t z = 0; z < o.r; ++z) {
      for (uint32_t y = 0; y < o.r; ++y) {
        for (uint32_t x = 0; x < o.r; ++x, ++s) {
          const double px = b.lo.x + (b.hi.x - b.lo.x) * double(x) / double(o.r - 1);
          f0[s] = float(px);
          f1[s] = float(10 * px + 3);
        }
      }
    }
    const float* fields[] = {f0.data(), f1.data()};
    writer.add_brick(id, fields, nullptr);
  }
  std::vector<store_format::TfErrorEntry> table;
  if (o.tf_table) {
    table.resize(nodes.size() * 2);
    for (uint64_t id = 0; id < nodes.size(); ++id) {
      const Bounds b = node_bounds(root, nodes[id]);
      store_format::TfErrorEntry& e = table[id * 2];
      for (int g = 0; g <= store_format::kTfErrorGroups; ++g) {
        e.bound[g] = uint16_t(std::lround((b.lo.x + (b.hi.x - b.lo.x) * g / store_format::kTfErrorGroups) * 65535));
      }
      for (int g = 0; g < store_format::kTfErrorGroups; ++g) {
        e.spread[g] = nodes[id].is_leaf() ? 0 : uint16_t(std::ceil(std::ldexp(0.02, -nodes[id].level) * 65535));
        e.weight[g] = 32;
      }
    }
  }
  writer.commit(nodes, errors, table);
  return std::make_unique<BrickStoreReader>(path);
}

// The stores the tests share, written once per process (the cut reads only the node table, which the reader holds
// in memory, so the file is removed as soon as it is open).
std::unique_ptr<BrickStoreReader> make_shared_store(const std::string& name, const StoreOptions& o) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("ugvr-test-lod-cut-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto store = make_store((dir / name).string(), o);
  std::filesystem::remove_all(dir);
  return store;
}
const BrickStoreReader& plain_store() {
  static const std::unique_ptr<BrickStoreReader> store = make_shared_store("plain.ubs", {});
  return *store;
}
const BrickStoreReader& tf_store() {
  static const std::unique_ptr<BrickStoreReader> store = make_shared_store("tf.ubs", {.tf_table = true});
  return *store;
}
const BrickStoreReader& holes_store() {
  static const std::unique_ptr<BrickStoreReader> store =
      make_shared_store("holes.ubs", {.root_without_brick = true, .last_leaf_without_brick = true});
  return *store;
}

// ---------------------------------------------------------------------------------------------------------------
// Helpers

TransferFunction tf_with(std::vector<OpacityPoint> points) {
  TransferFunction tf;
  tf.color_points = {{0, {0, 0, 0}}, {1, {1, 1, 1}}};
  tf.opacity_points = std::move(points);
  return tf;
}
TransferFunction opaque_tf() { return tf_with({{0, 1}, {1, 1}}); }

Camera framing_camera() { return reset_camera(Bounds{{0, 0, 0}, {1, 1, 1}}, 30, {0.3, -0.4, -1}); }

Camera looking(Vec3d from, Vec3d at, double angle = 30, Vec3d up = {0, 1, 0}) {
  Camera c;
  c.position = from;
  c.focal_point = at;
  c.view_up = up;
  c.view_angle = angle;
  return c;
}

std::vector<uint64_t> brick_leaves(const BrickStoreReader& s) {
  std::vector<uint64_t> out;
  for (uint64_t id = 0; id < s.node_count(); ++id)
    if (s.node(id).is_leaf() && s.node(id).has_brick()) out.push_back(id);
  return out;
}

bool hits(const Ray& ray, const Bounds& b) {
  double t0 = 0, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    const double o = ray.origin[a], d = ray.direction[a];
    if (d == 0) {
      if (o < b.lo[a] || o > b.hi[a]) return false;
      continue;
    }
    double ta = (b.lo[a] - o) / d, tb = (b.hi[a] - o) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1;
}

bool some_ray_hits(const CameraRays& rays, const Bounds& b) {
  for (int y = 0; y < rays.height(); ++y)
    for (int x = 0; x < rays.width(); ++x)
      if (hits(rays.pixel(x, y), b)) return true;
  return false;
}

bool somewhere_opaque(const TransferFunction& tf, double lo, double hi) {
  for (int i = 0; i <= 256; ++i)
    if (tf.opacity(lo + (hi - lo) * i / 256.0) > 0) return true;
  return false;
}

// The cut's structural invariants, and: every brick leaf that a pixel ray reaches (when frustum culling is on) and
// whose value range is somewhere opaque (when TF culling is on) has exactly one ancestor-or-self in the cut; every
// other brick leaf at most one.
void expect_exact_once(const BrickStoreReader& s, const Cut& cut, const Camera& camera, int w, int h,
                       const TransferFunction& tf, const CutOptions& o, const std::string& what) {
  const std::set<uint64_t> in(cut.nodes.begin(), cut.nodes.end());
  ASSERT_EQ(in.size(), cut.nodes.size()) << what << ": duplicate nodes";
  ASSERT_TRUE(std::is_sorted(cut.nodes.begin(), cut.nodes.end())) << what;
  for (uint64_t id : cut.nodes) {
    ASSERT_TRUE(s.node(id).has_brick()) << what << ": node " << id << " has no brick";
    for (uint64_t p = s.node(id).parent; p != kNoNode; p = s.node(p).parent)
      ASSERT_FALSE(in.count(p)) << what << ": node " << id << " and its ancestor " << p;
  }
  const CameraRays rays(camera, w, h);
  for (uint64_t leaf : brick_leaves(s)) {
    int covers = 0;
    for (uint64_t p = leaf; p != kNoNode; p = s.node(p).parent) covers += int(in.count(p));
    ASSERT_LE(covers, 1) << what << ": leaf " << leaf;
    if (covers == 1) continue;
    const FieldStats& st = s.stats(leaf, o.field);
    const bool needed = (!o.frustum_cull || some_ray_hits(rays, s.bounds(leaf))) &&
                        (!o.tf_cull || somewhere_opaque(tf, st.min, st.max));
    ASSERT_FALSE(needed) << what << ": visible leaf " << leaf << " not covered";
  }
  if (!cut.nodes.empty()) {
    int max_level = 0;
    double sum = 0;
    for (uint64_t id : cut.nodes) {
      max_level = std::max(max_level, int(s.node(id).level));
      sum += s.node(id).level;
    }
    EXPECT_EQ(cut.max_level, max_level) << what;
    EXPECT_NEAR(cut.mean_level, sum / double(cut.nodes.size()), 1e-12) << what;
  }
}

// Pixels of one voxel of `box` (the documented formula, perspective).
double projected_pixels(const BrickStoreReader& s, const Bounds& box, const Camera& c, int height) {
  const double h = (box.hi.x - box.lo.x) / double(s.resolution() - 1);
  const Vec3d f = c.direction();
  double d = kInf;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3d p{corner & 1 ? box.hi.x : box.lo.x, corner & 2 ? box.hi.y : box.lo.y, corner & 4 ? box.hi.z : box.lo.z};
    d = std::min(d, dot(p - c.position, f));
  }
  if (d <= 1e-6) return kInf;
  return h / (2 * d * std::tan(c.view_angle * std::numbers::pi / 360)) * height;
}

// ---------------------------------------------------------------------------------------------------------------
// The cut

TEST(LodCut, LeavesCutIsEveryBrickLeaf) {
  const BrickStoreReader* s = &plain_store();
  const Cut cut = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 64, 48, opaque_tf());
  EXPECT_EQ(cut.nodes, brick_leaves(*s));
  EXPECT_FALSE(cut.budget_limited);
  EXPECT_EQ(cut.culled_frustum, 0u);
  EXPECT_EQ(cut.culled_tf, 0u);
  EXPECT_EQ(cut.max_level, 4);
  // Deterministic.
  const Cut again = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 64, 48, opaque_tf());
  EXPECT_EQ(again.nodes, cut.nodes);
}

TEST(LodCut, NodesWithoutBrick) {
  const BrickStoreReader* s = &holes_store();
  ASSERT_FALSE(s->node(0).has_brick());
  const uint64_t last = s->node_count() - 1;
  ASSERT_TRUE(s->node(last).is_leaf());
  ASSERT_FALSE(s->node(last).has_brick());
  // The coarsest criterion would stop at the root, which cannot be drawn: its children replace it.
  const Cut coarse = select_cut(*s, parse_cut_spec("error:1000"), framing_camera(), 64, 48, opaque_tf());
  std::vector<uint64_t> children;
  for (int o = 0; o < 8; ++o)
    if (s->node(0).child(o) != kNoNode) children.push_back(s->node(0).child(o));
  EXPECT_EQ(children.size(), 7u);
  EXPECT_EQ(coarse.nodes, children);
  // Even under a budget smaller than that: the cut is returned and says it is over.
  CutOptions tight;
  tight.max_nodes = 3;
  const Cut over = select_cut(*s, parse_cut_spec("pixels:1"), framing_camera(), 64, 48, opaque_tf(), tight);
  EXPECT_EQ(over.nodes, children);
  EXPECT_TRUE(over.budget_limited);
  // The leaf without data never appears.
  const Cut leaves = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 64, 48, opaque_tf());
  EXPECT_EQ(leaves.nodes, brick_leaves(*s));
  EXPECT_FALSE(std::count(leaves.nodes.begin(), leaves.nodes.end(), last));
  expect_exact_once(*s, leaves, framing_camera(), 64, 48, opaque_tf(), {}, "leaves");
}

TEST(LodCut, ExactlyOnceOnRandomCameras) {
  const BrickStoreReader* plain = &plain_store();
  const BrickStoreReader* holes = &holes_store();
  const std::vector<TransferFunction> tfs = {opaque_tf(), tf_with({{0, 0}, {0.3, 0}, {1, 1}}),
                                             tf_with({{0.4, 0}, {0.5, 1}, {0.55, 0}}), tf_with({{0.2, 0.5}})};
  const std::vector<std::string> specs = {"leaves", "error:0", "error:0.05", "error:0.3", "pixels:0.5", "pixels:3"};
  const std::vector<uint64_t> budgets = {std::numeric_limits<uint64_t>::max(), 8, 30, 150};
  std::mt19937 rng(1234);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 60; ++trial) {
    const BrickStoreReader& s = trial % 2 ? *holes : *plain;
    Vec3d dir3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
    if (length(dir3) < 1e-3) dir3 = {1, 0, 0};
    const double dist = trial % 5 == 0 ? 0.3 * u(rng) : 0.8 + 3 * u(rng);  // some cameras inside the data
    Camera c;
    c.position = Vec3d{0.5, 0.5, 0.5} + normalized(dir3) * dist;
    c.focal_point = Vec3d{u(rng), u(rng), u(rng)};
    if (length(c.focal_point - c.position) < 1e-3) c.focal_point = c.position + Vec3d{0, 0, -1};
    c.view_up = normalized(Vec3d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
    if (length(cross(c.view_up, c.direction())) < 1e-3) c.view_up = cross(c.direction(), Vec3d{1, 0, 0});
    if (length(cross(c.view_up, c.direction())) < 1e-3) c.view_up = cross(c.direction(), Vec3d{0, 1, 0});
    c.view_angle = 5 + 80 * u(rng);
    c.parallel_projection = trial % 3 == 0;
    c.parallel_scale = 0.05 + 0.7 * u(rng);
    const int w = 8 + int(20 * u(rng)), h = 8 + int(20 * u(rng));
    CutOptions o;
    o.field = trial % 4 == 3 ? 1 : 0;
    o.max_nodes = budgets[size_t(trial) % budgets.size()];
    o.frustum_cull = trial % 7 != 6;
    o.tf_cull = trial % 6 != 5;
    TransferFunction tf = tfs[size_t(trial) % tfs.size()];
    if (o.field == 1) tf.rescale(3, 13);
    const std::string spec = specs[size_t(trial) % specs.size()];
    const std::string what = "trial " + std::to_string(trial) + " " + spec;
    const Cut cut = select_cut(s, parse_cut_spec(spec), c, w, h, tf, o);
    EXPECT_LE(cut.nodes.size(), o.max_nodes) << what;
    expect_exact_once(s, cut, c, w, h, tf, o, what);
    if (HasFatalFailure()) return;
  }
}

TEST(LodCut, ErrorCriterion) {
  const BrickStoreReader* s = &plain_store();
  CutOptions o;
  o.frustum_cull = o.tf_cull = false;
  size_t previous = 0;
  for (double e : {10.0, 1.0, 0.6, 0.4, 0.25, 0.15, 0.1, 0.06, 0.03, 0.01, 0.0}) {
    const CutSpec spec{CutSpec::Kind::Error, e};
    const Cut cut = select_cut(*s, spec, framing_camera(), 32, 32, opaque_tf(), o);
    EXPECT_GE(cut.nodes.size(), previous) << "error " << e;
    previous = cut.nodes.size();
    EXPECT_FALSE(cut.budget_limited);
    for (uint64_t id : cut.nodes)
      EXPECT_TRUE(s->node(id).is_leaf() || s->stats(id, 0).error_max <= e) << "error " << e << " node " << id;
    // Relative to the field's range: field 1 has 10× the range and 10× the errors.
    CutOptions o1 = o;
    o1.field = 1;
    EXPECT_EQ(select_cut(*s, spec, framing_camera(), 32, 32, opaque_tf(), o1).nodes, cut.nodes) << "error " << e;
    expect_exact_once(*s, cut, framing_camera(), 32, 32, opaque_tf(), o, "error");
  }
  EXPECT_EQ(select_cut(*s, {CutSpec::Kind::Error, 10}, framing_camera(), 32, 32, opaque_tf(), o).nodes,
            std::vector<uint64_t>{0});
  EXPECT_EQ(select_cut(*s, {CutSpec::Kind::Error, 0}, framing_camera(), 32, 32, opaque_tf(), o).nodes,
            brick_leaves(*s));
}

TEST(LodCut, PixelCriterion) {
  const BrickStoreReader* s = &plain_store();
  CutOptions o;
  o.frustum_cull = false;
  // Moving the camera closer never reduces the node count; every node meets the criterion or is a leaf.
  size_t previous = 0;
  for (double d : {20.0, 8.0, 5.0, 3.0, 2.0, 1.5, 1.2, 1.05, 0.7, 0.4}) {
    const Camera c = looking({0.5, 0.5, 0.5 + d}, {0.5, 0.5, 0.5});
    const Cut cut = select_cut(*s, {CutSpec::Kind::Pixels, 1.5}, c, 48, 64, opaque_tf(), o);
    EXPECT_GE(cut.nodes.size(), previous) << "distance " << d;
    previous = cut.nodes.size();
    for (uint64_t id : cut.nodes)
      EXPECT_TRUE(s->node(id).is_leaf() || projected_pixels(*s, s->bounds(id), c, 64) <= 1.5)
          << "distance " << d << " node " << id;
  }
  EXPECT_EQ(previous, brick_leaves(*s).size());  // inside the data: everything near refines fully
  // A bigger image needs more nodes.
  const Camera c = looking({0.5, 0.5, 3.5}, {0.5, 0.5, 0.5});
  const Cut small = select_cut(*s, parse_cut_spec("pixels:1"), c, 16, 16, opaque_tf(), o);
  const Cut big = select_cut(*s, parse_cut_spec("pixels:1"), c, 64, 64, opaque_tf(), o);
  EXPECT_GT(big.nodes.size(), small.nodes.size());
  EXPECT_GT(big.max_level, small.max_level);
  // Parallel: one voxel of a level-L node is 2^-L / 3 long and covers 4 · 2^-L pixels at scale 0.5 and height 12,
  // so pixels:1.5 stops at level 2.
  Camera p = c;
  p.parallel_projection = true;
  p.parallel_scale = 0.5;
  const Cut par = select_cut(*s, parse_cut_spec("pixels:1.5"), p, 12, 12, opaque_tf(), o);
  for (uint64_t id : par.nodes) EXPECT_TRUE(s->node(id).level == 2 || (s->node(id).is_leaf() && s->node(id).level < 2));
  EXPECT_EQ(par.max_level, 2);
}

TEST(LodCut, Budget) {
  const BrickStoreReader* s = &plain_store();
  const size_t leaves = brick_leaves(*s).size();
  for (uint64_t budget : std::vector<uint64_t>{1, 5, 8, 20, 100, leaves - 1}) {
    CutOptions o;
    o.max_nodes = budget;
    const Cut cut = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 64, 48, opaque_tf(), o);
    EXPECT_LE(cut.nodes.size(), budget);
    EXPECT_GE(cut.nodes.size(), budget < 7 ? 1u : 7u);
    EXPECT_TRUE(cut.budget_limited) << budget;
    expect_exact_once(*s, cut, framing_camera(), 64, 48, opaque_tf(), o, "budget " + std::to_string(budget));
  }
  CutOptions exact;
  exact.max_nodes = leaves;
  const Cut full = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 64, 48, opaque_tf(), exact);
  EXPECT_FALSE(full.budget_limited);
  EXPECT_EQ(full.nodes, brick_leaves(*s));
  // A budget spent where the voxels are largest on screen: near the camera (at x = -1) rather than far.
  CutOptions o;
  o.max_nodes = 60;
  o.frustum_cull = false;
  const Camera c = looking({-1, 0.5, 0.5}, {0.5, 0.5, 0.5});
  const Cut cut = select_cut(*s, parse_cut_spec("leaves"), c, 64, 64, opaque_tf(), o);
  EXPECT_TRUE(cut.budget_limited);
  int near_level = 0, far_level = 99;
  for (uint64_t id : cut.nodes) {
    const Bounds b = s->bounds(id);
    if (b.hi.x <= 0.5 && b.lo.x >= 0.25) near_level = std::max(near_level, int(s->node(id).level));
    if (b.lo.x >= 0.5) far_level = std::min(far_level, int(s->node(id).level));
  }
  EXPECT_GT(near_level, 1);
  EXPECT_LE(far_level, near_level);
  // Budget 0 is an error.
  CutOptions zero;
  zero.max_nodes = 0;
  EXPECT_THROW(select_cut(*s, parse_cut_spec("leaves"), c, 8, 8, opaque_tf(), zero), Error);
}

TEST(LodCut, FrustumCulling) {
  const BrickStoreReader* s = &plain_store();
  // Looking away from the data: nothing, the root culled.
  for (bool parallel : {false, true}) {
    Camera away = looking({0.5, 0.5, 3}, {0.5, 0.5, 5});
    away.parallel_projection = parallel;
    const Cut cut = select_cut(*s, parse_cut_spec("leaves"), away, 32, 32, opaque_tf());
    EXPECT_TRUE(cut.nodes.empty()) << parallel;
    EXPECT_EQ(cut.culled_frustum, 1u) << parallel;
    EXPECT_EQ(cut.max_level, 0);
    CutOptions off;
    off.frustum_cull = false;
    EXPECT_EQ(select_cut(*s, parse_cut_spec("leaves"), away, 32, 32, opaque_tf(), off).nodes, brick_leaves(*s));
  }
  // A narrow view needs fewer nodes than a wide one.
  const Camera wide = looking({0.5, 0.5, 3}, {0.5, 0.5, 0.5}, 60);
  const Camera narrow = looking({0.5, 0.5, 3}, {0.5, 0.5, 0.5}, 4);
  const Cut w = select_cut(*s, parse_cut_spec("leaves"), wide, 32, 32, opaque_tf());
  const Cut n = select_cut(*s, parse_cut_spec("leaves"), narrow, 32, 32, opaque_tf());
  EXPECT_EQ(w.nodes, brick_leaves(*s));
  EXPECT_LT(n.nodes.size(), w.nodes.size() / 4);
  EXPECT_GT(n.culled_frustum, 0u);
  expect_exact_once(*s, n, narrow, 32, 32, opaque_tf(), {}, "narrow");
  Camera narrow_parallel = narrow;
  narrow_parallel.parallel_projection = true;
  narrow_parallel.parallel_scale = 0.1;
  const Cut np = select_cut(*s, parse_cut_spec("leaves"), narrow_parallel, 32, 32, opaque_tf());
  EXPECT_LT(np.nodes.size(), w.nodes.size() / 4);
  expect_exact_once(*s, np, narrow_parallel, 32, 32, opaque_tf(), {}, "narrow parallel");
  // Inside the data looking along +x: what lies behind the camera plane is dropped.
  const Camera inside = looking({0.5, 0.5, 0.5}, {2, 0.5, 0.5}, 90);
  const Cut in = select_cut(*s, parse_cut_spec("leaves"), inside, 32, 32, opaque_tf());
  EXPECT_FALSE(in.nodes.empty());
  for (uint64_t id : in.nodes) EXPECT_GE(s->bounds(id).hi.x, 0.5) << id;
  expect_exact_once(*s, in, inside, 32, 32, opaque_tf(), {}, "inside");
}

TEST(LodCut, TransferFunctionCulling) {
  const BrickStoreReader* s = &plain_store();
  // Opacity zero up to 0.5: nodes whose x range lies in [0, 0.5] (touching 0.5 included) are invisible.
  const TransferFunction tf = tf_with({{0, 0}, {0.5, 0}, {1, 1}});
  const Cut cut = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 32, 32, tf);
  EXPECT_GT(cut.culled_tf, 0u);
  EXPECT_FALSE(cut.nodes.empty());
  for (uint64_t id : cut.nodes) EXPECT_GT(s->stats(id, 0).max, 0.5f) << id;
  expect_exact_once(*s, cut, framing_camera(), 32, 32, tf, {}, "tf");
  CutOptions off;
  off.tf_cull = false;
  EXPECT_EQ(select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 32, 32, tf, off).nodes, brick_leaves(*s));
  // Field 1 with the same TF over its own range culls the same.
  TransferFunction tf1 = tf;
  tf1.rescale(3, 13);
  CutOptions f1;
  f1.field = 1;
  EXPECT_EQ(select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 32, 32, tf1, f1).nodes, cut.nodes);
  // Fully transparent: nothing, the root culled.
  const Cut none = select_cut(*s, parse_cut_spec("leaves"), framing_camera(), 32, 32, tf_with({{0, 0}, {1, 0}}));
  EXPECT_TRUE(none.nodes.empty());
  EXPECT_EQ(none.culled_tf, 1u);
}

// ---------------------------------------------------------------------------------------------------------------
// The transfer-function-aware error (render/lod/tf_error.h)

// Cut nodes whose x range overlaps [lo, hi].
size_t nodes_over(const BrickStoreReader& s, const Cut& cut, double lo, double hi) {
  size_t n = 0;
  for (uint64_t id : cut.nodes) n += s.bounds(id).lo.x < hi && s.bounds(id).hi.x > lo;
  return n;
}

// White, opacity 0.5 with a gentle slope everywhere, and a steep rise by 0.45 over [lo, lo + 0.1].
TransferFunction steep_at(double lo) {
  TransferFunction tf;
  tf.color_points = {{0, {1, 1, 1}}, {1, {1, 1, 1}}};
  tf.opacity_points = {{0, 0.5}, {lo, 0.5 + 0.05 * lo}, {lo + 0.1, 0.95 + 0.05 * lo}, {1, 1}};
  return tf;
}

TEST(LodCutTfError, MovingTheOpacityMovesTheRefinement) {
  const BrickStoreReader& s = tf_store();
  ASSERT_TRUE(s.has_tf_errors());
  const Camera cam = framing_camera();
  CutOptions o;
  o.frustum_cull = false;
  o.max_nodes = 40;  // a budget: the nodes whose image differs most are refined first
  const TransferFunction a = steep_at(0.3), b = steep_at(0.6);
  const CutSpec spec = parse_cut_spec("pixels:0.01");
  const Cut ca = select_cut(s, spec, cam, 64, 64, a, o), cb = select_cut(s, spec, cam, 64, 64, b, o);
  EXPECT_TRUE(ca.budget_limited);
  // The steep part of each transfer function gets the nodes.
  EXPECT_GT(nodes_over(s, ca, 0.3, 0.4), nodes_over(s, cb, 0.3, 0.4));
  EXPECT_GT(nodes_over(s, cb, 0.6, 0.7), nodes_over(s, ca, 0.6, 0.7));
  expect_exact_once(s, ca, cam, 64, 64, a, o, "tf a");
  expect_exact_once(s, cb, cam, 64, 64, b, o, "tf b");
  // Without the transfer-function error the two cuts are the same: only the texel sizes rank the nodes.
  o.tf_error = false;
  EXPECT_EQ(select_cut(s, spec, cam, 64, 64, a, o).nodes, select_cut(s, spec, cam, 64, 64, b, o).nodes);
  // The errors themselves: larger where the transfer function is steep over the node's values.
  TfNodeErrors errors(s, 0);
  EXPECT_TRUE(errors.update(a));
  EXPECT_FALSE(errors.update(a));  // the same transfer function: nothing to recompute
  uint64_t steep = kNoNode, gentle = kNoNode;
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    const Bounds box = s.bounds(id);
    if (s.node(id).level != 3 || s.node(id).is_leaf()) continue;
    if (box.lo.x == 0.25) steep = id;  // [0.25, 0.375]: meets a's ramp [0.3, 0.4], none of b's
    if (box.lo.x >= 0.75) gentle = id;
  }
  ASSERT_NE(steep, kNoNode);
  ASSERT_NE(gentle, kNoNode);
  EXPECT_GT(errors.error(steep), 10 * errors.error(gentle));
  EXPECT_GT(errors.weight(steep), errors.weight(gentle));
  EXPECT_GE(errors.weight(gentle), 1.0);
  EXPECT_TRUE(errors.update(b));
  EXPECT_LT(errors.error(steep), errors.error(gentle) * 10);
}

TEST(LodCutTfError, TransparentOrUniformNodesAreNeverSplit) {
  for (const BrickStoreReader* s : {&plain_store(), &tf_store()}) {  // without and with the table
    CutOptions o;
    o.frustum_cull = false;
    o.tf_cull = false;  // as with the boundary overlay: transparent nodes stay on the cut
    // Transparent up to x = 0.5, then opaque white: uniform beyond 0.5 too. Only nodes whose x range crosses 0.5
    // differ from their finest data under it.
    TransferFunction tf;
    tf.color_points = {{0, {1, 1, 1}}, {1, {1, 1, 1}}};
    tf.opacity_points = {{0, 0}, {0.5, 0}, {0.5001, 1}, {1, 1}};
    const Cut cut = select_cut(*s, parse_cut_spec("pixels:0.001"), framing_camera(), 64, 64, tf, o);
    for (uint64_t id : cut.nodes) {
      const Bounds box = s->bounds(id);
      // A node's values are its x range: it differs from its finest data only if that meets the step [0.5, 0.5001].
      auto meets_step = [](const Bounds& b) { return b.lo.x < 0.5001 && b.hi.x > 0.5; };
      if (!meets_step(box)) {
        // Transparent or uniform: it was never split, so its parent (if any) meets the step.
        const uint64_t p = s->node(id).parent;
        EXPECT_TRUE(p == kNoNode || meets_step(s->bounds(p))) << id;
      } else {
        EXPECT_TRUE(s->node(id).is_leaf()) << id;  // crossing: refined to the leaves (pixels:0.001)
      }
    }
    expect_exact_once(*s, cut, framing_camera(), 64, 64, tf, o, "uniform");
    EXPECT_LT(cut.nodes.size(), brick_leaves(*s).size());
    // Without the weight the same spec refines everything to the leaves.
    o.tf_error = false;
    EXPECT_EQ(select_cut(*s, parse_cut_spec("pixels:0.001"), framing_camera(), 64, 64, tf, o).nodes, brick_leaves(*s));
  }
}

TEST(LodCut, InvalidArguments) {
  const BrickStoreReader* s = &plain_store();
  const Camera c = framing_camera();
  const CutSpec spec = parse_cut_spec("leaves");
  CutOptions bad_field;
  bad_field.field = 2;
  EXPECT_THROW(select_cut(*s, spec, c, 8, 8, opaque_tf(), bad_field), Error);
  EXPECT_THROW(select_cut(*s, spec, c, 0, 8, opaque_tf()), Error);
  Camera degenerate = c;
  degenerate.focal_point = degenerate.position;
  EXPECT_THROW(select_cut(*s, spec, degenerate, 8, 8, opaque_tf()), Error);
  Camera up = c;
  up.view_up = c.direction();
  EXPECT_THROW(select_cut(*s, spec, up, 8, 8, opaque_tf()), Error);
  EXPECT_THROW(select_cut(*s, {CutSpec::Kind::Pixels, 0}, c, 8, 8, opaque_tf()), Error);
  EXPECT_THROW(select_cut(*s, {CutSpec::Kind::Error, -1}, c, 8, 8, opaque_tf()), Error);
}

// ---------------------------------------------------------------------------------------------------------------
// Transparency of an interval

TEST(LodCut, TfTransparentOver) {
  const TransferFunction ramp = tf_with({{0, 0}, {0.5, 0}, {1, 1}});
  EXPECT_TRUE(tf_transparent_over(ramp, 0, 0.5));    // up to the last zero point, inclusive
  EXPECT_TRUE(tf_transparent_over(ramp, 0.2, 0.3));  // inside a zero segment
  EXPECT_TRUE(tf_transparent_over(ramp, -5, 0.1));   // below the points: clamped to the first (0)
  EXPECT_TRUE(tf_transparent_over(ramp, -kInf, 0.5));
  EXPECT_FALSE(tf_transparent_over(ramp, 0, std::nextafter(0.5, 1.0)));  // just past it the ramp starts
  EXPECT_FALSE(tf_transparent_over(ramp, 0.9, 2));
  EXPECT_FALSE(tf_transparent_over(ramp, 2, 3));  // above the points: clamped to the last (1)
  EXPECT_FALSE(tf_transparent_over(ramp, -kInf, kInf));

  // Intervals touching a nonzero point, and a spike strictly inside an interval whose ends are transparent.
  const TransferFunction spike = tf_with({{0.4, 0}, {0.5, 1}, {0.6, 0}});
  EXPECT_FALSE(tf_transparent_over(spike, 0.5, 0.5));
  EXPECT_FALSE(tf_transparent_over(spike, 0.45, 0.45));
  EXPECT_FALSE(tf_transparent_over(spike, 0.3, 0.7));
  EXPECT_FALSE(tf_transparent_over(spike, 0.3, 0.41));
  EXPECT_TRUE(tf_transparent_over(spike, 0.3, 0.4));  // touches the zero point next to the spike
  EXPECT_TRUE(tf_transparent_over(spike, 0.6, 10));
  EXPECT_TRUE(tf_transparent_over(spike, -kInf, 0.4));

  // Single-point functions are constant.
  EXPECT_TRUE(tf_transparent_over(tf_with({{0.3, 0}}), -kInf, kInf));
  EXPECT_FALSE(tf_transparent_over(tf_with({{0.3, 0.2}}), 5, 6));
  EXPECT_FALSE(tf_transparent_over(tf_with({{0.3, 0.2}}), -1, -1));
  // No opacity points: opacity 0 everywhere (TransferFunction::opacity).
  EXPECT_TRUE(tf_transparent_over(tf_with({}), 0, 1));

  // NaN: unknown values, never transparent; an empty interval (lo > hi: no data) always is.
  EXPECT_FALSE(tf_transparent_over(tf_with({{0, 0}, {1, 0}}), NAN, 0.5));
  EXPECT_FALSE(tf_transparent_over(tf_with({{0, 0}, {1, 0}}), 0.5, NAN));
  EXPECT_TRUE(tf_transparent_over(ramp, kInf, -kInf));
  EXPECT_TRUE(tf_transparent_over(ramp, 0.9, 0.8));
}

// ---------------------------------------------------------------------------------------------------------------
// Cut specs

TEST(LodCut, ParseCutSpec) {
  EXPECT_EQ(parse_cut_spec("leaves"), (CutSpec{CutSpec::Kind::Leaves, 0}));
  EXPECT_EQ(parse_cut_spec("error:0.01"), (CutSpec{CutSpec::Kind::Error, 0.01}));
  EXPECT_EQ(parse_cut_spec("error:0"), (CutSpec{CutSpec::Kind::Error, 0}));
  EXPECT_EQ(parse_cut_spec("error:1e-3"), (CutSpec{CutSpec::Kind::Error, 1e-3}));
  EXPECT_EQ(parse_cut_spec("pixels:2"), (CutSpec{CutSpec::Kind::Pixels, 2}));
  EXPECT_EQ(parse_cut_spec("pixels:0.5"), (CutSpec{CutSpec::Kind::Pixels, 0.5}));
  for (const char* text : {"leaves", "error:0.01", "error:0", "error:0.3333333333333333", "pixels:2", "pixels:0.75"}) {
    EXPECT_EQ(cut_spec_name(parse_cut_spec(text)), text);
    EXPECT_EQ(parse_cut_spec(cut_spec_name(parse_cut_spec(text))), parse_cut_spec(text));
  }
  EXPECT_EQ(cut_spec_name({CutSpec::Kind::Error, 1.0 / 3}), "error:0.3333333333333333");

  for (const char* bad :
       {"",           "leaf",       "leaves:1", "Leaves",    " leaves",   "error",    "error:",   "error:-1",
        "error:-0.5", "error:abc",  "error:1x", "error:nan", "error:inf", "error: 1", "error:+1", "pixels:0",
        "pixels:-2",  "pixels:inf", "pixels",   "pixels:",   "pixel:1",   "size:3",   ":1"}) {
    try {
      parse_cut_spec(bad);
      ADD_FAILURE() << "accepted \"" << bad << "\"";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("cut spec \"" + std::string(bad) + "\""), std::string::npos) << message;
    }
  }
  try {
    parse_cut_spec("error:-1");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(">= 0"), std::string::npos) << e.what();
  }
  try {
    parse_cut_spec("bogus");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("pixels:P"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ugvr
