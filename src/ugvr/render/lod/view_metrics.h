// The view as level-of-detail selection sees it: which octree boxes the camera can see at all, and how large a
// length (one texel of a node's brick) appears on screen. Shared by the per-frame cut selection (lod_cut.h) and the
// incrementally maintained active cut (active_cut.h), so that both classify and rank nodes with the same arithmetic:
// the active cut's fixed point equals select_cut's result bit for bit only if the numbers agree exactly.
//
// Frustum: the half-spaces dot(p - eye, normal) + offset >= 0 of the 4 side planes and of the plane through the
// camera perpendicular to the view direction (nothing behind the camera is drawn, in either projection). A box is
// outside when it lies entirely in the negative side of one plane: a conservative test (a box near a frustum corner
// may be kept although no ray reaches it), so a box that any pixel ray reaches is never reported outside.
//
// Projected size: a length h at the box's nearest depth d along the view direction (the depth of the box corner
// nearest the camera plane, clamped to 1e-9 of the root's diagonal so a box reaching the camera plane gets a huge,
// finite size) covers h / (2 d tan(view_angle / 2)) · height pixels in perspective, h / (2 parallel_scale) · height
// in parallel projection. The texel of a node is its box's longest edge / (R - 1), R the brick resolution (the brick's
// border samples lie on the cell faces). Since a child's box lies inside its parent's, is half as large and no nearer,
// a child's texel size is at most half its parent's: the size is monotone down the tree.
//
// Every projected size is then clamped to the image's diagonal in pixels (max_pixels()): a length cannot show larger
// than the whole image, and a box at or behind the eye (depth clamped as above) would otherwise report some 1e9 pixels,
// which the frame statistics average into an absurd "texel error" (the viewer's status bar showed 1838762107 px).
// The clamp keeps the order of every pair of sizes below it and the monotonicity down the tree (min(x, c) is
// monotone); such nodes still rank first for refinement and still exceed any pixels:P criterion with P < max_pixels().
#pragma once

#include <array>
#include <cstdint>

#include "ugvr/core/vec.h"
#include "ugvr/render/camera.h"

namespace ugvr {

class ViewMetrics {
 public:
  // `width` × `height` is the rendered image (CameraRays' conventions), `root` the octree's root cell (it scales the
  // depth clamp). Throws ugvr::Error ("lod cut: ...") for an image size < 1 or a degenerate camera (position at the
  // focal point, view up parallel to the view direction, view angle outside (0, 180), parallel scale <= 0).
  ViewMetrics(const Camera& camera, int width, int height, const Bounds& root);

  // Whether the box lies entirely outside the frustum (see the header comment).
  bool outside(const Bounds& box) const;
  // Pixels covered by a length `h` at the box's nearest depth, at most max_pixels().
  double pixels(const Bounds& box, double h) const;
  // The clamp of every projected size: the image's diagonal, in pixels.
  double max_pixels() const { return max_pixels_; }
  // Pixels covered by one texel of a brick of `resolution` (>= 2) samples per axis spanning `box`.
  double texel_pixels(const Bounds& box, uint32_t resolution) const;

 private:
  struct Plane {
    Vec3d normal;
    double offset = 0;
  };

  bool parallel_ = false;
  Vec3d eye_, forward_;
  double half_height_ = 1;  // tan(view_angle / 2) (perspective) or parallel_scale (parallel)
  double height_ = 1;       // pixels
  double max_pixels_ = 1;   // the image's diagonal, pixels
  double min_depth_ = 0;    // clamp of the perspective distance
  std::array<Plane, 5> planes_;
};

}  // namespace ugvr
