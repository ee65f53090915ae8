#include "ugvr/render/lod/brick_atlas.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "ugvr/core/error.h"
#include "ugvr/store/brick_pad.h"

namespace ugvr {

void make_atlas_slot(uint32_t resolution, float* samples, const uint8_t* mask, double lo, double hi,
                     std::vector<uint16_t>& texels) {
  const int r = int(resolution), s = r + 2;
  pad_brick(resolution, 1, samples, mask);
  texels.resize(size_t(s) * s * s * 2);
  const double scale = hi > lo ? 65535.0 / (hi - lo) : 0.0;
  for (int z = 0; z < s; ++z) {
    const int sz = std::clamp(z - 1, 0, r - 1);
    for (int y = 0; y < s; ++y) {
      const int sy = std::clamp(y - 1, 0, r - 1);
      uint16_t* out = texels.data() + (size_t(z) * s + y) * s * 2;
      const size_t row = (size_t(sz) * r + sy) * r;
      for (int x = 0; x < s; ++x) {
        const size_t i = row + size_t(std::clamp(x - 1, 0, r - 1));
        const double v = samples[i];
        const double code = std::isfinite(v) ? std::clamp(std::round((v - lo) * scale), 0.0, 65535.0) : 0.0;
        out[2 * x] = uint16_t(code);
        out[2 * x + 1] = mask[i] ? 65535 : 0;
      }
    }
  }
}

uint16_t cubic_margin_code(uint32_t resolution, const uint16_t* texels, const std::vector<double>* coefficients) {
  const int s = int(resolution) + 2;
  const auto index = [&](int x, int y, int z) { return (size_t(z) * s + y) * s + x; };
  std::vector<double> f(size_t(s) * s * s);
  for (size_t i = 0; i < f.size(); ++i) f[i] = double(texels[2 * i]);
  if (coefficients) {
    // The trilinear interpolant inside the brick never reads the apron, so the bound may take any apron for it: the
    // linear extrapolation of the border (axis by axis), whose second differences vanish there, instead of the clamp
    // (a second difference of a whole first difference, which the spline of the coefficients does not see).
    for (int axis = 0; axis < 3; ++axis) {
      const size_t stride = axis == 0 ? 1 : axis == 1 ? size_t(s) : size_t(s) * s;
      for (int b = 0; b < s; ++b)
        for (int a = 0; a < s; ++a) {
          const size_t base = axis == 0 ? index(0, a, b) : axis == 1 ? index(a, 0, b) : index(a, b, 0);
          f[base] = 2 * f[base + stride] - f[base + 2 * stride];
          const size_t last = base + size_t(s - 1) * stride;
          f[last] = 2 * f[last - stride] - f[last - 2 * stride];
        }
    }
  }
  double d[3] = {0, 0, 0}, g[3] = {0, 0, 0}, c = 0;
  for (int z = 0; z < s; ++z)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x) {
        const size_t i = index(x, y, z);
        const size_t step[3] = {1, size_t(s), size_t(s) * s};
        const int pos[3] = {x, y, z};
        for (int a = 0; a < 3; ++a) {
          if (pos[a] + 1 < s) {
            g[a] = std::max(g[a], std::abs(f[i + step[a]] - f[i]));
            if (coefficients)
              g[a] = std::max(g[a], 65535.0 * std::abs((*coefficients)[i + step[a]] - (*coefficients)[i]));
          }
          if (pos[a] > 0 && pos[a] + 1 < s) d[a] = std::max(d[a], std::abs(f[i - step[a]] - 2 * f[i] + f[i + step[a]]));
        }
        if (coefficients) c = std::max(c, std::abs((*coefficients)[i] * 65535.0 - f[i]));
      }
  double m = (d[0] + d[1] + d[2]) / 6.0 + (g[0] + g[1] + g[2]) / 128.0 + 2.0;
  if (coefficients) m += c + 1.0;  // the coefficients' codes step by 2 value codes
  return uint16_t(std::min(std::ceil(m), 65535.0));
}

namespace {

// The (R+2) × R matrix from a line's R samples to its R + 2 coefficients (row-major), by solving the interpolation
// conditions (c[i-1] + 4 c[i] + c[i+1]) / 6 = f[i] with the two end conditions, once per column (Gaussian
// elimination with partial pivoting; R is a brick's side, so this is small and done once per resolution).
std::vector<double> prefilter_matrix(int r) {
  const int n = r + 2;
  std::vector<double> a(size_t(n) * n, 0.0), inv(size_t(n) * n, 0.0);
  for (int i = 0; i < r; ++i) {
    a[size_t(i) * n + i] = 1.0 / 6.0;
    a[size_t(i) * n + i + 1] = 4.0 / 6.0;
    a[size_t(i) * n + i + 2] = 1.0 / 6.0;
  }
  if (r >= 5) {  // not-a-knot: the 4th difference of c[-1 .. 3] (and of the last five) vanishes
    const double q[5] = {1, -4, 6, -4, 1};
    for (int k = 0; k < 5; ++k) {
      a[size_t(r) * n + k] = q[k];
      a[size_t(r + 1) * n + n - 1 - k] = q[k];
    }
  } else {  // natural: the 2nd difference of c[-1 .. 1] (and of the last three) vanishes
    const double q[3] = {1, -2, 1};
    for (int k = 0; k < 3; ++k) {
      a[size_t(r) * n + k] = q[k];
      a[size_t(r + 1) * n + n - 1 - k] = q[k];
    }
  }
  for (int i = 0; i < n; ++i) inv[size_t(i) * n + i] = 1.0;
  for (int col = 0; col < n; ++col) {
    int piv = col;
    for (int row = col + 1; row < n; ++row)
      if (std::abs(a[size_t(row) * n + col]) > std::abs(a[size_t(piv) * n + col])) piv = row;
    for (int k = 0; k < n; ++k) {
      std::swap(a[size_t(col) * n + k], a[size_t(piv) * n + k]);
      std::swap(inv[size_t(col) * n + k], inv[size_t(piv) * n + k]);
    }
    const double p = a[size_t(col) * n + col];
    for (int k = 0; k < n; ++k) {
      a[size_t(col) * n + k] /= p;
      inv[size_t(col) * n + k] /= p;
    }
    for (int row = 0; row < n; ++row) {
      const double f = a[size_t(row) * n + col];
      if (row == col || f == 0.0) continue;
      for (int k = 0; k < n; ++k) {
        a[size_t(row) * n + k] -= f * a[size_t(col) * n + k];
        inv[size_t(row) * n + k] -= f * inv[size_t(col) * n + k];
      }
    }
  }
  // coefficients = inv · (f[0 .. r-1], 0, 0): the first r columns.
  std::vector<double> m(size_t(n) * r);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < r; ++j) m[size_t(i) * r + j] = inv[size_t(i) * n + j];
  return m;
}

// A 3-D texture of `format` over the atlas's texels, filtered linearly, clamped at its edges (the samples' texture and
// the spline coefficients' share the layout).
GlTexture atlas_texture(GLenum format, const int* texels, const char* what) {
  GlTexture t(GL_TEXTURE_3D);
  glTextureStorage3D(t.id(), 1, format, texels[0], texels[1], texels[2]);
  check_gl(what);
  glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
    glTextureParameteri(t.id(), w, GL_CLAMP_TO_EDGE);
  return t;
}

}  // namespace

bool cubic_coefficients(uint32_t resolution, const uint16_t* texels, std::vector<double>& coefficients) {
  const int r = int(resolution), s = r + 2;
  const auto at = [&](int x, int y, int z) { return (size_t(z) * s + y) * s + x; };
  for (int z = 1; z <= r; ++z)
    for (int y = 1; y <= r; ++y)
      for (int x = 1; x <= r; ++x)
        if (texels[2 * at(x, y, z) + 1] == 0) return false;
  thread_local int cached_r = -1;
  thread_local std::vector<double> m;
  if (cached_r != r) m = prefilter_matrix(r), cached_r = r;
  coefficients.assign(size_t(s) * s * s, 0.0);
  for (size_t i = 0; i < coefficients.size(); ++i) coefficients[i] = double(texels[2 * i]) / 65535.0;
  // Axis by axis, in place: the line's samples are its texels 1 .. r (the brick's), its coefficients all s texels.
  // Each pass runs over every line of the slot, apron lines included: the apron planes of the axes done before hold
  // coefficients there, which the later axes filter like the rest (the tensor product).
  std::vector<double> line(r);
  for (int axis = 0; axis < 3; ++axis) {
    const size_t stride = axis == 0 ? 1 : axis == 1 ? size_t(s) : size_t(s) * s;
    for (int b = 0; b < s; ++b)
      for (int a = 0; a < s; ++a) {
        const size_t base = axis == 0 ? at(0, a, b) : axis == 1 ? at(a, 0, b) : at(a, b, 0);
        for (int j = 0; j < r; ++j) line[j] = coefficients[base + (j + 1) * stride];
        for (int i = 0; i < s; ++i) {
          double c = 0;
          for (int j = 0; j < r; ++j) c += m[size_t(i) * r + j] * line[j];
          coefficients[base + i * stride] = c;
        }
      }
  }
  return true;
}

uint64_t BrickAtlas::max_slots(uint32_t resolution, int max_3d) {
  const uint64_t per_axis = uint64_t(max_3d) / (resolution + 2);
  return per_axis * per_axis * per_axis;
}

BrickAtlas::BrickAtlas(uint32_t resolution, uint64_t slots, int max_3d) : resolution_(resolution) {
  const int side = int(resolution) + 2;
  const int per_axis = max_3d / side;
  if (per_axis < 1) fail_in("brick atlas", "bricks of " + std::to_string(resolution) + "³ do not fit a 3D texture");
  slots = std::max<uint64_t>(slots, 1);
  if (slots > max_slots(resolution, max_3d))
    fail_in("brick atlas", std::to_string(slots) + " bricks exceed the largest 3D texture (" +
                               std::to_string(max_slots(resolution, max_3d)) + " slots)");
  // As close to a cube as the count allows: x first, then y, then z.
  int n = int(std::ceil(std::cbrt(double(slots))));
  n = std::min(n, per_axis);
  slots_[0] = n;
  slots_[1] = int(std::min<uint64_t>(per_axis, (slots + n - 1) / n));
  slots_[1] = std::min(slots_[1], n);
  slots_[2] = int((slots + uint64_t(slots_[0]) * slots_[1] - 1) / (uint64_t(slots_[0]) * slots_[1]));
  if (slots_[2] > per_axis) {  // a flat count: widen y
    slots_[1] = per_axis;
    slots_[2] = int((slots + uint64_t(slots_[0]) * slots_[1] - 1) / (uint64_t(slots_[0]) * slots_[1]));
  }
  for (int a = 0; a < 3; ++a) texels_[a] = slots_[a] * side;
  const char* no_bracket = std::getenv("UGVR_TRICUBIC_NO_BRACKET");
  no_bracket_ = no_bracket && *no_bracket;
  texture_ = atlas_texture(GL_RG16, texels_, "allocating the brick atlas");
}

uint64_t BrickAtlas::bytes() const {
  return uint64_t(texels_[0]) * texels_[1] * texels_[2] * (has_coefficients() ? 6 : 4) +
         (has_coefficients() ? capacity() * sizeof(float) : 0);
}

void BrickAtlas::add_coefficients() {
  if (has_coefficients()) return;
  coefficients_ = atlas_texture(GL_R16, texels_, "allocating the brick atlas's spline coefficients");
  // Until a slot uploads with the coefficients its margin is the whole range: the spline decides everywhere.
  const std::vector<float> everywhere(capacity(), 1.0f);
  margins_.upload(everywhere.data(), everywhere.size() * sizeof(float));
  check_gl("allocating the brick atlas's cubic margins");
}

void BrickAtlas::upload(uint64_t slot, const uint16_t* texels) {
  const int side = int(resolution_) + 2;
  const int x = int(slot % uint64_t(slots_[0])), y = int((slot / uint64_t(slots_[0])) % uint64_t(slots_[1]));
  const int z = int(slot / (uint64_t(slots_[0]) * slots_[1]));
  glTextureSubImage3D(texture_.id(), 0, x * side, y * side, z * side, side, side, side, GL_RG, GL_UNSIGNED_SHORT,
                      texels);
  if (!has_coefficients()) return;  // the margin and coefficients serve tricubic frames only
  const bool prefiltered = cubic_coefficients(resolution_, texels, scratch_);
  // [-1/2, 3/2] to [0, 1] (brick_atlas.h); without the prefilter, the samples themselves.
  std::vector<uint16_t> codes(size_t(side) * side * side);
  for (size_t i = 0; i < codes.size(); ++i) {
    const double c = prefiltered ? scratch_[i] : double(texels[2 * i]) / 65535.0;
    codes[i] = uint16_t(std::clamp(std::round((c + 0.5) * 0.5 * 65535.0), 0.0, 65535.0));
  }
  // Rows of one 16-bit channel are not 4-byte multiples for an odd side: unpack at 2-byte alignment.
  GLint alignment = 4;
  glGetIntegerv(GL_UNPACK_ALIGNMENT, &alignment);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
  glTextureSubImage3D(coefficients_.id(), 0, x * side, y * side, z * side, side, side, side, GL_RED, GL_UNSIGNED_SHORT,
                      codes.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, alignment);
  const float margin =
      no_bracket_ ? 1.0f : float(cubic_margin_code(resolution_, texels, prefiltered ? &scratch_ : nullptr)) / 65535.0f;
  glNamedBufferSubData(margins_.id(), GLintptr(slot * sizeof(float)), sizeof(float), &margin);
}

}  // namespace ugvr
