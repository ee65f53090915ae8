// The LOD engine's fidelity against the exact engine for one view (issue 25): PSNR and SSIM of the whole image, and
// the seam metric, the mean error on pixels along the projected borders between cut nodes of different levels divided
// by the mean error on the other covered pixels (about 1: no seam; well above 1: the level changes show).
//   bench_lod_seams [--plane PX,PY,PZ,NX,NY,NZ] STORE FIELD CAMERA.json TF.json CUT EXACT.pfm LOD.pfm [MASK.png]
//   [R,G,B]
// CAMERA.json and TF.json are what `ugvr render --save-camera --save-tf` wrote for the LOD image (the transfer
// function as rendered: rescaled, with its unit distance), so the cut chosen here is the one the render used
// (select_cut with the engine's defaults: transfer-function culling on, no node budget; the store must fit the
// default atlas, which the output's "budget_limited" would contradict). MASK.png, if given, shows the border
// pixels in white and the other covered pixels in grey; R,G,B is the background the images were rendered on (default
// RenderSettings', ParaView's). One JSON line on stdout.
//
// Borders: for every cut node and each of its 6 faces, the point just outside the face's centre is located in the
// cut; if the node there has another level (none: the data's edge is no seam and is skipped), the face's 4 edges,
// clipped to the data's bounds (a node's box may reach past them, where nothing is drawn), are projected, and every
// pixel whose centre lies within 1 pixel of one is a border pixel. Edges shorter than kMinEdgePixels on screen are
// left out: far away the nodes are a few pixels wide and their borders would cover everything, leaving no "elsewhere"
// to compare with. A coarse face next to finer nodes finds a finer one at its centre, a fine face next to a coarse
// one the coarse one. Covered: a pixel where either image differs from the background by more than 1/255.
// The per-pixel error is the mean absolute difference of R, G, B.
// With --plane PX,PY,PZ,NX,NY,NZ first (a slice, docs/slices.md, rendered with the volume hidden), the border pixels
// are those along the lines where the plane crosses the faces between levels (the seams a slice could show), not the
// faces' edges; and the cut is chosen as the engine chooses it for a frame with slices (no transfer-function culling
// or weighting: the slice shows transparent data too).
// Seen through a volume, the level changes inside it all project somewhere; the seams the issue saw (the demo's
// checkerboard) lie on the data's boundary, where an opaque wall layer meets the box. So a second ratio, "wall", counts
// only the border edges lying in a face of the data's bounding box (the demo's floor and top), against the same
// "elsewhere".
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

using namespace ugvr;

namespace {

constexpr double kMinEdgePixels = 8;

// Clips the segment a-b to the box; false if nothing is left.
bool clip_to_box(Vec3d& a, Vec3d& b, const Bounds& box) {
  double t0 = 0, t1 = 1;
  const Vec3d d = b - a;
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] == 0) {
      if (a[axis] < box.lo[axis] || a[axis] > box.hi[axis]) return false;
      continue;
    }
    double ta = (box.lo[axis] - a[axis]) / d[axis], tb = (box.hi[axis] - a[axis]) / d[axis];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
  }
  if (t0 > t1) return false;
  const Vec3d a0 = a;
  a = a0 + d * t0, b = a0 + d * t1;
  return true;
}

// The cut node containing p (a map from node id to "in the cut"), or kNoNode: descent from the root.
uint64_t locate(const BrickStoreReader& store, const std::vector<char>& in_cut, Vec3d p) {
  const Bounds& root = store.layout().root;
  if (p.x < root.lo.x || p.y < root.lo.y || p.z < root.lo.z || p.x > root.hi.x || p.y > root.hi.y || p.z > root.hi.z)
    return kNoNode;
  uint64_t n = 0;
  for (;;) {
    if (in_cut[n]) return n;
    const BrickNode& node = store.node(n);
    if (node.is_leaf()) return kNoNode;
    const Bounds b = store.bounds(n);
    const Vec3d c = (b.lo + b.hi) * 0.5;
    const int octant = (p.x >= c.x ? 1 : 0) | (p.y >= c.y ? 2 : 0) | (p.z >= c.z ? 4 : 0);
    const uint64_t child = node.child(octant);
    if (child == kNoNode) return kNoNode;
    n = child;
  }
}

struct Projector {
  Camera camera;
  CameraRays rays;
  // Pixel coordinates (x right, y down, pixel centres at +0.5) of a world point; false behind the camera plane.
  bool project(Vec3d p, double& px, double& py) const {
    const Vec3d d = p - camera.position;
    const double z = dot(d, rays.forward());
    double x = dot(d, rays.right()), y = dot(d, rays.up());
    if (!camera.parallel_projection) {
      if (z <= 1e-9) return false;
      x /= z, y /= z;
    }
    px = (x / rays.half_width() + 1) * 0.5 * rays.width();
    py = (1 - y / rays.half_height()) * 0.5 * rays.height();
    return true;
  }
};

// Marks the pixels whose centre lies within `radius` pixels of the segment a-b (image coordinates).
void mark_segment(std::vector<char>& mask, int w, int h, double ax, double ay, double bx, double by, double radius) {
  const int x0 = std::max(0, int(std::floor(std::min(ax, bx) - radius))),
            x1 = std::min(w - 1, int(std::max(ax, bx) + radius));
  const int y0 = std::max(0, int(std::floor(std::min(ay, by) - radius))),
            y1 = std::min(h - 1, int(std::max(ay, by) + radius));
  const double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double cx = x + 0.5, cy = y + 0.5;
      const double t = len2 > 0 ? std::clamp(((cx - ax) * dx + (cy - ay) * dy) / len2, 0.0, 1.0) : 0.0;
      const double ex = ax + t * dx - cx, ey = ay + t * dy - cy;
      if (ex * ex + ey * ey <= radius * radius) mask[size_t(y) * w + x] = 1;
    }
}

}  // namespace

int main(int argc, char** argv) {
  std::optional<std::array<double, 6>> slice_plane;
  if (argc > 2 && std::string(argv[1]) == "--plane") {
    std::array<double, 6> p{};
    if (std::sscanf(argv[2], "%lf,%lf,%lf,%lf,%lf,%lf", &p[0], &p[1], &p[2], &p[3], &p[4], &p[5]) != 6) {
      std::fprintf(stderr, "--plane: expected PX,PY,PZ,NX,NY,NZ\n");
      return 1;
    }
    slice_plane = p;
    argv += 2, argc -= 2;
  }
  if (argc < 8) {
    std::fprintf(
        stderr,
        "usage: %s [--plane PX,PY,PZ,NX,NY,NZ] STORE FIELD CAMERA.json TF.json CUT EXACT.pfm LOD.pfm [MASK.png]\n",
        argv[0]);
    return 2;
  }
  try {
    const BrickStoreReader store(argv[1]);
    const int field = store.field_index(argv[2]);
    if (field < 0) fail_in(argv[1], std::string("no field \"") + argv[2] + "\"");
    const Camera camera = read_camera(argv[3]);
    const TransferFunction tf = read_paraview_preset(argv[4]);
    const CutSpec spec = parse_cut_spec(argv[5]);
    const Image exact = read_pfm(argv[6]), lod = read_pfm(argv[7]);
    if (exact.width != lod.width || exact.height != lod.height) fail_in(argv[7], "not the size of the exact image");
    const int w = exact.width, h = exact.height;
    CutOptions co;
    co.field = uint32_t(field);
    if (slice_plane) co.tf_cull = false, co.tf_error = false;  // as LodEngine::render with slices
    const Cut cut = select_cut(store, spec, camera, w, h, tf, co);

    std::vector<char> in_cut(store.node_count(), 0);
    for (uint64_t n : cut.nodes) in_cut[n] = 1;
    const Projector proj{camera, CameraRays(camera, w, h)};
    std::vector<char> border(size_t(w) * h, 0), wall(size_t(w) * h, 0);
    const Bounds& data = store.layout().data;
    const Vec3d data_size = data.hi - data.lo;
    // Whether both ends lie in one face of the data's box.
    auto on_box_face = [&](Vec3d p, Vec3d q) {
      for (int axis = 0; axis < 3; ++axis)
        for (double plane : {data.lo[axis], data.hi[axis]}) {
          const double eps = 1e-6 * data_size[axis];
          if (std::abs(p[axis] - plane) <= eps && std::abs(q[axis] - plane) <= eps) return true;
        }
      return false;
    };
    uint64_t seam_faces = 0;
    for (uint64_t n : cut.nodes) {
      const Bounds b = store.bounds(n);
      const Vec3d size = b.hi - b.lo;
      const int level = store.node(n).level;
      for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
          Vec3d c = (b.lo + b.hi) * 0.5;
          const double eps = 1e-6 * size[axis];
          c[axis] = side ? b.hi[axis] + eps : b.lo[axis] - eps;
          const uint64_t other = locate(store, in_cut, c);
          if (other == kNoNode || store.node(other).level == level) continue;
          ++seam_faces;
          // The face's corners, in order around it.
          const int u = (axis + 1) % 3, v = (axis + 2) % 3;
          Vec3d corner[4];
          for (int k = 0; k < 4; ++k) {
            Vec3d q;
            q[axis] = side ? b.hi[axis] : b.lo[axis];
            q[u] = (k == 1 || k == 2) ? b.hi[u] : b.lo[u];
            q[v] = (k >= 2) ? b.hi[v] : b.lo[v];
            corner[k] = q;
          }
          if (slice_plane) {
            // Where the plane crosses the face: the points where it crosses the face's edges (two, unless it only
            // touches the face).
            const Vec3d pp{(*slice_plane)[0], (*slice_plane)[1], (*slice_plane)[2]},
                pn{(*slice_plane)[3], (*slice_plane)[4], (*slice_plane)[5]};
            std::vector<Vec3d> hits;
            for (int k = 0; k < 4; ++k) {
              const Vec3d a = corner[k], e = corner[(k + 1) % 4];
              const double da = dot(a - pp, pn), de = dot(e - pp, pn);
              if ((da < 0) != (de < 0)) hits.push_back(a + (e - a) * (da / (da - de)));
            }
            double ax, ay, bx, by;
            Vec3d p = hits.size() >= 2 ? hits[0] : Vec3d{}, q = hits.size() >= 2 ? hits[1] : Vec3d{};
            if (hits.size() >= 2 && clip_to_box(p, q, store.layout().data) && proj.project(p, ax, ay) &&
                proj.project(q, bx, by) && std::hypot(bx - ax, by - ay) >= kMinEdgePixels)
              mark_segment(border, w, h, ax, ay, bx, by, 1.0);
            continue;
          }
          for (int k = 0; k < 4; ++k) {
            Vec3d p = corner[k], q = corner[(k + 1) % 4];
            double ax, ay, bx, by;
            if (clip_to_box(p, q, store.layout().data) && proj.project(p, ax, ay) && proj.project(q, bx, by) &&
                std::hypot(bx - ax, by - ay) >= kMinEdgePixels) {
              mark_segment(border, w, h, ax, ay, bx, by, 1.0);
              if (on_box_face(p, q)) mark_segment(wall, w, h, ax, ay, bx, by, 1.0);
            }
          }
        }
    }

    float bgc[3];
    const std::array<double, 4> default_bg = RenderSettings{}.background;
    for (int c = 0; c < 3; ++c) bgc[c] = float(default_bg[size_t(c)]);
    if (argc > 9 && std::sscanf(argv[9], "%f,%f,%f", &bgc[0], &bgc[1], &bgc[2]) != 3)
      fail_in(argv[9], "expected the background as R,G,B");
    double sum_border = 0, sum_else = 0, sum_wall = 0;
    uint64_t n_border = 0, n_else = 0, n_wall = 0;
    std::vector<unsigned char> mask_rgb(size_t(w) * h, 0);
    for (size_t i = 0; i < size_t(w) * h; ++i) {
      bool covered = false;
      double err = 0;
      for (int c = 0; c < 3; ++c) {
        covered = covered || std::abs(exact.rgba[4 * i + c] - bgc[c]) > 1.0 / 255 ||
                  std::abs(lod.rgba[4 * i + c] - bgc[c]) > 1.0 / 255;
        err += std::abs(double(exact.rgba[4 * i + c]) - double(lod.rgba[4 * i + c])) / 3;
      }
      if (!covered) continue;
      if (wall[i]) sum_wall += err, ++n_wall;
      if (border[i]) {
        sum_border += err, ++n_border;
        mask_rgb[i] = 255;
      } else {
        sum_else += err, ++n_else;
        mask_rgb[i] = 100;
      }
    }
    if (argc > 8) {
      Image m(w, h);
      for (size_t i = 0; i < size_t(w) * h; ++i)
        for (int c = 0; c < 4; ++c) m.rgba[4 * i + c] = c == 3 ? 1.0f : float(mask_rgb[i]) / 255;
      write_image(argv[8], m);
    }
    const double mean_border = n_border ? sum_border / double(n_border) : 0;
    const double mean_else = n_else ? sum_else / double(n_else) : 0;
    const double mean_wall = n_wall ? sum_wall / double(n_wall) : 0;
    const ImageDifference d = compare_images(exact, lod);
    std::printf(
        "{\"psnr_db\":%.3f,\"ssim\":%.5f,\"seam_ratio\":%.4f,\"border_mean_error\":%.6g,\"other_mean_error\":%.6g,"
        "\"wall_seam_ratio\":%.4f,\"wall_mean_error\":%.6g,\"wall_pixels\":%llu,\"border_pixels\":%llu,\"other_"
        "pixels\":%llu,\"seam_faces\":%llu,\"cut_nodes\":%zu,\"max_level\":%d,"
        "\"budget_limited\":%s}\n",
        d.psnr_db, ssim(exact, lod), mean_else > 0 ? mean_border / mean_else : 0.0, mean_border, mean_else,
        mean_else > 0 ? mean_wall / mean_else : 0.0, mean_wall, (unsigned long long)n_wall,
        (unsigned long long)n_border, (unsigned long long)n_else, (unsigned long long)seam_faces, cut.nodes.size(),
        cut.max_level, cut.budget_limited ? "true" : "false");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_lod_seams: %s\n", e.what());
    return 1;
  }
  return 0;
}
