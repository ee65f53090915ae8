// The optical table on the GPU: the closed-form integral of a ray segment over which the scalar is linear, the same
// method as the CPU's OpticalTable (src/ugvr/render/optical_table.h has the derivation), in single precision.
//
// The includer defines OPTICAL_TABLE_BINDING (a storage-buffer binding point) before including this file, and
// binds the buffer that OpticalTable::pack_for_gpu() fills: two vec4 per breakpoint i,
//   optical_entries[2i]     = (x[i], 1 / (x[i+1] - x[i]) (0 for the last), 0, 0)
//   optical_entries[2i + 1] = (r[i], g[i], b[i], tau[i])       colour and extinction per world unit at x[i]
// linear in between, constant beyond the ends.
//
// The accumulator is a vec4: rgb = premultiplied radiance, a = transmittance (1 at the start of a ray).
//
// Differences from the CPU, all below 1e-6 in a pixel: psi's Gauss-Legendre pieces span a growth of the exponent of
// 1 (not 1/2; relative error ~5e-7, float's own) and stop at an optical depth of 17 (transmittance < 5e-8).

#ifndef OPTICAL_TABLE_BINDING
#error "define OPTICAL_TABLE_BINDING before including optical.glsl"
#endif

layout(std430, binding = OPTICAL_TABLE_BINDING) readonly buffer OpticalTableBuffer { vec4 optical_entries[]; };

int optical_count() { return optical_entries.length() / 2; }
float optical_x(int i) { return optical_entries[2 * i].x; }

// Index i of the interval [x[i], x[i+1]) holding s: -1 below x[0], n-1 at or above x[n-1]. Tries the hint and its
// neighbours first (consecutive segments of a ray continue where the previous one ended), then bisects.
int optical_interval(float s, int hint) {
  int n = optical_count();
  if (hint >= 0 && hint + 1 < n && optical_x(hint) <= s && s < optical_x(hint + 1)) return hint;
  if (hint + 2 < n && hint + 1 >= 0 && optical_x(hint + 1) <= s && s < optical_x(hint + 2)) return hint + 1;
  if (hint >= 1 && hint < n && optical_x(hint - 1) <= s && s < optical_x(hint)) return hint - 1;
  // upper_bound(x, s) - 1
  int lo = 0, hi = n;
  while (lo < hi) {
    int mid = (lo + hi) >> 1;
    if (optical_x(mid) <= s)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo - 1;
}

// Colour (rgb) and extinction (a) at s inside interval j (constant extension outside the table).
vec4 optical_values(int j, float s) {
  int n = optical_count();
  if (j < 0) return optical_entries[1];
  if (j + 1 >= n) return optical_entries[2 * n - 1];
  float f = (s - optical_entries[2 * j].x) * optical_entries[2 * j].y;
  return mix(optical_entries[2 * j + 1], optical_entries[2 * j + 3], f);
}

// Colour and extinction at s (for isosurface and MIP colours).
vec4 optical_at(float s) { return optical_values(optical_interval(s, -1), s); }

// psi(a, b) = integral_0^1 exp(-(a u + (b - a) u^2 / 2)) du for a, b >= 0 (segment_transmittance_mean on the CPU).
float optical_psi(float a, float b) {
  float depth = 0.5 * (a + b);
  float k = 0.5 * (b - a);
  if (depth <= 0.1) {
    float a2 = a * a, k2 = k * k, ak = a * k;
    float m1 = 0.5 * a + (1.0 / 3.0) * k;
    float m2 = (1.0 / 3.0) * a2 + 0.5 * ak + 0.2 * k2;
    float m3 = a * (0.25 * a2 + 0.6 * ak + 0.5 * k2) + (1.0 / 7.0) * k2 * k;
    float m4 = a2 * (0.2 * a2 + (2.0 / 3.0) * a * k + (6.0 / 7.0) * k2) + k2 * (0.5 * ak + (1.0 / 9.0) * k2);
    return (1.0 - m1) + (0.5 * m2 - (1.0 / 6.0) * m3) + (1.0 / 24.0) * m4;
  }
  if (abs(k) <= 1e-6 * depth) return -(exp(-depth) - 1.0) / depth;
  const float node0 = 0.3399810435848563, node1 = 0.8611363115940526;
  const float weight0 = 0.6521451548625461, weight1 = 0.3478548451374538;
  float sum = 0.0, u0 = 0.0;
  float last = min(depth, 17.0);
  for (float target = 1.0;; target += 1.0) {
    float f = min(target, last);
    float u1 = f >= depth ? 1.0 : 2.0 * f / (a + sqrt(max(0.0, a * a + 4.0 * k * f)));
    float mid = 0.5 * (u0 + u1), half_width = 0.5 * (u1 - u0);
    float ua = mid - half_width * node0, ub = mid + half_width * node0;
    float uc = mid - half_width * node1, ud = mid + half_width * node1;
    float piece = weight0 * (exp(-(a * ua + k * ua * ua)) + exp(-(a * ub + k * ub * ub))) +
                  weight1 * (exp(-(a * uc + k * uc * uc)) + exp(-(a * ud + k * ud * ud)));
    sum += piece * half_width;
    u0 = u1;
    if (f >= last) break;
  }
  return sum;
}

// One piece over which colour and extinction are both linear in distance: tau0 -> tau1, c0 -> c1 over length h.
void optical_piece(vec4 v0, vec4 v1, float h, float shade, inout vec4 acc) {
  float a = v0.a * h, b = v1.a * h;
  if (a == 0.0 && b == 0.0) return;
  float depth = 0.5 * (a + b);
  float t = exp(-depth);
  vec3 radiance;
  if (v0.rgb == v1.rgb) {
    radiance = v0.rgb * (1.0 - t);
  } else {
    float psi = optical_psi(a, b);
    radiance = v0.rgb - v1.rgb * t + (v1.rgb - v0.rgb) * psi;
  }
  acc.rgb += radiance * (acc.a * shade);
  acc.a *= t;
}

// Adds a segment of `len` over which s goes linearly from s0 to s1, its emission scaled by `shade`. A NaN end makes
// the segment contribute nothing. `hint` carries the table interval from one call to the next (start with -1).
void optical_integrate(float s0, float s1, float len, float shade, inout vec4 acc, inout int hint) {
  if (!(len > 0.0) || isnan(s0) || isnan(s1)) return;
  int j = optical_interval(s0, hint);
  int j_end = optical_interval(s1, j);
  hint = j_end;
  vec4 va = optical_values(j, s0);
  if (j == j_end) {
    optical_piece(va, optical_values(j, s1), len, shade, acc);
    return;
  }
  float inv_ds = 1.0 / (s1 - s0);
  float pos = 0.0;
  bool ascending = s1 > s0;
  while (j != j_end && acc.a > 1e-7) {
    int next_j = ascending ? j + 1 : j - 1;
    float breakpoint = ascending ? optical_x(j + 1) : optical_x(j);
    float f = clamp((breakpoint - s0) * inv_ds, pos, 1.0);
    optical_piece(va, optical_values(j, breakpoint), (f - pos) * len, shade, acc);
    pos = f;
    j = next_j;
    va = optical_values(j, breakpoint);
  }
  if (acc.a > 1e-7) optical_piece(va, optical_values(j, s1), (1.0 - pos) * len, shade, acc);
}
