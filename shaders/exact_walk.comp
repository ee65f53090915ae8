#version 450
// The exact engine on the GPU: one invocation per pixel walks its ray from cell to cell across shared faces and
// integrates each cell's stretch in closed form — the CPU engine's method (src/ugvr/render/exact/exact_engine.cpp,
// docs/exact-engine.md), line for line where it matters:
//  - watertight edge functions on per-vertex ray-local projections (ray_frame.h), `precise` so that no compiler
//    contracts them into FMAs differently in two places: the two cells sharing a face get the same numbers;
//  - native tetrahedra, pyramids, wedges and hexahedra; quadrilateral faces as two triangles along the walk mesh's
//    diagonal; vertex or cell data;
//  - in non-tetrahedral cells the field along the ray is split into linear pieces at midpoints until the midpoint is
//    within the tolerance of the chord (Newton on the cell's monomial form for the point's parametric coordinates);
//  - entries and re-entries from the boundary triangles binned per 16x16 screen tile (boundary_bins.h), taken in
//    order of (t, triangle) as the CPU sorts them;
//  - emission-absorption (optical.glsl), MIP, isosurfaces, the boundary overlay, the clip plane, lighting.
// Engine and shader share their bindings and the per-frame block through exact_shared.h.

#include "exact_shared.h"
#define OPTICAL_TABLE_BINDING EXACT_OPTICAL_BINDING
#include "optical.glsl"

#ifndef MODE
#define MODE EXACT_MODE_EA
#endif
#ifndef EXACT_DOUBLE
#define EXACT_DOUBLE 1
#endif
#ifndef TETS_ONLY
#define TETS_ONLY 0
#endif
#ifndef SLICES
#define SLICES 0  // cutting planes (u_slice_*; docs/slices.md)
#endif
#ifndef SLICE_CONTOURS
#define SLICE_CONTOURS 0  // some slice has contour lines (a variant: their gradient code is compiled only then)
#endif
#ifndef VOLUME_LIGHTING
#define VOLUME_LIGHTING 0  // compile time: without it (and outside isosurfaces) no gradient code, no registers for it
#endif
#if EXACT_DOUBLE
#define real double
#define real3 dvec3
#else
#define real float
#define real3 vec3
#endif

layout(local_size_x = EXACT_WORKGROUP_SIZE, local_size_y = EXACT_WORKGROUP_SIZE) in;

layout(rgba32f, binding = EXACT_OUT_IMAGE_BINDING) uniform writeonly image2D u_out;
layout(location = EXACT_BAND_ORIGIN_LOCATION) uniform ivec2 u_band_origin;  // (0, 0) but in a band (lod_shared.h)
layout(binding = EXACT_TF_TEXTURE_BINDING) uniform sampler1D u_tf;
layout(std430, binding = EXACT_POINTS_BINDING) readonly buffer Points { float points[]; };
layout(std430, binding = EXACT_CONN_BINDING + 0) readonly buffer Conn0 { uint conn0[]; };
layout(std430, binding = EXACT_CONN_BINDING + 1) readonly buffer Conn1 { uint conn1[]; };
layout(std430, binding = EXACT_CONN_BINDING + 2) readonly buffer Conn2 { uint conn2[]; };
layout(std430, binding = EXACT_CONN_BINDING + 3) readonly buffer Conn3 { uint conn3[]; };
layout(std430, binding = EXACT_NBR_BINDING + 0) readonly buffer Nbr0 { uint nbr0[]; };
layout(std430, binding = EXACT_NBR_BINDING + 1) readonly buffer Nbr1 { uint nbr1[]; };
layout(std430, binding = EXACT_NBR_BINDING + 2) readonly buffer Nbr2 { uint nbr2[]; };
layout(std430, binding = EXACT_NBR_BINDING + 3) readonly buffer Nbr3 { uint nbr3[]; };
layout(std430, binding = EXACT_QUAD_SPLIT_BINDING) readonly buffer QuadSplit { uint quad_split[]; };
layout(std430, binding = EXACT_VALUES_BINDING) readonly buffer Values { float values[]; };
layout(std430, binding = EXACT_BOUNDARY_BINDING) readonly buffer Boundary { uvec2 boundary[]; };
layout(std430, binding = EXACT_BOXES_BINDING) readonly buffer Boxes { uvec2 boxes[]; };
layout(std430, binding = EXACT_TILES_BINDING) readonly buffer Tiles { uint tiles[]; };
layout(std430, binding = EXACT_COUNTERS_BINDING) buffer Counters { uint counters[]; };

const float AMBIENT = 0.2, DIFFUSE = 0.8, SPECULAR = 0.25, SHININESS = 32.0;
const vec3 OVERLAY_COLOR = vec3(0.85);
#include "cell_walk.glsl"  // the cell tables, the ray frame and the walk, shared with lod_raycast.comp
#include "loop_limit_probe.glsl"


// ---- mesh access ---------------------------------------------------------------------------------------------------
uint chunk_mask() { return (1u << uint(u_counts.z)) - 1u; }
uint conn_at(uint i) {
  uint c = i >> uint(u_counts.z), j = i & chunk_mask();
  if (c == 0u) return conn0[j];
  if (c == 1u) return conn1[j];
  if (c == 2u) return conn2[j];
  return conn3[j];
}
uint nbr_at(uint i) {
  uint c = i >> uint(u_counts.z), j = i & chunk_mask();
  if (c == 0u) return nbr0[j];
  if (c == 1u) return nbr1[j];
  if (c == 2u) return nbr2[j];
  return nbr3[j];
}
// TETS_ONLY (a mesh of tetrahedra alone): every cell is type 0, so the compiler drops the code of the other types
// (non-linear subdivision, Newton, quadrilateral faces) and the registers it holds, which lets more rays run at once.
int type_index(uint c) {
#if TETS_ONLY
  return 0;
#else
  return c < u_type_begin.y ? 0 : c < u_type_begin.z ? 1 : c < u_type_begin.w ? 2 : 3;
#endif
}
uint vertex_id(uint c, int k, int i) {
  return conn_at(u_conn_begin[k] + (c - u_type_begin[k]) * uint(VERTEX_COUNT[k]) + uint(i));
}
uint neighbor(uint c, int k, int f) {
  return nbr_at(u_face_begin[k] + (c - u_type_begin[k]) * uint(FACE_COUNT[k]) + uint(f));
}
bool quad_split_13(uint c, int f) {
  uint i = c - u_type_begin.y;
  return ((quad_split[i >> 2] >> (8u * (i & 3u) + uint(f))) & 1u) != 0u;
}
vec3 point_at(uint id) { return vec3(points[3u * id], points[3u * id + 1u], points[3u * id + 2u]); }
bool cell_data() { return u_flags.x != 0; }
float vertex_value(uint id) { return values[id]; }
float cell_value(uint c) { return values[c]; }
real nonlinear_tolerance() { return real(u_tolerance.x); }
// ---- the ray (the rest of its state is cell_walk.glsl's) --------------------------------------------------------
int g_hint = -1;
float g_mip_max;
bool g_mip_hit = false;

// ---- shading -------------------------------------------------------------------------------------------------------
vec3 shade_surface(vec3 color, vec3 normal, vec3 view_dir) {
  if (u_flags.z == 0) return color;
  float len = length(normal);
  if (!(len > 0.0)) return color;
  float c = abs(dot(normal, view_dir)) / len;
  float spec = SPECULAR * pow(c, SHININESS);
  return min(color * (AMBIENT + DIFFUSE * c) + vec3(spec), vec3(1.0));
}
void composite_surface(vec3 color, float alpha) {
  g_acc.rgb += color * (g_acc.a * alpha);
  g_acc.a *= 1.0 - alpha;
}
vec4 tf_lookup(float value) {
  float u = clamp(value * u_tf_map.x + u_tf_map.y, 0.0, 1.0);
  return texture(u_tf, (u * float(EXACT_TF_TEXELS - 1) + 0.5) / float(EXACT_TF_TEXELS));
}

vec3 triangle_normal(int k, int face, ivec3 c) {
  ivec4 fv = FACE_V[k * 6 + face];
  vec3 a = point_at(g_vid[fv[c.x]]), b = point_at(g_vid[fv[c.y]]), d = point_at(g_vid[fv[c.z]]);
  return cross(b - a, d - a);
}

void overlay(int k, int face, ivec3 c, real t) {
#if MODE != EXACT_MODE_MIP
  float alpha = u_params.x;
  if (!(alpha > 0.0) || t < g_t_lo || t > g_t_hi) return;
  composite_surface(shade_surface(OVERLAY_COLOR, triangle_normal(k, face, c), vec3(-g_dir)), alpha);
#endif
}

float iso_value(int i) { return u_iso[i >> 2][i & 3]; }

// The isosurfaces the field crosses from a to b, in the order the ray meets them. normal_face >= 0: the surface lies
// on that face (a jump across it); else the normal is the field's gradient where it crosses v, linear from (ta, a)
// to (tb, b).
void iso_crossings(float a, float b, int k, real ta, real tb, int normal_face, ivec3 corners) {
  int n = u_counts.y;
  bool up = b > a;
  for (int i = 0; i < n && !done(); ++i) {
    float v = iso_value(up ? i : n - 1 - i);
    if ((a < v) == (b < v)) continue;
    vec3 normal;
    if (normal_face >= 0) {
      normal = triangle_normal(k, normal_face, corners);
    } else {
      need_monomials(k);
      normal = cell_gradient_at(k, ta + real((v - a) / (b - a)) * (tb - ta));
    }
    composite_surface(shade_surface(tf_lookup(v).rgb, normal, vec3(-g_dir)), u_params.y);
  }
}

#if SLICES
// Slices, as the CPU engine draws them (exact_engine.cpp RayTracer::piece): the crossings ahead of the ray, sorted,
// split the pieces; the field at a crossing by the cell's own interpolant; the volume only in [g_vol_lo, g_vol_hi].
layout(binding = EXACT_SLICE_TEXTURE_BINDING) uniform sampler2D u_slice_colors;
real g_st[EXACT_MAX_SLICES];
int g_si[EXACT_MAX_SLICES];
int g_ns = 0, g_sj = 0;
real g_vol_lo, g_vol_hi;

// The field of the current cell at t: `linear` (the piece's value there) is exact in a tetrahedron and for cell data.
// g_slice_rst: where it was found in the cell's parametric space (the centre where the field is linear), for the
// contour lines' gradient, so that they need no second Newton solve (llvmpipe compiles each inlined copy).
real3 g_slice_rst;
float slice_value(int k, real t, float linear) {
  g_slice_rst = real3(CENTER[k]);
  if (k == 0 || u_flags.x != 0) return linear;
  need_monomials(k);
  real3 rst;
  if (!inverse_map(g_origin + g_dir * t, real3(CENTER[k]), 1e-9, rst)) return linear;
  g_slice_rst = rst;
  return float(field_at(rst));
}

#include "slice_contours.glsl"

// Slice i's colour where the ray crosses it at t in cell type k, the field there being v: its colour table (row i of
// 2 × EXACT_MAX_SLICES), with its contour lines blended in (the cell's gradient projected onto the plane along the
// pixel's footprint at that depth, as the CPU engine's RayTracer::slice_color).
vec3 slice_color(int i, int k, real t, float v) {
  float u = clamp(v * u_slice_map[i].x + u_slice_map[i].y, 0.0, 1.0);
  vec3 color = texture(u_slice_colors, vec2((u * float(EXACT_SLICE_TEXELS - 1) + 0.5) / float(EXACT_SLICE_TEXELS),
                                            (float(i) + 0.5) / float(2 * EXACT_MAX_SLICES))).rgb;
#if SLICE_CONTOURS
  int row = EXACT_MAX_SLICES + i;
  if (slice_contour_count(u_slice_colors, row) == 0) return color;
  need_monomials(k);
  vec3 g = gradient_at_rst(g_slice_rst);  // slice_value's point
  float depth = u_eye.w != 0.0 ? 1.0 : float(t) * float(dot(g_dir, real3(u_forward.xyz)));
  vec3 px = vec3(u_right.xyz) * float(2.0 * u_forward.w / double(u_size.x)) * depth;
  vec3 py = vec3(u_up.xyz) * float(2.0 * u_right.w / double(u_size.y)) * depth;
  float per_pixel = slice_screen_derivative(g, vec3(u_slice_plane[i].xyz), vec3(g_dir), px, py);
  return slice_contour_blend(u_slice_colors, row, color, v, per_pixel);
#else
  return color;
#endif
}
#endif

// One linear piece of the volume inside the current cell (where hide_volume lets it show).
void volume_piece(real ta, real tb, float sa, float sb, int k) {
#if SLICES
  if (tb <= g_vol_lo || ta >= g_vol_hi || !(tb > ta)) return;
  if (ta < g_vol_lo) sa = sa + (sb - sa) * float((g_vol_lo - ta) / (tb - ta)), ta = g_vol_lo;
  if (tb > g_vol_hi) sb = sa + (sb - sa) * float((g_vol_hi - ta) / (tb - ta)), tb = g_vol_hi;
#endif
#if MODE == EXACT_MODE_EA
  float shade = 1.0;
  if (VOLUME_LIGHTING != 0 && sa != sb) {
    need_monomials(k);
    vec3 g = cell_gradient_at(k, 0.5 * (ta + tb));
    float len = length(g);
    if (len > 0.0) shade = AMBIENT + DIFFUSE * abs(dot(g, vec3(-g_dir))) / len;
  }
  optical_integrate(sa, sb, float(tb - ta), shade, g_acc, g_hint);
#elif MODE == EXACT_MODE_MIP
  if (!isnan(sa) && sa > g_mip_max) g_mip_max = sa, g_mip_hit = true;
  if (!isnan(sb) && sb > g_mip_max) g_mip_max = sb, g_mip_hit = true;
#else
  if (sa == sb || isnan(sa) || isnan(sb)) return;
  iso_crossings(sa, sb, k, ta, tb, -1, ivec3(0));
#endif
}

// One linear piece of the field along the ray inside the current cell; the slices it crosses split it (a crossing
// belongs to the piece with ta <= t < tb; one behind ta lies where the ray was outside the mesh).
void piece(real ta, real tb, float sa, float sb, int k) {
  if (tb <= g_t_lo || ta >= g_t_hi || !(tb > ta)) return;
  if (ta < g_t_lo) sa = sa + (sb - sa) * float((g_t_lo - ta) / (tb - ta)), ta = g_t_lo;
  if (tb > g_t_hi) sb = sa + (sb - sa) * float((g_t_hi - ta) / (tb - ta)), tb = g_t_hi;
#if SLICES
  while (g_sj < g_ns && g_st[g_sj] < tb) {
    real tp = g_st[g_sj];
    int i = g_si[g_sj];
    ++g_sj;
    if (tp < ta) continue;
    float sp = sa + (sb - sa) * float((tp - ta) / (tb - ta));
    volume_piece(ta, tp, sa, sp, k);
    if (done()) return;
    float v = slice_value(k, tp, sp);
    if (!isnan(v)) composite_surface(slice_color(i, k, tp, v), u_slice_map[i].z);
    if (done()) return;
    ta = tp, sa = sp;
  }
#endif
  volume_piece(ta, tb, sa, sb, k);
}

// Boundary triangle tri's corner vertex ids.
uvec3 boundary_vertices(uint tri, out uint cell, out int k, out int face, out ivec3 corners) {
  uvec2 b = boundary[tri];
  cell = b.x >> 3;
  face = int(b.x & 7u);
  corners = ivec3(int(b.y & 3u), int((b.y >> 2) & 3u), int((b.y >> 4) & 3u));
  k = type_index(cell);
  ivec4 fv = FACE_V[k * 6 + face];
  return uvec3(vertex_id(cell, k, fv[corners.x]), vertex_id(cell, k, fv[corners.y]),
               vertex_id(cell, k, fv[corners.z]));
}

// The first entering crossing after (after_t, after_tri) in (t, triangle) order with t >= min_t, among the tile's
// triangles whose box holds the pixel. Returns the triangle or EXACT_BOUNDARY.
uint next_entry(ivec2 pixel, uint tile, real after_t, uint after_tri, real min_t, out real best_t,
                out real3 best_lambda) {
  uint best = EXACT_BOUNDARY;
  best_t = INF;
  best_lambda = real3(0.0);
  uint begin = tiles[tile], end = tiles[tile + 1u];
  for (uint i = begin; i < end; ++i) {
    uint tri = tiles[i];
    uvec2 box = boxes[tri];
    if (pixel.x < int(box.x & 0xFFFFu) || pixel.x > int(box.x >> 16) || pixel.y < int(box.y & 0xFFFFu) ||
        pixel.y > int(box.y >> 16))
      continue;
    uint cell;
    int k, face;
    ivec3 corners;
    uvec3 v = boundary_vertices(tri, cell, k, face, corners);
    real3 a = project(point_at(v.x)), b = project(point_at(v.y)), c = project(point_at(v.z));
    real e_ab = edge_side(a, b), e_bc = edge_side(b, c), e_ca = edge_side(c, a);
    precise real sum = e_ab + e_bc + e_ca;
    if (!(e_ab <= 0.0 && e_bc <= 0.0 && e_ca <= 0.0 && sum < 0.0)) continue;
    precise real3 lambda = real3(e_bc / sum, e_ca / sum, e_ab / sum);
    precise real t = lambda.x * a.z + lambda.y * b.z + lambda.z * c.z;
    if (t < min_t) continue;
    if (t < after_t || (t == after_t && tri <= after_tri)) continue;
    if (t < best_t || (t == best_t && tri < best)) best = tri, best_t = t, best_lambda = lambda;
  }
  return best;
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy) + u_band_origin;
  int width = u_size.x, height = u_size.y;
  if (pixel.x >= width || pixel.y >= height) return;

  // The ray (CameraRays::at) and its frame (RayFrame: Duff et al. 2017), operation for operation as the CPU computes
  // them (`precise`: no fused multiply-adds), so that both engines walk the same rays.
  precise double sx = 2.0 * (double(pixel.x) + 0.5) / double(width) - 1.0;
  precise double sy = 1.0 - 2.0 * (double(pixel.y) + 0.5) / double(height);
  precise double ox = sx * u_forward.w, oy = sy * u_right.w;
  precise dvec3 offset = dvec3(u_right.x * ox + u_up.x * oy, u_right.y * ox + u_up.y * oy, u_right.z * ox + u_up.z * oy);
  precise dvec3 origin, dir;
  if (u_eye.w != 0.0) {
    origin = u_eye.xyz + offset, dir = u_forward.xyz;
  } else {
    origin = u_eye.xyz;
    dir = u_forward.xyz + offset;
    precise double len = sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
    if (len > 0.0) dir = dir * (1.0 / len);  // normalized() in camera.cpp
  }
  precise double sgn = (unpackDouble2x32(dir.z).y & 0x80000000u) != 0u ? -1.0 : 1.0;  // copysign(1, dir.z)
  precise double fa = -1.0 / (sgn + dir.z);
  precise double fb = dir.x * dir.y * fa;
  precise dvec3 e1 = dvec3(1.0 + sgn * dir.x * dir.x * fa, sgn * fb, -sgn * dir.x);
  precise dvec3 e2 = dvec3(dir.y * e1.z - dir.z * e1.y, dir.z * e1.x - dir.x * e1.z, dir.x * e1.y - dir.y * e1.x);
  g_origin = real3(origin), g_dir = real3(dir), g_e1 = real3(e1), g_e2 = real3(e2);

  g_t_lo = 0.0, g_t_hi = INF;
  if (u_flags.y != 0) {
    double nd = dot(u_clip.xyz, dir);
    double t_plane = (u_clip.w - dot(u_clip.xyz, origin)) / nd;
    if (nd > 0.0)
      g_t_lo = max(g_t_lo, real(t_plane));
    else if (nd < 0.0)
      g_t_hi = min(g_t_hi, real(t_plane));
    else if (dot(u_clip.xyz, origin) - u_clip.w < 0.0)
      g_t_hi = -INF;
  }
#if SLICES
  g_vol_lo = -INF, g_vol_hi = u_slice_info.y == 3 ? -INF : INF;
  for (int i = 0; i < u_slice_info.x; ++i) {
    dvec4 pl = u_slice_plane[i];
    double nd = dot(pl.xyz, dir), g0 = dot(pl.xyz, origin) - pl.w;
    if (u_slice_info.y == 1 || u_slice_info.y == 2) {
      double sg = u_slice_info.y == 2 ? 1.0 : -1.0;  // keep sg · (dot(n, p) - w) >= 0
      if (sg * nd > 0.0)
        g_vol_lo = max(g_vol_lo, real(-g0 / nd));
      else if (sg * nd < 0.0)
        g_vol_hi = min(g_vol_hi, real(-g0 / nd));
      else if (sg * g0 < 0.0)
        g_vol_hi = -INF;
    }
    if (nd == 0.0) continue;
    real ts = real((pl.w - dot(pl.xyz, origin)) / nd);
    if (!(ts >= g_t_lo && ts <= g_t_hi)) continue;
    int j = g_ns++;
    for (; j > 0 && g_st[j - 1] > ts; --j) g_st[j] = g_st[j - 1], g_si[j] = g_si[j - 1];
    g_st[j] = ts, g_si[j] = i;
  }
#endif
  g_stop_transmittance = u_params.z;
  g_mip_max = -FLOAT_INF;

  uint tile = uint(pixel.y / u_size.w) * uint(u_size.z) + uint(pixel.x / u_size.w);
  uint max_steps = 4u * uint(u_counts.x) + 16u;
  real reentry_slack = real(u_up.w);
  bool entered = false, lost = false;
  real last_exit = -INF, prev_t = -INF;
  uint prev_tri = EXACT_BOUNDARY;
  uint steps = 0u, rays_hit = 0u, reentries = 0u, cell_steps = 0u;

  while (!done() && !lost) {
    real t_entry;
    real3 lambda;
    uint tri = next_entry(pixel, tile, prev_t, prev_tri == EXACT_BOUNDARY ? 0u : prev_tri,
                          entered ? last_exit - reentry_slack : -INF, t_entry, lambda);
    if (tri == EXACT_BOUNDARY || t_entry > g_t_hi) break;
    prev_t = t_entry, prev_tri = tri;
    if (entered)
      ++reentries;
    else
      ++rays_hit;
    entered = true;

    // start_walk
    uint cell;
    int k, entry_face;
    ivec3 corners;
    boundary_vertices(tri, cell, k, entry_face, corners);
    load_cell(cell, k);
    g_monomials_built = false;
    Crossing x;
    x.face = entry_face, x.corners = corners, x.lambda = lambda, x.t = t_entry;
    real t_in = t_entry;
    float s_in = scalar_at_face(cell, k, x);
    {
      ivec4 fv = FACE_V[k * 6 + entry_face];
      for (int i = 0; i < 3; ++i) g_entry_ids[i] = g_vid[fv[corners[i]]];
      g_entry_lambda = lambda;
    }
    overlay(k, entry_face, corners, t_in);
    int stall = 0;
    bool in_walk = true;
    while (in_walk && !done()) {
      ++cell_steps;
      Crossing o;
      exit_of(cell, k, entry_face, o);
      real t_out = max(o.t, t_in);
      bool stalled = !(t_out > t_in);
      float s_out = scalar_at_face(cell, k, o);
      cell_segment(cell, k, t_in, t_out, s_in, s_out, o);
      {
        ivec4 fv = FACE_V[k * 6 + o.face];
        for (int i = 0; i < 3; ++i) g_entry_ids[i] = g_vid[fv[o.corners[i]]];
        g_entry_lambda = o.lambda;
      }
      t_in = t_out;
      s_in = s_out;
      uint next = neighbor(cell, k, o.face);
      stall = stalled ? stall + 1 : 0;
      if (stall > MAX_STALL_STEPS || ++steps > max_steps) {
        lost = true;
        break;
      }
      if (done()) break;
      if (next == EXACT_BOUNDARY) {
        overlay(k, o.face, o.corners, t_in);
        last_exit = t_in;
        in_walk = false;
        break;
      }
      uint next_cell = next >> 3;
      if (u_flags.x != 0) {
        float s_next = values[next_cell];
#if MODE == EXACT_MODE_ISO
#if SLICES
        bool shown = t_in >= g_vol_lo && t_in <= g_vol_hi;
#else
        const bool shown = true;
#endif
        if (shown && s_in != s_next && t_in >= g_t_lo && t_in <= g_t_hi && !isnan(s_in) && !isnan(s_next))
          iso_crossings(s_in, s_next, k, t_in, t_in, o.face, o.corners);
#endif
        s_in = s_next;
      }
      cell = next_cell;
      entry_face = int(next & 7u);
      k = type_index(cell);
      load_cell(cell, k);
      g_monomials_built = false;
    }
  }

  vec4 result = g_acc;
#if MODE == EXACT_MODE_MIP
  // g_acc holds the slices alone (nothing without them); the maximum is drawn behind them.
  if (g_mip_hit) {
    vec4 c = tf_lookup(g_mip_max);
    result = vec4(g_acc.rgb + g_acc.a * c.rgb * c.a, g_acc.a * (1.0 - c.a));
  }
#endif
  // A ray that llvmpipe's loop limit cut short is flagged (transmittance -1) for the engine to trace on the CPU, which
  // counts its walk: not counted here.
  bool cut = loop_limit_reached(u_counts.w);
  if (cut) result = vec4(0.0, 0.0, 0.0, -1.0);
  imageStore(u_out, pixel, result);
  if (cut) {
    atomicAdd(counters[EXACT_COUNTER_CUT], 1u);
    return;
  }
  if (rays_hit > 0u) atomicAdd(counters[EXACT_COUNTER_RAYS_HIT], rays_hit);
  if (reentries > 0u) atomicAdd(counters[EXACT_COUNTER_REENTRIES], reentries);
  if (g_nonlinear > 0u) atomicAdd(counters[EXACT_COUNTER_NONLINEAR], g_nonlinear);
  if (lost) atomicAdd(counters[EXACT_COUNTER_LOST], 1u);
  if (cell_steps > 0u) {
    uint old = atomicAdd(counters[EXACT_COUNTER_STEPS_LO], cell_steps);
    if (old + cell_steps < old) atomicAdd(counters[EXACT_COUNTER_STEPS_HI], 1u);
  }
}
