// Contour lines on slices (docs/slices.md; render_settings.h slice_contour_coverage, slice_screen_derivative: the
// CPU engine computes the same), shared by exact_walk.comp and lod_raycast.comp.
//
// The slice colour texture has 2 × MAX_SLICES rows: row i holds slice i's colour table, row MAX_SLICES + i its
// contour lines, read with texelFetch:
//   texel 0: x the number of values n (0: no lines), y the line width in pixels;
//   texel 1: rgb the line colour;
//   texels 2 .. n + 1: r the values, in the engine's value units (the LOD engine's normalised ones).

// How many of slice row `row`'s contour values there are (0: none, the caller skips the gradient).
int slice_contour_count(sampler2D table, int row) { return int(texelFetch(table, ivec2(0, row), 0).x); }

// The change of a field with world gradient g from one pixel to the next along a plane with normal n (any length),
// seen along the ray direction dir: the pixel's world footprint vectors px, py at the crossing's depth moved along
// the ray onto the plane. Compute shaders have no dFdx: this is its analytic form.
float slice_screen_derivative(vec3 g, vec3 n, vec3 dir, vec3 px, vec3 py) {
  float nd = dot(n, dir);
  if (nd == 0.0) return 0.0;
  vec3 ex = px - dir * (dot(n, px) / nd), ey = py - dir * (dot(n, py) / nd);
  return length(vec2(dot(g, ex), dot(g, ey)));
}

// `color` with the lines of contour row `row` blended in where the field is `value` and changes by `per_pixel` per
// pixel: coverage 1 within width / 2 - 0.5 pixels of the nearest value, 0 beyond width / 2 + 0.5.
vec3 slice_contour_blend(sampler2D table, int row, vec3 color, float value, float per_pixel) {
  vec4 head = texelFetch(table, ivec2(0, row), 0);
  int n = int(head.x);
  if (n == 0 || isnan(value)) return color;
  float nearest = 3.0e38;
  for (int j = 0; j < n; ++j) nearest = min(nearest, abs(value - texelFetch(table, ivec2(2 + j, row), 0).r));
  float d = per_pixel > 0.0 ? nearest / per_pixel : (nearest == 0.0 ? 0.0 : 3.0e38);
  float a = clamp(0.5 * head.y + 0.5 - d, 0.0, 1.0);
  return mix(color, texelFetch(table, ivec2(1, row), 0).rgb, a);
}
