#include "ugvr/store/boundary_planes.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <iterator>

namespace ugvr {
namespace {

using store_format::BoundaryNodeEntry;
using store_format::BoundaryTriangleRecord;
using store_format::kBoundaryOverflow;

Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// How far (normalised coordinates) a corner may lie off a plane and still be on it, and how much of a cell's section
// of the plane its triangles may leave open (relative): float corners of one flat face lie on their plane to ~1e-7.
constexpr double kPlaneTolerance = 1e-6;
constexpr double kCoverTolerance = 1e-5;

Vec3d triangle_corner(const BoundaryTriangleRecord& t, int i) {
  return Vec3d{t.p[3 * i], t.p[3 * i + 1], t.p[3 * i + 2]};
}

// A convex polygon of at most kMaxCorners corners, on the stack: the planes are computed for every node of a store
// when it is opened, over millions of triangles for a large mesh, and a heap vector per clip step made the allocator
// most of that time (a billion-cell store's 16 pieces took ~28 s to open, 40 % of it clipping, 28 % malloc/free).
// A triangle or a square clipped by the six faces of a box keeps at most 3 + 6 (4 + 6) corners; the room beyond is
// for corners that rounding makes nearly collinear at a face, and a corner past it is dropped rather than written.
constexpr int kMaxCorners = 16;
// Plain doubles, not Vec3d: the clip makes two of these per call, and Vec3d's zero initialisation of every corner was
// a third of the clip's time.
struct Polygon {
  double corner[kMaxCorners][3];
  int size = 0;
  void add(const double* p) {
    if (size == kMaxCorners) return;
    std::copy(p, p + 3, corner[size++]);
  }
  Vec3d at(int i) const { return Vec3d{corner[i][0], corner[i][1], corner[i][2]}; }
};

Polygon polygon(std::initializer_list<Vec3d> corners) {
  Polygon p;
  for (const Vec3d& c : corners) {
    const double xyz[3] = {c.x, c.y, c.z};
    p.add(xyz);
  }
  return p;
}

// The convex polygon `poly` clipped to the closed box (Sutherland-Hodgman, one face at a time; a face that every
// corner is inside of leaves the polygon as it is and is skipped).
Polygon clip_to_box(const Polygon& poly, const Bounds& box) {
  Polygon buffer[2];
  buffer[0] = poly;
  int now = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int upper = 0; upper < 2; ++upper) {
      const Polygon& in = buffer[now];
      if (in.size == 0) return in;
      const double bound = upper ? box.hi[axis] : box.lo[axis];
      auto inside = [&](const double* p) { return upper ? p[axis] <= bound : p[axis] >= bound; };
      bool all_inside = true;
      for (int i = 0; i < in.size && all_inside; ++i) all_inside = inside(in.corner[i]);
      if (all_inside) continue;
      Polygon& kept = buffer[1 - now];
      kept.size = 0;
      for (int i = 0; i < in.size; ++i) {
        const double* a = in.corner[i];
        const double* b = in.corner[(i + 1) % in.size];
        if (inside(a)) kept.add(a);
        if (inside(a) != inside(b)) {
          const double f = (bound - a[axis]) / (b[axis] - a[axis]);
          double x[3];
          for (int k = 0; k < 3; ++k) x[k] = a[k] + (b[k] - a[k]) * f;
          x[axis] = bound;
          kept.add(x);
        }
      }
      now = 1 - now;
    }
  }
  return buffer[now];
}

double polygon_area(const Polygon& poly, const Vec3d& normal) {
  Vec3d sum{};
  for (int i = 0; i < poly.size; ++i) sum = sum + cross(poly.at(i), poly.at((i + 1) % poly.size));
  return 0.5 * std::abs(dot(sum, normal));
}

bool inside_closed(const Vec3d& p, const Bounds& box) {
  return p.x >= box.lo.x && p.x <= box.hi.x && p.y >= box.lo.y && p.y <= box.hi.y && p.z >= box.lo.z && p.z <= box.hi.z;
}

// The area of the triangle's part inside the closed box. Most of a node's triangles lie wholly inside its cell; the
// clip would return their corners unchanged and in order, so they skip it (the same area, bit for bit).
double area_in_box(const Polygon& triangle, const Bounds& box, const Vec3d& normal) {
  const bool whole =
      inside_closed(triangle.at(0), box) && inside_closed(triangle.at(1), box) && inside_closed(triangle.at(2), box);
  return polygon_area(whole ? triangle : clip_to_box(triangle, box), normal);
}

// The plane's section of the box: a square in the plane larger than the box, clipped to it.
double section_area(const BoundaryPlane& plane, const Bounds& box) {
  const Vec3d& n = plane.normal;
  const Vec3d helper = std::abs(n.x) < 0.6 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  Vec3d u = cross(n, helper);
  u = u * (1.0 / std::sqrt(dot(u, u)));
  const Vec3d v = cross(n, u);
  const Vec3d centre = (box.lo + box.hi) * 0.5;
  const Vec3d c = centre - n * (dot(n, centre) - plane.offset);
  const Vec3d diag = box.hi - box.lo;
  const double r = std::sqrt(dot(diag, diag));
  return polygon_area(
      clip_to_box(polygon({c - u * r - v * r, c + u * r - v * r, c + u * r + v * r, c - u * r + v * r}), box), n);
}

// What an entry reaches: whether any triangle, whether they all lie on one plane facing one way, and if so which
// triangles (ascending, each once) and the plane.
struct Reach {
  bool any = false;
  bool planar = false;
  BoundaryPlane plane;
  std::vector<uint32_t> triangles;
};

bool same_plane(const BoundaryPlane& a, const BoundaryPlane& b) {
  return dot(a.normal, b.normal) > 1.0 - 1e-12 && std::abs(a.offset - b.offset) <= kPlaneTolerance;
}

// The plane of a run of triangles, from its largest (the best-conditioned normal), if all lie on it facing one way.
std::optional<BoundaryPlane> plane_of(const StoreBoundary& b, std::span<const uint32_t> run) {
  double largest = 0;
  BoundaryPlane plane;
  for (uint32_t t : run) {
    const Vec3d p0 = triangle_corner(b.triangles[t], 0);
    const Vec3d n = cross(triangle_corner(b.triangles[t], 1) - p0, triangle_corner(b.triangles[t], 2) - p0);
    const double len = std::sqrt(dot(n, n));
    if (len > largest) {
      largest = len;
      plane.normal = n * (1.0 / len);
      plane.offset = dot(plane.normal, p0);
    }
  }
  if (!(largest > 0)) return std::nullopt;
  for (uint32_t t : run) {
    const Vec3d p0 = triangle_corner(b.triangles[t], 0);
    const Vec3d n = cross(triangle_corner(b.triangles[t], 1) - p0, triangle_corner(b.triangles[t], 2) - p0);
    if (dot(n, plane.normal) < 0) return std::nullopt;  // a face of the other orientation: a sheet, two sides
    for (int i = 0; i < 3; ++i)
      if (std::abs(dot(plane.normal, triangle_corner(b.triangles[t], i)) - plane.offset) > kPlaneTolerance)
        return std::nullopt;
  }
  return plane;
}

}  // namespace

std::vector<std::optional<BoundaryPlane>> boundary_face_planes(const StoreBoundary& boundary,
                                                               std::span<const OctreeNode> nodes) {
  std::vector<std::optional<BoundaryPlane>> out(boundary.nodes.size());
  if (boundary.empty() || nodes.empty()) return out;
  // Bottom-up over the entries (depth first from the root, with each entry's cell): an entry's reach is its own run,
  // or the union of its children's (tree children for a node over the cap, else its 8 virtual nodes).
  // The top levels' children are visited in parallel (each writes only its own entries of `out`), their reaches
  // merged in child order as before, so the planes do not depend on the threads: opening a store with millions of
  // boundary triangles spends seconds here.
  constexpr int kParallelDepth = 3;
  auto visit = [&](auto& self, uint64_t entry, const Bounds& cell, int depth) -> Reach {
    Reach r;
    if (entry >= boundary.nodes.size()) return r;
    const BoundaryNodeEntry e = boundary.nodes[entry];
    if (e.count == 0) return r;
    r.any = true;
    if (e.count != kBoundaryOverflow) {
      const std::span<const uint32_t> run(boundary.refs.data() + e.first, e.count);
      if (const auto plane = plane_of(boundary, run)) {
        r.planar = true;
        r.plane = *plane;
        r.triangles.assign(run.begin(), run.end());
        std::sort(r.triangles.begin(), r.triangles.end());
      }
    } else {
      r.planar = true;
      const Vec3d half = (cell.hi - cell.lo) * 0.5;
      std::array<Reach, 8> reach;
      auto visit_child = [&](int o) {
        uint64_t child = kNoNode;
        if (e.first != 0) {
          child = uint64_t(e.first) + uint64_t(o);
        } else if (entry < nodes.size()) {
          child = nodes[entry].child(o);
        }
        if (child == kNoNode) return;
        Bounds c;
        c.lo = cell.lo + Vec3d{(o & 1) * half.x, (o >> 1 & 1) * half.y, (o >> 2 & 1) * half.z};
        c.hi = c.lo + half;
        reach[size_t(o)] = self(self, child, c, depth + 1);
      };
      if (depth < kParallelDepth) {
        tbb::parallel_for(0, 8, visit_child);
      } else {
        for (int o = 0; o < 8; ++o) visit_child(o);
      }
      bool first = true;
      for (Reach& k : reach) {
        if (!k.any) continue;
        if (!k.planar || (!first && !same_plane(k.plane, r.plane))) {
          r.planar = false;
        } else if (r.planar) {
          if (first) r.plane = k.plane;
          first = false;
          std::vector<uint32_t> merged;
          std::set_union(r.triangles.begin(), r.triangles.end(), k.triangles.begin(), k.triangles.end(),
                         std::back_inserter(merged));
          r.triangles = std::move(merged);
        }
      }
      if (first) r.planar = false;  // over the cap but no child reached: leave it to the walk
    }
    if (!r.planar) {
      r.triangles = {};
      return r;
    }
    const double section = section_area(r.plane, cell);
    double covered = 0;
    for (uint32_t t : r.triangles) {
      const BoundaryTriangleRecord& tri = boundary.triangles[t];
      covered += area_in_box(polygon({triangle_corner(tri, 0), triangle_corner(tri, 1), triangle_corner(tri, 2)}), cell,
                             r.plane.normal);
    }
    const double cell_area = (cell.hi.x - cell.lo.x) * (cell.hi.x - cell.lo.x);
    if (section > 1e-9 * cell_area && std::abs(covered - section) <= kCoverTolerance * section) out[entry] = r.plane;
    return r;
  };
  Bounds root;
  root.lo = Vec3d{0, 0, 0};
  root.hi = Vec3d{1, 1, 1};
  visit(visit, 0, root, 0);
  return out;
}

}  // namespace ugvr
