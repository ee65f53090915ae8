#version 450
// Single-pass ray casting of a cut of the brick octree (engine: src/ugvr/render/lod/lod_engine.cpp; the buffers,
// textures and per-frame parameters it binds are declared once for both in lod_shared.h). One invocation per pixel;
// the ray walks the octree front to back, finds the cut node at its current position by descending from the root,
// marches that node's brick up to the node's exit, and moves on. Coordinates are the root cell's, normalised to
// [0, 1]³ per axis; ray parameters t are world distances, measured from where the ray enters the root cell so that
// they stay small (float precision).
//
// Samples sit on one grid per level along each ray: the points k·step_L with step_L = step_0 / 2^L, plus the ray's
// entry into and exit from each node. Between consecutive samples of one node the value is taken as linear and the
// segment is integrated over the transfer function with a table of its integrals (pre-integration: integral_at), so
// that a transfer function steeper than the step is integrated, not point-sampled, and the image hardly depends on
// the step. A coarse level's grid points are a subset of the finer level's, and every node is integrated from its
// entry to its exit, so where bricks or levels meet no stretch of the ray is counted twice or skipped and no sample
// pattern changes abruptly (no seams; gvdb-voxels #99, OSPRay PR 187).

#include "lod_shared.h"  // constants, bindings and the uniform block LodFrame, shared with the engine
#include "loop_limit_probe.glsl"  // rays llvmpipe's loop limit cut short, counted

// Compile-time choices (the engine compiles one program per combination it meets): on llvmpipe every branch of the
// sample loop costs its full price whatever a uniform says, so code a frame does not need must not be there.
#ifndef MODE
#define MODE LOD_MODE_EA
#endif
#ifndef VOLUME_LIGHTING
#define VOLUME_LIGHTING 0
#endif
#ifndef OVERLAY
#define OVERLAY 0  // the boundary overlay (never with LOD_MODE_MIP)
#endif
#ifndef FACES
#define FACES 0  // the store keeps the mesh's boundary faces per node: clip at them (below)
#endif
#ifndef LOD_FACE_BATCH_NODES
#define LOD_FACE_BATCH_NODES 16  // FACES: node steps between two batches of face passes (main)
#endif
#ifndef SLICES
#define SLICES 0  // cutting planes (u_slice_*; docs/slices.md)
#endif
#ifndef TRICUBIC
#define TRICUBIC 0  // isosurfaces on the cubic B-spline of the bricks' samples (LOD_MODE_ISO only; docs/tricubic.md)
#endif
#ifndef FOCUS_WINDOWS
#define FOCUS_WINDOWS 0  // smooth brush edges: each sample's interest from the u_focus windows (docs/hybrid.md)
#endif
#ifndef HYBRID
#define HYBRID 0  // exact cells in the nodes granted them (no overlay, slices, tricubic; docs/hybrid.md)
#endif
// Tricubic isosurfaces bracket on the trilinear samples and evaluate the spline after the walk (below, g_cand);
// with slices, whose crossings must be known in order, the spline is evaluated in the sample loop instead.
#define TRICUBIC_WALK (TRICUBIC && MODE == LOD_MODE_ISO && !SLICES)
#if HYBRID && (OVERLAY || SLICES || TRICUBIC)
#error HYBRID is a variant without the boundary overlay, slices and tricubic interpolation
#endif

layout(local_size_x = WORKGROUP_SIZE, local_size_y = WORKGROUP_SIZE) in;

layout(rgba32f, binding = OUT_IMAGE_BINDING) uniform writeonly image2D u_out;
layout(location = BAND_ORIGIN_LOCATION) uniform ivec2 u_band_origin;  // (0, 0) but in a band of an interruptible frame
layout(binding = ATLAS_TEXTURE_BINDING) uniform sampler3D u_atlas;
layout(binding = TF_TEXTURE_BINDING) uniform sampler1D u_tf;
layout(binding = PREINT_TEXTURE_BINDING) uniform sampler1D u_preint;
layout(std430, binding = TREE_BUFFER_BINDING) readonly buffer Tree { uvec2 tree[]; };
layout(std430, binding = STATE_BUFFER_BINDING) readonly buffer State { uint node_state[]; };
layout(std430, binding = COUNTERS_BUFFER_BINDING) buffer Counters { uint counters[]; };

#if SLICES
// Slices (LaMar 2000, ch. 6; docs/slices.md). Where the ray crosses a plane is made a sample point of whichever node
// holds it, like the faces below: the volume segment ends there, the brick is sampled there (trilinear, the same
// texel data as the volume, so the slice and the volume agree), and the slice is composited at that depth with its
// own colour map and opacity before the volume behind it. Levels: the sample is the cut node's own brick, whose
// border texels a coarser neighbour shares (octree-build.md); a seam between levels is the difference of two
// trilinear reconstructions of one field, which bench/bench_lod_seams measures (docs/slices.md for the figure).
layout(binding = SLICE_TEXTURE_BINDING) uniform sampler2D u_slice_colors;
float g_st[LOD_MAX_SLICES];  // the ray's crossings ahead, ascending (t from base)
int g_si[LOD_MAX_SLICES];    // their slice
int g_ns;                    // how many

#include "slice_contours.glsl"
vec3 gradient_at(vec3 c, vec3 h);

// Slice i at a sample of atlas coordinate c (voxels of world size h), at world distance t_world from the eye along
// dir_world, the normalised value there `value`: its colour table (row i of 2 × LOD_MAX_SLICES) with its contour
// lines blended in, the brick's gradient projected onto the plane along the pixel's footprint at that depth (as the
// exact engines do with the cell's gradient).
void composite_slice(int i, float value, vec3 c, vec3 h, float t_world, vec3 dir_world, inout vec3 radiance,
                     inout float transmittance) {
  vec4 m = u_slice_map[i];
  float u = clamp(value * m.x + m.y, 0.0, 1.0);
  vec3 color = texture(u_slice_colors, vec2((u * (float(SLICE_TEXELS) - 1.0) + 0.5) / float(SLICE_TEXELS),
                                            (float(i) + 0.5) / float(2 * LOD_MAX_SLICES))).rgb;
  int row = LOD_MAX_SLICES + i;
  if (slice_contour_count(u_slice_colors, row) > 0) {
    float depth = u_parallel ? 1.0 : t_world * dot(dir_world, u_forward);
    vec3 px = u_right * (2.0 * u_half.x / float(u_size.x) * depth);
    vec3 py = u_up * (2.0 * u_half.y / float(u_size.y) * depth);
    vec3 n = u_slice_plane[i].xyz / u_root_size;  // the plane's normal in world coordinates (not unit: no matter)
    color = slice_contour_blend(u_slice_colors, row, color, value,
                                slice_screen_derivative(gradient_at(c, h), n, dir_world, px, py));
  }
  radiance += transmittance * m.z * color;
  transmittance *= 1.0 - m.z;
}
#endif

#if FACES
// The exact boundary (Muigg 2008, section 5.1.2; docs/lod-engine.md, "Exact boundary"): a node the mesh boundary
// crosses lists the boundary triangles that overlap it (at most the builder's cap; store/brick_store_format.h). A ray
// in such a node intersects the line with each, keeps the crossings inside the node, sorted, and knows whether it is
// inside the mesh between them from the faces' orientation (outward normals: a face the ray meets head-on is an entry).
// The node's samples then include the crossings, and each segment between two samples counts wholly or not at all,
// so the data ends exactly on the mesh's faces, at every level; the stencil decides in nodes without faces.
layout(std430, binding = FACE_NODE_BUFFER_BINDING) readonly buffer FaceNodes { uvec2 face_node[]; };
layout(std430, binding = FACE_REF_BUFFER_BINDING) readonly buffer FaceRefs { uint face_ref[]; };
layout(std430, binding = FACE_TRI_BUFFER_BINDING) readonly buffer FaceTris { float face_tri[]; };

// The current node's crossings along the ray: t, +1 entering / -1 leaving, the face's normal (normalised coordinates;
// the overlay's only: without it, not kept, as its stores in add_crossing's shifts cost llvmpipe even though nothing
// reads them).
float g_fh[MAX_FACE_HITS];
float g_fs[MAX_FACE_HITS];
#if OVERLAY
vec3 g_fn[MAX_FACE_HITS];
#endif
int g_nh;
uint g_face_passes = 0u;  // node_faces calls (COUNTER_FACE_PASSES)

// The point of triangle (a, b, c) nearest to p (Ericson, "Real-Time Collision Detection", 5.1.5).
vec3 closest_on_triangle(vec3 p, vec3 a, vec3 b, vec3 c) {
  vec3 ab = b - a, ac = c - a, ap = p - a;
  float d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  vec3 bp = p - b;
  float d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + ab * (d1 / (d1 - d3));
  vec3 cp = p - c;
  float d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + ac * (d2 / (d2 - d6));
  float va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  float denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Inside (1) or outside (0) the mesh at p, from the nearest of the run's triangles: the side of its plane p lies on
// (outward normals). Where several are nearly as near (p nearest to an edge or a corner they share), the one whose
// plane p is farthest from decides, the usual cure for the pseudo-normal problem at edges. For a point whose ray
// meets none of a node's faces (a ray passing beside the boundary), where the stencil would put it within half a
// voxel.
int side_of_faces(uvec2 fe, vec3 p) {
  float best = 3.0e38, best_plane = -1.0;
  int side = -1;
  for (uint i = 0u; i < fe.y; ++i) {
    uint b = face_ref[fe.x + i] * 9u;
    vec3 p0 = vec3(face_tri[b], face_tri[b + 1u], face_tri[b + 2u]);
    vec3 p1 = vec3(face_tri[b + 3u], face_tri[b + 4u], face_tri[b + 5u]);
    vec3 p2 = vec3(face_tri[b + 6u], face_tri[b + 7u], face_tri[b + 8u]);
    vec3 q = closest_on_triangle(p, p0, p1, p2);
    float dist = length(p - q);
    vec3 n = cross(p1 - p0, p2 - p0);
    float nl = length(n);
    if (!(nl > 0.0)) continue;
    float plane = dot(p - p0, n) / nl;
    if (dist < best * (1.0 - 1e-4) || (dist <= best * (1.0 + 1e-4) && abs(plane) > best_plane)) {
      best = min(best, dist);
      best_plane = abs(plane);
      side = plane > 0.0 ? 0 : 1;
    }
  }
  return side;
}

// Adds a crossing (t, +1 entering / -1 leaving, the face's normal) to g_f*, sorted; false: MAX_FACE_HITS already.
bool add_crossing(float th, float sg, vec3 n) {
  if (g_nh == MAX_FACE_HITS) return false;
  int j = g_nh++;
  for (; j > 0 && g_fh[j - 1] > th; --j) {
    g_fh[j] = g_fh[j - 1];
    g_fs[j] = g_fs[j - 1];
#if OVERLAY
    g_fn[j] = g_fn[j - 1];
#endif
  }
  g_fh[j] = th;
  g_fs[j] = sg;
#if OVERLAY
  g_fn[j] = n;
#endif
  return true;
}

// Intersects the line o + d·t with the triangles of one node's run `fe` (Möller-Trumbore, barycentric tolerance 1e-6
// so that a ray through a shared edge meets at least one of its triangles: two meeting it count once, below). Adds
// the crossings in [t0, t1) to g_f*, sorted (false: more than MAX_FACE_HITS). `state`: if < 0 on entry, set to the
// state at t0 when the line meets any of the triangles: from the nearest crossings ahead (leaving: inside now), else
// the nearest behind (entering: inside now). Crossings within eps of each other are one whose sign is their sum (a
// face of two blocks that are not welded: leaving one and entering the other cancel).
bool cell_faces(uvec2 fe, vec3 o, vec3 d, float t0, float t1, float eps, inout int state) {
  float ahead_t = 3.0e38, ahead_s = 0.0, behind_t = -3.0e38, behind_s = 0.0;
  for (uint i = 0u; i < fe.y; ++i) {
    uint b = face_ref[fe.x + i] * 9u;
    vec3 p0 = vec3(face_tri[b], face_tri[b + 1u], face_tri[b + 2u]);
    vec3 e1 = vec3(face_tri[b + 3u], face_tri[b + 4u], face_tri[b + 5u]) - p0;
    vec3 e2 = vec3(face_tri[b + 6u], face_tri[b + 7u], face_tri[b + 8u]) - p0;
    // Where the line meets the triangle's plane first: once the state is known only crossings in [t0, t1) matter, and
    // most triangles of a cell are rejected here, before the barycentric tests.
    vec3 n = cross(e1, e2);
    float dn = dot(d, n);
    if (dn == 0.0 || (state >= 0 && !(dot(p0 - o, n) / dn >= t0 && dot(p0 - o, n) / dn < t1))) continue;
    vec3 pv = cross(d, e2);
    float det = dot(e1, pv);  // = -dot(e1 × e2, d): > 0 where the outward normal faces the ray
    if (det == 0.0) continue;
    float inv = 1.0 / det;
    vec3 tv = o - p0;
    float u = dot(tv, pv) * inv;
    if (u < -1e-6 || u > 1.0 + 1e-6) continue;
    vec3 qv = cross(tv, e1);
    float v = dot(d, qv) * inv;
    if (v < -1e-6 || u + v > 1.0 + 1e-6) continue;
    float th = dot(e2, qv) * inv;
    float sg = det > 0.0 ? 1.0 : -1.0;
    if (th >= t0) {
      if (th < ahead_t - eps) {
        ahead_t = th;
        ahead_s = sg;
      } else if (th <= ahead_t + eps) {
        ahead_s += sg;
      }
      if (th < t1 && !add_crossing(th, sg, n)) return false;
    } else if (th > behind_t + eps) {
      behind_t = th;
      behind_s = sg;
    } else if (th >= behind_t - eps) {
      behind_s += sg;
    }
  }
  if (state < 0) state = ahead_s != 0.0 ? (ahead_s < 0.0 ? 1 : 0) : behind_s != 0.0 ? (behind_s > 0.0 ? 1 : 0) : -1;
  return true;
}

// cell_faces for a cell whose faces all lie on one plane and cover its section (FACE_PLANE; the plane n·p = w at
// face_tri[at]): the line crosses the boundary in the cell where it crosses the plane, so one division stands for the
// triangles. The state as cell_faces sets it: from the crossing ahead or behind, or the side of the plane for a line
// parallel to it (side_of_faces' answer there).
bool plane_faces(uint at, vec3 o, vec3 d, float t0, float t1, inout int state) {
  vec3 n = vec3(face_tri[at], face_tri[at + 1u], face_tri[at + 2u]);
  float h = face_tri[at + 3u] - dot(n, o);  // > 0: o lies inside, behind the outward normal
  float dn = dot(d, n);
  if (dn == 0.0) {
    if (state < 0) state = h >= 0.0 ? 1 : 0;
    return true;
  }
  float th = h / dn;
  float sg = dn < 0.0 ? 1.0 : -1.0;  // against the outward normal: entering
  if (state < 0) state = (th >= t0) == (sg > 0.0) ? 0 : 1;
  return !(th >= t0 && th < t1) || add_crossing(th, sg, n);
}

// The crossings of the ray with the mesh boundary inside cut node `node` (box lo, size), between t0 and t1, into
// g_f*, and the state at t0: 1 inside the mesh, 0 outside, -1 unknown (the stencil decides). A node that lists its
// faces is one call of cell_faces, one whose faces lie on one plane one call of plane_faces. A node with more than
// the cap (a coarse node) is walked along the ray through its descendants in the store's tree (all of them are on the
// GPU, drawn or not) and below a leaf in its virtual nodes: at each position, down to the first node that lists its
// faces, has them on one plane, or has none, whose faces are tested over the stretch of the ray inside it; a child the
// tree lacks holds no cells, so no faces. So the boundary is the same at every level of the cut. Unknown where no face
// is near, or past MAX_FACE_HITS crossings.
int node_faces(uint node, vec3 clo, float csize, vec3 o, vec3 d, vec3 inv_d, float t0, float t1, float eps) {
  g_nh = 0;
  ++g_face_passes;
  uvec2 fe = face_node[node];
  if (fe.y == 0u) return -1;
  int state = -1;
  if (fe.y == FACE_PLANE) return plane_faces(fe.x, o, d, t0, t1, state) ? state : -1;
  float ts = t0;
  uvec2 first_fe = uvec2(0u);  // the first cell with faces on the way, and the middle of the ray's stretch in it
  float first_mid = 0.0;
  for (int guard = 0; guard < 4096 && ts < t1; ++guard) {  // a bound only: a ray crosses far fewer cells
    vec3 p = o + d * (ts + eps);
    uint n = node;
    vec3 lo = clo;
    float size = csize;
    uvec2 e = fe;
    while (e.y == FACE_OVERFLOW) {
      vec3 centre = lo + 0.5 * size;
      uvec3 oc = uvec3(greaterThanEqual(p, centre));
      uint octant = oc.x | (oc.y << 1) | (oc.z << 2);
      size *= 0.5;
      lo += vec3(oc) * size;
      if (e.x != 0u) {  // a leaf's or a virtual node's: 8 virtual children from e.x
        e = face_node[e.x + octant];
        continue;
      }
      uvec2 tn = tree[n];
      uint mask = tn.y & TREE_CHILD_MASK;
      if ((mask & (1u << octant)) == 0u) {
        e = uvec2(0u);  // no child there: no cells, no faces
      } else {
        n = tn.x + uint(bitCount(mask & ((1u << octant) - 1u)));
        e = face_node[n];
      }
    }
    vec3 tx = ((lo + mix(vec3(0.0), vec3(size), greaterThan(inv_d, vec3(0.0)))) - o) * inv_d;
    float te = max(min(min(tx.x, tx.y), min(tx.z, t1)), ts + eps);
    if (e.y == FACE_PLANE) {
      if (!plane_faces(e.x, o, d, ts, te, state)) return -1;
    } else if (e.y > 0u) {
      if (!cell_faces(e, o, d, ts, te, eps, state)) return -1;
      if (first_fe.y == 0u) {
        first_fe = e;
        first_mid = 0.5 * (ts + te);
      }
    }
    ts = te;
  }
  if (ts < t1) return -1;
  // The line meets none of the faces on the way (no crossing in the node): the nearest face of the first cell that
  // has any decides, at the middle of the ray's stretch in it. Only then: it costs a closest point per face.
  if (state < 0 && first_fe.y > 0u) state = side_of_faces(first_fe, o + d * first_mid);
  return state;
}
#endif

const float AMBIENT = LOD_AMBIENT, DIFFUSE = LOD_DIFFUSE, SPECULAR = LOD_SPECULAR, SHININESS = LOD_SHININESS;
const vec3 OVERLAY_COLOR = vec3(LOD_OVERLAY_GREY);

// Isovalue i (of u_iso_count), four to a vec4.
float iso_value(int i) { return u_iso[i >> 2][i & 3]; }

vec4 tf_at(float value) {
  float u = clamp(value * u_tf_map.x + u_tf_map.y, 0.0, 1.0);
  return texture(u_tf, (u * (float(TF_TEXELS) - 1.0) + 0.5) / float(TF_TEXELS));
}

#if MODE == LOD_MODE_EA
// Pre-integration. u_preint holds, over the transfer function's range u in [0, 1], the integrals I(u) = (∫ c·τ du',
// ∫ τ du') from 0 to u (c colour, τ extinction per world unit). Along a segment of length len over which the value
// goes linearly from u0 to u1, τ's mean is (I(u1) - I(u0)).a / (u1 - u0), exactly for any transfer function (up to
// the table's resolution), and the segment's transmittance exp(-mean τ · len); its colour is the τ-weighted mean
// colour, which leaves out the attenuation inside the segment (second order in its optical depth). Each sample's I is
// read once and serves the segments on both sides. Beyond the range the transfer function is constant, so I extends
// linearly with its end values (g_tf_lo, g_tf_hi: (c·τ, τ) at u = 0 and 1). Where the value changes by less than half
// a texel over a segment (the difference of two nearly equal integrals would lose float's precision; the table is
// linear inside a texel anyway), and over the valid part of a segment that leaves or enters the data, the colour
// table's point value at the middle is used instead.
vec4 g_tf_lo, g_tf_hi;

vec4 integral_at(float u) {
  vec4 v = texture(u_preint, (clamp(u, 0.0, 1.0) * (float(TF_TEXELS) - 1.0) + 0.5) / float(TF_TEXELS));
  return v + g_tf_lo * min(u, 0.0) + g_tf_hi * max(u - 1.0, 0.0);
}
#endif

#if FOCUS_WINDOWS
// Smooth brush edges: the degree of interest of transfer-function coordinate u under the FOCUS_WINDOWS windows of
// u_focus (x MIN, y MAX, z 1 / EDGE, w group): per range 1 - smoothstep over the edge (hybrid_select.h focus_window),
// a group's the least of its ranges', the result the greatest group's (node_interest, per value instead of per node
// range). A compile-time count, so that the loop unrolls into uniform loads: llvmpipe runs this for every segment.
float sample_interest(float u) {
  float best = 0.0, all = 1.0;
  for (int i = 0; i < FOCUS_WINDOWS; ++i) {
    vec4 w = u_focus[i];
    float x = clamp(max(w.x - u, u - w.y) * w.z, 0.0, 1.0);
    all = min(all, 1.0 - x * x * (3.0 - 2.0 * x));
    if (i + 1 == FOCUS_WINDOWS || u_focus[min(i + 1, LOD_MAX_FOCUS_WINDOWS - 1)].w != w.w) {
      best = max(best, all);
      all = 1.0;
    }
  }
  return best;
}

// A segment's mean mixed between its context version (context_sample's, with the luminance taken from the
// premultiplied colour: no division) and itself by `interest`.
vec4 interest_mix(vec4 mean, float interest) {
  vec3 grey = vec3(dot(mean.rgb, vec3(0.2126, 0.7152, 0.0722)));
  vec4 context = vec4(mix(grey, mean.rgb, u_context.x), mean.a) * u_context.y;
  return mix(context, mean, interest);
}

// The same for an exact piece, integrated in closed form from accumulator `before` to `after`: the piece's mean
// colour and transmittance T are recovered from the two, its extinction scaled by k = mix(context opacity, 1,
// interest) (T^k) and its colour mixed as interest_mix mixes colour × extinction.
vec4 interest_mix_piece(vec4 before, vec4 after, float interest) {
  if (!(before.a > 0.0)) return after;
  float t = after.a / before.a;
  float k = max(mix(u_context.y, 1.0, interest), 1e-6);
  float tk = pow(max(t, 0.0), k);
  // Premultiplied: the piece's radiance is before.a · (1 - T) · colour; the mixed one before.a · (1 - T^k) · mixed.
  float scale = 1.0 - t > 1e-6 ? (1.0 - tk) / (1.0 - t) : k;
  vec3 d = after.rgb - before.rgb;
  vec3 grey = vec3(dot(d, vec3(0.2126, 0.7152, 0.0722)));
  vec3 mixed = mix(mix(grey, d, u_context.x) * u_context.y, d, interest) / k;
  return vec4(before.rgb + mixed * scale, before.a * tk);
}
#endif

#if HYBRID
// Exact nodes (Muigg 2007; docs/hybrid.md). A cut node whose state has NODE_EXACT is drawn by walking its own cells,
// the exact engine's walk (cell_walk.glsl, in float): the cells overlapping the node, replicated across node borders
// (store format version 5), with their own neighbours; a face whose neighbour the node does not keep, or the mesh's
// boundary, ends the walk. The ray enters the node's cells at the first entering crossing of those faces (the node's
// entry triangles, tested exactly as the exact engine tests its boundary), walks, re-enters after each exit, and only
// the stretch [t, t_exit] of the node counts (Muigg's F18: the ray's segment clamped to the node's box, so that
// neighbouring nodes, exact or resampled, meet without a seam or an overlap: both clamp at the same float t), into
// the one compositing state of the ray. The pieces are integrated in closed form as the exact engine integrates them
// (shaders/optical.glsl: the same transfer function model as the bricks' pre-integration table, without its float
// difference quotients, which cost a cell's short pieces 5 to 10 dB against the exact engine; docs/hybrid.md). The
// walk's frame: origin `base`, direction dir / |dir| (normalised coordinates), so that walk t = |dir| × the LOD
// shader's t.
#define real float
#define real3 vec3
layout(std430, binding = CELL_NODE_BUFFER_BINDING) readonly buffer CellNodes { uvec4 cell_node[]; };
layout(std430, binding = CELL_INT_BUFFER_BINDING) readonly buffer CellInts { uint cell_ints[]; };
layout(std430, binding = CELL_FLOAT_BUFFER_BINDING) readonly buffer CellFloats { float cell_floats[]; };
#include "cell_walk.glsl"
#define OPTICAL_TABLE_BINDING CELL_OPTICAL_BUFFER_BINDING
#include "optical.glsl"

// The current node's record (render/lod/cell_cache.h CellNodeRecord): [0] first local cell of each type, [1] where
// each type's connectivity starts in cell_ints, [2] each type's neighbours, [3] (first point's float index, first
// value's float index, first quad-split word, first entry triangle's uint index), [4] (entry triangles, cells, -, -).
uvec4 g_cn[CELL_NODE_UVEC4S];
float g_len;         // |dir|: walk t = g_len × t
uint g_cell_steps = 0u;

int type_index(uint c) { return c < g_cn[0].y ? 0 : c < g_cn[0].z ? 1 : c < g_cn[0].w ? 2 : 3; }
uint vertex_id(uint c, int k, int i) {
  return cell_ints[g_cn[1][k] + (c - g_cn[0][k]) * uint(VERTEX_COUNT[k]) + uint(i)];
}
uint neighbor(uint c, int k, int f) { return cell_ints[g_cn[2][k] + (c - g_cn[0][k]) * uint(FACE_COUNT[k]) + uint(f)]; }
bool quad_split_13(uint c, int f) {
  uint i = c - g_cn[0].y;
  return ((cell_ints[g_cn[3].z + (i >> 2)] >> (8u * (i & 3u) + uint(f))) & 1u) != 0u;
}
vec3 point_at(uint id) {
  uint b = g_cn[3].x + 3u * id;
  return vec3(cell_floats[b], cell_floats[b + 1u], cell_floats[b + 2u]);
}
bool cell_data() { return u_cell_data != 0; }
float vertex_value(uint id) { return cell_floats[g_cn[3].y + id]; }
float cell_value(uint c) { return cell_floats[g_cn[3].y + c]; }
real nonlinear_tolerance() { return u_cell_tolerance; }

// A linear piece of the field, clamped to the node's stretch [g_t_lo, g_t_hi] and integrated in closed form. In MIP
// and isosurfaces the exact engine's rules, on values normalised to the field's range as the bricks' samples are
// (u_focus_map.zw): one maximum per ray, and the same isovalues, for cells and samples. MIP: the piece's larger end.
// Isosurfaces: where the linear piece crosses each value, in the order the ray meets them, shaded by the cell's own
// gradient there (vertex data only: the engine draws a cell field's surfaces from the bricks).
vec3 shade_surface(vec3 color, vec3 g, vec3 view);
int g_hint = -1;
float g_mip_max = -1.0;
vec3 g_dir_world;  // the ray's world direction (surface shading)
void piece(real ta, real tb, float sa, float sb, int k) {
  if (tb <= g_t_lo || ta >= g_t_hi || !(tb > ta)) return;
  if (ta < g_t_lo) sa = sa + (sb - sa) * float((g_t_lo - ta) / (tb - ta)), ta = g_t_lo;
  if (tb > g_t_hi) sb = sa + (sb - sa) * float((g_t_hi - ta) / (tb - ta)), tb = g_t_hi;
#if MODE == LOD_MODE_MIP
  g_mip_max = max(g_mip_max, max(sa, sb) * u_focus_map.z + u_focus_map.w);
#elif MODE == LOD_MODE_ISO
  float a = sa * u_focus_map.z + u_focus_map.w, b = sb * u_focus_map.z + u_focus_map.w;
  if (a == b) return;
  bool up = b > a;
  for (int i = 0; i < u_iso_count && !done(); ++i) {
    float v = iso_value(up ? i : u_iso_count - 1 - i);
    if ((a < v) == (b < v)) continue;
    need_monomials(k);
    // The walk's coordinates are the root cell's, normalised per axis: the world gradient divides by its size.
    vec3 g = cell_gradient_at(k, ta + real((v - a) / (b - a)) * (tb - ta)) / u_root_size;
    vec3 color = shade_surface(tf_at(v).rgb, g, g_dir_world);
    g_acc.rgb += g_acc.a * u_iso_opacity * color;
    g_acc.a *= 1.0 - u_iso_opacity;
  }
#else
#if FOCUS_WINDOWS
  vec4 before = g_acc;
#endif
  optical_integrate(sa, sb, float(tb - ta) / g_len, 1.0, g_acc, g_hint);
#if FOCUS_WINDOWS
  float interest = sample_interest(0.5 * (sa + sb) * u_focus_map.x + u_focus_map.y);
  if (interest < 1.0) g_acc = interest_mix_piece(before, g_acc, interest);
#endif
#endif
}

// The ray's frame (ray_frame.h, Duff et al. 2017) for the walk, once per ray.
void walk_frame(vec3 base, vec3 dir) {
  g_len = length(dir);
  vec3 d = dir / g_len;
  float sgn = d.z < 0.0 ? -1.0 : 1.0;
  float fa = -1.0 / (sgn + d.z);
  float fb = d.x * d.y * fa;
  vec3 e1 = vec3(1.0 + sgn * d.x * d.x * fa, sgn * fb, -sgn * d.x);
  g_origin = base, g_dir = d, g_e1 = e1, g_e2 = cross(d, e1);
  g_stop_transmittance = u_min_transmittance;
}

// The handover from one exact node to the next along the ray (both exact): the cell the walk was in when it passed
// the node's end, by its id in the input mesh, and how the ray entered it (face, corners as slots of the cell's
// vertices, barycentric weights, t, value). A cell crossing a node border is kept by both nodes, so the next node
// looks it up (binary search over its ids) and goes on from there instead of searching its entry triangles: the
// same cell, entered the same way, gives the same pieces, clamped on either side of the border.
bool g_carry = false;
uvec2 g_carry_id;
int g_carry_face;
ivec3 g_carry_slots;
real3 g_carry_lambda;
real g_carry_t;
float g_carry_s;

uvec2 cell_global_id(uint c) { return uvec2(cell_ints[g_cn[4].z + 2u * c], cell_ints[g_cn[4].z + 2u * c + 1u]); }

// The node's cell whose input-mesh id is `id`, or 0xFFFFFFFF.
uint find_cell(uvec2 id) {
  uint lo = 0u, hi = g_cn[4].y;
  while (lo < hi) {
    uint mid = (lo + hi) >> 1;
    uint c = cell_ints[g_cn[4].w + mid];
    uvec2 m = cell_global_id(c);
    if (m == id) return c;
    if (m.y < id.y || (m.y == id.y && m.x < id.x))
      lo = mid + 1u;
    else
      hi = mid;
  }
  return 0xFFFFFFFFu;
}

// Entry triangle i's entering crossing, if it comes after (prev_t, prev_tri) in (t, triangle) order, not before
// min_t, and before the best so far (best, best_t, best_lambda): the exact engine's watertight edge functions.
void test_entry(uint i, real min_t, real prev_t, uint prev_tri, inout uint best, inout real best_t,
                inout real3 best_lambda) {
  uint b0 = cell_ints[g_cn[3].w + 2u * i], b1 = cell_ints[g_cn[3].w + 2u * i + 1u];
  uint c = b0 >> 3;
  int kc = type_index(c);
  ivec4 fv = FACE_V[kc * 6 + int(b0 & 7u)];
  ivec3 cr = ivec3(int(b1 & 3u), int((b1 >> 2) & 3u), int((b1 >> 4) & 3u));
  real3 a = project(point_at(vertex_id(c, kc, fv[cr.x]))), b = project(point_at(vertex_id(c, kc, fv[cr.y])));
  real3 d = project(point_at(vertex_id(c, kc, fv[cr.z])));
  real e_ab = edge_side(a, b), e_bc = edge_side(b, d), e_ca = edge_side(d, a);
  precise real sum = e_ab + e_bc + e_ca;
  if (!(e_ab <= 0.0 && e_bc <= 0.0 && e_ca <= 0.0 && sum < 0.0)) return;
  precise real3 lambda = real3(e_bc / sum, e_ca / sum, e_ab / sum);
  precise real t = lambda.x * a.z + lambda.y * b.z + lambda.z * d.z;
  if (t < min_t || t < prev_t || (t == prev_t && i <= prev_tri && prev_tri != 0xFFFFFFFFu)) return;
  if (t < best_t || (t == best_t && i < best)) best = i, best_t = t, best_lambda = lambda;
}

// The first entering crossing of the node's entry triangles after (prev_t, prev_tri) in (t, triangle) order, not
// before min_t, or best = 0xFFFFFFFF; only crossings before g_t_hi matter to the caller. The node's entry grid
// (cell_cache.h) is walked along the ray from where a crossing could first be (3D DDA), testing the triangles listed
// in each grid cell, until a grid cell ends after the best crossing found: every triangle that could cross the ray
// earlier is listed in a grid cell already visited (its box, grown by ENTRY_GRID_MARGIN, meets the ray there), so the
// result is the linear scan's, bit for bit. A triangle listed in several visited grid cells is tested again, with the
// same result.
const real ENTRY_GRID_MARGIN = 1e-5;  // half of cell_cache.h kEntryGridMargin
void entry_search(real min_t, real prev_t, uint prev_tri, out uint best, out real best_t, out real3 best_lambda) {
  best = 0xFFFFFFFFu, best_t = INF, best_lambda = real3(0.0);
  uint offsets = g_cn[5].x, fb = g_cn[5].y;
  uvec3 n = uvec3(g_cn[5].z & 1023u, (g_cn[5].z >> 10) & 1023u, g_cn[5].z >> 20);
  uint list = offsets + n.x * n.y * n.z + 1u;
  vec3 lo = vec3(cell_floats[fb], cell_floats[fb + 1u], cell_floats[fb + 2u]);
  vec3 h = vec3(cell_floats[fb + 3u], cell_floats[fb + 4u], cell_floats[fb + 5u]);
  // The ray's stretch through the grid's box, from the first t a crossing may have to just past g_t_hi.
  real ta = max(min_t, prev_t) - ENTRY_GRID_MARGIN, tb = g_t_hi + ENTRY_GRID_MARGIN;
  for (int a = 0; a < 3; ++a) {
    real o = g_origin[a], d = g_dir[a], l = lo[a], u = lo[a] + float(n[a]) * h[a];
    if (d == 0.0) {
      if (o < l || o > u) return;
      continue;
    }
    real s0 = (l - o) / d, s1 = (u - o) / d;
    ta = max(ta, min(s0, s1)), tb = min(tb, max(s0, s1));
  }
  if (!(ta <= tb)) return;
  ivec3 c = clamp(ivec3(floor((g_origin + g_dir * ta - lo) / h)), ivec3(0), ivec3(n) - 1);
  ivec3 stp = ivec3(sign(g_dir));
  for (uint guard = 0u; guard < n.x + n.y + n.z + 3u; ++guard) {
    uint cell = uint(c.x) + n.x * (uint(c.y) + n.y * uint(c.z));
    uint e = cell_ints[offsets + cell + 1u];
    for (uint j = cell_ints[offsets + cell]; j < e; ++j) {
      uint i = list == offsets + 2u ? j : (cell_ints[list + (j >> 1)] >> ((j & 1u) << 4)) & 0xFFFFu;
      test_entry(i, min_t, prev_t, prev_tri, best, best_t, best_lambda);
    }
    // Where the ray leaves this grid cell, per axis (recomputed from the cell, not accumulated).
    vec3 tn;
    for (int a = 0; a < 3; ++a)
      tn[a] = stp[a] == 0 ? INF : (lo[a] + float(c[a] + max(stp[a], 0)) * h[a] - g_origin[a]) / g_dir[a];
    real t_out = min(min(tn.x, tn.y), tn.z);
    if (best_t < t_out - ENTRY_GRID_MARGIN || t_out > tb) return;
    int a = tn.x <= tn.y && tn.x <= tn.z ? 0 : tn.y <= tn.z ? 1 : 2;
    c[a] += stp[a];
    if (c[a] < 0 || c[a] >= int(n[a])) return;
  }
}

// Walks cache entry `entry` over the ray's stretch [t0, t1] (LOD t), compositing into g_acc.
void walk_node(uint entry, float t0, float t1) {
  for (int i = 0; i < CELL_NODE_UVEC4S; ++i) g_cn[i] = cell_node[entry * uint(CELL_NODE_UVEC4S) + uint(i)];
  g_t_lo = g_len * t0, g_t_hi = g_len * t1;
  bool entered = false;
  real last_exit = -INF, prev_t = -INF;
  uint prev_tri = 0xFFFFFFFFu;
  uint steps = 0u, max_steps = 4u * g_cn[4].y + 16u;
  const real slack = 1e-6;
  uint carried = g_carry ? find_cell(g_carry_id) : 0xFFFFFFFFu;
  g_carry = false;
  while (!done()) {
    uint cell;
    int k, entry_face;
    real t_in;
    float s_in;
    if (carried != 0xFFFFFFFFu) {
      cell = carried;
      carried = 0xFFFFFFFFu;
      k = type_index(cell);
      load_cell(cell, k);
      for (int i = 0; i < 3; ++i) g_entry_ids[i] = g_vid[g_carry_slots[i]];
      g_entry_lambda = g_carry_lambda;
      entry_face = g_carry_face;
      t_in = g_carry_t;
      s_in = g_carry_s;
      entered = true;
    } else {
      // The first entering crossing after (prev_t, prev_tri) in (t, triangle) order, not before the last exit.
      uint best;
      real best_t;
      real3 best_lambda;
      entry_search(entered ? last_exit - slack : -INF, prev_t, prev_tri, best, best_t, best_lambda);
      if (best == 0xFFFFFFFFu || best_t >= g_t_hi) return;
      prev_t = best_t, prev_tri = best;
      entered = true;
      uint b0 = cell_ints[g_cn[3].w + 2u * best], b1 = cell_ints[g_cn[3].w + 2u * best + 1u];
      cell = b0 >> 3;
      entry_face = int(b0 & 7u);
      ivec3 corners = ivec3(int(b1 & 3u), int((b1 >> 2) & 3u), int((b1 >> 4) & 3u));
      k = type_index(cell);
      load_cell(cell, k);
      Crossing x;
      x.face = entry_face, x.corners = corners, x.lambda = best_lambda, x.t = best_t;
      t_in = best_t;
      s_in = scalar_at_face(cell, k, x);
      ivec4 fv = FACE_V[k * 6 + entry_face];
      for (int i = 0; i < 3; ++i) g_entry_ids[i] = g_vid[fv[corners[i]]];
      g_entry_lambda = best_lambda;
    }
    g_monomials_built = false;
    int stall = 0;
    while (!done()) {
      ++g_cell_steps;
      Crossing o;
      exit_of(cell, k, entry_face, o);
      real t_out = max(o.t, t_in);
      bool stalled = !(t_out > t_in);
      float s_out = scalar_at_face(cell, k, o);
      cell_segment(cell, k, t_in, t_out, s_in, s_out, o);
      if (t_out >= g_t_hi) {
        // Past the node's stretch: the next node goes on, in this cell if it is exact too.
        g_carry = true;
        g_carry_id = cell_global_id(cell);
        g_carry_face = entry_face;
        for (int i = 0; i < 3; ++i) {
          int j = 0;
          while (j < VERTEX_COUNT[k] - 1 && g_vid[j] != g_entry_ids[i]) ++j;
          g_carry_slots[i] = j;
        }
        g_carry_lambda = g_entry_lambda;
        g_carry_t = t_in;
        g_carry_s = s_in;
        return;
      }
      {
        ivec4 fv = FACE_V[k * 6 + o.face];
        for (int i = 0; i < 3; ++i) g_entry_ids[i] = g_vid[fv[o.corners[i]]];
        g_entry_lambda = o.lambda;
      }
      t_in = t_out;
      s_in = s_out;
      stall = stalled ? stall + 1 : 0;
      if (stall > MAX_STALL_STEPS || ++steps > max_steps) return;
      uint next = neighbor(cell, k, o.face);
      if (next == 0xFFFFFFFFu) {  // the mesh's boundary or a cell the node does not keep
        last_exit = t_in;
        break;
      }
      cell = next >> 3;
      entry_face = int(next & 7u);
      k = type_index(cell);
      if (cell_data()) s_in = cell_value(cell);
      load_cell(cell, k);
      g_monomials_built = false;
    }
  }
}
#endif

// Focus+context (Muigg 2007, eq. 3.15): a context segment's mean (rgb colour × extinction, extinction) with its
// colour mixed towards its luminance (Rec. 709 weights), keeping u_context.x of the saturation, and its extinction
// scaled by u_context.y (the opacity of a thin segment scales alike; a thick one saturates more slowly).
vec4 context_sample(vec4 mean) {
  vec3 c = mean.rgb / mean.a;
  float luminance = dot(c, vec3(0.2126, 0.7152, 0.0722));
  float a = mean.a * u_context.y;
  return vec4(mix(vec3(luminance), c, u_context.x) * a, a);
}

vec3 slot_origin(uint slot) {
  uint sx = uint(u_slots.x), sy = uint(u_slots.y);
  return vec3(float(slot % sx), float((slot / sx) % sy), float(slot / (sx * sy))) * float(u_resolution + 2);
}

// World-space gradient of the normalised value at atlas coordinate c of a node whose voxels measure h (world).
vec3 gradient_at(vec3 c, vec3 h) {
  vec3 g;
  g.x = texture(u_atlas, c + vec3(u_atlas_inv.x, 0, 0)).r - texture(u_atlas, c - vec3(u_atlas_inv.x, 0, 0)).r;
  g.y = texture(u_atlas, c + vec3(0, u_atlas_inv.y, 0)).r - texture(u_atlas, c - vec3(0, u_atlas_inv.y, 0)).r;
  g.z = texture(u_atlas, c + vec3(0, 0, u_atlas_inv.z)).r - texture(u_atlas, c - vec3(0, 0, u_atlas_inv.z)).r;
  return g / (2.0 * h);
}

#if TRICUBIC
// The uniform cubic B-spline that interpolates the brick's samples (LaMar 2000 ch. 3: its coefficients, prefiltered
// per brick when the brick uploads, brick_atlas.h), evaluated with 8 linear fetches (Sigg & Hadwiger 2005): along
// each axis the four weights of the 4-texel stencil are positive, so each pair (w0, w1), (w2, w3) is one linear
// fetch between two texels at h = the pair's centre of mass, weighted by g = the pair's sum. The first derivative has
// weights of one sign per pair as well (dw0, dw1 <= 0 <= dw2, dw3), so a partial derivative is 8 fetches too. The
// stencil reaches one texel beyond the cell: at a brick's border that is its 1-texel apron, the coefficient the
// brick's own samples extrapolate (not-a-knot), not the neighbour's data (the seam docs/tricubic.md describes). The
// coefficient texture stores [-1/2, 3/2] of the normalised range as [0, 1].
layout(binding = COEF_TEXTURE_BINDING) uniform sampler3D u_coef;

// axis_weights: x in texel units (texel k's centre at k + 0.5); g0, g1 the pair weights, h0, h1 the pair positions
// (texel units), of the value (deriv false) or of the derivative d/dx (deriv true).
void axis_weights(vec3 x, bvec3 deriv, out vec3 g0, out vec3 g1, out vec3 h0, out vec3 h1) {
  vec3 xs = x - 0.5;
  vec3 i = floor(xs), f = xs - i;
  vec3 f2 = f * f, f3 = f2 * f, r = 1.0 - f;
  vec3 w0 = r * r * r / 6.0, w1 = (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0;
  vec3 w2 = (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0, w3 = f3 / 6.0;
  vec3 d0 = -0.5 * r * r, d1 = 0.5 * f * (3.0 * f - 4.0), d2 = 0.5 * r * (3.0 * f + 1.0), d3 = 0.5 * f2;
  w0 = mix(w0, d0, deriv);
  w1 = mix(w1, d1, deriv);
  w2 = mix(w2, d2, deriv);
  w3 = mix(w3, d3, deriv);
  g0 = w0 + w1;  // value: >= 1/6; derivative: in [-5/8, -1/2], never 0
  g1 = w2 + w3;
  h0 = i - 0.5 + w1 / g0;
  h1 = i + 1.5 + w3 / g1;
}

// The spline's value (or its partial derivative per texel when deriv has that axis) at atlas coordinate c.
float cubic_at(vec3 c, bvec3 deriv) {
  vec3 g0, g1, h0, h1;
  axis_weights(c / u_atlas_inv, deriv, g0, g1, h0, h1);
  h0 *= u_atlas_inv;
  h1 *= u_atlas_inv;
  float v00 = g0.x * texture(u_coef, vec3(h0.x, h0.y, h0.z)).r + g1.x * texture(u_coef, vec3(h1.x, h0.y, h0.z)).r;
  float v10 = g0.x * texture(u_coef, vec3(h0.x, h1.y, h0.z)).r + g1.x * texture(u_coef, vec3(h1.x, h1.y, h0.z)).r;
  float v01 = g0.x * texture(u_coef, vec3(h0.x, h0.y, h1.z)).r + g1.x * texture(u_coef, vec3(h1.x, h0.y, h1.z)).r;
  float v11 = g0.x * texture(u_coef, vec3(h0.x, h1.y, h1.z)).r + g1.x * texture(u_coef, vec3(h1.x, h1.y, h1.z)).r;
  float v = g0.z * (g0.y * v00 + g1.y * v10) + g1.z * (g0.y * v01 + g1.y * v11);
  // The weights sum to 1 for the value, to 0 for a derivative: the storage's offset cancels there.
  return any(deriv) ? 2.0 * v : 2.0 * v - 0.5;
}

// The spline's analytic gradient, world units (h: the node's voxel size, world), 24 fetches: only at a surface.
vec3 cubic_gradient(vec3 c, vec3 h) {
  return vec3(cubic_at(c, bvec3(true, false, false)), cubic_at(c, bvec3(false, true, false)),
              cubic_at(c, bvec3(false, false, true))) /
         h;
}

// Slot `slot`'s cubic margin (brick_atlas.h): |spline - trilinear| <= it anywhere in the slot's cells, normalised
// units.
layout(std430, binding = MARGIN_BUFFER_BINDING) readonly buffer Margins { float slot_margin[]; };
float cubic_margin(uint slot) { return slot_margin[slot]; }

// The value whose sign against each iso value is the spline's, at atlas point c (trilinear value and stencil vt): vt
// itself where it is farther than `margin` from every iso value (then the spline is on the same side of each), else
// the spline's value (8 fetches). So the samples bracket exactly the crossings the spline has between them, at the
// price of the trilinear path plus the spline near the surface.
float bracket_value(vec3 c, float vt, float margin) {
  for (int i = 0; i < u_iso_count; ++i)
    if (abs(vt - iso_value(i)) < margin) return cubic_at(c, bvec3(false));
  return vt;
}

// The crossing of iso between ta (value fa) and tb (fb) on opposite sides, on the spline along the ray (atlas point
// c0 + c1 t): regula falsi with the Illinois fix (the end that stays twice has its residual halved, so neither end
// sticks), 4 steps of 8 fetches; then the secant through the last bracket.
float cubic_crossing(float ta, float fa, float tb, float fb, float iso, vec3 c0, vec3 c1) {
  float ra = fa - iso, rb = fb - iso;
  int side = 0;
  for (int it = 0; it < 4; ++it) {
    float tm = ta + ra / (ra - rb) * (tb - ta);
    float rm = cubic_at(c0 + c1 * tm, bvec3(false)) - iso;
    if ((rm < 0.0) == (ra < 0.0)) {
      ta = tm;
      ra = rm;
      if (side == -1) rb *= 0.5;
      side = -1;
    } else {
      tb = tm;
      rb = rm;
      if (side == 1) ra *= 0.5;
      side = 1;
    }
  }
  return ra == rb ? 0.5 * (ta + tb) : ta + ra / (ra - rb) * (tb - ta);
}
#endif

#if TRICUBIC_WALK
// The spline stays out of the sample loop (llvmpipe pays for a branch's body at every sample whether or not a pixel of
// its SIMD group takes it, so a spline evaluated at a few samples costs as much as at all of them). The walk samples
// the trilinear value only; a segment whose ends' trilinear values are both farther than the slot's cubic margin
// from every iso value, on the same side, has no sign change of the spline either. The first segment that may have
// one (a candidate: trilinear signs differ, or an end within the margin whose spline sign is not known) stops the
// walk; after it the spline decides at the ends (16 fetches), locates and shades the crossings there (regula falsi
// and the gradient), goes on along the node's samples on the spline while their trilinear value stays within the
// margin, and the walk resumes at the last one with the spline's value there as a known sign. Each candidate is one
// round of the loop around the walk (at most TRICUBIC_ROUNDS: a ray with more candidates ends there), so a group of
// pixels pays the spline once per round, not once per sample.
#define TRICUBIC_ROUNDS 8
bool g_cand;
float g_cand_ta, g_cand_fa, g_cand_tb, g_cand_t, g_cand_transmittance;
bool g_cand_sure;  // the spline's sign at ta is g_cand_fa's (no evaluation needed there)
vec3 g_cand_c0, g_cand_c1, g_cand_voxel;
float g_cand_step, g_cand_exit, g_cand_margin;  // the node's sample step, exit and cubic margin
#define TRICUBIC_STEPS 16  // samples on the spline per round, while the trilinear value stays within the margin
#endif

vec3 shade_surface(vec3 color, vec3 g, vec3 view) {
  float len = length(g);
  if (!u_lighting || !(len > 0.0)) return color;
  float c = abs(dot(g, view)) / len;
  return min(color * (AMBIENT + DIFFUSE * c) + vec3(SPECULAR * pow(c, SHININESS)), vec3(1.0));
}

#if OVERLAY
// The boundary overlay: the boundary of the valid region as the samples see it. The validity V(p) of a point is the
// filtered stencil of the cut node containing it, 0 outside the root cell and in empty (or culled) octants; the ray is
// inside the data where V >= 1/2, and wherever that changes between two samples the crossing is located by bisection
// on V and the overlay composited there, shaded by the gradient of V (docs/lod-engine.md, "Boundary overlay").
vec3 g_base, g_dir;  // the ray: point base + dir · t, normalised coordinates

// The cut node at normalised point p (descent from the root as in main): its atlas slot or NODE_SKIP; its box lo,
// size.
uint locate(vec3 p, out vec3 lo, out float size) {
  lo = vec3(0.0);
  size = 1.0;
  if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return NODE_SKIP;
  uint node = 0u;
  int level = 0;
  uint state = node_state[0];
  while (state == NODE_DESCEND && level < 31) {
    vec3 centre = lo + 0.5 * size;
    uvec3 o = uvec3(greaterThanEqual(p, centre));
    uint octant = o.x | (o.y << 1) | (o.z << 2);
    size *= 0.5;
    lo += vec3(o) * size;
    ++level;
    uvec2 tn = tree[node];
    uint mask = tn.y & TREE_CHILD_MASK;
    if ((mask & (1u << octant)) == 0u) return NODE_SKIP;
    node = tn.x + uint(bitCount(mask & ((1u << octant) - 1u)));
    state = node_state[node];
  }
  return state >= NODE_DESCEND ? NODE_SKIP : state & ~NODE_CONTEXT;
}

float validity(vec3 p) {
  vec3 lo;
  float size;
  uint slot = locate(p, lo, size);
  if (slot == NODE_SKIP) return 0.0;
  return texture(u_atlas, (slot_origin(slot) + 1.5 + (p - lo) * (float(u_resolution - 1) / size)) * u_atlas_inv).g;
}

// The crossing between ta, on the side `a_inside`, and tb, on the other: bisection on V (12 halvings: the interval is
// usually one sample step, so the error is well below a voxel's thousandth). Returns the crossing and the last point
// known to be on its valid side (V >= 1/2 there: a node with a brick, next to the crossing).
vec2 boundary_crossing(float ta, float tb, bool a_inside) {
  for (int i = 0; i < 12; ++i) {
    float tm = 0.5 * (ta + tb);
    if ((validity(g_base + g_dir * tm) >= 0.5) == a_inside) ta = tm;
    else tb = tm;
  }
  return vec2(0.5 * (ta + tb), a_inside ? ta : tb);
}

// V for the normal at q: 0 where the cut has no data there, else the stencil of one node's brick (slot, box lo,
// size), read up to 3/8 voxel outside the node (the apron repeats its border). Reading a neighbour's brick
// instead would put the step between the boundaries of two levels (half of either's voxel out) into the normal.
float validity_near(vec3 q, uint slot, vec3 lo, float size) {
  vec3 lo2;
  float size2;
  if (locate(q, lo2, size2) == NODE_SKIP) return 0.0;
  return texture(u_atlas, (slot_origin(slot) + 1.5 + (q - lo) * (float(u_resolution - 1) / size)) * u_atlas_inv).g;
}

// Composites the overlay at the crossing x.x; x.y is a point on its valid side, whose node gives the brick and the
// scale h: a quarter of its voxel (the stencil then reaches at most 3/8 voxel outside the node: its apron). The
// normal is the world gradient of V (validity_near) by central differences ±h. V is 0 outside the cut, so a boundary
// on a node face or the root's face, where G itself is 1 right up to the face, has one too. The differences are
// taken about a point h/2 inside along the ray: about the crossing itself, those along a boundary lying on a node
// face would fall on that face, in either node by rounding (noise). Where the gradient vanishes, the view direction;
// shade_surface is two-sided, so orientation is moot.
void composite_overlay(vec2 x, vec3 dir_world, inout vec3 radiance, inout float transmittance) {
  float tc = x.x, side = x.y >= x.x ? 1.0 : -1.0;
  vec3 lo;
  float size;
  uint slot = locate(g_base + g_dir * x.y, lo, size);
  vec3 g = dir_world;
  if (slot != NODE_SKIP) {
    float h = 0.25 * size / float(u_resolution - 1);
    float shift = 0.5 * h * min(u_root_size.x, min(u_root_size.y, u_root_size.z));
    vec3 p = g_base + g_dir * (tc + side * shift);
    vec3 d = vec3(validity_near(p + vec3(h, 0, 0), slot, lo, size) - validity_near(p - vec3(h, 0, 0), slot, lo, size),
                  validity_near(p + vec3(0, h, 0), slot, lo, size) - validity_near(p - vec3(0, h, 0), slot, lo, size),
                  validity_near(p + vec3(0, 0, h), slot, lo, size) - validity_near(p - vec3(0, 0, h), slot, lo, size)) /
             (2.0 * h * u_root_size);
    if (length(d) > 0.0) g = d;
  }
  vec3 color = shade_surface(OVERLAY_COLOR, g, dir_world);
  radiance += transmittance * u_overlay_opacity * color;
  transmittance *= 1.0 - u_overlay_opacity;
}

#if FACES
// The overlay on a boundary face: its own normal (normalised coordinates; world normals scale by 1 / root size).
void composite_face(vec3 n, vec3 dir_world, inout vec3 radiance, inout float transmittance) {
  vec3 color = shade_surface(OVERLAY_COLOR, n / u_root_size, dir_world);
  radiance += transmittance * u_overlay_opacity * color;
  transmittance *= 1.0 - u_overlay_opacity;
}
#endif
#endif

// The samples of one node (atlas line c0 + c1·t, sample step, world voxel size, cubic margin, context) from tstart to
// its exit t_exit (t: where the ray entered it); the ray's accumulation (radiance onwards) carried from node to node.
// `crossings` is a literal at each call (march_node's two passes) and every call is inlined, so the first pass's
// loop has no crossing code at all (fstate is -1 there: the stencil decides) and only the second's pays for it.
// First pass, fpend: the node has faces not yet looked at; the loop stops at the first sample near the boundary
// (returns true, tstart set where the second pass starts).
bool sample_run(const bool crossings, float t, float t_exit, vec3 c0, vec3 c1, float step, vec3 voxel, float margin,
                bool context, bool fpend, int fstate, inout float tstart, vec3 dir_world, float t_end, float t_base,
                float vol_lo, float vol_hi, inout vec3 radiance, inout float transmittance, inout float mip_max,
                inout uint samples, inout bool have_prev, inout float prev_value, inout float prev_t,
                inout bool prev_sure, inout bool ov_inside, inout float ov_t, inout int sj) {
  bool restart = false;
#if FACES
  // fj: the next crossing to pass. fnext: g_fh[fj], or beyond any sample when there is none or the stencil decides:
  // the sample loop compares each sample with this one float, where reading g_fh[fj] cost llvmpipe a gather per
  // sample (fj differs between the lanes) even where no face was ever looked at.
  int fj = 0;
  float fnext = crossings && fstate >= 0 && g_nh > 0 ? g_fh[0] : 3.0e38;
#endif
  float k = floor(tstart / step);
  float sa = tstart;
  vec2 va = vec2(0.0);
#if MODE == LOD_MODE_EA
  vec4 ia = vec4(0.0);  // the integrals at the previous sample's value
#endif
#if MODE == LOD_MODE_EA && VOLUME_LIGHTING
  float shade_a = 1.0;
#endif
  for (float sb = tstart;;) {
    vec3 c = c0 + c1 * sb;
#if TRICUBIC && !TRICUBIC_WALK
    // The stencil trilinear (as in the trilinear path), the value the spline's wherever its sign could differ.
    vec2 vb = texture(u_atlas, c).rg;
    vb.r = bracket_value(c, vb.r, margin);
#else
    vec2 vb = texture(u_atlas, c).rg;
#endif
#if SLICES
    float stencil_b = vb.g;  // before the faces' state replaces it (below)
#endif
    ++samples;
    bool first = sb == tstart;
#if FACES
    if (!crossings && fpend && ((vb.g > 0.001 && vb.g < 0.999) || (!first && (vb.g >= 0.5) != (va.g >= 0.5)))) {
      fpend = false;
      restart = true;
      tstart = first ? tstart : sa;
      break;
    }
    if (crossings && fstate >= 0) {  // the segment [sa, sb] lies wholly on one side of the faces
      va.g = vb.g = fstate == 1 ? 1.0 : 0.0;
    }
#endif
#if OVERLAY
    // The overlay's state is read at each segment's midpoint tm, never at a node's faces: there the point just
    // inside a crossing, whose node gives the normal's brick, could be located in the neighbour by rounding. A
    // change between ov_t and tm: entering, the overlay lies before this segment's valid part; leaving, after it.
    // (Past t_end only where the last node's exit passes it by rounding: outside the ray, no state.)
    float tm = 0.5 * (sa + sb);
    bool ov_state = !first && tm < t_end;
#if FACES
    bool ov_cross = ov_state && (!crossings || fstate < 0) && (texture(u_atlas, c0 + c1 * tm).g >= 0.5) != ov_inside;
#else
    bool ov_cross = ov_state && (texture(u_atlas, c0 + c1 * tm).g >= 0.5) != ov_inside;
#endif
    bool ov_leave = ov_cross && ov_inside;
    if (ov_cross && !ov_inside) {
      composite_overlay(boundary_crossing(ov_t, tm, false), dir_world, radiance, transmittance);
      ov_inside = true;
      if (transmittance <= u_min_transmittance) break;
    }
#endif
#if MODE == LOD_MODE_EA
    {
#if VOLUME_LIGHTING
      // The shade at each sample (the gradient where the data there is not transparent); a segment takes the mean
      // of its ends'.
      float shade_b = 1.0;
      if (vb.g >= 0.5 && tf_at(vb.r).a > 0.0) {
        vec3 g = gradient_at(c, voxel);
        float gl = length(g);
        if (gl > 0.0) shade_b = AMBIENT + DIFFUSE * abs(dot(g, dir_world)) / gl;
      }
      float shade = 0.5 * (shade_a + shade_b);
      shade_a = shade_b;
#else
      const float shade = 1.0;
#endif
      bool ga = va.g >= 0.5, gb = vb.g >= 0.5;
      float ua = va.r * u_tf_map.x + u_tf_map.y, ub = vb.r * u_tf_map.x + u_tf_map.y;
      vec4 ib = integral_at(ub);
#if SLICES
      float tmid = 0.5 * (sa + sb);
      bool shown = tmid >= vol_lo && tmid <= vol_hi;
#else
      const bool shown = true;
#endif
      if (!first && (ga || gb) && shown) {
        float len = sb - sa;
        vec4 mean;
        float um = 0.5 * (ua + ub);  // the segment's middle value (of its valid part), for its interest
        if (ga && gb && abs(ub - ua) >= 0.5 / (float(TF_TEXELS) - 1.0)) {
          mean = (ib - ia) / (ub - ua);
        } else {
          // The value is linear between the samples. Where only one end is valid, the stencil's 1/2 crossing (linear
          // between them) ends the data, and the value is the same line up to there.
          float u0 = ua, u1 = ub;
          if (!(ga && gb)) {
            float f = clamp((0.5 - va.g) / (vb.g - va.g), 0.0, 1.0);
            float uf = mix(ua, ub, f);
            if (ga) {
              u1 = uf;
              len *= f;
            } else {
              u0 = uf;
              len *= 1.0 - f;
            }
          }
          um = 0.5 * (u0 + u1);
          vec4 p = texture(u_tf, (clamp(um, 0.0, 1.0) * (float(TF_TEXELS) - 1.0) + 0.5) / float(TF_TEXELS));
          mean = vec4(p.rgb * p.a, p.a);
        }
        if (context && mean.a > 0.0) mean = context_sample(mean);
#if FOCUS_WINDOWS
        if (!context) {
          // Smooth brush edges: the focus border follows the values, not the nodes. Interest 1 leaves the segment
          // as it was, bit for bit.
          float interest = sample_interest(um);
          mean = interest < 1.0 ? interest_mix(mean, interest) : mean;
        }
#endif
        if (mean.a > 0.0) {
          float a = 1.0 - exp(-mean.a * len);
          radiance += transmittance * a * shade * (mean.rgb / mean.a);
          transmittance *= 1.0 - a;
        }
      }
      ia = ib;
    }
#elif MODE == LOD_MODE_MIP
#if SLICES
    if (vb.g >= 0.5 && sb >= vol_lo && sb <= vol_hi) mip_max = max(mip_max, vb.r);
#else
    if (vb.g >= 0.5) mip_max = max(mip_max, vb.r);
#endif
#elif TRICUBIC_WALK
    if (vb.g < 0.5) {
      have_prev = false;
    } else if (!(have_prev && sb <= prev_t)) {  // a resumed walk's first sample: the known one stays
      bool sure = true;  // the spline's sign here is the trilinear value's for every iso value
      bool crosses = false;
      for (int i = 0; i < u_iso_count; ++i) {
        float iso = iso_value(i);
        sure = sure && abs(vb.r - iso) >= margin;
        crosses = crosses || (have_prev && (prev_value < iso) != (vb.r < iso));
      }
      if (have_prev && (crosses || !sure || !prev_sure)) {
        g_cand = true;
        g_cand_ta = max(prev_t, t), g_cand_fa = prev_value, g_cand_sure = prev_sure, g_cand_tb = sb;
        g_cand_t = t, g_cand_c0 = c0, g_cand_c1 = c1, g_cand_voxel = voxel;
        g_cand_step = step, g_cand_exit = t_exit, g_cand_margin = margin;
        g_cand_transmittance = transmittance;
        transmittance = 0.0;  // stops the walk
      }
      have_prev = true;
      prev_value = vb.r;
      prev_t = sb;
      prev_sure = sure;
    }
#else
    if (vb.g < 0.5) {
      have_prev = false;
    } else {
      if (have_prev && vb.r != prev_value) {
        bool up = vb.r > prev_value;
        for (int i = 0; i < u_iso_count; ++i) {
          float iso = iso_value(up ? i : u_iso_count - 1 - i);
          if ((prev_value < iso) == (vb.r < iso)) continue;
#if TRICUBIC
          // Bracketed by the samples (their signs are the spline's: bracket_value), located on the spline (a
          // crossing of the previous node's last segment has prev_t at this node's entry t, up to rounding:
          // searched from t in this node's brick).
          float th = cubic_crossing(max(prev_t, t), prev_value, sb, vb.r, iso, c0, c1);
#else
          float th = prev_t + (iso - prev_value) / (vb.r - prev_value) * (sb - prev_t);
#endif
#if SLICES
          if (th < vol_lo || th > vol_hi) continue;
#endif
          vec3 ch = c0 + c1 * max(th, t);  // a crossing just before this brick: its entry
#if TRICUBIC
          vec3 color = shade_surface(tf_at(iso).rgb, cubic_gradient(ch, voxel), dir_world);
#else
          vec3 color = shade_surface(tf_at(iso).rgb, gradient_at(ch, voxel), dir_world);
#endif
          radiance += transmittance * u_iso_opacity * color;
          transmittance *= 1.0 - u_iso_opacity;
        }
      }
      have_prev = true;
      prev_value = vb.r;
      prev_t = sb;
    }
#endif
#if OVERLAY
    if (ov_leave) {
      composite_overlay(boundary_crossing(ov_t, tm, true), dir_world, radiance, transmittance);
      ov_inside = false;
    }
    if (ov_state) ov_t = tm;
#endif
#if FACES
    // Passing crossings at sb (those within u_nudge of it are one, their signs summed): the state after them.
    if (crossings && fnext <= sb) {
      float sum = 0.0;
#if OVERLAY
      vec3 fn = vec3(0.0);
#endif
      for (; fj < g_nh && g_fh[fj] <= sb + u_nudge; ++fj) {
        sum += g_fs[fj];
#if OVERLAY
        fn = g_fn[fj];
#endif
      }
      int next = sum > 0.0 ? 1 : sum < 0.0 ? 0 : fstate;
#if OVERLAY
      if (next != fstate && sb < t_end) {
        composite_face(fn, dir_world, radiance, transmittance);
        ov_inside = next == 1;
        ov_t = sb;
      }
#endif
      fstate = next;
      fnext = fj < g_nh ? g_fh[fj] : 3.0e38;
    }
#endif
#if SLICES
    // The slices at this sample (it was put on their crossing): inside the data, the brick's value there. Inside:
    // where the stencil is wholly valid, even if the faces' state says otherwise (a seam of the mesh, such as an
    // O-grid's cut, has faces on both sides whose crossings may leave the state wrong over a segment: too short to
    // see in the volume, a crack in a slice); near the boundary (the stencil strictly between), the faces' state.
    bool slice_inside = stencil_b >= 0.999 || (stencil_b > 0.001 && vb.g >= 0.5);
    for (; sj < g_ns && g_st[sj] <= sb; ++sj)
      if (slice_inside) composite_slice(g_si[sj], vb.r, c, voxel, t_base + sb, dir_world, radiance, transmittance);
#endif
    if (transmittance <= u_min_transmittance || sb >= t_exit) break;
    sa = sb;
    va = vb;
    // The next grid point past sa (float rounding may need a second try), or the exit; with faces, or the next
    // crossing if that comes first.
    do {
      k += 1.0;
      sb = min(k * step, t_exit);
    } while (!(sb > sa));
    float sb_grid = sb;
#if FACES
    if (crossings && fnext < sb) {
      sb = max(fnext, sa);
      if (!(sb > sa)) sb = min(sa + u_nudge, t_exit);
    }
#endif
#if SLICES
    if (sj < g_ns && g_st[sj] < sb) sb = g_st[sj];  // > sa: those up to sa are passed
#endif
    if (sb < sb_grid) k -= 1.0;  // the grid point stays ahead
  }
  return restart;
}

// One cut node's brick (main's walk found it: tree index, state (slot and NODE_CONTEXT), box lo, size and level),
// from the ray's entry t to its exit t_exit. `faces_pass` is a literal at each call (main's two loops): false, the
// first pass, sample_run until the node's exit or until it stops near the boundary (returns true, tstart set where it
// stopped); true, the node's faces and sample_run again from tstart with their crossings.
bool march_node(const bool faces_pass, uint node, uint state, vec3 lo, float size, int level, float t, float t_exit, vec3 base, vec3 dir,
                vec3 inv_dir, vec3 dir_world, float t_end, float t_base, float vol_lo, float vol_hi,
                inout vec3 radiance, inout float transmittance, inout float mip_max, inout uint samples,
                inout bool have_prev, inout float prev_value, inout float prev_t, inout bool prev_sure,
                inout bool ov_inside, inout float ov_t, inout int sj, inout float tstart) {
  // Focus+context: a node of zero interest is drawn as context (context_sample); its state is its slot otherwise.
  bool context = (state & NODE_CONTEXT) != 0u;
  state &= ~NODE_CONTEXT;
  // The atlas coordinate is affine in t inside one node: c(t) = c0 + c1 · t.
  vec3 scale = vec3(float(u_resolution - 1) / size) * u_atlas_inv;
  vec3 c0 = (slot_origin(state) + 1.5) * u_atlas_inv + (base - lo) * scale;
  vec3 c1 = dir * scale;
  float step = u_fixed_step ? u_step0 : u_step0 / float(1 << level);
  vec3 voxel = u_root_size * (size / float(u_resolution - 1));
  float margin = 0.0;
#if TRICUBIC
  margin = cubic_margin(state);
#endif
#if FACES
  // The faces are looked at lazily: only once the stencil along the ray is neither wholly valid nor wholly empty (a
  // sample strictly between, or a change), i.e. near the boundary; before that the stencil is the faces' answer (up
  // to a feature thinner than a voxel). Most rays through a node the boundary crosses never come near it. Then the
  // first pass stops before that sample's segment, the faces are intersected from the previous sample on (fstate:
  // inside the mesh (1) or not (0) at tstart; -1: the stencil decides), and a second pass starts there with their
  // crossings (node_faces stays out of the sample loop, whose code llvmpipe compiles far slower with it inside). The
  // first pass has no crossing code (sample_run): on llvmpipe each branch of the sample loop costs on every sample
  // whether taken or not (8 rays a SIMD vector, masks, more live values), and most samples, in nodes without faces
  // and in those with faces before the trigger, need none of it.
  bool fpend = face_node[node].y != 0u;
#else
  const bool fpend = false;
#endif
  if (!faces_pass) {
    // Samples at the node's entry t, at the level's grid points k·step inside, and at its exit; sa, va: the previous
    // sample of this node (none before the entry).
    tstart = t;
    return sample_run(false, t, t_exit, c0, c1, step, voxel, margin, context, fpend, -1, tstart, dir_world, t_end,
                      t_base, vol_lo, vol_hi, radiance, transmittance, mip_max, samples, have_prev, prev_value, prev_t,
                      prev_sure, ov_inside, ov_t, sj);
  }
#if FACES
  int fstate = node_faces(node, lo, size, base, dir, inv_dir, tstart, t_exit, u_nudge);
#if OVERLAY
  if (fstate >= 0) ov_inside = fstate == 1;  // the faces know better than the stencil
#endif
  sample_run(true, t, t_exit, c0, c1, step, voxel, margin, context, false, fstate, tstart, dir_world, t_end, t_base,
             vol_lo, vol_hi, radiance, transmittance, mip_max, samples, have_prev, prev_value, prev_t, prev_sure,
             ov_inside, ov_t, sj);
#endif
  return false;
}

void main() {
  ivec2 pix = ivec2(gl_GlobalInvocationID.xy) + u_band_origin;
  if (pix.x >= u_size.x || pix.y >= u_size.y) return;
  vec2 s = vec2(2.0 * (float(pix.x) + 0.5) / float(u_size.x) - 1.0, 1.0 - 2.0 * (float(pix.y) + 0.5) / float(u_size.y));
  vec3 offset = u_right * (s.x * u_half.x) + u_up * (s.y * u_half.y);
  vec3 dir_world = u_parallel ? u_forward : normalize(u_forward + offset);
  vec3 origin = u_parallel ? u_eye + offset / u_root_size : u_eye;
  vec3 dir = dir_world / u_root_size;

  vec3 radiance = vec3(0.0);
  float transmittance = 1.0;
  float mip_max = -1.0;

  // The root cell [0, 1]³; rays are lines, contributions start at t >= 0 (the eye or the parallel near plane).
  vec3 safe_dir = mix(dir, vec3(1e-30), equal(dir, vec3(0.0)));
  vec3 inv_dir = 1.0 / safe_dir;
  vec3 ta = (vec3(0.0) - origin) * inv_dir, tb = (vec3(1.0) - origin) * inv_dir;
  float t_in = max(max(min(ta.x, tb.x), min(ta.y, tb.y)), min(ta.z, tb.z));
  float t_out = min(min(max(ta.x, tb.x), max(ta.y, tb.y)), max(ta.z, tb.z));
  float t_base = max(t_in, 0.0);
  vec3 base = origin + dir * t_base;  // t below is measured from here
  float t = 0.0, t_end = t_out - t_base;
  if (u_clip) {
    float f0 = dot(u_clip_plane.xyz, base) + u_clip_plane.w, df = dot(u_clip_plane.xyz, dir);
    if (df > 0.0) t = max(t, -f0 / df);
    else if (df < 0.0) t_end = min(t_end, -f0 / df);
    else if (f0 < 0.0) t_end = -1.0;
  }
  if (u_box_lo.w > 0.5) {
    // This rank's kd-tree box (src/ugvr/mpi): a t-range limit like the clip plane's, so neighbouring boxes' ranges
    // meet at the same t (the same float plane, the same arithmetic).
    vec3 ba = (u_box_lo.xyz - base) * inv_dir, bb = (u_box_hi.xyz - base) * inv_dir;
    t = max(t, max(max(min(ba.x, bb.x), min(ba.y, bb.y)), min(ba.z, bb.z)));
    t_end = min(t_end, min(min(max(ba.x, bb.x), max(ba.y, bb.y)), max(ba.z, bb.z)));
  }
  // Declared whatever the variant (march_node takes them; unused, they fold away): the volume's t-range and the next
  // slice crossing (SLICES), the overlay's state (OVERLAY), the tricubic walk's sign (TRICUBIC_WALK).
  float vol_lo = -3.0e38, vol_hi = 3.0e38;
  int sj = 0;  // the next crossing to pass
  bool ov_inside = false;
  float ov_t = t;
  bool prev_sure = true;
#if SLICES
  // The crossings in [t, t_end], sorted; the volume shows in [vol_lo, vol_hi] only (hide_volume: front keeps each
  // plane's negative side, back its positive side). Each bound is a crossing, hence a sample: a segment between two
  // samples is wholly in or out, decided at its middle.
  g_ns = 0;
  if (u_hide_volume == 3) vol_lo = 1.0, vol_hi = -1.0;
  for (int i = 0; i < u_slice_count; ++i) {
    float f0 = dot(u_slice_plane[i].xyz, base) + u_slice_plane[i].w, df = dot(u_slice_plane[i].xyz, dir);
    if (u_hide_volume == 1 || u_hide_volume == 2) {
      float sg = u_hide_volume == 2 ? 1.0 : -1.0;  // keep sg · f >= 0
      if (sg * df > 0.0) vol_lo = max(vol_lo, -f0 / df);
      else if (sg * df < 0.0) vol_hi = min(vol_hi, -f0 / df);
      else if (sg * f0 < 0.0) vol_hi = -1.0, vol_lo = 1.0;
    }
    if (df == 0.0) continue;
    float ts = -f0 / df;
    if (!(ts >= t && ts <= t_end)) continue;
    int j = g_ns++;
    for (; j > 0 && g_st[j - 1] > ts; --j) {
      g_st[j] = g_st[j - 1];
      g_si[j] = g_si[j - 1];
    }
    g_st[j] = ts;
    g_si[j] = i;
  }
#endif
#if OVERLAY
  // Like the exact engine's faces: crossings between the ray's start and end only. A ray that starts at the root
  // cell's entry starts outside the data; one that starts at the eye or the clip plane starts in whatever state V has
  // there (the clip plane's cut and the eye are no boundary). ov_t: the last point whose state (ov_inside) is known.
  g_base = base;
  g_dir = dir;
  bool clip_end = t_end < t_out - t_base;
  bool ov_ran = t < t_end;  // the ray has a stretch to walk at all
  if (ov_ran && (t > 0.0 || t_in < 0.0)) ov_inside = validity(base + dir * (t + u_nudge)) >= 0.5;
#endif

  bool have_prev = false;
  float prev_value = 0.0, prev_t = 0.0;
  uint samples = 0u, bricks = 0u;
#if MODE == LOD_MODE_EA
  vec4 end_lo = texture(u_tf, 0.5 / float(TF_TEXELS)), end_hi = texture(u_tf, 1.0 - 0.5 / float(TF_TEXELS));
  g_tf_lo = vec4(end_lo.rgb * end_lo.a, end_lo.a);
  g_tf_hi = vec4(end_hi.rgb * end_hi.a, end_hi.a);
#endif
#if HYBRID
  walk_frame(base, dir);
  g_dir_world = dir_world;
#endif
#if TRICUBIC_WALK
  for (int round = 0; round < TRICUBIC_ROUNDS; ++round) {  // not indented: the walk inside is everyone's
  g_cand = false;
#endif
  int guard = 0;
#if FACES
  // The face passes are batched (docs/lod-engine.md, "Exact boundary", "Batched"): a ray whose first pass stops near
  // the boundary leaves the node loop with the node it stopped in (f_*), the others go on for up to
  // LOD_FACE_BATCH_NODES node steps, and then the stopped rays' faces and second passes run together, once. On
  // llvmpipe (8 rays a SIMD vector, with masks) the face code runs whether any ray of the vector needs it or not, and
  // a loop's body at least once: in every node step it cost about as much as the faces' actual work.
  for (int fround = 0; fround < 65536; ++fround) {  // not indented: the node loop inside is everyone's
  bool f_pending = false;
  uint f_node = 0u, f_state = 0u;
  vec3 f_lo = vec3(0.0);
  float f_size = 0.0, f_t = 0.0, f_exit = 0.0, f_start = 0.0;
  int f_level = 0;
  for (int batch = 0; batch < LOD_FACE_BATCH_NODES && guard < 65536 && t < t_end &&
                      transmittance > u_min_transmittance; ++batch, ++guard) {
#else
  for (; guard < 65536 && t < t_end && transmittance > u_min_transmittance; ++guard) {
#endif
    // Point location: descend from the root to the cut node (or empty region) just past t.
    vec3 p = base + dir * (t + u_nudge);
    uint node = 0u;
    vec3 lo = vec3(0.0);
    float size = 1.0;
    int level = 0;
    uint state = node_state[0];
    while (state == NODE_DESCEND && level < 31) {
      vec3 centre = lo + 0.5 * size;
      uvec3 o = uvec3(greaterThanEqual(p, centre));
      uint octant = o.x | (o.y << 1) | (o.z << 2);
      size *= 0.5;
      lo += vec3(o) * size;
      ++level;
      uvec2 tn = tree[node];
      uint mask = tn.y & TREE_CHILD_MASK;
      if ((mask & (1u << octant)) == 0u) {
        state = NODE_SKIP;
        break;
      }
      node = tn.x + uint(bitCount(mask & ((1u << octant) - 1u)));
      state = node_state[node];
    }
    // The exit face on each axis is the one safe_dir moves towards: for a zero component (safe_dir +1e-30) the
    // upper face, so that axis's exit is far ahead; choosing by dir would put it far behind, and the ray would creep
    // on by u_nudge per step (the middle column or row of an odd-sized image).
    vec3 tx = ((lo + mix(vec3(0.0), vec3(size), greaterThan(safe_dir, vec3(0.0)))) - base) * inv_dir;
    float t_exit = min(min(tx.x, tx.y), min(tx.z, t_end));
    t_exit = max(t_exit, t + u_nudge);
#if HYBRID
    if (state >= NODE_DESCEND || (state & NODE_EXACT) == 0u) g_carry = false;  // a handover only between exact nodes
#endif
    if (state == NODE_SKIP || state == NODE_DESCEND) {
      have_prev = false;
#if SLICES
      while (sj < g_ns && g_st[sj] < t_exit) ++sj;  // outside the data: no slice
#endif
#if OVERLAY
      if (ov_inside) {  // leaving the data for an empty octant: the crossing lies before t
        composite_overlay(boundary_crossing(ov_t, t, true), dir_world, radiance, transmittance);
        ov_inside = false;
      }
      ov_t = min(t_exit, t_end);
#endif
      t = t_exit;
      continue;
    }
#if HYBRID
    if ((state & NODE_EXACT) != 0u) {
      g_acc = vec4(radiance, transmittance);
      walk_node(state & ~NODE_EXACT, t, min(t_exit, t_end));
      radiance = g_acc.rgb, transmittance = g_acc.a;
      have_prev = false;  // the next node's samples start at its entry: no isosurface crossing spans this one
      ++bricks;
      t = t_exit;
      continue;
    }
#endif

    ++bricks;
    float tstart = t;
    bool stopped = march_node(false, node, state, lo, size, level, t, t_exit, base, dir, inv_dir, dir_world, t_end,
                              t_base, vol_lo, vol_hi, radiance, transmittance, mip_max, samples, have_prev, prev_value,
                              prev_t, prev_sure, ov_inside, ov_t, sj, tstart);
#if FACES
    if (stopped) {  // near the boundary: this node's faces wait for the batch's end
      f_pending = true;
      f_node = node, f_state = state, f_lo = lo, f_size = size, f_level = level;
      f_t = t, f_exit = t_exit, f_start = tstart;
      break;
    }
#endif
    t = t_exit;
  }
#if FACES
  if (f_pending) {
    march_node(true, f_node, f_state, f_lo, f_size, f_level, f_t, f_exit, base, dir, inv_dir, dir_world, t_end, t_base,
               vol_lo, vol_hi, radiance, transmittance, mip_max, samples, have_prev, prev_value, prev_t, prev_sure,
               ov_inside, ov_t, sj, f_start);
    t = f_exit;
  } else if (!(guard < 65536 && t < t_end && transmittance > u_min_transmittance)) {
    break;
  }
  }
#endif
#if TRICUBIC_WALK
  if (!g_cand) break;
  // The candidate segment [ta, tb] of the node whose atlas line is c0 + c1 t: the spline's values at its ends, then
  // each iso value whose sign differs, in the order the ray meets them, located and composited.
  transmittance = g_cand_transmittance;
  float ta = g_cand_ta, tb = g_cand_tb;
  // At the node's entry the known value is the previous brick's: this brick's spline there instead (as the sample
  // loop's path takes it), so that a crossing at a brick border is located on one spline.
  bool known = g_cand_sure && ta > g_cand_t;
  float fa = known ? g_cand_fa : cubic_at(g_cand_c0 + g_cand_c1 * ta, bvec3(false));
  float fb = cubic_at(g_cand_c0 + g_cand_c1 * tb, bvec3(false));
  for (int n = 0; n < TRICUBIC_STEPS; ++n) {
    bool up = fb > fa;
    for (int i = 0; i < u_iso_count; ++i) {
      float iso = iso_value(up ? i : u_iso_count - 1 - i);
      if ((fa < iso) == (fb < iso)) continue;
      float th = cubic_crossing(ta, fa, tb, fb, iso, g_cand_c0, g_cand_c1);
      vec3 ch = g_cand_c0 + g_cand_c1 * max(th, g_cand_t);
      vec3 color = shade_surface(tf_at(iso).rgb, cubic_gradient(ch, g_cand_voxel), dir_world);
      radiance += transmittance * u_iso_opacity * color;
      transmittance *= 1.0 - u_iso_opacity;
    }
    if (transmittance <= u_min_transmittance || tb >= g_cand_exit) break;
    float vt = texture(u_atlas, g_cand_c0 + g_cand_c1 * tb).r;
    bool sure = true;
    for (int i = 0; i < u_iso_count; ++i) sure = sure && abs(vt - iso_value(i)) >= g_cand_margin;
    if (sure) break;
    // The next sample of the node's grid (as the walk places them), on the spline; not past the data (the stencil
    // below 1/2 there, as the walk's samples): the coefficients there hold the fill of samples without data, a smooth
    // extension of the field whose crossings are outside the mesh (docs/tricubic.md, "Samples without data"). The walk
    // resumes at tb and meets the sample without data itself.
    float k = floor(tb / g_cand_step) + 1.0, tn = min(k * g_cand_step, g_cand_exit);
    if (!(tn > tb)) tn = min((k + 1.0) * g_cand_step, g_cand_exit);
    if (texture(u_atlas, g_cand_c0 + g_cand_c1 * tn).g < 0.5) break;
    ta = tb, fa = fb, tb = tn;
    fb = cubic_at(g_cand_c0 + g_cand_c1 * tb, bvec3(false));
  }
  // Resume at tb (its sample is known: the walk skips it), unless the ray is done.
  t = tb;
  have_prev = true;
  prev_value = fb;
  prev_t = tb;
  prev_sure = true;
  if (transmittance <= u_min_transmittance) break;
  }
#endif
#if OVERLAY
  // The end: the root cell's exit is outside the data; at the clip plane the state is V's there. (The last node's
  // exit may pass t_end by rounding, and a sample with it: the state ignores samples past t_end.)
  if (ov_ran && transmittance > u_min_transmittance) {
    bool end_inside = clip_end && validity(base + dir * (t_end - u_nudge)) >= 0.5;
    if (end_inside != ov_inside)
      composite_overlay(boundary_crossing(min(ov_t, t_end), t_end, ov_inside), dir_world, radiance, transmittance);
  }
#endif

  vec4 result = vec4(radiance, transmittance);
#if MODE == LOD_MODE_MIP
#if HYBRID
  mip_max = max(mip_max, g_mip_max);  // the exact nodes' maximum
#endif
  // radiance and transmittance hold the slices alone (none without SLICES); the maximum is drawn behind them.
  if (mip_max >= 0.0) {
    vec4 tf = tf_at(mip_max);
    float a = 1.0 - exp(-tf.a * u_unit_distance);
    result = vec4(radiance + transmittance * tf.rgb * a, transmittance * (1.0 - a));
  }
#endif
  // A ray llvmpipe's loop limit cut short holds whatever it had gathered: counted, never silent; in the hybrid
  // variant flagged (transmittance -1) for the engine to draw from the voxels instead.
  bool cut = loop_limit_reached(u_loop_probe);
#if HYBRID
  if (cut) result = vec4(0.0, 0.0, 0.0, -1.0);
#endif
  imageStore(u_out, pix, result);
  if (cut) atomicAdd(counters[COUNTER_LOOP_LIMIT], 1u);
  atomicAdd(counters[COUNTER_SAMPLES], samples);
  atomicAdd(counters[COUNTER_BRICKS], bricks);
#if FACES
  if (g_face_passes > 0u) atomicAdd(counters[COUNTER_FACE_PASSES], g_face_passes);
#endif
#if HYBRID
  if (g_cell_steps > 0u) atomicAdd(counters[COUNTER_CELL_STEPS], g_cell_steps);
#endif
}
