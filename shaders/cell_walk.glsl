// The cell walk shared by the exact engine's shader (shaders/exact_walk.comp) and the hybrid variant of the LOD ray
// caster (shaders/lod_raycast.comp, HYBRID: exact cells inside the nodes of the cut granted them, docs/hybrid.md): the
// cell tables, the ray's watertight frame, loading a cell, the exit face, the field at a face and the error-bounded
// subdivision of non-linear cells. One copy, so that both walk the same cells with the same arithmetic.
//
// The including shader defines, before including this file, `real` and `real3` (double or float arithmetic of the
// walk) and optionally TETS_ONLY; and defines anywhere (prototypes below) how the mesh is read and what a piece is:
uint vertex_id(uint c, int k, int i);  // vertex i of cell c of type index k (0 tetra, 1 pyramid, 2 wedge, 3 hexahedron)
bool quad_split_13(uint c, int f);     // quadrilateral face f of cell c is split along its 1-3 diagonal
vec3 point_at(uint id);                // a vertex's position, in the walk's coordinates
bool cell_data();                      // the field is per cell (else per vertex)
float vertex_value(uint id);
float cell_value(uint c);
real nonlinear_tolerance();  // the subdivision's tolerance in the field's units (as the values are stored)
// One linear piece of the field along the ray inside the current cell, from (ta, sa) to (tb, sb): the integration.
void piece(real ta, real tb, float sa, float sb, int k);

#ifndef TETS_ONLY
#define TETS_ONLY 0
#endif

const int MAX_STALL_STEPS = 1000;
const int MAX_NONLINEAR_DEPTH = 6;
// Infinity (1.0 / 0.0 is undefined in GLSL).
#define INF real(uintBitsToFloat(0x7F800000u))
#define FLOAT_INF uintBitsToFloat(0x7F800000u)

// ---- cell tables (cell_type.h: VTK order, faces counter-clockwise seen from outside) ----------------------------
const int VERTEX_COUNT[4] = int[4](4, 5, 6, 8);  // tetra, pyramid, wedge, hexahedron (the walk mesh's type order)
const int FACE_COUNT[4] = int[4](4, 5, 5, 6);
const int FACE_SIZE[24] = int[24](3, 3, 3, 3, 0, 0,  // tetra
                                  4, 3, 3, 3, 3, 0,  // pyramid
                                  3, 3, 4, 4, 4, 0,  // wedge
                                  4, 4, 4, 4, 4, 4);
const ivec4 FACE_V[24] = ivec4[24](ivec4(0, 1, 3, 0), ivec4(1, 2, 3, 0), ivec4(2, 0, 3, 0), ivec4(0, 2, 1, 0),
                                   ivec4(0), ivec4(0),  //
                                   ivec4(0, 3, 2, 1), ivec4(0, 1, 4, 0), ivec4(1, 2, 4, 0), ivec4(2, 3, 4, 0),
                                   ivec4(3, 0, 4, 0), ivec4(0),  //
                                   ivec4(0, 1, 2, 0), ivec4(3, 5, 4, 0), ivec4(0, 3, 4, 1), ivec4(1, 4, 5, 2),
                                   ivec4(2, 5, 3, 0), ivec4(0),  //
                                   ivec4(0, 4, 7, 3), ivec4(1, 2, 6, 5), ivec4(0, 1, 5, 4), ivec4(3, 7, 6, 2),
                                   ivec4(0, 3, 2, 1), ivec4(4, 5, 6, 7));
// Parametric corners of each vertex (cell_interpolation.h) for pyramid, wedge, hexahedron.
const vec3 CORNER[24] = vec3[24](vec3(0, 0, 0), vec3(1, 0, 0), vec3(1, 1, 0), vec3(0, 1, 0), vec3(0, 0, 1), vec3(0),
                                 vec3(0), vec3(0),  // pyramid
                                 vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 1), vec3(1, 0, 1),
                                 vec3(0, 1, 1), vec3(0), vec3(0),  // wedge
                                 vec3(0, 0, 0), vec3(1, 0, 0), vec3(1, 1, 0), vec3(0, 1, 0), vec3(0, 0, 1),
                                 vec3(1, 0, 1), vec3(1, 1, 1), vec3(0, 1, 1));

ivec3 triangle_corners(int face_size, bool split_13, int tri) {
  if (face_size == 3) return ivec3(0, 1, 2);
  if (split_13) return tri == 0 ? ivec3(0, 1, 3) : ivec3(1, 2, 3);
  return tri == 0 ? ivec3(0, 1, 2) : ivec3(0, 2, 3);
}

// ---- the ray -------------------------------------------------------------------------------------------------------
real3 g_origin, g_dir, g_e1, g_e2;
real g_t_lo, g_t_hi;  // the stretch of the ray whose pieces count
vec4 g_acc = vec4(0, 0, 0, 1);  // premultiplied radiance, transmittance
float g_stop_transmittance;
uint g_nonlinear = 0u;

bool done() { return g_acc.a <= g_stop_transmittance; }

// (u, v, w) of a vertex in the ray's frame; `precise`: every cell that projects it gets the same bits.
real3 project(vec3 p) {
  precise real3 a = real3(p) - g_origin;
  precise real u = a.x * g_e1.x + a.y * g_e1.y + a.z * g_e1.z;
  precise real v = a.x * g_e2.x + a.y * g_e2.y + a.z * g_e2.z;
  precise real w = a.x * g_dir.x + a.y * g_dir.y + a.z * g_dir.z;
  return real3(u, v, w);
}
real edge_side(real3 a, real3 b) {
  precise real e = a.x * b.y - a.y * b.x;
  return e;
}

// The current cell: its vertices, their projections and (vertex data) values.
// Sized for the largest cell the program meets (TETS_ONLY: 4): these live in local memory, and smaller is faster.
const int MAX_VERTICES = TETS_ONLY != 0 ? 4 : 8;
uint g_vid[MAX_VERTICES];
real3 g_proj[MAX_VERTICES];
float g_s[MAX_VERTICES];

void load_cell(uint cell, int k) {
  for (int i = 0; i < VERTEX_COUNT[k]; ++i) {
    uint id = vertex_id(cell, k, i);
    g_vid[i] = id;
    g_proj[i] = project(point_at(id));
    if (!cell_data()) g_s[i] = vertex_value(id);
  }
}

struct Crossing {
  int face;
  ivec3 corners;  // indices into the face's vertex list
  real3 lambda;   // barycentric weights of those corners
  real t;
};

// ---- cell interpolation (cell_interpolation.h): shape functions and the monomial form -----------------------------
void shape_functions(int k, real3 p, out real N[8]) {
  real r = p.x, s = p.y, t = p.z;
  real rm = 1.0 - r, sm = 1.0 - s, tm = 1.0 - t;
  for (int i = 0; i < 8; ++i) N[i] = 0.0;
  if (k == 0) {
    N[0] = 1.0 - r - s - t, N[1] = r, N[2] = s, N[3] = t;
  } else if (k == 1) {
    N[0] = rm * sm * tm, N[1] = r * sm * tm, N[2] = r * s * tm, N[3] = rm * s * tm, N[4] = t;
  } else if (k == 2) {
    real u = 1.0 - r - s;
    N[0] = u * tm, N[1] = r * tm, N[2] = s * tm, N[3] = u * t, N[4] = r * t, N[5] = s * t;
  } else {
    N[0] = rm * sm * tm, N[1] = r * sm * tm, N[2] = r * s * tm, N[3] = rm * s * tm;
    N[4] = rm * sm * t, N[5] = r * sm * t, N[6] = r * s * t, N[7] = rm * s * t;
  }
}

// Monomial coefficients (1, r, s, t, rs, rt, st, rst) of the current cell's map and field, from the values at the
// unit cube's corners.
real3 g_map[8];
real g_field[8];

void build_monomials(int k) {
  real3 cx[8];
  real cs[8];
  for (int q = 0; q < 8; ++q) {
    real N[8];
    shape_functions(k, real3(real(q & 1), real((q >> 1) & 1), real((q >> 2) & 1)), N);
    cx[q] = real3(0.0);
    cs[q] = 0.0;
    for (int i = 0; i < VERTEX_COUNT[k]; ++i) {
      cx[q] += real3(point_at(g_vid[i])) * N[i];
      cs[q] += real(g_s[i]) * N[i];
    }
  }
  g_map[0] = cx[0], g_map[1] = cx[1] - cx[0], g_map[2] = cx[2] - cx[0], g_map[3] = cx[4] - cx[0];
  g_map[4] = cx[3] - cx[1] - cx[2] + cx[0], g_map[5] = cx[5] - cx[1] - cx[4] + cx[0];
  g_map[6] = cx[6] - cx[2] - cx[4] + cx[0];
  g_map[7] = cx[7] - cx[3] - cx[5] - cx[6] + cx[1] + cx[2] + cx[4] - cx[0];
  g_field[0] = cs[0], g_field[1] = cs[1] - cs[0], g_field[2] = cs[2] - cs[0], g_field[3] = cs[4] - cs[0];
  g_field[4] = cs[3] - cs[1] - cs[2] + cs[0], g_field[5] = cs[5] - cs[1] - cs[4] + cs[0];
  g_field[6] = cs[6] - cs[2] - cs[4] + cs[0];
  g_field[7] = cs[7] - cs[3] - cs[5] - cs[6] + cs[1] + cs[2] + cs[4] - cs[0];
}
real field_at(real3 p) {
  real rs = p.x * p.y, rt = p.x * p.z, st = p.y * p.z;
  return g_field[0] + g_field[1] * p.x + g_field[2] * p.y + g_field[3] * p.z + g_field[4] * rs + g_field[5] * rt +
         g_field[6] * st + g_field[7] * (rs * p.z);
}
// Jacobian columns of the map at rst.
void jacobian(real3 rst, out real3 jr, out real3 js, out real3 jt) {
  real r = rst.x, s = rst.y, t = rst.z;
  real3 q = g_map[6] + g_map[7] * r;
  jr = g_map[1] + g_map[4] * s + (g_map[5] + g_map[7] * s) * t;
  js = g_map[2] + g_map[4] * r + q * t;
  jt = g_map[3] + g_map[5] * r + q * s;
}
// Newton on the monomial form (inverse_map_monomial).
bool inverse_map(real3 point, real3 guess, real tolerance, out real3 rst) {
  rst = guess;
  real3 target = point - g_map[0];
  real det_floor2 = -1.0;
  for (int it = 0; it < 16; ++it) {
    real r = rst.x, s = rst.y, t = rst.z;
    real3 jr, js, jt;
    jacobian(rst, jr, js, jt);
    real3 x = jr * r + (g_map[2] + g_map[6] * t) * s + g_map[3] * t;
    real3 a0 = cross(js, jt), a1 = cross(jt, jr), a2 = cross(jr, js);
    real det = dot(jr, a0);
    if (det_floor2 < 0.0) det_floor2 = 1e-24 * dot(jr, jr) * dot(js, js) * dot(jt, jt);
    if (!(det * det > det_floor2)) return false;
    real3 b = target - x;
    real3 delta = real3(dot(a0, b), dot(a1, b), dot(a2, b)) / det;
    rst += delta;
    real step = max(abs(delta.x), max(abs(delta.y), abs(delta.z)));
    if (step < tolerance) return true;
    if (!(step < 1e8)) return false;
  }
  return false;
}
const vec3 CENTER[4] = vec3[4](vec3(0.25), vec3(0.4, 0.4, 0.2), vec3(1.0 / 3.0, 1.0 / 3.0, 0.5), vec3(0.5));

bool g_monomials_built = false;  // for the current cell
void need_monomials(int k) {
  if (!g_monomials_built) build_monomials(k);
  g_monomials_built = true;
}

// The gradient of the field at parametric point rst of the current cell (need_monomials done), in the walk's
// coordinates; zero for cell data.
vec3 gradient_at_rst(real3 rst) {
  if (cell_data()) return vec3(0);
  real3 jr, js, jt;
  jacobian(rst, jr, js, jt);
  real3 a0 = cross(js, jt), a1 = cross(jt, jr), a2 = cross(jr, js);
  real det = dot(jr, a0);
  if (!(abs(det) > 0.0)) return vec3(0);
  real r = rst.x, s = rst.y, tt = rst.z;
  real gr = g_field[1] + g_field[4] * s + g_field[5] * tt + g_field[7] * s * tt;
  real gs = g_field[2] + g_field[4] * r + g_field[6] * tt + g_field[7] * r * tt;
  real gt = g_field[3] + g_field[5] * r + g_field[6] * s + g_field[7] * r * s;
  // J^-T g: the rows of J^-1 are a0, a1, a2 over det.
  return vec3((a0 * gr + a1 * gs + a2 * gt) / det);
}
// The same at distance t along the ray inside the current cell (need_monomials done).
vec3 cell_gradient_at(int k, real t) {
  if (cell_data()) return vec3(0);
  real3 rst = real3(CENTER[k]);
  if (k != 0 && !inverse_map(g_origin + g_dir * t, rst, 1e-9, rst)) rst = real3(CENTER[k]);
  return gradient_at_rst(rst);
}

// ---- the walk ------------------------------------------------------------------------------------------------------
uint g_entry_ids[3];
real3 g_entry_lambda;

// The scalar where the ray crosses a face of the current cell (loaded).
float scalar_at_face(uint cell, int k, Crossing x) {
  if (cell_data()) return cell_value(cell);
  ivec4 fv = FACE_V[k * 6 + x.face];
  if (k == 0 || FACE_SIZE[k * 6 + x.face] == 3) {
    real s = x.lambda.x * real(g_s[fv[x.corners.x]]) + x.lambda.y * real(g_s[fv[x.corners.y]]) +
             x.lambda.z * real(g_s[fv[x.corners.z]]);
    return float(s);
  }
  // Bilinear over the quadrilateral at face parameters interpolated from the triangle's corners.
  const real CU[4] = real[4](0.0, 1.0, 1.0, 0.0), CV[4] = real[4](0.0, 0.0, 1.0, 1.0);
  real u = x.lambda.x * CU[x.corners.x] + x.lambda.y * CU[x.corners.y] + x.lambda.z * CU[x.corners.z];
  real v = x.lambda.x * CV[x.corners.x] + x.lambda.y * CV[x.corners.y] + x.lambda.z * CV[x.corners.z];
  real s0 = g_s[fv.x], s1 = g_s[fv.y], s2 = g_s[fv.z], s3 = g_s[fv.w];
  return float((1.0 - u) * (1.0 - v) * s0 + u * (1.0 - v) * s1 + u * v * s2 + (1.0 - u) * v * s3);
}

void set_crossing(inout Crossing o, int f, ivec3 c, ivec4 fv, real l0, real l1, real l2) {
  o.face = f;
  o.corners = c;
  o.lambda = real3(l0, l1, l2);
  precise real t = l0 * g_proj[fv[c.x]].z + l1 * g_proj[fv[c.y]].z + l2 * g_proj[fv[c.z]].z;
  o.t = t;
}

// The face (not entry_face) through which the ray leaves the current cell; false when no triangle passes the exact
// test, `o` then being the least-violating one (exit_of on the CPU).
bool exit_of(uint cell, int k, int entry_face, out Crossing o) {
  o.face = 0, o.corners = ivec3(0, 1, 2), o.lambda = real3(1.0 / 3.0), o.t = -INF;
  if (k == 0) {
    real e01 = edge_side(g_proj[0], g_proj[1]), e12 = edge_side(g_proj[1], g_proj[2]);
    real e20 = edge_side(g_proj[2], g_proj[0]), e03 = edge_side(g_proj[0], g_proj[3]);
    real e13 = edge_side(g_proj[1], g_proj[3]), e23 = edge_side(g_proj[2], g_proj[3]);
    real ab[4] = real[4](e01, e12, e20, -e20), bc[4] = real[4](e13, e23, e03, -e12);
    real ca[4] = real[4](-e03, -e13, -e23, -e01);
    for (int f = 0; f < 4; ++f) {
      if (f == entry_face || !(ab[f] >= 0.0 && bc[f] >= 0.0 && ca[f] >= 0.0)) continue;
      real sum = ab[f] + bc[f] + ca[f];
      if (!(sum > 0.0)) continue;
      real inv = 1.0 / sum;
      set_crossing(o, f, ivec3(0, 1, 2), FACE_V[f], bc[f] * inv, ca[f] * inv, ab[f] * inv);
      return true;
    }
  } else {
    for (int f = 0; f < FACE_COUNT[k]; ++f) {
      if (f == entry_face) continue;
      int size = FACE_SIZE[k * 6 + f];
      ivec4 fv = FACE_V[k * 6 + f];
      bool split = size == 4 && quad_split_13(cell, f);
      for (int tri = 0; tri < size - 2; ++tri) {
        ivec3 c = triangle_corners(size, split, tri);
        real3 a = g_proj[fv[c.x]], b = g_proj[fv[c.y]], d = g_proj[fv[c.z]];
        real e_ab = edge_side(a, b), e_bc = edge_side(b, d), e_ca = edge_side(d, a);
        real sum = e_ab + e_bc + e_ca;
        if (!(e_ab >= 0.0 && e_bc >= 0.0 && e_ca >= 0.0 && sum > 0.0)) continue;
        real inv = 1.0 / sum;
        set_crossing(o, f, c, fv, e_bc * inv, e_ca * inv, e_ab * inv);
        return true;
      }
    }
  }
  real best_score = -INF;
  for (int f = 0; f < FACE_COUNT[k]; ++f) {
    if (f == entry_face) continue;
    int size = FACE_SIZE[k * 6 + f];
    ivec4 fv = FACE_V[k * 6 + f];
    bool split = k != 0 && size == 4 && quad_split_13(cell, f);
    for (int tri = 0; tri < size - 2; ++tri) {
      ivec3 c = triangle_corners(size, split, tri);
      real3 a = g_proj[fv[c.x]], b = g_proj[fv[c.y]], d = g_proj[fv[c.z]];
      real e_ab = edge_side(a, b), e_bc = edge_side(b, d), e_ca = edge_side(d, a);
      real sum = e_ab + e_bc + e_ca;
      real norm = abs(e_ab) + abs(e_bc) + abs(e_ca);
      real score = norm > 0.0 ? min(e_ab, min(e_bc, e_ca)) / norm : -INF;
      if (score > best_score && sum > 0.0) {
        best_score = score;
        real l0 = max(e_bc, 0.0), l1 = max(e_ca, 0.0), l2 = max(e_ab, 0.0);
        real ls = l0 + l1 + l2;
        if (ls > 0.0)
          set_crossing(o, f, c, fv, l0 / ls, l1 / ls, l2 / ls);
        else
          set_crossing(o, f, c, fv, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0);
      }
    }
  }
  if (best_score == -INF) {
    o.face = entry_face == 0 ? 1 : 0;
    o.corners = ivec3(0, 1, 2);
    o.lambda = real3(1.0 / 3.0);
    o.t = -INF;
  }
  return false;
}

// The field between two face crossings of the current cell (cell_segment on the CPU).
void cell_segment(uint cell, int k, real t0, real t1, float s0, float s1, Crossing exit_crossing) {
  if (k == 0 || cell_data() || !(t1 > t0) || t1 <= g_t_lo || t0 >= g_t_hi) {
    piece(t0, t1, s0, s1, k);
    return;
  }
  int n = VERTEX_COUNT[k];
  float lo = FLOAT_INF, hi = -FLOAT_INF;
  for (int i = 0; i < n; ++i) lo = min(lo, g_s[i]), hi = max(hi, g_s[i]);
  real tolerance = nonlinear_tolerance();
  if (!(real(hi) - real(lo) > tolerance)) {
    piece(t0, t1, s0, s1, k);
    return;
  }
  need_monomials(k);
  real3 rst_in = real3(0.0), rst_out = real3(0.0);
  ivec4 xv = FACE_V[k * 6 + exit_crossing.face];
  for (int i = 0; i < 3; ++i) {
    int j = 0;
    while (j < n - 1 && g_vid[j] != g_entry_ids[i]) ++j;
    rst_in += real3(CORNER[(k - 1) * 8 + j]) * g_entry_lambda[i];
    rst_out += real3(CORNER[(k - 1) * 8 + xv[exit_crossing.corners[i]]]) * exit_crossing.lambda[i];
  }
  real inv_length = 1.0 / (t1 - t0);
  // Midpoint subdivision with an explicit stack of right halves (end t, end s, depth): the CPU's recursion in order.
  real stack_t[MAX_NONLINEAR_DEPTH + 1];
  float stack_s[MAX_NONLINEAR_DEPTH + 1];
  int stack_d[MAX_NONLINEAR_DEPTH + 1];
  int sp = 0;
  stack_t[0] = t1, stack_s[0] = s1, stack_d[0] = 0, sp = 1;
  real ta = t0;
  float sa = s0;
  while (sp > 0 && !done()) {
    --sp;
    real tb = stack_t[sp];
    float sb = stack_s[sp];
    int depth = stack_d[sp];
    real tm = 0.5 * (ta + tb);
    float sm = 0.5 * (sa + sb);
    ++g_nonlinear;
    real3 rst;
    if (inverse_map(g_origin + g_dir * tm, rst_in + (rst_out - rst_in) * ((tm - t0) * inv_length), 1e-7, rst))
      sm = float(field_at(rst));
    if (depth + 1 >= MAX_NONLINEAR_DEPTH || abs(real(sm) - 0.5 * (real(sa) + real(sb))) <= tolerance) {
      piece(ta, tm, sa, sm, k);
      if (!done()) piece(tm, tb, sm, sb, k);
      ta = tb, sa = sb;
    } else {
      stack_t[sp] = tb, stack_s[sp] = sb, stack_d[sp] = depth + 1, ++sp;
      stack_t[sp] = tm, stack_s[sp] = sm, stack_d[sp] = depth + 1, ++sp;
    }
  }
}

