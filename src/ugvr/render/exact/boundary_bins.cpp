#include "ugvr/render/exact/boundary_bins.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace ugvr {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

// Positions of a boundary triangle's three vertices.
inline void triangle_vertices(const WalkMesh& m, const BoundaryTriangle& bt, uint32_t out[3]) {
  const int k = m.type_index(bt.cell);
  const CellFace face = cell_info(kAllCellTypes[k]).faces[bt.local_face];
  const uint32_t* vid = m.cell_vertices(bt.cell, k);
  for (int i = 0; i < 3; ++i) out[i] = vid[face.v[bt.corners[i]]];
}

}  // namespace

BoundaryBins::BoundaryBins(const WalkMesh& mesh, const Camera& camera, int width, int height, int tile_size)
    : tile_(tile_size), tiles_x_((width + tile_size - 1) / tile_size), tiles_y_((height + tile_size - 1) / tile_size) {
  const CameraRays rays(camera, width, height);
  const Vec3d fwd = rays.forward(), right = rays.right(), up = rays.up();
  const double half_h =
      camera.parallel_projection ? camera.parallel_scale : std::tan(0.5 * camera.view_angle * kDegree);
  const double half_w = half_h * double(width) / double(height);
  const double near = 1e-9 * std::max(1.0, length(mesh.bounds.size()));
  const size_t n = mesh.boundary.size();
  boxes_.resize(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      uint32_t v[3];
      triangle_vertices(mesh, mesh.boundary[i], v);
      double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
      bool everywhere = false;
      int behind = 0;
      for (uint32_t id : v) {
        const Vec3d a = to_double(mesh.points[id]) - camera.position;
        double sx = dot(a, right), sy = dot(a, up);
        if (!camera.parallel_projection) {
          // Rays are lines through the eye, so a triangle wholly behind it projects through the eye like one in
          // front (where the lines meet it, t < 0); only one straddling the eye's plane has no bounded projection.
          const double z = dot(a, fwd);
          if (std::abs(z) <= near) {
            everywhere = true;
            break;
          }
          behind += z < 0;
          sx /= z, sy /= z;
        }
        const double px = (sx / half_w + 1) * 0.5 * width, py = (1 - sy / half_h) * 0.5 * height;
        x0 = std::min(x0, px), x1 = std::max(x1, px), y0 = std::min(y0, py), y1 = std::max(y1, py);
      }
      PixelBox& b = boxes_[i];
      if (everywhere || (behind > 0 && behind < 3)) {
        b = {0, 0, width - 1, height - 1};
        continue;
      }
      // Pixel x has its centre at x + 0.5; one pixel of margin absorbs the rounding of this projection.
      const double lim = 4.0 * std::max(width, height);
      b.x0 = int(std::floor(std::clamp(x0 - 0.5, -lim, lim))) - 1;
      b.x1 = int(std::ceil(std::clamp(x1 - 0.5, -lim, lim))) + 1;
      b.y0 = int(std::floor(std::clamp(y0 - 0.5, -lim, lim))) - 1;
      b.y1 = int(std::ceil(std::clamp(y1 - 0.5, -lim, lim))) + 1;
      b.x0 = std::max(b.x0, 0), b.y0 = std::max(b.y0, 0);
      b.x1 = std::min(b.x1, width - 1), b.y1 = std::min(b.y1, height - 1);
    }
  });
  // Bin by tile: counts, prefix sums, then a fill in triangle order (deterministic).
  const size_t tiles = size_t(tiles_x_) * size_t(tiles_y_);
  offsets_.assign(tiles + 1, 0);
  auto for_tiles = [&](const PixelBox& b, auto&& f) {
    if (b.x0 > b.x1 || b.y0 > b.y1) return;
    for (int ty = b.y0 / tile_; ty <= b.y1 / tile_; ++ty)
      for (int tx = b.x0 / tile_; tx <= b.x1 / tile_; ++tx) f(size_t(ty) * tiles_x_ + tx);
  };
  for (size_t i = 0; i < n; ++i) for_tiles(boxes_[i], [&](size_t t) { ++offsets_[t + 1]; });
  for (size_t t = 0; t < tiles; ++t) offsets_[t + 1] += offsets_[t];
  triangles_.resize(offsets_[tiles]);
  std::vector<uint64_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (size_t i = 0; i < n; ++i) for_tiles(boxes_[i], [&](size_t t) { triangles_[fill[t]++] = uint32_t(i); });
}

void tile_entries(const WalkMesh& mesh, const BoundaryBins& bins, int tile, int width, int height,
                  const std::vector<RayFrame>& frames, std::vector<EntryHit>& hits,
                  std::vector<uint32_t>& pixel_begin) {
  const int ts = bins.tile_size();
  const int tx0 = (tile % bins.tiles_x()) * ts, ty0 = (tile / bins.tiles_x()) * ts;
  const int tw = std::min(ts, width - tx0), th = std::min(ts, height - ty0);
  struct Keyed {
    uint32_t pixel;
    EntryHit hit;
  };
  thread_local std::vector<Keyed> keyed;
  keyed.clear();
  for (uint32_t tri : bins.tile_triangles(tile)) {
    const PixelBox& b = bins.box(tri);
    const int x0 = std::max(b.x0, tx0), x1 = std::min(b.x1, tx0 + tw - 1);
    const int y0 = std::max(b.y0, ty0), y1 = std::min(b.y1, ty0 + th - 1);
    if (x0 > x1 || y0 > y1) continue;
    uint32_t v[3];
    triangle_vertices(mesh, mesh.boundary[tri], v);
    const Vec3f p0 = mesh.points[v[0]], p1 = mesh.points[v[1]], p2 = mesh.points[v[2]];
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const uint32_t pixel = uint32_t((y - ty0) * tw + (x - tx0));
        const RayFrame& f = frames[pixel];
        const ProjectedVertex a = project(f, p0), bb = project(f, p1), c = project(f, p2);
        const double e_ab = edge_side(a, bb), e_bc = edge_side(bb, c), e_ca = edge_side(c, a);
        const double sum = e_ab + e_bc + e_ca;
        if (!(e_ab <= 0 && e_bc <= 0 && e_ca <= 0 && sum < 0)) continue;
        EntryHit h;
        h.triangle = tri;
        h.lambda[0] = e_bc / sum, h.lambda[1] = e_ca / sum, h.lambda[2] = e_ab / sum;
        h.t = h.lambda[0] * a.w + h.lambda[1] * bb.w + h.lambda[2] * c.w;
        keyed.push_back({pixel, h});
      }
  }
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    if (a.pixel != b.pixel) return a.pixel < b.pixel;
    if (a.hit.t != b.hit.t) return a.hit.t < b.hit.t;
    return a.hit.triangle < b.hit.triangle;
  });
  const uint32_t pixels = uint32_t(tw * th);
  pixel_begin.assign(pixels + 1, 0);
  hits.clear();
  for (const Keyed& kh : keyed) {
    ++pixel_begin[kh.pixel + 1];
    hits.push_back(kh.hit);
  }
  for (uint32_t p = 0; p < pixels; ++p) pixel_begin[p + 1] += pixel_begin[p];
}

}  // namespace ugvr
