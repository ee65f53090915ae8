#include "ugvr/render/exact/exact_engine.h"

#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>

#include "ugvr/core/error.h"
#include "ugvr/core/threads.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/render/exact/boundary_bins.h"
#include "ugvr/render/exact/ray_frame.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/optical_table.h"
#include "ugvr/render/renderer.h"

namespace ugvr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Headlight shading (light at the eye, so the half vector is the view vector); two-sided.
constexpr double kAmbient = 0.2, kDiffuse = 0.8, kSpecular = 0.25, kShininess = 32;
constexpr Vec3d kOverlayColor{0.85, 0.85, 0.85};

// A walk that makes no progress for this many steps (a ray running exactly along faces can bounce between cells
// with zero-length segments) is abandoned and counted in lost_rays.
constexpr int kMaxStallSteps = 1000;
// Recursion depth of the error-bounded subdivision in non-tetrahedral cells (at most 2^6 linear pieces a cell).
constexpr int kMaxNonlinearDepth = 6;

Vec3d shade_surface(Vec3d color, Vec3d normal, Vec3d view_dir, bool lighting) {
  if (!lighting) return color;
  const double len = length(normal);
  if (!(len > 0)) return color;
  const double c = std::abs(dot(normal, view_dir)) / len;
  const double spec = kSpecular * std::pow(c, kShininess);
  const Vec3d out = color * (kAmbient + kDiffuse * c) + Vec3d{spec, spec, spec};
  return {std::min(out.x, 1.0), std::min(out.y, 1.0), std::min(out.z, 1.0)};
}

double shade_volume(Vec3d gradient, Vec3d view_dir) {
  const double len = length(gradient);
  if (!(len > 0)) return 1;
  return kAmbient + kDiffuse * std::abs(dot(gradient, view_dir)) / len;
}

void composite_surface(RayAccumulator& acc, Vec3d color, double alpha) {
  acc.radiance = acc.radiance + color * (acc.transmittance * alpha);
  acc.transmittance *= 1 - alpha;
}

struct Counters {
  uint64_t rays_hit = 0, cell_steps = 0, reentries = 0, nonlinear_samples = 0, lost_rays = 0;
};

// Where a ray crosses a face of the current cell.
struct Crossing {
  uint8_t face = 0;
  std::array<uint8_t, 3> corners{};  // indices into the face's vertex list
  double lambda[3] = {0, 0, 0};      // barycentric weights of those corners
  double t = 0;
};

// Corners of triangle `tri` (0 or 1) of a face; quadrilaterals split along 0-2 or 1-3 (walk_mesh.h).
inline std::array<uint8_t, 3> triangle_corners(int face_size, bool split_13, int tri) {
  if (face_size == 3) return {0, 1, 2};
  if (split_13) return tri == 0 ? std::array<uint8_t, 3>{0, 1, 3} : std::array<uint8_t, 3>{1, 2, 3};
  return tri == 0 ? std::array<uint8_t, 3>{0, 1, 2} : std::array<uint8_t, 3>{0, 2, 3};
}

}  // namespace

struct ExactEngine::Impl {
  WalkMesh mesh;
  std::vector<float> values;         // per vertex or per cell (engine order)
  std::function<bool()> keep_going;  // set_keep_going
  bool per_cell = false;
  bool bound = false;
  std::string field_name;
  double field_min = 0, field_max = 1;
  double nonlinear_tolerance = 1e-3;
  double build_seconds = 0;
  std::optional<Bounds> clip_box;
  // After restrict_to_box: the source index of each kept cell and point, and the source mesh's sizes (set_field
  // reads the dataset in the source numbering, then gathers).
  bool restricted = false;
  std::vector<uint32_t> cell_source, point_source;
  uint64_t source_points = 0, source_cells = 0;
};

namespace {

// A slice as the rays see it: the plane dot(n, p) = d, the colour map over the slice's range and its contour lines.
struct SlicePlane {
  Vec3d n;
  double d = 0;
  double opacity = 1;
  TransferFunction colors;       // only color() is used
  std::vector<double> contours;  // slice_contour_values; empty: no lines
  double contour_width = 0;
  Vec3d contour_color;
};

// One pixel's footprint across the image, for the contour lines' screen-space derivative: world vectors from one
// column (px) and one row (py) to the next, at unit distance along the view direction for a perspective camera (a
// crossing at depth z has z times them), everywhere for a parallel one.
struct PixelFootprint {
  Vec3d px{}, py{}, forward{};
  bool parallel = false;
};

// Everything one render() needs, shared read-only by the tiles.
struct Scene {
  const std::vector<float>& values;  // the bound field, per vertex or per cell
  bool per_cell;
  const WalkMesh& mesh;
  const OpticalTable& table;
  const TransferFunction& tf;
  const RenderSettings& settings;
  std::vector<double> iso_ascending;
  double tolerance_abs;  // nonlinear tolerance in scalar units
  double reentry_slack;  // distance within which a re-entry counts as continuing where the ray left
  const std::optional<Bounds>& clip_box;
  std::vector<SlicePlane> slices;
  PixelFootprint footprint{};
};

// The interval [lo, hi] of t where o + t d satisfies dot(n, p) - c >= 0 (keep_positive) or <= 0, intersected into
// [lo, hi]; a ray parallel to the plane on the wrong side empties it.
void keep_half_space(Vec3d n, double c, Vec3d o, Vec3d d, bool keep_positive, double& lo, double& hi) {
  const double sign = keep_positive ? 1 : -1;
  const double nd = sign * dot(n, d), g0 = sign * (dot(n, o) - c);
  if (nd > 0) {
    lo = std::max(lo, -g0 / nd);
  } else if (nd < 0) {
    hi = std::min(hi, -g0 / nd);
  } else if (g0 < 0) {
    hi = -kInf;
  }
}

// Limits [t_lo, t_hi] to the stretch of the ray inside `box` (slabs). The same plane value gives the same t bit for
// bit in the two boxes that share it, so the stretches of neighbouring boxes meet exactly.
void clip_to_box(const RayFrame& frame, const Bounds& box, double& t_lo, double& t_hi) {
  const double o[3] = {frame.origin.x, frame.origin.y, frame.origin.z};
  const double d[3] = {frame.dir.x, frame.dir.y, frame.dir.z};
  const double lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] >= hi[a]) t_hi = -kInf;  // parallel to the slab, outside it (half-open: one box owns it)
      continue;
    }
    double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    t_lo = std::max(t_lo, t0), t_hi = std::min(t_hi, t1);
  }
}

// The state of one ray.
class RayTracer {
 public:
  RayTracer(const RayTracer&) = delete;  // proj_ points into its own buffers
  RayTracer& operator=(const RayTracer&) = delete;
  RayTracer(const Scene& scene, const RayFrame& frame, Counters& counters)
      : sc_(scene), m_(scene.mesh), frame_(frame), counters_(counters) {
    const RenderSettings& s = scene.settings;
    t_lo_ = 0, t_hi_ = kInf;
    if (s.clip_plane) {
      // Keep dot(p - point, normal) >= 0 along p = o + t d.
      const double nd = dot(s.clip_plane->normal, frame.dir);
      const double t_plane = dot(s.clip_plane->normal, s.clip_plane->point - frame.origin) / nd;
      if (nd > 0) {
        t_lo_ = std::max(t_lo_, t_plane);
      } else if (nd < 0) {
        t_hi_ = std::min(t_hi_, t_plane);
      } else if (dot(s.clip_plane->normal, frame.origin - s.clip_plane->point) < 0) {
        t_hi_ = -kInf;  // parallel to the plane, on the removed side
      }
    }
    if (scene.clip_box) clip_to_box(frame, *scene.clip_box, t_lo_, t_hi_);
    view_dir_ = frame.dir * -1.0;
    // Slices: where the ray crosses each plane inside [t_lo, t_hi], in depth order; the volume's own interval.
    vol_lo_ = -kInf, vol_hi_ = kInf;
    if (s.hide_volume == HideVolume::All) vol_hi_ = -kInf;
    for (size_t i = 0; i < scene.slices.size(); ++i) {
      const SlicePlane& sl = scene.slices[i];
      if (s.hide_volume == HideVolume::Front || s.hide_volume == HideVolume::Back)
        keep_half_space(sl.n, sl.d, frame.origin, frame.dir, s.hide_volume == HideVolume::Back, vol_lo_, vol_hi_);
      const double nd = dot(sl.n, frame.dir);
      if (nd == 0) continue;
      const double t = (sl.d - dot(sl.n, frame.origin)) / nd;
      if (t >= t_lo_ && t <= t_hi_) slice_t_[slice_count_] = t, slice_index_[slice_count_++] = uint8_t(i);
    }
    for (int i = 1; i < slice_count_; ++i)  // insertion sort: at most kMaxSlices
      for (int j = i; j > 0 && slice_t_[j] < slice_t_[j - 1]; --j)
        std::swap(slice_t_[j], slice_t_[j - 1]), std::swap(slice_index_[j], slice_index_[j - 1]);
    mode_ = s.mode;
    stop_opacity_ = s.early_termination_opacity;
    max_steps_ = 4 * uint64_t(scene.mesh.cell_count()) + 16;
  }

  // The ray walks through the mesh entering at the boundary crossings `entries` (sorted by t), one cell per call
  // of advance(), which returns false once the ray is finished. (Interleaving the steps of 8 rays per thread was
  // measured: no faster, the walk is bound by instruction throughput, not by memory latency.)
  void begin(const EntryHit* entries, size_t count) { entries_ = entries, entry_count_ = count; }
  bool advance();

  RayAccumulator result() const;

 private:
  bool done() const { return acc_.opacity() >= stop_opacity_; }
  double scalar_at_face(uint32_t cell, int k, const Crossing& x) const;
  template <CellType T>
  double scalar_at_face(uint32_t cell, const uint32_t* vid, const Crossing& x) const;
  // One cell of the walk: finds the exit, integrates the segment; returns the packed neighbour across the exit
  // face (or kWalkBoundary) and updates t_in / s_in to the exit.
  template <CellType T>
  uint32_t step(uint32_t cell, int entry_face, double& t_in, double& s_in, Crossing& out, bool& stalled);
  void start_walk(const EntryHit& entry);
  void walk_step();
  template <CellType T>
  bool exit_of(uint32_t cell, int entry_face, Crossing& out);
  template <CellType T>
  void cell_segment(uint32_t cell, double t0, double t1, double s0, double s1, const Crossing& exit);
  void piece(double ta, double tb, double sa, double sb, uint32_t cell, int k);
  void volume_piece(double ta, double tb, double sa, double sb, uint32_t cell, int k);
  Vec3d slice_color(const SlicePlane& sl, uint32_t cell, int k, double t, double v) const;
  double value_at(uint32_t cell, int k, double t, double linear) const;
  Vec3d gradient_at(uint32_t cell, int k, double t) const;
  Vec3d triangle_normal(uint32_t cell, int k, int face, const std::array<uint8_t, 3>& corners) const;
  void overlay(uint32_t cell, int k, int face, const std::array<uint8_t, 3>& corners, double t);
  void face_jump(double s_before, double s_after, double t, uint32_t cell, int k, const Crossing& x);
  // Composites the isosurface of each iso value the field crosses from a to b (neither NaN, a != b), in the order the
  // ray meets them, until the ray is opaque; normal_at(v) is the surface normal where the field crosses v.
  template <class NormalAt>
  void composite_iso_crossings(double a, double b, NormalAt normal_at);

  const Scene& sc_;
  const WalkMesh& m_;
  const RayFrame& frame_;
  Counters& counters_;
  RenderMode mode_;
  double stop_opacity_;
  double t_lo_, t_hi_;
  Vec3d view_dir_;
  RayAccumulator acc_;
  const EntryHit* entries_ = nullptr;
  size_t entry_count_ = 0, next_entry_ = 0;
  bool entered_ = false, in_walk_ = false, finished_ = false;
  uint32_t cell_ = 0;
  int k_ = 0, entry_face_ = 0, stall_ = 0;
  double t_in_ = 0, s_in_ = 0;
  // The face crossing the ray entered the current cell through: its corner vertices and their weights (to start
  // Newton inside non-tetrahedral cells from parametric coordinates interpolated between entry and exit).
  uint32_t entry_ids_[3] = {0, 0, 0};
  double entry_lambda_[3] = {0, 0, 0};
  uint64_t steps_ = 0, max_steps_ = 0;
  double last_exit_ = -kInf;
  double mip_max_ = -kInf;
  bool mip_hit_ = false;
  bool lost_ = false;
  // The slice crossings ahead of the ray (sorted by t) and the part of the ray where the volume shows.
  double slice_t_[kMaxSlices];
  uint8_t slice_index_[kMaxSlices];
  int slice_count_ = 0, next_slice_ = 0;
  double vol_lo_ = -kInf, vol_hi_ = kInf;
  // Projections of the current cell's vertices, and of the previous cell's (which shares the entry face with it):
  // a tetrahedron entered through a face then needs one new projection instead of four.
  ProjectedVertex proj_buffer_[2][kMaxCellVertices];
  uint32_t id_buffer_[2][kMaxCellVertices];
  ProjectedVertex* proj_ = proj_buffer_[0];
  ProjectedVertex* prev_proj_ = proj_buffer_[1];
  uint32_t* proj_id_ = id_buffer_[0];
  uint32_t* prev_id_ = id_buffer_[1];
  int proj_count_ = 0;
};

// In MIP mode acc_ holds only the slices (composited in depth order); the maximum is drawn behind them.
RayAccumulator RayTracer::result() const {
  if (mode_ != RenderMode::Mip || !mip_hit_) return acc_;
  RayAccumulator out = acc_;
  const double a = sc_.tf.opacity(mip_max_);
  out.radiance = out.radiance + sc_.tf.color(mip_max_) * (a * acc_.transmittance);
  out.transmittance = acc_.transmittance * (1 - a);
  return out;
}

double RayTracer::scalar_at_face(uint32_t cell, int k, const Crossing& x) const {
  switch (k) {
    case 0: return scalar_at_face<CellType::Tetra>(cell, m_.cell_vertices(cell, 0), x);
    case 1: return scalar_at_face<CellType::Pyramid>(cell, m_.cell_vertices(cell, 1), x);
    case 2: return scalar_at_face<CellType::Wedge>(cell, m_.cell_vertices(cell, 2), x);
    default: return scalar_at_face<CellType::Hexahedron>(cell, m_.cell_vertices(cell, 3), x);
  }
}

template <CellType T>
double RayTracer::scalar_at_face(uint32_t cell, const uint32_t* vid, const Crossing& x) const {
  if (sc_.per_cell) return sc_.values[cell];
  constexpr CellInfo info = cell_info(T);
  const CellFace& face = info.faces[x.face];
  const float* values = sc_.values.data();
  if (T == CellType::Tetra || face.size == 3) {
    double s = 0;
    for (int i = 0; i < 3; ++i) s += x.lambda[i] * double(values[vid[face.v[x.corners[i]]]]);
    return s;
  }
  // Bilinear over the quadrilateral (the trilinear field restricted to the face) at face parameters interpolated
  // from the triangle's corners: symmetric in the corner order, so both cells sharing the face agree.
  static constexpr double kCornerU[4] = {0, 1, 1, 0}, kCornerV[4] = {0, 0, 1, 1};
  double u = 0, v = 0;
  for (int i = 0; i < 3; ++i) u += x.lambda[i] * kCornerU[x.corners[i]], v += x.lambda[i] * kCornerV[x.corners[i]];
  const double s0 = values[vid[face.v[0]]], s1 = values[vid[face.v[1]]];
  const double s2 = values[vid[face.v[2]]], s3 = values[vid[face.v[3]]];
  return (1 - u) * (1 - v) * s0 + u * (1 - v) * s1 + u * v * s2 + (1 - u) * v * s3;
}

// Finds the face (other than entry_face) through which the ray leaves `cell`. Returns false when no triangle
// passes the exact test (a degenerate, non-convex or inverted cell); `out` is then the least-violating triangle with
// its weights clamped, so the walk can go on.
template <CellType T>
bool RayTracer::exit_of(uint32_t cell, int entry_face, Crossing& out) {
  static constexpr CellInfo info = cell_info(T);
  constexpr int k = T == CellType::Tetra ? 0 : T == CellType::Pyramid ? 1 : T == CellType::Wedge ? 2 : 3;
  const uint32_t* vid = m_.cell_vertices(cell, k);
  std::swap(proj_, prev_proj_);
  std::swap(proj_id_, prev_id_);
  const int prev_count = proj_count_;
  for (int i = 0; i < info.vertex_count; ++i) {
    const uint32_t id = vid[i];
    proj_id_[i] = id;
    int j = 0;
    while (j < prev_count && prev_id_[j] != id) ++j;
    proj_[i] = j < prev_count ? prev_proj_[j] : project(frame_, m_.points[id]);
  }
  proj_count_ = info.vertex_count;
  if constexpr (T == CellType::Tetra) {
    // The six edges once (each face's three are among them, reversed where the face runs against them).
    const ProjectedVertex &p0 = proj_[0], &p1 = proj_[1], &p2 = proj_[2], &p3 = proj_[3];
    const double e01 = edge_side(p0, p1), e12 = edge_side(p1, p2), e20 = edge_side(p2, p0);
    const double e03 = edge_side(p0, p3), e13 = edge_side(p1, p3), e23 = edge_side(p2, p3);
    // Faces (0,1,3) (1,2,3) (2,0,3) (0,2,1): edge values ab, bc, ca as the generic loop below computes them.
    const double ab[4] = {e01, e12, e20, -e20}, bc[4] = {e13, e23, e03, -e12}, ca[4] = {-e03, -e13, -e23, -e01};
    for (int f = 0; f < 4; ++f) {
      if (f == entry_face || !(ab[f] >= 0 && bc[f] >= 0 && ca[f] >= 0)) continue;
      const double sum = ab[f] + bc[f] + ca[f];
      if (!(sum > 0)) continue;
      const CellFace& face = info.faces[f];
      const double inv = 1 / sum;
      out.face = uint8_t(f);
      out.corners = {0, 1, 2};
      out.lambda[0] = bc[f] * inv, out.lambda[1] = ca[f] * inv, out.lambda[2] = ab[f] * inv;
      out.t =
          out.lambda[0] * proj_[face.v[0]].w + out.lambda[1] * proj_[face.v[1]].w + out.lambda[2] * proj_[face.v[2]].w;
      return true;
    }
  }
  // Every triangle of every face but the entry one, with its three edge values: the exact test first, then (no
  // triangle passes) the front-facing one the ray misses least (scale-free), weights clamped.
  auto for_each_triangle = [&](auto&& visit) {
    for (int f = 0; f < info.face_count; ++f) {
      if (f == entry_face) continue;
      const CellFace& face = info.faces[f];
      const bool split = T != CellType::Tetra && face.size == 4 && m_.quad_split_13(cell, f);
      for (int tri = 0; tri < face.size - 2; ++tri) {
        const std::array<uint8_t, 3> c = triangle_corners(face.size, split, tri);
        const ProjectedVertex& a = proj_[face.v[c[0]]];
        const ProjectedVertex& b = proj_[face.v[c[1]]];
        const ProjectedVertex& d = proj_[face.v[c[2]]];
        if (visit(f, c, a, b, d, edge_side(a, b), edge_side(b, d), edge_side(d, a))) return true;
      }
    }
    return false;
  };
  auto set_crossing = [&](int f, const std::array<uint8_t, 3>& c, const ProjectedVertex& a, const ProjectedVertex& b,
                          const ProjectedVertex& d, double l0, double l1, double l2) {
    out.face = uint8_t(f);
    out.corners = c;
    out.lambda[0] = l0, out.lambda[1] = l1, out.lambda[2] = l2;
    out.t = l0 * a.w + l1 * b.w + l2 * d.w;
  };
  if constexpr (T != CellType::Tetra) {
    const bool found = for_each_triangle([&](int f, const std::array<uint8_t, 3>& c, const ProjectedVertex& a,
                                             const ProjectedVertex& b, const ProjectedVertex& d, double e_ab,
                                             double e_bc, double e_ca) {
      const double sum = e_ab + e_bc + e_ca;
      if (!(e_ab >= 0 && e_bc >= 0 && e_ca >= 0 && sum > 0)) return false;
      const double inv = 1 / sum;
      set_crossing(f, c, a, b, d, e_bc * inv, e_ca * inv, e_ab * inv);
      return true;
    });
    if (found) return true;
  }
  double best_score = -kInf;
  for_each_triangle([&](int f, const std::array<uint8_t, 3>& c, const ProjectedVertex& a, const ProjectedVertex& b,
                        const ProjectedVertex& d, double e_ab, double e_bc, double e_ca) {
    const double sum = e_ab + e_bc + e_ca;
    const double norm = std::abs(e_ab) + std::abs(e_bc) + std::abs(e_ca);
    const double score = norm > 0 ? std::min({e_ab, e_bc, e_ca}) / norm : -kInf;
    if (score > best_score && sum > 0) {
      best_score = score;
      const double l0 = std::max(e_bc, 0.0), l1 = std::max(e_ca, 0.0), l2 = std::max(e_ab, 0.0);
      const double ls = l0 + l1 + l2;
      if (ls > 0)
        set_crossing(f, c, a, b, d, l0 / ls, l1 / ls, l2 / ls);
      else
        set_crossing(f, c, a, b, d, 1.0 / 3, 1.0 / 3, 1.0 / 3);
    }
    return false;
  });
  if (best_score == -kInf) {
    // Not even a front-facing candidate: leave through the first other face at the entry distance.
    out.face = uint8_t(entry_face == 0 ? 1 : 0);
    out.corners = {0, 1, 2};
    out.lambda[0] = out.lambda[1] = out.lambda[2] = 1.0 / 3;
    out.t = -kInf;
  }
  return false;
}

Vec3d RayTracer::triangle_normal(uint32_t cell, int k, int face, const std::array<uint8_t, 3>& corners) const {
  const CellFace f = cell_info(kAllCellTypes[k]).faces[face];
  const uint32_t* vid = m_.cell_vertices(cell, k);
  const Vec3d a = to_double(m_.points[vid[f.v[corners[0]]]]);
  const Vec3d b = to_double(m_.points[vid[f.v[corners[1]]]]);
  const Vec3d c = to_double(m_.points[vid[f.v[corners[2]]]]);
  return cross(b - a, c - a);
}

void RayTracer::overlay(uint32_t cell, int k, int face, const std::array<uint8_t, 3>& corners, double t) {
  const double alpha = sc_.settings.boundary_overlay_opacity;
  if (!(alpha > 0) || mode_ == RenderMode::Mip || t < t_lo_ || t > t_hi_) return;
  composite_surface(
      acc_, shade_surface(kOverlayColor, triangle_normal(cell, k, face, corners), view_dir_, sc_.settings.lighting),
      alpha);
}

// World-space gradient of the field in `cell` at distance t along the ray (zero for cell data).
Vec3d RayTracer::gradient_at(uint32_t cell, int k, double t) const {
  if (sc_.per_cell) return {};
  const uint32_t* vid = m_.cell_vertices(cell, k);
  return with_cell_type(kAllCellTypes[k], [&](auto tag) {
    constexpr CellType T = decltype(tag)::value;
    constexpr int n = kVertexCount<T>;
    Vec3d v[n];
    double s[n];
    for (int i = 0; i < n; ++i) v[i] = to_double(m_.points[vid[i]]), s[i] = sc_.values[vid[i]];
    Vec3d rst = parametric_center<T>();
    if constexpr (T != CellType::Tetra) {
      if (!inverse_map<T>(v, frame_.at(t), rst, rst)) rst = parametric_center<T>();
    }
    return gradient_in_cell<T>(v, rst, s);
  });
}

template <class NormalAt>
void RayTracer::composite_iso_crossings(double a, double b, NormalAt normal_at) {
  const std::vector<double>& iso = sc_.iso_ascending;
  const int n = int(iso.size());
  const bool up = b > a;
  for (int i = 0; i < n && !done(); ++i) {
    const double v = iso[up ? i : n - 1 - i];
    if ((a < v) == (b < v)) continue;
    const Vec3d c = shade_surface(sc_.tf.color(v), normal_at(v), view_dir_, sc_.settings.lighting);
    composite_surface(acc_, c, sc_.settings.iso_opacity);
  }
}

// The field of `cell` at distance t along the ray, by the cell's own interpolant: `linear` (the piece's value there)
// is already exact in a tetrahedron and for cell data; other cells invert their isoparametric map.
double RayTracer::value_at(uint32_t cell, int k, double t, double linear) const {
  if (sc_.per_cell || k == 0) return linear;
  const uint32_t* vid = m_.cell_vertices(cell, k);
  return with_cell_type(kAllCellTypes[k], [&](auto tag) {
    constexpr CellType T = decltype(tag)::value;
    constexpr int n = kVertexCount<T>;
    Vec3d v[n];
    double s[n];
    for (int i = 0; i < n; ++i) v[i] = to_double(m_.points[vid[i]]), s[i] = sc_.values[vid[i]];
    Vec3d rst;
    if (!inverse_map<T>(v, frame_.at(t), parametric_center<T>(), rst)) return linear;
    return interpolate<T>(rst, s);
  });
}

// The colour of slice `sl` where the ray crosses it at t in `cell`, the field there being v: its colour map, blended
// with its contour colour by the lines' coverage. The screen derivative is the cell's gradient (exact: the
// interpolant's own) projected onto the plane along the pixel's footprint at that depth.
Vec3d RayTracer::slice_color(const SlicePlane& sl, uint32_t cell, int k, double t, double v) const {
  const Vec3d base = sl.colors.color(v);
  if (sl.contours.empty()) return base;
  const PixelFootprint& fp = sc_.footprint;
  const double depth = fp.parallel ? 1 : t * dot(frame_.dir, fp.forward);
  const double per_pixel =
      slice_screen_derivative(gradient_at(cell, k, t), sl.n, frame_.dir, fp.px * depth, fp.py * depth);
  const double a = slice_contour_coverage(sl.contours, sl.contour_width, v, per_pixel);
  return base * (1 - a) + sl.contour_color * a;
}

// One linear piece of the field along the ray inside `cell`: s goes from sa at ta to sb at tb. The slices the piece
// crosses split it: the volume in front, then the slice at its depth, then the rest.
void RayTracer::piece(double ta, double tb, double sa, double sb, uint32_t cell, int k) {
  if (tb <= t_lo_ || ta >= t_hi_ || !(tb > ta)) return;
  if (ta < t_lo_) sa = sa + (sb - sa) * (t_lo_ - ta) / (tb - ta), ta = t_lo_;
  if (tb > t_hi_) sb = sa + (sb - sa) * (t_hi_ - ta) / (tb - ta), tb = t_hi_;
  // Each crossing belongs to the piece with ta <= t < tb, so a plane through a face is drawn once; one behind ta lies
  // where the ray was outside the mesh and is not drawn.
  while (next_slice_ < slice_count_ && slice_t_[next_slice_] < tb) {
    const double tp = slice_t_[next_slice_];
    const SlicePlane& sl = sc_.slices[slice_index_[next_slice_++]];
    if (tp < ta) continue;
    const double sp = sa + (sb - sa) * (tp - ta) / (tb - ta);
    volume_piece(ta, tp, sa, sp, cell, k);
    if (done()) return;
    const double v = value_at(cell, k, tp, sp);
    if (!std::isnan(v)) composite_surface(acc_, slice_color(sl, cell, k, tp, v), sl.opacity);
    if (done()) return;
    ta = tp, sa = sp;
  }
  volume_piece(ta, tb, sa, sb, cell, k);
}

// A linear piece of the volume, restricted to where hide_volume lets it show.
void RayTracer::volume_piece(double ta, double tb, double sa, double sb, uint32_t cell, int k) {
  if (tb <= vol_lo_ || ta >= vol_hi_ || !(tb > ta)) return;
  if (ta < vol_lo_) sa = sa + (sb - sa) * (vol_lo_ - ta) / (tb - ta), ta = vol_lo_;
  if (tb > vol_hi_) sb = sa + (sb - sa) * (vol_hi_ - ta) / (tb - ta), tb = vol_hi_;
  switch (mode_) {
    case RenderMode::EmissionAbsorption: {
      double shade = 1;
      if (sc_.settings.volume_lighting && sa != sb)
        shade = shade_volume(gradient_at(cell, k, 0.5 * (ta + tb)), view_dir_);
      sc_.table.integrate_linear_segment(sa, sb, tb - ta, shade, acc_);
      break;
    }
    case RenderMode::Mip:
      for (double s : {sa, sb})
        if (!std::isnan(s) && s > mip_max_) mip_max_ = s, mip_hit_ = true;
      break;
    case RenderMode::Isosurface:
      if (sa == sb || std::isnan(sa) || std::isnan(sb)) break;
      composite_iso_crossings(sa, sb,
                              [&](double v) { return gradient_at(cell, k, ta + (v - sa) / (sb - sa) * (tb - ta)); });
      break;
  }
}

// A jump of the field across a face (cell data, or vertex data of separate blocks) crossing an iso value is a piece
// of isosurface lying on that face.
void RayTracer::face_jump(double s_before, double s_after, double t, uint32_t cell, int k, const Crossing& x) {
  if (mode_ != RenderMode::Isosurface || s_before == s_after || t < t_lo_ || t > t_hi_) return;
  if (t < vol_lo_ || t > vol_hi_) return;
  if (std::isnan(s_before) || std::isnan(s_after)) return;
  composite_iso_crossings(s_before, s_after, [&](double) { return triangle_normal(cell, k, x.face, x.corners); });
}

// The field inside a cell between two face crossings. Linear in tetrahedra (and constant for cell data); in the
// other cells the isoparametric field along a line is a polynomial of degree up to 3 in t, approximated by linear
// pieces split at midpoints until the midpoint deviates from the chord by at most the tolerance.
template <CellType T>
void RayTracer::cell_segment(uint32_t cell, double t0, double t1, double s0, double s1, const Crossing& exit) {
  constexpr int k = T == CellType::Tetra ? 0 : T == CellType::Pyramid ? 1 : T == CellType::Wedge ? 2 : 3;
  if constexpr (T == CellType::Tetra) {
    (void)exit;
    piece(t0, t1, s0, s1, cell, k);
  } else {
    if (sc_.per_cell || !(t1 > t0) || t1 <= t_lo_ || t0 >= t_hi_) {
      piece(t0, t1, s0, s1, cell, k);
      return;
    }
    constexpr int n = kVertexCount<T>;
    const uint32_t* vid = m_.cell_vertices(cell, k);
    double s[n];
    double lo = kInf, hi = -kInf;
    for (int i = 0; i < n; ++i) {
      s[i] = sc_.values[vid[i]];
      lo = std::min(lo, s[i]), hi = std::max(hi, s[i]);
    }
    // The field and any chord of it stay within [lo, hi]: a narrow range bounds the error without sampling.
    if (!(hi - lo > sc_.tolerance_abs)) {
      piece(t0, t1, s0, s1, cell, k);
      return;
    }
    Vec3d v[n];
    for (int i = 0; i < n; ++i) v[i] = to_double(m_.points[vid[i]]);
    // Parametric coordinates of the entry and exit crossings (the faces are planar in parametric space, so the
    // triangle weights carry over exactly); Newton starts from their interpolation and converges in 2-3 steps.
    static constexpr std::array<Vec3d, 8> kCorner =
        T == CellType::Hexahedron
            ? std::array<Vec3d,
                         8>{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}}
        : T == CellType::Wedge
            ? std::array<Vec3d, 8>{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {}, {}}}
            : std::array<Vec3d, 8>{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {}, {}, {}}};
    constexpr CellInfo kInfo = cell_info(T);
    Vec3d rst_in{}, rst_out{};
    for (int i = 0; i < 3; ++i) {
      int j = 0;
      while (j < n - 1 && vid[j] != entry_ids_[i]) ++j;
      rst_in = rst_in + kCorner[j] * entry_lambda_[i];
      rst_out = rst_out + kCorner[kInfo.faces[exit.face].v[exit.corners[i]]] * exit.lambda[i];
    }
    const double inv_length = 1 / (t1 - t0);
    // The cell's map and field in monomial form: cheaper per Newton step than the shape functions.
    const MonomialForm<Vec3d> map = to_monomial<T>(v);
    const MonomialForm<double> field = to_monomial<T>(s);
    auto eval = [&](double t, double fallback) {
      ++counters_.nonlinear_samples;
      const Vec3d guess = rst_in + (rst_out - rst_in) * ((t - t0) * inv_length);
      Vec3d rst;
      // An update below 1e-7 leaves an error of ~1e-14 (quadratic convergence): enough for a field value.
      if (!inverse_map_monomial(map, frame_.at(t), guess, rst, 1e-7)) return fallback;
      return field.evaluate(rst);
    };
    auto refine = [&](auto&& self, double ta, double tb, double sa, double sb, int depth) -> void {
      const double tm = 0.5 * (ta + tb);
      const double sm = eval(tm, 0.5 * (sa + sb));
      if (depth + 1 >= kMaxNonlinearDepth || std::abs(sm - 0.5 * (sa + sb)) <= sc_.tolerance_abs) {
        piece(ta, tm, sa, sm, cell, k);
        if (!done()) piece(tm, tb, sm, sb, cell, k);
        return;
      }
      self(self, ta, tm, sa, sm, depth + 1);
      if (!done()) self(self, tm, tb, sm, sb, depth + 1);
    };
    refine(refine, t0, t1, s0, s1, 0);
  }
}

void RayTracer::start_walk(const EntryHit& entry) {
  const BoundaryTriangle& bt = m_.boundary[entry.triangle];
  proj_count_ = 0;
  cell_ = bt.cell;
  k_ = m_.type_index(cell_);
  Crossing in;
  in.face = bt.local_face;
  in.corners = bt.corners;
  for (int i = 0; i < 3; ++i) in.lambda[i] = entry.lambda[i];
  in.t = entry.t;
  t_in_ = entry.t;
  s_in_ = scalar_at_face(cell_, k_, in);
  entry_face_ = bt.local_face;
  {
    const CellFace face = cell_info(kAllCellTypes[k_]).faces[bt.local_face];
    const uint32_t* vid = m_.cell_vertices(cell_, k_);
    for (int i = 0; i < 3; ++i) entry_ids_[i] = vid[face.v[bt.corners[i]]], entry_lambda_[i] = entry.lambda[i];
  }
  overlay(cell_, k_, bt.local_face, bt.corners, t_in_);
  stall_ = 0;
  in_walk_ = true;
}

void RayTracer::walk_step() {
  ++counters_.cell_steps;
  Crossing out;
  bool stalled = false;
  uint32_t next;
  switch (k_) {
    case 0: next = step<CellType::Tetra>(cell_, entry_face_, t_in_, s_in_, out, stalled); break;
    case 1: next = step<CellType::Pyramid>(cell_, entry_face_, t_in_, s_in_, out, stalled); break;
    case 2: next = step<CellType::Wedge>(cell_, entry_face_, t_in_, s_in_, out, stalled); break;
    default: next = step<CellType::Hexahedron>(cell_, entry_face_, t_in_, s_in_, out, stalled); break;
  }
  stall_ = stalled ? stall_ + 1 : 0;
  if (stall_ > kMaxStallSteps || ++steps_ > max_steps_) {
    lost_ = true;
    return;
  }
  if (done()) return;
  if (next == kWalkBoundary) {
    overlay(cell_, k_, out.face, out.corners, t_in_);
    last_exit_ = t_in_;
    in_walk_ = false;
    return;
  }
  const uint32_t next_cell = next >> 3;
  if (sc_.per_cell) {
    const double s_next = sc_.values[next_cell];
    face_jump(s_in_, s_next, t_in_, cell_, k_, out);
    s_in_ = s_next;
  }
  cell_ = next_cell;
  entry_face_ = int(next & 7);
  k_ = m_.type_index(cell_);
}

template <CellType T>
uint32_t RayTracer::step(uint32_t cell, int entry_face, double& t_in, double& s_in, Crossing& out, bool& stalled) {
  constexpr int k = T == CellType::Tetra ? 0 : T == CellType::Pyramid ? 1 : T == CellType::Wedge ? 2 : 3;
  exit_of<T>(cell, entry_face, out);
  const double t_out = std::max(out.t, t_in);
  stalled = !(t_out > t_in);
  const double s_out = scalar_at_face<T>(cell, m_.cell_vertices(cell, k), out);
  cell_segment<T>(cell, t_in, t_out, s_in, s_out, out);
  {
    // Where the next cell is entered (it may be a non-tetrahedral cell starting Newton from here).
    constexpr CellInfo info = cell_info(T);
    const CellFace& face = info.faces[out.face];
    const uint32_t* vid = m_.cell_vertices(cell, k);
    for (int i = 0; i < 3; ++i) entry_ids_[i] = vid[face.v[out.corners[i]]], entry_lambda_[i] = out.lambda[i];
  }
  t_in = t_out;
  s_in = s_out;
  return m_.cell_neighbors(cell, k)[out.face];
}

bool RayTracer::advance() {
  if (finished_) return false;
  if (!done() && !lost_) {
    // Past the end of a clip box's range nothing more is drawn: no need to walk on. (Not for the clip plane alone,
    // whose walk the GPU engine mirrors step for step.)
    if (sc_.clip_box && in_walk_ && t_in_ > t_hi_) in_walk_ = false, next_entry_ = entry_count_;
    if (in_walk_) {
      walk_step();
      return true;
    }
    while (next_entry_ < entry_count_) {
      const EntryHit& e = entries_[next_entry_++];
      if (e.t > t_hi_) break;
      // Crossings behind the point where the ray left belong to the stretch it already walked (or to overlapping
      // pieces, which cannot both be inside); a coincident face of a touching block is within the slack.
      if (entered_ && e.t < last_exit_ - sc_.reentry_slack) continue;
      ++(entered_ ? counters_.reentries : counters_.rays_hit);
      entered_ = true;
      start_walk(e);
      return true;
    }
  }
  if (lost_) ++counters_.lost_rays;
  finished_ = true;
  return false;
}

constexpr int kTileSize = 16;

void write_pixel(Image& image, int x, int y, const RayAccumulator& acc, const std::array<double, 4>& bg) {
  const double radiance[3] = {acc.radiance.x, acc.radiance.y, acc.radiance.z};
  composite_pixel(image.pixel(x, y), radiance, acc.transmittance, bg);
}

}  // namespace

ExactEngine::ExactEngine(const Dataset& dataset) : impl_(std::make_unique<Impl>()) {
  const auto t0 = std::chrono::steady_clock::now();
  impl_->mesh = build_walk_mesh(dataset);
  impl_->build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ExactEngine::~ExactEngine() = default;
ExactEngine::ExactEngine(ExactEngine&&) noexcept = default;
ExactEngine& ExactEngine::operator=(ExactEngine&&) noexcept = default;

void ExactEngine::set_field(const Dataset& dataset, std::string_view selector) {
  Impl& I = *impl_;
  if (dataset.blocks.size() != I.mesh.point_base.size())
    fail_in("exact engine", "set_field: the dataset is not the one the engine was built from");
  std::string name(selector);
  if (name.empty()) {
    if (dataset.blocks[0].fields.empty()) fail_in("exact engine", "the dataset has no fields to render");
    name = dataset.blocks[0].fields[0].name();
  }
  std::vector<ScalarRef> refs;
  for (const Block& b : dataset.blocks) refs.push_back(b.fields.scalar(name));
  const Association assoc = refs[0].field->association();
  for (size_t b = 1; b < refs.size(); ++b)
    if (refs[b].field->association() != assoc)
      fail_in("exact engine", "field \"" + name + "\" is per vertex in some blocks and per cell in others");
  std::vector<float> values;
  if (assoc == Association::Vertex) {
    values.resize(I.restricted ? I.source_points : I.mesh.points.size());
    for (size_t b = 0; b < refs.size(); ++b) {
      const uint64_t n = grid_point_count(dataset.blocks[b].grid);
      const uint64_t base = I.mesh.point_base[b];
      tbb::parallel_for(tbb::blocked_range<uint64_t>(0, n, 1 << 16), [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t p = r.begin(); p != r.end(); ++p)
          values[base + p] = float(refs[b].field->scalar(p, refs[b].component));
      });
    }
  } else {
    values.resize(I.restricted ? I.source_cells : I.mesh.cell_count());
    for (size_t b = 0; b < refs.size(); ++b) {
      const std::vector<uint32_t> order = block_cell_order(dataset, I.mesh, b);
      for (uint64_t c = 0; c < order.size(); ++c)
        if (order[c] != kWalkBoundary) values[order[c]] = float(refs[b].field->scalar(c, refs[b].component));
    }
  }
  double lo = kInf, hi = -kInf;
  for (float v : values)
    if (!std::isnan(v)) lo = std::min(lo, double(v)), hi = std::max(hi, double(v));
  if (lo > hi) lo = hi = 0;  // all NaN
  if (I.restricted) {        // the range above is the whole mesh's; keep the part's values
    const std::vector<uint32_t>& source = assoc == Association::Cell ? I.cell_source : I.point_source;
    std::vector<float> part(source.size());
    for (size_t i = 0; i < source.size(); ++i) part[i] = values[source[i]];
    values = std::move(part);
  }
  I.values = std::move(values);
  I.per_cell = assoc == Association::Cell;
  I.field_name = name;
  I.field_min = lo, I.field_max = hi;
  I.bound = true;
}

const std::string& ExactEngine::field_name() const { return impl_->field_name; }
double ExactEngine::field_min() const { return impl_->field_min; }
double ExactEngine::field_max() const { return impl_->field_max; }
void ExactEngine::set_nonlinear_tolerance(double relative) {
  if (!(relative > 0) || !std::isfinite(relative)) fail_in("exact engine", "nonlinear tolerance must be > 0");
  impl_->nonlinear_tolerance = relative;
}
void ExactEngine::set_clip_box(std::optional<Bounds> box) { impl_->clip_box = box; }
void ExactEngine::set_keep_going(std::function<bool()> keep_going) { impl_->keep_going = std::move(keep_going); }
const std::optional<Bounds>& ExactEngine::clip_box() const { return impl_->clip_box; }
void ExactEngine::restrict_to_box(const Bounds& box) {
  Impl& I = *impl_;
  if (I.restricted) fail_in("exact engine", "restrict_to_box: the engine already holds only a part of its mesh");
  WalkMeshPart part = restrict_walk_mesh(I.mesh, box);
  if (I.bound) {
    const std::vector<uint32_t>& source = I.per_cell ? part.cell_source : part.point_source;
    std::vector<float> values(source.size());
    for (size_t i = 0; i < source.size(); ++i) values[i] = I.values[source[i]];
    I.values = std::move(values);
  }
  I.source_points = I.mesh.points.size();
  I.source_cells = I.mesh.cell_count();
  I.mesh = std::move(part.mesh);
  I.cell_source = std::move(part.cell_source);
  I.point_source = std::move(part.point_source);
  I.restricted = true;
  I.clip_box = box;
}
Bounds ExactEngine::bounds() const { return impl_->mesh.bounds; }
uint64_t ExactEngine::cell_count() const { return impl_->mesh.cell_count(); }
uint64_t ExactEngine::point_count() const { return impl_->mesh.points.size(); }
uint64_t ExactEngine::memory_bytes() const {
  return impl_->mesh.memory_bytes() + impl_->values.capacity() * sizeof(float) +
         (impl_->cell_source.capacity() + impl_->point_source.capacity()) * sizeof(uint32_t);
}
double ExactEngine::build_seconds() const { return impl_->build_seconds; }
const WalkMesh& ExactEngine::walk_mesh() const { return impl_->mesh; }
const std::vector<float>& ExactEngine::bound_values() const { return impl_->values; }
bool ExactEngine::per_cell() const { return impl_->per_cell; }
double ExactEngine::tolerance_abs(const TransferFunction& tf) const {
  const double tf_width = tf.range_max() - tf.range_min();
  const double scale = tf_width > 0 ? tf_width : std::max(impl_->field_max - impl_->field_min, 1e-30);
  return impl_->nonlinear_tolerance * scale;
}

namespace {

// One frame of the walk over the tiles of the image: every pixel (`only` empty), or those `only` lists (y * width + x),
// written into `image`. Returns false when `keep_going` stopped it.
bool trace_frame(const WalkMesh& mesh, const std::vector<float>& values, bool per_cell,
                 const std::optional<Bounds>& clip_box, double tolerance, const std::function<bool()>& keep_going,
                 const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                 std::span<const uint32_t> only, Image& image, Counters& total) {
  const bool all = only.empty();
  const OpticalTable table(tf);
  std::vector<double> iso = settings.iso_values;
  std::sort(iso.begin(), iso.end());
  const double diagonal = length(mesh.bounds.size());
  Scene scene{values, per_cell, mesh, table, tf, settings, iso, tolerance, 1e-7 * diagonal, clip_box, {}};
  for (const Slice& sl : settings.slices) {
    TransferFunction colors = sl.color_map.empty() ? tf : builtin_preset(sl.color_map);
    if (sl.range)
      colors.rescale((*sl.range)[0], (*sl.range)[1]);
    else if (!sl.color_map.empty())
      colors.rescale(tf.range_min(), tf.range_max());
    // The plane with a unit normal, so that the volume's half-spaces and the crossings share one scale.
    const Vec3d n = sl.normal * (1 / length(sl.normal));
    scene.slices.push_back({n, dot(n, sl.point), sl.opacity, std::move(colors),
                            slice_contour_values(sl, tf.range_min(), tf.range_max()), sl.contour_width,
                            Vec3d{sl.contour_color[0], sl.contour_color[1], sl.contour_color[2]}});
  }

  const int width = settings.width, height = settings.height;
  const CameraRays rays(camera, width, height);
  scene.footprint = {rays.right() * (2 * rays.half_width() / width), rays.up() * (2 * rays.half_height() / height),
                     rays.forward(), camera.parallel_projection};
  const BoundaryBins bins(mesh, camera, width, height, kTileSize);
  const auto& bg = settings.background;
  tbb::combinable<Counters> counters;
  const int tiles = bins.tiles_x() * bins.tiles_y();
  // With `only`: which pixels of each tile to trace (a tile without any is skipped).
  std::vector<uint8_t> wanted;
  std::vector<uint8_t> tile_wanted;
  if (!all) {
    wanted.assign(size_t(width) * size_t(height), 0);
    tile_wanted.assign(size_t(tiles), 0);
    for (uint32_t i : only) {
      wanted[i] = 1;
      tile_wanted[size_t((int(i) / width) / kTileSize) * bins.tiles_x() + (int(i) % width) / kTileSize] = 1;
    }
  }
  std::atomic<bool> stopped{false};  // keep_going said no: the tiles not begun are skipped
  tbb::parallel_for(tbb::blocked_range<int>(0, tiles, 1), [&](const tbb::blocked_range<int>& r) {
    thread_local std::vector<RayFrame> frames;
    thread_local std::vector<EntryHit> hits;
    thread_local std::vector<uint32_t> pixel_begin;
    Counters& local = counters.local();
    for (int tile = r.begin(); tile != r.end(); ++tile) {
      if (keep_going && (stopped.load(std::memory_order_relaxed) || !keep_going())) {
        stopped.store(true, std::memory_order_relaxed);
        return;
      }
      if (!all && !tile_wanted[size_t(tile)]) continue;
      const int x0 = (tile % bins.tiles_x()) * kTileSize, y0 = (tile / bins.tiles_x()) * kTileSize;
      const int tw = std::min(kTileSize, width - x0), th = std::min(kTileSize, height - y0);
      frames.clear();
      for (int y = y0; y < y0 + th; ++y)
        for (int x = x0; x < x0 + tw; ++x) frames.emplace_back(rays.pixel(x, y));
      tile_entries(mesh, bins, tile, width, height, frames, hits, pixel_begin);
      for (int p = 0; p < tw * th; ++p) {
        const int x = x0 + p % tw, y = y0 + p / tw;
        if (!all && !wanted[size_t(y) * size_t(width) + size_t(x)]) continue;
        RayTracer tracer(scene, frames[p], local);
        tracer.begin(hits.data() + pixel_begin[p], pixel_begin[p + 1] - pixel_begin[p]);
        while (tracer.advance()) {
        }
        write_pixel(image, x, y, tracer.result(), bg);
      }
    }
  });
  total = counters.combine([](Counters a, const Counters& b) {
    a.rays_hit += b.rays_hit, a.cell_steps += b.cell_steps, a.reentries += b.reentries;
    a.nonlinear_samples += b.nonlinear_samples, a.lost_rays += b.lost_rays;
    return a;
  });
  return !stopped.load();
}

}  // namespace

Image ExactEngine::render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                          ExactRenderStats* stats) const {
  const Impl& I = *impl_;
  if (!I.bound) fail_in("exact engine", "no field bound: call set_field first");
  settings.validate("render settings");
  tf.validate("transfer function");
  const auto t0 = std::chrono::steady_clock::now();
  Image image(settings.width, settings.height);
  Counters total;
  if (!trace_frame(I.mesh, I.values, I.per_cell, I.clip_box, tolerance_abs(tf), I.keep_going, camera, tf, settings, {},
                   image, total))
    throw FrameInterrupted();
  if (stats) {
    stats->render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    stats->rays = uint64_t(settings.width) * uint64_t(settings.height);
    stats->rays_hit = total.rays_hit;
    stats->cell_steps = total.cell_steps;
    stats->reentries = total.reentries;
    stats->nonlinear_samples = total.nonlinear_samples;
    stats->lost_rays = total.lost_rays;
    stats->threads = worker_threads();
  }
  return image;
}

void trace_exact_pixels(const WalkMesh& mesh, const std::vector<float>& values, bool per_cell, const Camera& camera,
                        const TransferFunction& tf, const RenderSettings& settings, double tolerance_abs,
                        std::span<const uint32_t> pixels, Image& image, ExactRenderStats* stats) {
  if (pixels.empty()) return;
  if (image.width != settings.width || image.height != settings.height)
    fail_in("exact engine", "the image to trace pixels into is not the settings' size");
  for (uint32_t i : pixels)
    if (uint64_t(i) >= uint64_t(settings.width) * uint64_t(settings.height))
      fail_in("exact engine", "pixel " + std::to_string(i) + " is outside the image");
  Counters total;
  trace_frame(mesh, values, per_cell, std::nullopt, tolerance_abs, {}, camera, tf, settings, pixels, image, total);
  if (stats) {
    stats->rays_hit += total.rays_hit;
    stats->reentries += total.reentries;
    stats->cell_steps += total.cell_steps;
    stats->nonlinear_samples += total.nonlinear_samples;
    stats->lost_rays += total.lost_rays;
  }
}

}  // namespace ugvr
