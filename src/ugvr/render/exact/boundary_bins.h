// Where rays enter the mesh. Per frame, every boundary triangle is projected to the screen and binned into the image
// tiles its (conservative) pixel box touches; a tile then tests exactly, with the same watertight edge tests the walk
// uses (ray_frame.h), each of its triangles against each pixel of the triangle's box, and keeps the entering
// crossings (all edge values <= 0) sorted per pixel by distance. Rays of non-convex meshes, meshes with holes and
// several pieces re-enter at the next crossing beyond the point where they left. Rays are whole lines (a camera
// inside the mesh walks from where the line enters behind it and keeps t >= 0): triangles wholly behind a
// perspective camera project through the eye like any other, and only those straddling the plane of the eye, a thin
// band, are tested against every pixel.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/render/camera.h"
#include "ugvr/render/exact/ray_frame.h"
#include "ugvr/render/exact/walk_mesh.h"

namespace ugvr {

struct EntryHit {
  double t;
  uint32_t triangle;  // index into WalkMesh::boundary
  double lambda[3];   // barycentric weights of the triangle's corners
};

struct PixelBox {
  int x0, y0, x1, y1;  // inclusive pixel ranges; x0 > x1 when empty
};

class BoundaryBins {
 public:
  BoundaryBins(const WalkMesh& mesh, const Camera& camera, int width, int height, int tile_size);

  int tile_size() const { return tile_; }
  int tiles_x() const { return tiles_x_; }
  int tiles_y() const { return tiles_y_; }
  std::span<const uint32_t> tile_triangles(int tile) const {
    return {triangles_.data() + offsets_[tile], size_t(offsets_[tile + 1] - offsets_[tile])};
  }
  const PixelBox& box(uint32_t triangle) const { return boxes_[triangle]; }

 private:
  int tile_, tiles_x_, tiles_y_;
  std::vector<PixelBox> boxes_;
  std::vector<uint64_t> offsets_;
  std::vector<uint32_t> triangles_;
};

// The entering crossings of each pixel of tile `tile`: hits grouped by pixel (row-major within the tile), sorted by
// t then triangle; pixel_begin has one entry per tile pixel plus one. frames are the tile's pixel rays, row-major.
void tile_entries(const WalkMesh& mesh, const BoundaryBins& bins, int tile, int width, int height,
                  const std::vector<RayFrame>& frames, std::vector<EntryHit>& hits, std::vector<uint32_t>& pixel_begin);

}  // namespace ugvr
