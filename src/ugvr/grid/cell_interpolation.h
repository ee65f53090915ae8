// Interpolation inside the linear volume cells, with VTK's parametric coordinates and shape functions
// (vtkTetra / vtkHexahedron / vtkWedge / vtkPyramid), so values match what VTK-based tools show for the same data.
//
// Parametric spaces (r, s, t) and shape functions, vertex order as in cell_type.h:
//   Tetra       r, s, t >= 0, r + s + t <= 1      N = (1-r-s-t, r, s, t)
//   Hexahedron  unit cube                          trilinear; vertex i sits at corner
//                                                  0:(0,0,0) 1:(1,0,0) 2:(1,1,0) 3:(0,1,0) 4:(0,0,1) 5:(1,0,1)
//                                                  6:(1,1,1) 7:(0,1,1)
//   Wedge       r, s >= 0, r + s <= 1, t in [0,1]  N = ((1-r-s)(1-t), r(1-t), s(1-t), (1-r-s)t, rt, st)
//   Pyramid     unit cube (t = 1 is the apex)      N = ((1-r)(1-s)(1-t), r(1-s)(1-t), rs(1-t), (1-r)s(1-t), t)
// The pyramid's map collapses the whole top face of the cube onto the apex, so its Jacobian is singular at t = 1
// and the inverse map fails there (the apex is a vertex of neighbouring cells, which find it).
//
// Derivative layout (VTK's InterpolationDerivs): dN is 3 x n, row-major: dN[0..n) = dN/dr, dN[n..2n) = dN/ds,
// dN[2n..3n) = dN/dt, n = cell_vertex_count(type).
//
// Everything hot is inline and has a compile-time cell type variant (the `<CellType T>` templates) so the ray caster
// and the voxelizer can hoist the type switch out of their inner loops; the CellType-argument overloads dispatch.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <type_traits>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

inline constexpr int kMaxCellVertices = 8;

// Newton stops when the largest component of the parametric update is below this (parametric space has unit size,
// so it is relative to the cell) ...
inline constexpr double kInverseMapTolerance = 1e-12;
// ... or gives up after this many steps. Quadratic convergence from the centre of a reasonable cell takes 3-5.
inline constexpr int kInverseMapMaxIterations = 16;
// A Jacobian whose determinant is below this fraction of the product of its column lengths is treated as singular
// (scale-free: it measures how close the columns are to coplanar, not how small the cell is).
inline constexpr double kSingularJacobian = 1e-12;

// ---- compile-time cell type kernels ------------------------------------------------------------------------------

template <CellType T>
inline constexpr int kVertexCount = cell_vertex_count(T);

template <CellType T>
inline void shape_functions(Vec3d p, double* N) {
  const double r = p.x, s = p.y, t = p.z;
  if constexpr (T == CellType::Tetra) {
    N[0] = 1.0 - r - s - t, N[1] = r, N[2] = s, N[3] = t;
  } else if constexpr (T == CellType::Hexahedron) {
    const double rm = 1.0 - r, sm = 1.0 - s, tm = 1.0 - t;
    N[0] = rm * sm * tm, N[1] = r * sm * tm, N[2] = r * s * tm, N[3] = rm * s * tm;
    N[4] = rm * sm * t, N[5] = r * sm * t, N[6] = r * s * t, N[7] = rm * s * t;
  } else if constexpr (T == CellType::Wedge) {
    const double u = 1.0 - r - s, tm = 1.0 - t;
    N[0] = u * tm, N[1] = r * tm, N[2] = s * tm, N[3] = u * t, N[4] = r * t, N[5] = s * t;
  } else {
    static_assert(T == CellType::Pyramid);
    const double rm = 1.0 - r, sm = 1.0 - s, tm = 1.0 - t;
    N[0] = rm * sm * tm, N[1] = r * sm * tm, N[2] = r * s * tm, N[3] = rm * s * tm, N[4] = t;
  }
}

template <CellType T>
inline void shape_derivatives(Vec3d p, double* dN) {
  constexpr int n = kVertexCount<T>;
  double* dr = dN;
  double* ds = dN + n;
  double* dt = dN + 2 * n;
  const double r = p.x, s = p.y, t = p.z;
  if constexpr (T == CellType::Tetra) {
    dr[0] = -1, dr[1] = 1, dr[2] = 0, dr[3] = 0;
    ds[0] = -1, ds[1] = 0, ds[2] = 1, ds[3] = 0;
    dt[0] = -1, dt[1] = 0, dt[2] = 0, dt[3] = 1;
  } else if constexpr (T == CellType::Hexahedron) {
    const double rm = 1.0 - r, sm = 1.0 - s, tm = 1.0 - t;
    dr[0] = -sm * tm, dr[1] = sm * tm, dr[2] = s * tm, dr[3] = -s * tm;
    dr[4] = -sm * t, dr[5] = sm * t, dr[6] = s * t, dr[7] = -s * t;
    ds[0] = -rm * tm, ds[1] = -r * tm, ds[2] = r * tm, ds[3] = rm * tm;
    ds[4] = -rm * t, ds[5] = -r * t, ds[6] = r * t, ds[7] = rm * t;
    dt[0] = -rm * sm, dt[1] = -r * sm, dt[2] = -r * s, dt[3] = -rm * s;
    dt[4] = rm * sm, dt[5] = r * sm, dt[6] = r * s, dt[7] = rm * s;
  } else if constexpr (T == CellType::Wedge) {
    const double u = 1.0 - r - s, tm = 1.0 - t;
    dr[0] = -tm, dr[1] = tm, dr[2] = 0, dr[3] = -t, dr[4] = t, dr[5] = 0;
    ds[0] = -tm, ds[1] = 0, ds[2] = tm, ds[3] = -t, ds[4] = 0, ds[5] = t;
    dt[0] = -u, dt[1] = -r, dt[2] = -s, dt[3] = u, dt[4] = r, dt[5] = s;
  } else {
    static_assert(T == CellType::Pyramid);
    const double rm = 1.0 - r, sm = 1.0 - s, tm = 1.0 - t;
    dr[0] = -sm * tm, dr[1] = sm * tm, dr[2] = s * tm, dr[3] = -s * tm, dr[4] = 0;
    ds[0] = -rm * tm, ds[1] = -r * tm, ds[2] = r * tm, ds[3] = rm * tm, ds[4] = 0;
    dt[0] = -rm * sm, dt[1] = -r * sm, dt[2] = -r * s, dt[3] = -rm * s, dt[4] = 1;
  }
}

template <CellType T>
constexpr bool parametric_inside(Vec3d p, double tol) {
  if constexpr (T == CellType::Tetra) {
    return p.x >= -tol && p.y >= -tol && p.z >= -tol && p.x + p.y + p.z <= 1.0 + tol;
  } else if constexpr (T == CellType::Wedge) {
    return p.x >= -tol && p.y >= -tol && p.x + p.y <= 1.0 + tol && p.z >= -tol && p.z <= 1.0 + tol;
  } else {  // hexahedron, pyramid: the unit cube
    return p.x >= -tol && p.y >= -tol && p.z >= -tol && p.x <= 1.0 + tol && p.y <= 1.0 + tol && p.z <= 1.0 + tol;
  }
}

// How far inside the parametric domain rst is: the smallest of the domain's bounding inequalities (negative outside).
// parametric_inside(rst, tol) is parametric_margin(rst) >= -tol (up to rounding); samplers use the margin to tell
// points well inside a cell (no other cell can claim them) from points on or near a face (several can).
template <CellType T>
constexpr double parametric_margin(Vec3d p) {
  const double lo = std::min(p.x, std::min(p.y, p.z));
  if constexpr (T == CellType::Tetra) {
    return std::min(lo, 1.0 - p.x - p.y - p.z);
  } else if constexpr (T == CellType::Wedge) {
    return std::min(std::min(lo, 1.0 - p.x - p.y), 1.0 - p.z);
  } else {
    return std::min(lo, 1.0 - std::max(p.x, std::max(p.y, p.z)));
  }
}

// VTK's GetParametricCenter values (the pyramid's is its centroid, not the cube's centre).
template <CellType T>
constexpr Vec3d parametric_center() {
  if constexpr (T == CellType::Tetra) return {0.25, 0.25, 0.25};
  if constexpr (T == CellType::Hexahedron) return {0.5, 0.5, 0.5};
  if constexpr (T == CellType::Wedge) return {1.0 / 3.0, 1.0 / 3.0, 0.5};
  if constexpr (T == CellType::Pyramid) return {0.4, 0.4, 0.2};
  return {};
}

template <CellType T>
inline double interpolate(Vec3d p, const double* values) {
  double N[kVertexCount<T>];
  shape_functions<T>(p, N);
  double f = 0;
  for (int i = 0; i < kVertexCount<T>; ++i) f += N[i] * values[i];
  return f;
}

namespace detail {

// The inverse of a 3x3 matrix given by its columns c0, c1, c2, as its rows (c1 x c2, c2 x c0, c0 x c1) / det.
// Returns false when the matrix is singular in the scale-free sense of kSingularJacobian (or not finite).
inline bool inverse_rows(Vec3d c0, Vec3d c1, Vec3d c2, Vec3d rows[3]) {
  const Vec3d a0 = cross(c1, c2), a1 = cross(c2, c0), a2 = cross(c0, c1);
  const double det = dot(c0, a0);
  const double scale = std::sqrt(dot(c0, c0) * dot(c1, c1) * dot(c2, c2));
  if (!(std::abs(det) > kSingularJacobian * scale)) return false;  // also catches NaN
  const double inv = 1.0 / det;
  rows[0] = a0 * inv, rows[1] = a1 * inv, rows[2] = a2 * inv;
  return true;
}

// Jacobian columns dx/dr, dx/ds, dx/dt from the derivative rows.
template <int n>
inline void jacobian_columns(const Vec3d* v, const double* dN, Vec3d cols[3]) {
  for (int j = 0; j < 3; ++j) {
    Vec3d c{};
    for (int i = 0; i < n; ++i) c = c + v[i] * dN[j * n + i];
    cols[j] = c;
  }
}

}  // namespace detail

// Newton's method on x(rst) = point. Works for every type (for a tetrahedron it converges in one step, up to
// rounding); inverse_map<Tetra> uses the closed form instead.
// `tolerance` bounds the last parametric update; Newton converges quadratically, so a caller that needs the
// coordinates to ~1e-14 may stop at an update of 1e-7 and save an iteration.
template <CellType T>
inline bool inverse_map_newton(const Vec3d* v, Vec3d point, Vec3d guess, Vec3d& rst,
                               double tolerance = kInverseMapTolerance) {
  constexpr int n = kVertexCount<T>;
  rst = guess;
  for (int it = 0; it < kInverseMapMaxIterations; ++it) {
    double N[n], dN[3 * n];
    shape_functions<T>(rst, N);
    shape_derivatives<T>(rst, dN);
    Vec3d x{};
    for (int i = 0; i < n; ++i) x = x + v[i] * N[i];
    Vec3d cols[3], inv[3];
    detail::jacobian_columns<n>(v, dN, cols);
    if (!detail::inverse_rows(cols[0], cols[1], cols[2], inv)) return false;
    const Vec3d b = point - x;
    const Vec3d delta{dot(inv[0], b), dot(inv[1], b), dot(inv[2], b)};
    rst = rst + delta;
    const double step = std::max(std::abs(delta.x), std::max(std::abs(delta.y), std::abs(delta.z)));
    if (step < tolerance) return true;
    if (!(step < 1e8)) return false;  // diverging (or NaN): the point is nowhere near this cell
  }
  return false;
}

// Parametric coordinates of `point` in the cell with vertices v (cell_vertex_count(T) of them, VTK order). Returns
// false when the Jacobian is singular or Newton does not converge; rst is then meaningless. Points outside the cell
// get coordinates outside its parametric domain: test them with parametric_inside.
template <CellType T>
inline bool inverse_map(const Vec3d* v, Vec3d point, Vec3d guess, Vec3d& rst) {
  if constexpr (T == CellType::Tetra) {
    // Barycentric coordinates: one 3x3 solve with the edge vectors from vertex 0.
    Vec3d inv[3];
    if (!detail::inverse_rows(v[1] - v[0], v[2] - v[0], v[3] - v[0], inv)) return false;
    const Vec3d b = point - v[0];
    rst = {dot(inv[0], b), dot(inv[1], b), dot(inv[2], b)};
    return true;
  } else {
    return inverse_map_newton<T>(v, point, guess, rst);
  }
}

// World-space gradient of the interpolated field at rst: J^-T (df/dr, df/ds, df/dt). Zero when J is singular.
template <CellType T>
inline Vec3d gradient_in_cell(const Vec3d* v, Vec3d rst, const double* values) {
  constexpr int n = kVertexCount<T>;
  double dN[3 * n];
  shape_derivatives<T>(rst, dN);
  Vec3d cols[3], inv[3];
  detail::jacobian_columns<n>(v, dN, cols);
  if (!detail::inverse_rows(cols[0], cols[1], cols[2], inv)) return {};
  double g[3] = {0, 0, 0};
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < n; ++i) g[j] += dN[j * n + i] * values[i];
  // J^-T g: the rows of J^-1 are the columns of J^-T.
  return inv[0] * g[0] + inv[1] * g[1] + inv[2] * g[2];
}

// ---- monomial form -----------------------------------------------------------------------------------------------

// A cell's map (or a vertex field over it) in the monomial basis m = (1, r, s, t, rs, rt, st, rst):
//   x(r, s, t) = sum_k c[k] m_k(r, s, t).
// Every type's shape functions span a subset of that basis (tetra: the first 4; wedge: no rs, rst), so one
// evaluator serves all four and costs about a third of shape functions plus a weighted sum. Inner loops that test or
// interpolate the same cell many times (voxelizers, ray casters) convert once with to_monomial and then use
// evaluate / inverse_map_monomial.
template <class V>
struct MonomialForm {
  std::array<V, 8> c{};

  V evaluate(Vec3d p) const {
    const double rs = p.x * p.y, rt = p.x * p.z, st = p.y * p.z;
    return c[0] + c[1] * p.x + c[2] * p.y + c[3] * p.z + c[4] * rs + c[5] * rt + c[6] * st + c[7] * (rs * p.z);
  }
};

// The monomial coefficients of the map whose vertex values are `values` (positions or scalars): the map evaluated at
// the 8 corners of the unit cube (shape functions are polynomials, so this holds outside the domain too), then the
// inclusion-exclusion that turns corner values of a trilinear function into its coefficients.
template <CellType T, class V>
MonomialForm<V> to_monomial(const V* values) {
  V corner[8];  // corner[i | j << 1 | k << 2] at (i, j, k)
  if constexpr (T == CellType::Hexahedron) {
    // The corners are the vertices (hot in the ray caster: no shape functions to evaluate).
    static constexpr int kVertexAt[8] = {0, 1, 3, 2, 4, 5, 7, 6};
    for (int q = 0; q < 8; ++q) corner[q] = values[kVertexAt[q]];
  } else
    for (int q = 0; q < 8; ++q) {
      double N[kVertexCount<T>];
      shape_functions<T>({double(q & 1), double((q >> 1) & 1), double((q >> 2) & 1)}, N);
      V v = values[0] * N[0];
      for (int i = 1; i < kVertexCount<T>; ++i) v = v + values[i] * N[i];
      corner[q] = v;
    }
  MonomialForm<V> m;
  m.c[0] = corner[0];
  m.c[1] = corner[1] - corner[0];
  m.c[2] = corner[2] - corner[0];
  m.c[3] = corner[4] - corner[0];
  m.c[4] = corner[3] - corner[1] - corner[2] + corner[0];
  m.c[5] = corner[5] - corner[1] - corner[4] + corner[0];
  m.c[6] = corner[6] - corner[2] - corner[4] + corner[0];
  m.c[7] = corner[7] - corner[3] - corner[5] - corner[6] + corner[1] + corner[2] + corner[4] - corner[0];
  return m;
}

// Newton on a monomial form: as inverse_map_newton, with the stopping step `tolerance` (1e-9 already leaves an error
// far below 1e-12 in any cell where Newton converges quadratically).
inline bool inverse_map_monomial(const MonomialForm<Vec3d>& m, Vec3d point, Vec3d guess, Vec3d& rst,
                                 double tolerance = kInverseMapTolerance) {
  rst = guess;
  const Vec3d target = point - m.c[0];
  double det_floor2 = -1;  // kSingularJacobian's threshold, squared, from the first iterate's columns
  for (int it = 0; it < kInverseMapMaxIterations; ++it) {
    const double r = rst.x, s = rst.y, t = rst.z;
    // The Jacobian columns and the map share their terms: x - c0 = r jr + s (c2 + c6 t) + c3 t.
    const Vec3d q = m.c[6] + m.c[7] * r;
    const Vec3d jr = m.c[1] + m.c[4] * s + (m.c[5] + m.c[7] * s) * t;
    const Vec3d js = m.c[2] + m.c[4] * r + q * t;
    const Vec3d jt = m.c[3] + m.c[5] * r + q * s;
    const Vec3d x = jr * r + (m.c[2] + m.c[6] * t) * s + m.c[3] * t;
    const Vec3d a0 = cross(js, jt), a1 = cross(jt, jr), a2 = cross(jr, js);
    const double det = dot(jr, a0);
    if (det_floor2 < 0) {
      det_floor2 = kSingularJacobian * kSingularJacobian * dot(jr, jr) * dot(js, js) * dot(jt, jt);
    }
    if (!(det * det > det_floor2)) return false;  // also catches NaN
    const Vec3d b = target - x;
    const double inv = 1.0 / det;
    const Vec3d delta{dot(a0, b) * inv, dot(a1, b) * inv, dot(a2, b) * inv};
    rst = rst + delta;
    const double step = std::max(std::abs(delta.x), std::max(std::abs(delta.y), std::abs(delta.z)));
    if (step < tolerance) return true;
    if (!(step < 1e8)) return false;
  }
  return false;
}

// ---- Newton with a second-order correction (voxelizers) ----------------------------------------------------------
//
// A trilinear map's Taylor expansion ends after the cubic term, so the residual a Newton step leaves is known in
// closed form: from iterate u with update d = J(u)^-1 (p - x(u)),
//   x(u + d) - p = Q_u(d) = (c4 + c7 t) dr ds + (c5 + c7 s) dr dt + (c6 + c7 r) ds dt + c7 dr ds dt,
// and subtracting c = J(u)^-1 Q_u(d) (no new Jacobian: the inverse is the step's own) leaves an error of third order
// in |d| instead of second: the residual is then (J(u) - J(u + d)) c - Q_{u+d}(c), so for u in the unit cube
//   |error| <= |J^-1| · S · (|d| + |c|) · |c|,   S = 2 (|c4| + |c5| + |c6|) + 9 |c7|
// (Euclidean norms; |J^-1| <= its Frobenius norm; J^-1 at u standing in for J^-1 near the solution, a first-order
// estimate). A sampler whose guesses come from a neighbouring sample (off by 1e-3 to 1e-5) then stops after one step
// with the coordinates within 1e-12, where plain Newton takes two or three steps to know that it has converged.
// The step returns the bound squared (no square roots, absolute values or maxima: vectorizes cleanly).
//
// The arithmetic is written once for a scalar (T = double) and for lanes of a GCC/Clang vector type (T = double
// __attribute__((vector_size(16))), two points at once): each lane rounds exactly as the scalar code (IEEE
// operations only, no contraction: -ffp-contract=off), so a point gets the same bits whichever way it is processed.

// S above for a cell's map: 0 for an affine map (a parallelepiped), whose inverse the first step finds exactly.
inline double monomial_nonlinearity(const MonomialForm<Vec3d>& m) {
  return 2.0 * (length(m.c[4]) + length(m.c[5]) + length(m.c[6])) + 9.0 * length(m.c[7]);
}

template <class T>
struct InverseMapStep {
  Vec3<T> rst;                     // the corrected iterate
  T error2;                        // the bound above on |rst - exact|, squared
  T step2;                         // |d|^2: large (say 1e16) or NaN when diverging
  T det2;                          // det(J(u))^2, for a singularity test
  std::array<Vec3<T>, 3> inverse;  // rows of J(u)^-1: d rst / d x, for predicting a nearby point's coordinates
};

// One corrected Newton step from `rst` towards the point whose offset from m.c[0] is `target`; `nonlinearity` is
// monomial_nonlinearity(m). No test inside: the caller checks det2, step2 and error2 (per lane).
template <class T>
[[gnu::always_inline]] inline InverseMapStep<T> inverse_map_step(const MonomialForm<Vec3<T>>& m, T nonlinearity,
                                                                 Vec3<T> target, Vec3<T> rst) {
  const T r = rst.x, s = rst.y, t = rst.z;
  // The Jacobian columns and the map share their terms, as in inverse_map_monomial.
  const Vec3<T> q = m.c[6] + m.c[7] * r;
  const Vec3<T> p5 = m.c[5] + m.c[7] * s;
  const Vec3<T> jr = m.c[1] + m.c[4] * s + p5 * t;
  const Vec3<T> js = m.c[2] + m.c[4] * r + q * t;
  const Vec3<T> jt = m.c[3] + m.c[5] * r + q * s;
  const Vec3<T> x = jr * r + (m.c[2] + m.c[6] * t) * s + m.c[3] * t;
  const Vec3<T> a0 = cross(js, jt), a1 = cross(jt, jr), a2 = cross(jr, js);
  const T det = dot(jr, a0);
  const T inv = 1.0 / det;
  const Vec3<T> b = target - x;
  const Vec3<T> d{dot(a0, b) * inv, dot(a1, b) * inv, dot(a2, b) * inv};
  const Vec3<T> quad =
      (m.c[4] + m.c[7] * t) * (d.x * d.y) + p5 * (d.x * d.z) + q * (d.y * d.z) + m.c[7] * (d.x * d.y * d.z);
  const Vec3<T> c{dot(a0, quad) * inv, dot(a1, quad) * inv, dot(a2, quad) * inv};
  InverseMapStep<T> out;
  out.rst = rst + d - c;
  out.step2 = dot(d, d);
  const T c2 = dot(c, c);
  const T inverse2 = (dot(a0, a0) + dot(a1, a1) + dot(a2, a2)) * (inv * inv);  // Frobenius norm of J^-1, squared
  out.error2 = inverse2 * (nonlinearity * nonlinearity) * (2.0 * (out.step2 + c2)) * c2;  // (a+b)^2 <= 2(a²+b²)
  out.det2 = det * det;
  out.inverse = {a0 * inv, a1 * inv, a2 * inv};
  return out;
}

// Where inverse_map_step's iterations end for one point.
struct InverseMapResult {
  Vec3d rst;
  std::array<Vec3d, 3> inverse;  // rows of J^-1 at the last iterate but one
};

// Corrected Newton steps from `guess` until the error bound is at most `accuracy`. Fails (returns false) when the
// Jacobian is singular (det^2 <= det_floor2), Newton diverges, or `iterations` steps do not converge.
inline bool inverse_map_corrected(const MonomialForm<Vec3d>& m, double nonlinearity, double det_floor2, Vec3d target,
                                  Vec3d guess, double accuracy, InverseMapResult& out,
                                  int iterations = kInverseMapMaxIterations) {
  Vec3d rst = guess;
  for (int it = 0; it < iterations; ++it) {
    const InverseMapStep<double> st = inverse_map_step(m, nonlinearity, target, rst);
    if (!(st.det2 > det_floor2) || !(st.step2 < 1e16)) return false;  // also catches NaN
    rst = st.rst;
    if (st.error2 <= accuracy * accuracy) {
      out.rst = rst;
      out.inverse = st.inverse;
      return true;
    }
  }
  return false;
}

// ---- run-time cell type ------------------------------------------------------------------------------------------

template <CellType T>
using CellTypeTag = std::integral_constant<CellType, T>;

// Calls f(CellTypeTag<T>{}) for the run-time type, so one generic lambda instantiates the kernels for all four types
// and callers switch once per cell (or per brick) rather than once per kernel call:
//   with_cell_type(type, [&](auto tag) { constexpr CellType T = decltype(tag)::value; ... });
// `type` must be a valid CellType (UnstructuredMesh::validate guarantees it for meshes).
template <class F>
inline decltype(auto) with_cell_type(CellType type, F&& f) {
  switch (type) {
    case CellType::Tetra: return f(CellTypeTag<CellType::Tetra>{});
    case CellType::Hexahedron: return f(CellTypeTag<CellType::Hexahedron>{});
    case CellType::Wedge: return f(CellTypeTag<CellType::Wedge>{});
    case CellType::Pyramid: break;
  }
  return f(CellTypeTag<CellType::Pyramid>{});
}

inline void shape_functions(CellType type, Vec3d rst, double* N) {
  with_cell_type(type, [&](auto tag) { shape_functions<decltype(tag)::value>(rst, N); });
}
inline void shape_derivatives(CellType type, Vec3d rst, double* dN) {
  with_cell_type(type, [&](auto tag) { shape_derivatives<decltype(tag)::value>(rst, dN); });
}
inline bool parametric_inside(CellType type, Vec3d rst, double tolerance) {
  return with_cell_type(type, [&](auto tag) { return parametric_inside<decltype(tag)::value>(rst, tolerance); });
}
inline double parametric_margin(CellType type, Vec3d rst) {
  return with_cell_type(type, [&](auto tag) { return parametric_margin<decltype(tag)::value>(rst); });
}
inline Vec3d parametric_center(CellType type) {
  return with_cell_type(type, [&](auto tag) { return parametric_center<decltype(tag)::value>(); });
}
inline double interpolate(CellType type, Vec3d rst, const double* vertex_values) {
  return with_cell_type(type, [&](auto tag) { return interpolate<decltype(tag)::value>(rst, vertex_values); });
}
inline bool inverse_map(CellType type, const Vec3d* cell_vertices, Vec3d point, Vec3d initial_guess, Vec3d& rst_out) {
  return with_cell_type(
      type, [&](auto tag) { return inverse_map<decltype(tag)::value>(cell_vertices, point, initial_guess, rst_out); });
}
inline bool inverse_map_newton(CellType type, const Vec3d* cell_vertices, Vec3d point, Vec3d initial_guess,
                               Vec3d& rst_out) {
  return with_cell_type(type, [&](auto tag) {
    return inverse_map_newton<decltype(tag)::value>(cell_vertices, point, initial_guess, rst_out);
  });
}
inline Vec3d gradient_in_cell(CellType type, const Vec3d* vertices, Vec3d rst, const double* values) {
  return with_cell_type(type, [&](auto tag) { return gradient_in_cell<decltype(tag)::value>(vertices, rst, values); });
}

// Parametric coordinates of vertex i of the type (VTK's GetParametricCoords; the pyramid's apex is (0, 0, 1)).
Vec3d parametric_vertex(CellType type, int i);

// The cell's vertex positions, widened to double, in VTK order; returns the vertex count (<= kMaxCellVertices).
inline int gather_cell_vertices(const UnstructuredMesh& mesh, uint64_t cell, Vec3d* out) {
  const std::span<const uint32_t> ids = mesh.cell(cell);
  for (size_t i = 0; i < ids.size(); ++i) out[i] = to_double(mesh.points[ids[i]]);
  return int(ids.size());
}

}  // namespace ugvr
