// The MPI-free part of data-parallel rendering (src/ugvr/mpi/kd_partition.h): the kd-tree's boxes tile space and
// balance the points, its visibility order is the order rays meet the boxes, and blending is "under".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "ugvr/core/error.h"
#include "ugvr/mpi/kd_partition.h"

namespace ugvr {
namespace {

bool inside(const Bounds& b, const Vec3d& p) {
  // Half-open, as the tree splits: [lo, hi).
  return p.x >= b.lo.x && p.x < b.hi.x && p.y >= b.lo.y && p.y < b.hi.y && p.z >= b.lo.z && p.z < b.hi.z;
}

std::vector<Vec3d> random_points(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3d> p(n);
  for (Vec3d& v : p) v = {u(rng) * 3, u(rng), u(rng) * u(rng)};  // uneven extents and density
  return p;
}

TEST(KdPartition, BoxesTileSpaceAndBalanceThePoints) {
  const std::vector<Vec3d> points = random_points(10007, 1);
  for (int parts : {1, 2, 3, 4, 5, 7, 8}) {
    const KdTree tree = build_kd_tree(points, parts);
    ASSERT_EQ(tree.parts(), parts);
    std::vector<size_t> count(size_t(parts), 0);
    for (const Vec3d& p : points) {
      int owners = 0;
      for (int b = 0; b < parts; ++b)
        if (inside(tree.boxes[size_t(b)], p)) ++owners, ++count[size_t(b)];
      ASSERT_EQ(owners, 1) << parts << " parts";
    }
    // Points far outside the data still belong to exactly one box: the outer faces are infinite.
    for (const Vec3d& p : {Vec3d{1e9, -1e9, 0}, Vec3d{-1e9, 1e9, 1e9}}) {
      int owners = 0;
      for (int b = 0; b < parts; ++b) owners += inside(tree.boxes[size_t(b)], p);
      EXPECT_EQ(owners, 1);
    }
    const auto [lo, hi] = std::minmax_element(count.begin(), count.end());
    EXPECT_LE(double(*hi - *lo), 0.01 * double(points.size()) + 2) << parts << " parts";
  }
}

TEST(KdPartition, SameInputSameTreeInAnyOrder) {
  std::vector<Vec3d> points = random_points(3000, 2);
  const KdTree a = build_kd_tree(points, 6);
  std::reverse(points.begin(), points.end());
  const KdTree b = build_kd_tree(points, 6);
  for (size_t i = 0; i < a.boxes.size(); ++i) {
    EXPECT_EQ(a.boxes[i].lo, b.boxes[i].lo);
    EXPECT_EQ(a.boxes[i].hi, b.boxes[i].hi);
  }
}

// Marches rays through the boxes: the boxes each ray passes through, in order, must appear in that order in the
// visibility order (it is a valid front-to-back order for every ray).
void expect_rays_agree(const KdTree& tree, const Camera& camera, unsigned seed) {
  const std::vector<int> order = tree.visibility_order(camera);
  ASSERT_EQ(int(order.size()), tree.parts());
  std::vector<int> position(order.size());
  for (size_t i = 0; i < order.size(); ++i) position[size_t(order[i])] = int(i);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const Vec3d dir = camera.direction();
  for (int r = 0; r < 300; ++r) {
    const Vec3d target{u(rng) * 3, u(rng), u(rng)};
    Vec3d origin = camera.position, d = normalized(target - camera.position);
    if (camera.parallel_projection) d = dir, origin = target - dir * 20.0;
    int last = -1;
    for (double t = 0; t < 40; t += 0.01) {
      const Vec3d p = origin + d * t;
      for (int b = 0; b < tree.parts(); ++b) {
        if (!inside(tree.boxes[size_t(b)], p)) continue;
        ASSERT_GE(position[size_t(b)], last) << "ray " << r << " meets box " << b << " after a later one";
        last = position[size_t(b)];
      }
    }
  }
}

TEST(KdPartition, VisibilityOrderIsTheOrderRaysMeetTheBoxes) {
  const KdTree tree = build_kd_tree(random_points(5000, 3), 7);
  Camera outside;
  outside.position = {9, -4, 2.5};
  outside.focal_point = {0, 0, 0};
  expect_rays_agree(tree, outside, 4);
  Camera inside_data;  // the eye inside the data, between boxes
  inside_data.position = {0.3, 0.1, 0.05};
  inside_data.focal_point = {-3, 1, 0};
  expect_rays_agree(tree, inside_data, 5);
  Camera parallel = outside;
  parallel.parallel_projection = true;
  expect_rays_agree(tree, parallel, 6);
}

TEST(KdPartition, RejectsZeroParts) { EXPECT_THROW(build_kd_tree({}, 0), Error); }

TEST(KdPartition, BlendUnderAndBackground) {
  // Front: half-transparent red; back: opaque blue (premultiplied).
  std::vector<float> front = {0.5f, 0, 0, 0.5f}, back = {0, 0, 1, 1};
  blend_under(front, back);
  EXPECT_FLOAT_EQ(front[0], 0.5f);
  EXPECT_FLOAT_EQ(front[2], 0.5f);
  EXPECT_FLOAT_EQ(front[3], 1.0f);
  // Over a background, as composite_pixel finishes a ray: radiance 0.2 with transmittance 0.6 over grey.
  const std::vector<float> premult = {0.2f, 0.1f, 0, 0.4f};
  const Image img = apply_background(premult, 1, 1, {0.5, 0.5, 0.5, 1});
  EXPECT_NEAR(img.rgba[0], 0.2 + 0.5 * 0.6, 1e-6);
  EXPECT_NEAR(img.rgba[1], 0.1 + 0.5 * 0.6, 1e-6);
  EXPECT_NEAR(img.rgba[2], 0.5 * 0.6, 1e-6);
  EXPECT_NEAR(img.rgba[3], 1, 1e-6);
  // premultiplied() undoes a transparent background: straight colour times alpha.
  Image straight(1, 1);
  straight.rgba = {0.5f, 0.25f, 1, 0.4f};
  const std::vector<float> p = premultiplied(straight);
  EXPECT_FLOAT_EQ(p[0], 0.2f);
  EXPECT_FLOAT_EQ(p[1], 0.1f);
  EXPECT_FLOAT_EQ(p[3], 0.4f);
}

}  // namespace
}  // namespace ugvr
