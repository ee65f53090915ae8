// Ray-local coordinates for watertight walking (after Marmitt & Slusallek 2006's Plücker tests, in the projected
// form of Woop et al. 2013): each ray gets an orthonormal frame (e1, e2, dir); a vertex p becomes
//   u = (p - o) . e1,  v = (p - o) . e2,  w = (p - o) . dir
// and the ray is the line u = v = 0. Which side of a directed edge (a, b) the ray passes is the sign of
//   edge(a, b) = u_a v_b - v_a u_b,
// computed from per-vertex numbers only, so every cell that contains the edge gets the same value, and
// edge(b, a) == -edge(a, b) exactly (the build disables FMA contraction for this): two cells sharing a face can
// never both miss or both claim a crossing, whatever the rounding. For a triangle (a, b, c) listed counter-clockwise
// seen from outside, the ray leaves through it when all three edge values are >= 0 (sum > 0) and enters when all
// are <= 0; the barycentric weights of the crossing are (edge(b,c), edge(c,a), edge(a,b)) / sum and its distance
// along the ray is the weighted w.
#pragma once

#include <cmath>

#include "ugvr/core/vec.h"
#include "ugvr/render/camera.h"

namespace ugvr {

struct RayFrame {
  Vec3d origin, dir, e1, e2;

  explicit RayFrame(const Ray& ray) : origin(ray.origin), dir(ray.direction) {
    // Duff et al. 2017, "Building an orthonormal basis, revisited"; e2 = dir x e1 makes (e1, e2, dir) right-handed.
    const double sign = std::copysign(1.0, dir.z);
    const double a = -1.0 / (sign + dir.z);
    const double b = dir.x * dir.y * a;
    e1 = {1.0 + sign * dir.x * dir.x * a, sign * b, -sign * dir.x};
    e2 = cross(dir, e1);
  }
  Vec3d at(double t) const { return origin + dir * t; }
};

struct ProjectedVertex {
  double u, v, w;
};

inline ProjectedVertex project(const RayFrame& frame, Vec3f p) {
  const Vec3d a = to_double(p) - frame.origin;
  return {dot(a, frame.e1), dot(a, frame.e2), dot(a, frame.dir)};
}

inline double edge_side(const ProjectedVertex& a, const ProjectedVertex& b) { return a.u * b.v - a.v * b.u; }

}  // namespace ugvr
