#include "ugvr/mpi/kd_partition.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ugvr/core/error.h"
#include "ugvr/render/exact/walk_mesh.h"

namespace ugvr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Splits points[begin, end) among parts [first_part, first_part + parts) inside `box`; returns the node index.
int build(KdTree& tree, std::vector<Vec3d>& points, size_t begin, size_t end, int first_part, int parts,
          const Bounds& box) {
  const int index = int(tree.nodes.size());
  tree.nodes.emplace_back();
  if (parts == 1) {
    tree.nodes[size_t(index)].part = first_part;
    tree.boxes[size_t(first_part)] = box;
    return index;
  }
  Bounds extent;
  for (size_t i = begin; i < end; ++i) extent.add(points[i]);
  int axis = 0;
  double split = 0;
  const int left_parts = parts / 2;
  if (extent.empty()) {
    // No points here: halve the box where it is finite, else split at 0 (the boxes stay a partition either way).
    const Vec3d lo = box.lo, hi = box.hi;
    const double mid = std::isfinite(lo.x) && std::isfinite(hi.x) ? 0.5 * (lo.x + hi.x) : 0;
    split = mid;
  } else {
    const Vec3d size = extent.hi - extent.lo;
    axis = size.x >= size.y && size.x >= size.z ? 0 : size.y >= size.z ? 1 : 2;
    // The left side takes cells in proportion to its parts; the plane at the first right point's coordinate.
    const size_t k = begin + (end - begin) * size_t(left_parts) / size_t(parts);
    auto by_axis = [axis](const Vec3d& a, const Vec3d& b) { return a[axis] < b[axis]; };
    std::nth_element(points.begin() + std::ptrdiff_t(begin), points.begin() + std::ptrdiff_t(k),
                     points.begin() + std::ptrdiff_t(end), by_axis);
    split = k < end ? points[k][axis] : extent.hi[axis];
  }
  // Points on the plane go right (the boxes are half-open, [lo, split) and [split, hi)).
  const auto mid_it = std::partition(points.begin() + std::ptrdiff_t(begin), points.begin() + std::ptrdiff_t(end),
                                     [&](const Vec3d& p) { return p[axis] < split; });
  const size_t mid = size_t(mid_it - points.begin());
  Bounds left = box, right = box;
  left.hi[axis] = split;
  right.lo[axis] = split;
  const int c0 = build(tree, points, begin, mid, first_part, left_parts, left);
  const int c1 = build(tree, points, mid, end, first_part + left_parts, parts - left_parts, right);
  KdNode& node = tree.nodes[size_t(index)];
  node.axis = axis;
  node.split = split;
  node.child = {c0, c1};
  return index;
}

void order(const KdTree& tree, int node, const Camera& camera, const Vec3d& dir, std::vector<int>& out) {
  const KdNode& n = tree.nodes[size_t(node)];
  if (n.axis < 0) {
    out.push_back(n.part);
    return;
  }
  // Perspective rays start at the eye: its side is met first. Parallel rays come from infinitely far: the side the
  // direction leaves first.
  const bool low_first = camera.parallel_projection ? dir[n.axis] >= 0 : camera.position[n.axis] < n.split;
  order(tree, n.child[low_first ? 0 : 1], camera, dir, out);
  order(tree, n.child[low_first ? 1 : 0], camera, dir, out);
}

}  // namespace

KdTree build_kd_tree(std::vector<Vec3d> points, int parts) {
  if (parts < 1) fail_in("kd-tree", "the number of parts must be >= 1, not " + std::to_string(parts));
  KdTree tree;
  tree.boxes.resize(size_t(parts));
  const Bounds all{{-kInf, -kInf, -kInf}, {kInf, kInf, kInf}};
  build(tree, points, 0, points.size(), 0, parts, all);
  return tree;
}

std::vector<int> KdTree::visibility_order(const Camera& camera) const {
  std::vector<int> out;
  out.reserve(boxes.size());
  if (!nodes.empty()) order(*this, 0, camera, camera.direction(), out);
  return out;
}

int KdTree::part_of(const Vec3d& p) const {
  int node = 0;
  while (nodes[size_t(node)].axis >= 0) {
    const KdNode& n = nodes[size_t(node)];
    node = n.child[p[n.axis] < n.split ? 0 : 1];
  }
  return nodes[size_t(node)].part;
}

Vec3d centroid_of(std::span<const Vec3f> corners) {
  return mean_of_corners(int(corners.size()), [&](int i) { return corners[size_t(i)]; });
}

uint64_t split_sample_stride(uint64_t cells) {
  return std::max<uint64_t>(1, (cells + kMaxSplitSamples - 1) / kMaxSplitSamples);
}

std::vector<Vec3d> cell_centroids(const WalkMesh& mesh) {
  std::vector<Vec3d> out(mesh.cell_count());
  for (uint32_t c = 0; c < mesh.cell_count(); ++c) {
    const int k = mesh.type_index(c);
    const int n = cell_vertex_count(kAllCellTypes[k]);
    const uint32_t* v = mesh.cell_vertices(c, k);
    out[c] = mean_of_corners(n, [&](int i) { return mesh.points[v[i]]; });
  }
  return out;
}

std::vector<float> premultiplied(const Image& image) {
  std::vector<float> out(image.rgba.size());
  for (size_t i = 0; i < out.size(); i += 4) {
    const float a = image.rgba[i + 3];
    for (int c = 0; c < 3; ++c) out[i + size_t(c)] = image.rgba[i + size_t(c)] * a;
    out[i + 3] = a;
  }
  return out;
}

void blend_under(std::span<float> front, std::span<const float> back) {
  if (front.size() != back.size()) fail_in("compositing", "images of different sizes");
  for (size_t i = 0; i < front.size(); i += 4) {
    const float t = 1 - front[i + 3];
    for (size_t c = 0; c < 4; ++c) front[i + c] += t * back[i + c];
  }
}

Image apply_background(std::span<const float> premult, int width, int height, const std::array<double, 4>& background) {
  Image image(width, height);
  if (premult.size() != image.rgba.size()) fail_in("compositing", "image size does not match");
  for (size_t i = 0; i < premult.size(); i += 4) {
    const double radiance[3] = {premult[i], premult[i + 1], premult[i + 2]};
    composite_pixel(image.rgba.data() + i, radiance, 1.0 - double(premult[i + 3]), background);
  }
  return image;
}

}  // namespace ugvr
