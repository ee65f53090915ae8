// Sort-last data-parallel rendering, the part without MPI: a kd-tree that splits space into one box per rank holding
// about equal numbers of cells, the ranks' front-to-back order for a camera, and blending their images.
//
// The tree is built by every rank from the same points with the same arithmetic, so all ranks agree on it without
// communicating. Each split is an axis-aligned plane at a point coordinate (the median, or the quantile that gives
// each side cells in proportion to its ranks when the count is odd), on the longest axis of the points' bounds.
// Boxes are half-open kd cells whose faces on the outside of the tree are infinite: nothing at the data's boundary
// is ever clipped, and the boxes tile space, so the ray stretches of all ranks add up to the whole ray.
#pragma once
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"

namespace ugvr {

struct WalkMesh;

struct KdNode {
  int axis = -1;               // 0, 1, 2; -1 for a leaf
  double split = 0;            // the plane coordinate: below goes to child[0]
  std::array<int, 2> child{};  // node indices (inner nodes)
  int part = -1;               // leaves: the part (rank) whose box this is
};

struct KdTree {
  std::vector<KdNode> nodes;  // nodes[0] is the root
  std::vector<Bounds> boxes;  // per part; faces outside every split are +-infinity
  int parts() const { return int(boxes.size()); }
  // The part whose half-open box holds `p` (a point on a split plane goes to child[1], as build_kd_tree splits).
  int part_of(const Vec3d& p) const;
  // The parts front to back as seen by `camera`: at each split the side the eye is on first (perspective), or the
  // side the view direction leaves first (parallel projection). Exact for the convex boxes of a kd-tree.
  std::vector<int> visibility_order(const Camera& camera) const;
};

// Splits into `parts` (>= 1) boxes by the points (cell centroids), balanced by count. Throws ugvr::Error for
// parts < 1. Fewer points than parts leaves some boxes empty of points (still valid: their ranks draw nothing).
KdTree build_kd_tree(std::vector<Vec3d> points, int parts);

// The centroid of every cell of the walk mesh (the mean of its vertices).
std::vector<Vec3d> cell_centroids(const WalkMesh& mesh);

// The mean of a cell's n corners (corner(i): a Vec3f), summed in order in double then scaled by 1/n. Every centroid
// of a cell is taken with it (centroid_of, cell_centroids, mesh_part.h's cell_centroid), so a centroid taken from a
// streamed cell is the in-core mesh's bit for bit.
template <class Corner>
Vec3d mean_of_corners(int n, Corner&& corner) {
  Vec3d sum{0, 0, 0};
  for (int i = 0; i < n; ++i) sum = sum + to_double(corner(i));
  return sum * (1.0 / double(n));
}
Vec3d centroid_of(std::span<const Vec3f> corners);

// The split sample, one rule for every tree built from part of the cells (a .pvtu part read, mpi_part_read.h; an
// out-of-core partitioned build, piece_build_ooc.h): the centroids of cells 0, s, 2s, ... with s the smallest stride
// that leaves at most kMaxSplitSamples of `cells` (6 MiB of centroids, gathered on every rank of a part read). The
// boxes then balance the sample, not every cell: within sampling error of a tree over every centroid.
inline constexpr uint64_t kMaxSplitSamples = uint64_t(1) << 18;
uint64_t split_sample_stride(uint64_t cells);

// A rendered image as premultiplied RGBA: an engine's straight-colour image drawn over a transparent background
// (alpha = the volume's opacity) times its alpha.
std::vector<float> premultiplied(const Image& image);

// `back` under `front`, in place into `front` (premultiplied RGBA, the same length): front + (1 - front.a) * back.
void blend_under(std::span<float> front, std::span<const float> back);

// The composited premultiplied image over the straight-colour background, as every engine finishes its rays
// (composite_pixel, image.h), so the result compares with a one-rank image.
Image apply_background(std::span<const float> premultiplied, int width, int height,
                       const std::array<double, 4>& background);

}  // namespace ugvr
