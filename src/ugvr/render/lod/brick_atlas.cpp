#include "ugvr/render/lod/brick_atlas.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

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

namespace {

// The margin (cubic_margin_code, brick_atlas.h) for the values f (codes, the slot's layout) standing for the samples.
double margin_for(int s, const std::vector<double>& f, const std::vector<double>* coefficients) {
  const auto index = [&](int x, int y, int z) { return (size_t(z) * s + y) * s + x; };
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
  return m;
}

}  // namespace

uint16_t cubic_margin_code(uint32_t resolution, const uint16_t* texels, const std::vector<double>* coefficients) {
  const int s = int(resolution) + 2;
  const auto index = [&](int x, int y, int z) { return (size_t(z) * s + y) * s + x; };
  std::vector<double> f(size_t(s) * s * s);
  for (size_t i = 0; i < f.size(); ++i) f[i] = double(texels[2 * i]);
  if (!coefficients) return uint16_t(std::min(std::ceil(margin_for(s, f, nullptr)), 65535.0));
  // The trilinear interpolant inside the brick never reads the apron, so the bound may take any apron for it, and
  // takes the better of two: the linear extrapolation of the border (axis by axis), whose second differences vanish
  // there, instead of the clamp (a second difference of a whole first difference, which the spline of the
  // coefficients does not see); or the apron's coefficients, whose |coefficient - sample| term vanishes there. The
  // first suits smooth data; the second the bricks next to samples without data, whose apron coefficients are large
  // (a not-a-knot end next to the fill's kink): there the whole difference entered the bound, now a sixth of it as a
  // second difference (blunt fin: mean margin of the partial bricks 8,860 -> 7,414 codes, pixels the walk misses at
  // iso 0.8 511 -> 133; docs/tricubic.md).
  std::vector<double> apron = f;
  for (int axis = 0; axis < 3; ++axis) {
    const size_t stride = axis == 0 ? 1 : axis == 1 ? size_t(s) : size_t(s) * s;
    for (int b = 0; b < s; ++b)
      for (int a = 0; a < s; ++a) {
        const size_t base = axis == 0 ? index(0, a, b) : axis == 1 ? index(a, 0, b) : index(a, b, 0);
        const size_t last = base + size_t(s - 1) * stride;
        f[base] = 2 * f[base + stride] - f[base + 2 * stride];
        f[last] = 2 * f[last - stride] - f[last - 2 * stride];
        apron[base] = 65535.0 * (*coefficients)[base];
        apron[last] = 65535.0 * (*coefficients)[last];
      }
  }
  const double m = std::min(margin_for(s, f, coefficients), margin_for(s, apron, coefficients));
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

namespace {

// prefilter_matrix(n) for the lines of n samples, computed once per length and thread.
const std::vector<double>& prefilter_for(int n) {
  thread_local std::map<int, std::vector<double>> matrices;
  auto it = matrices.find(n);
  if (it == matrices.end()) it = matrices.emplace(n, prefilter_matrix(n)).first;
  return it->second;
}

// Whether every sample of a slot has data.
bool all_data(uint32_t resolution, const uint16_t* texels) {
  const int r = int(resolution), s = r + 2;
  for (int z = 1; z <= r; ++z)
    for (int y = 1; y <= r; ++y)
      for (int x = 1; x <= r; ++x)
        if (texels[2 * ((size_t(z) * s + y) * s + x) + 1] == 0) return false;
  return true;
}

// How far the prefilter's block reaches past the brick on each side of each axis (lo[a], hi[a] samples): `k` where
// the face neighbour is usable, else 0, then sides dropped until every neighbour the box reaches is usable.
// With `fill`, a neighbour is usable wherever it exists (its samples without data are filled like the brick's), so
// that two same-level bricks next to the mesh boundary solve over the same lattice; without, only with data
// everywhere (the approximating spline's days: a side of partial neighbours was dropped).
void extension_box(uint32_t resolution, const CubicNeighbourhood* n, int k, bool fill, int lo[3], int hi[3]) {
  bool usable[27] = {};
  if (n)
    for (int d = 0; d < 27; ++d) usable[d] = d != 13 && (*n)[d] && (fill || all_data(resolution, (*n)[d]));
  const auto index = [](int dx, int dy, int dz) { return (dx + 1) + 3 * (dy + 1) + 9 * (dz + 1); };
  for (int a = 0; a < 3; ++a) {
    int minus[3] = {0, 0, 0}, plus[3] = {0, 0, 0};
    minus[a] = -1, plus[a] = 1;
    lo[a] = usable[index(minus[0], minus[1], minus[2])] ? k : 0;
    hi[a] = usable[index(plus[0], plus[1], plus[2])] ? k : 0;
  }
  for (bool changed = true; changed;) {
    changed = false;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int d[3] = {dx, dy, dz};
          bool reached = index(dx, dy, dz) != 13;
          for (int a = 0; a < 3; ++a) reached = reached && (d[a] == 0 || (d[a] < 0 ? lo[a] : hi[a]) > 0);
          if (!reached || usable[index(dx, dy, dz)]) continue;
          for (int a = 0; a < 3; ++a) {
            if (d[a] < 0) lo[a] = 0;
            if (d[a] > 0) hi[a] = 0;
          }
          changed = true;
        }
  }
}

// Applies the prefilter along `axis` of `in` (dims[0] × dims[1] × dims[2], x fastest): each line of dims[axis]
// samples gives its coefficients at rows first .. first + count - 1 of prefilter_matrix(dims[axis]); `out` has the
// same dims but count along axis.
void prefilter_axis(const std::vector<double>& in, const int dims[3], int axis, int first, int count,
                    std::vector<double>& out) {
  const int n = dims[axis];
  const std::vector<double>& m = prefilter_for(n);
  int od[3] = {dims[0], dims[1], dims[2]};
  od[axis] = count;
  out.assign(size_t(od[0]) * od[1] * od[2], 0.0);
  const size_t in_stride = axis == 0 ? 1 : axis == 1 ? size_t(dims[0]) : size_t(dims[0]) * dims[1];
  const size_t out_stride = axis == 0 ? 1 : axis == 1 ? size_t(od[0]) : size_t(od[0]) * od[1];
  const int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;  // the other two axes
  std::vector<double> line(n);
  for (int b = 0; b < dims[v]; ++b)
    for (int a = 0; a < dims[u]; ++a) {
      int pi[3] = {0, 0, 0}, po[3] = {0, 0, 0};
      pi[u] = po[u] = a, pi[v] = po[v] = b;
      const size_t in_base = (size_t(pi[2]) * dims[1] + pi[1]) * dims[0] + pi[0];
      const size_t out_base = (size_t(po[2]) * od[1] + po[1]) * od[0] + po[0];
      for (int j = 0; j < n; ++j) line[j] = in[in_base + j * in_stride];
      for (int i = 0; i < count; ++i) {
        const double* row = m.data() + size_t(first + i) * n;
        double c = 0;
        for (int j = 0; j < n; ++j) c += row[j] * line[j];
        out[out_base + i * out_stride] = c;
      }
    }
}

// Gives the block's samples without data (valid[i] == 0) the values of a deterministic extension of the data
// (docs/tricubic.md, "Samples without data"): layer by layer outward from the data, by Chebyshev distance (a
// breadth-first pass over the 26 neighbours), each sample the mean of its 26 neighbours of earlier layers, as
// store/brick_pad.h grows its one layer. A filled value depends only on the samples within its distance from the
// data, so two bricks whose blocks overlap there fill it alike; the prefilter then sees a continuous field across
// the boundary and the spline interpolates every data sample. False where the block has no data at all.
bool extend_into_samples_without_data(std::vector<double>& block, const std::vector<uint8_t>& valid,
                                      const int dims[3]) {
  // On a copy padded by one sample on every side that no layer reaches (kPad), so that a sample's 26 neighbours are
  // fixed offsets, in the order (z, then y, then x, ascending) in which the means are summed: the values do not
  // depend on the padding (the same bits as a bounds-checked walk), at a fraction of its cost.
  constexpr int kUnreached = -1, kPad = -2;
  const size_t nx = size_t(dims[0]), ny = size_t(dims[1]), nz = size_t(dims[2]);
  const size_t px = nx + 2, py = ny + 2, plane = px * py;
  thread_local std::vector<int> layer;
  thread_local std::vector<double> value;
  thread_local std::vector<size_t> frontier, next, without;
  layer.assign(plane * (nz + 2), kPad);
  value.assign(layer.size(), 0.0);
  frontier.clear(), without.clear();
  // Plain pointers in the loops: through the thread_local vectors each access reloaded their storage (a third of the
  // fill's time).
  int* const lay = layer.data();
  double* const val = value.data();
  for (size_t z = 0; z < nz; ++z)
    for (size_t y = 0; y < ny; ++y) {
      const size_t from = (z * ny + y) * nx, to = ((z + 1) * py + y + 1) * px + 1;
      for (size_t x = 0; x < nx; ++x) {
        val[to + x] = block[from + x];
        lay[to + x] = valid[from + x] ? 0 : kUnreached;
        (valid[from + x] ? frontier : without).push_back(to + x);
      }
    }
  if (frontier.empty()) return false;
  std::array<ptrdiff_t, 26> around;
  size_t count_around = 0;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if (dx || dy || dz) around[count_around++] = (ptrdiff_t(dz) * ptrdiff_t(py) + dy) * ptrdiff_t(px) + dx;
  for (int l = 1; !frontier.empty(); ++l) {
    next.clear();
    if (l == 1 && without.size() < frontier.size()) {
      // The first layer from the side with fewer samples (the data's frontier is all of the data): a sample without
      // data next to one with data. The same layer, so the same values.
      for (size_t j : without)
        for (ptrdiff_t o : around)
          if (lay[ptrdiff_t(j) + o] == 0) {
            lay[j] = 1, next.push_back(j);
            break;
          }
    } else {
      for (size_t i : frontier)
        for (ptrdiff_t o : around) {
          const size_t j = size_t(ptrdiff_t(i) + o);
          if (lay[j] == kUnreached) lay[j] = l, next.push_back(j);
        }
    }
    for (size_t j : next) {
      double sum = 0;
      int count = 0;
      for (ptrdiff_t o : around) {
        const size_t m = size_t(ptrdiff_t(j) + o);
        if (lay[m] >= 0 && lay[m] < l) sum += val[m], ++count;
      }
      val[j] = sum / count;  // count >= 1: j was reached from the previous layer
    }
    std::swap(frontier, next);
  }
  for (size_t z = 0; z < nz; ++z)
    for (size_t y = 0; y < ny; ++y) {
      const size_t from = ((z + 1) * py + y + 1) * px + 1, to = (z * ny + y) * nx;
      std::copy(value.begin() + ptrdiff_t(from), value.begin() + ptrdiff_t(from + nx), block.begin() + ptrdiff_t(to));
    }
  return true;
}

}  // namespace

namespace {

// Whether a brick of the neighbourhood (the brick included) has samples without data, or stands for a position
// without a brick (the engine's all-zero slot): the brick is next to the mesh's boundary.
bool next_to_samples_without_data(uint32_t resolution, const uint16_t* texels, const CubicNeighbourhood* n) {
  if (!all_data(resolution, texels)) return true;
  if (n)
    for (int d = 0; d < 27; ++d)
      if (d != 13 && (*n)[size_t(d)] && !all_data(resolution, (*n)[size_t(d)])) return true;
  return false;
}

// The neighbourhood's sample at brick sample q (each axis -(r - 1) .. 2 (r - 1)) into `value`, and whether it has
// data. A sample on a brick border belongs to every brick that meets there (neighbours share their border samples):
// the slot it lies in is tried first (below r - 1 the brick's own, as the tensor of q's axes gives), then the others
// that hold it, so that a border sample has data wherever one of its bricks has it there. Without that, a slot that
// stands for a position without a brick (all zero) hid the border samples of the brick across from it, in the blocks
// that took the sample from that slot only: two bricks next to it disagreed about those samples (their fill differed,
// a seam of up to 1.9e-3 in gradient on the blunt fin).
bool neighbourhood_sample(int r, const uint16_t* texels, const CubicNeighbourhood* n, const int q[3], double& value) {
  const int s = r + 2;
  int d[3], t[3], others[3] = {0, 0, 0};  // others[a]: the other slot's d along a when q lies on a border, else 0
  for (int a = 0; a < 3; ++a) {
    d[a] = q[a] < 0 ? -1 : q[a] > r - 1 ? 1 : 0;
    t[a] = q[a] - d[a] * (r - 1) + 1;  // texel in that brick's slot
    if (t[a] == r && d[a] < 1) others[a] = 1;
    if (t[a] == 1 && d[a] > -1) others[a] = -1;
  }
  bool found = false;
  for (int alt = 0; alt < 8 && !found; ++alt) {
    int da[3], ta[3];
    bool holds = true;
    for (int a = 0; a < 3; ++a) {
      const bool other = alt >> a & 1;
      if (other && others[a] == 0) holds = false;
      da[a] = other ? d[a] + others[a] : d[a];
      ta[a] = other ? (others[a] > 0 ? 1 : r) : t[a];
    }
    if (!holds) continue;
    const int which = (da[0] + 1) + 3 * (da[1] + 1) + 9 * (da[2] + 1);
    const uint16_t* from = which == 13 ? texels : n ? (*n)[size_t(which)] : nullptr;
    if (!from) continue;
    const size_t texel = (size_t(ta[2]) * s + ta[1]) * s + ta[0];
    if (alt == 0) value = double(from[2 * texel]) / 65535.0;  // the slot's own value where none has data
    if (from[2 * texel + 1] != 0) value = double(from[2 * texel]) / 65535.0, found = true;
  }
  return found;
}

}  // namespace

int cubic_reach(int extension, bool next_to_fill, bool fill_nearby) {
  if (next_to_fill) return extension + 3 * extension / 4;
  if (fill_nearby) return extension + extension / 4;
  return extension;
}

bool cubic_coefficients(uint32_t resolution, const uint16_t* texels, std::vector<double>& coefficients,
                        const CubicNeighbourhood* neighbours, int extension, bool fill, bool fill_nearby) {
  const int r = int(resolution), s = r + 2;
  const bool complete = all_data(resolution, texels);
  if (!complete && !fill) return false;
  // Next to samples without data the fill is only C0 at the mesh's boundary, and a block's not-a-knot end near that
  // kink leaves a residual 0.27^k of a large third difference: the prefilter reaches farther there, and a little
  // farther one brick away (brick_atlas.h, cubic_reach).
  if (fill)
    extension = cubic_reach(extension, next_to_samples_without_data(resolution, texels, neighbours), fill_nearby);
  int lo[3], hi[3];
  extension_box(resolution, neighbours, std::clamp(extension, 0, r - 1), fill, lo, hi);
  // The block of samples: brick sample q (-lo .. r - 1 + hi along each axis) from the brick or the neighbours that
  // hold it (neighbourhood_sample).
  const int dims[3] = {r + lo[0] + hi[0], r + lo[1] + hi[1], r + lo[2] + hi[2]};
  std::vector<double> block(static_cast<size_t>(dims[0]) * dims[1] * dims[2]);
  std::vector<uint8_t> valid(block.size());
  bool all_valid = true;
  // Along each axis, each block coordinate's slot offset (-1, 0, 1) and texel in that slot; the shared border samples
  // without data in their first slot look at the others that hold them (neighbourhood_sample).
  std::vector<int> slot_of[3], texel_of[3];
  std::vector<char> border_of[3];
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i < dims[a]; ++i) {
      const int q = i - lo[a], d = q < 0 ? -1 : q > r - 1 ? 1 : 0, t = q - d * (r - 1) + 1;
      slot_of[a].push_back(d), texel_of[a].push_back(t), border_of[a].push_back(t == 1 || t == r);
    }
  for (int z = 0; z < dims[2]; ++z)
    for (int y = 0; y < dims[1]; ++y)
      for (int x = 0; x < dims[0]; ++x) {
        const int which =
            (slot_of[0][size_t(x)] + 1) + 3 * (slot_of[1][size_t(y)] + 1) + 9 * (slot_of[2][size_t(z)] + 1);
        const uint16_t* from = which == 13 ? texels : (*neighbours)[size_t(which)];
        const size_t texel =
            (size_t(texel_of[2][size_t(z)]) * s + size_t(texel_of[1][size_t(y)])) * s + size_t(texel_of[0][size_t(x)]);
        const size_t at = (size_t(z) * dims[1] + y) * dims[0] + x;
        block[at] = double(from[2 * texel]) / 65535.0;
        valid[at] = from[2 * texel + 1] != 0;
        if (!valid[at] && (border_of[0][size_t(x)] || border_of[1][size_t(y)] || border_of[2][size_t(z)])) {
          const int q[3] = {x - lo[0], y - lo[1], z - lo[2]};
          valid[at] = neighbourhood_sample(r, texels, neighbours, q, block[at]);
        }
        all_valid = all_valid && valid[at];
      }
  // With data everywhere the block is the samples as they are: the same coefficients, bit for bit, as before fills.
  // (Extending a partial block's box k samples past a missing neighbour too, all filled, was tried: the two sides of
  // a face where one brick's block has data everywhere and drops that side then disagree more, 3.1e-2 in gradient.)
  if (!all_valid && !extend_into_samples_without_data(block, valid, dims)) return false;
  // Axis by axis (the tensor product): the coefficients of brick samples -1 .. r are the block's rows lo .. lo + r + 1.
  std::vector<double> a, b;
  int d1[3] = {s, dims[1], dims[2]};
  prefilter_axis(block, dims, 0, lo[0], s, a);
  int d2[3] = {s, s, dims[2]};
  prefilter_axis(a, d1, 1, lo[1], s, b);
  prefilter_axis(b, d2, 2, lo[2], s, coefficients);
  return true;
}

void refine_coefficients(uint32_t resolution, const std::vector<double>& parent, int octant,
                         std::vector<double>& child) {
  const int r = int(resolution), s = r + 2;
  std::vector<double> a = parent, b(a.size());
  for (int axis = 0; axis < 3; ++axis) {
    const int offset = (octant >> axis & 1) ? r - 1 : 0;
    const size_t stride = axis == 0 ? 1 : axis == 1 ? size_t(s) : size_t(s) * s;
    for (int z = 0; z < s; ++z)
      for (int y = 0; y < s; ++y)
        for (int x = 0; x < s; ++x) {
          const int t[3] = {x, y, z};
          const size_t at = (size_t(z) * s + y) * s + x, line = at - size_t(t[axis]) * stride;
          const auto p = [&](int m) { return a[line + size_t(m + 1) * stride]; };  // parent sample index m
          const int f = offset + t[axis] - 1;
          const int m = f >= 0 ? f / 2 : -1;  // floor(f / 2); f >= -1
          b[at] = (f & 1) ? 0.5 * (p(m) + p(m + 1)) : (p(m - 1) + 6 * p(m) + p(m + 1)) / 8;
        }
    std::swap(a, b);
  }
  child = std::move(a);
}

double level_blend_weight(uint32_t resolution, const std::array<bool, 27>& towards, int tx, int ty, int tz) {
  const int r = int(resolution), zone = kCubicBlendZone(resolution);
  const int q[3] = {tx - 1, ty - 1, tz - 1};  // sample index
  double weight = 0;
  for (int d = 0; d < 27; ++d) {
    if (d == 13 || !towards[size_t(d)]) continue;
    const int dir[3] = {d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1};
    int distance = -1;  // to the coarser node's region, samples (Chebyshev)
    for (int a = 0; a < 3; ++a)
      if (dir[a] != 0) distance = std::max(distance, dir[a] < 0 ? q[a] : r - 1 - q[a]);
    const double u = std::clamp(double(distance - 1) / zone, 0.0, 1.0);
    weight = std::max(weight, 1 - u * u * (3 - 2 * u));  // smoothstep from 1 to 0
  }
  return weight;
}

void blend_towards_coarser(uint32_t resolution, const CubicLevelBlend& blend, std::vector<double>& coefficients) {
  const int s = int(resolution) + 2;
  for (const CubicLevelTarget& target : blend)
    for (int z = 0; z < s; ++z)
      for (int y = 0; y < s; ++y)
        for (int x = 0; x < s; ++x) {
          const double w = level_blend_weight(resolution, target.towards, x, y, z);
          const size_t i = (size_t(z) * s + y) * s + x;
          coefficients[i] += w * (target.coefficients[i] - coefficients[i]);
        }
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
  const char* extension = std::getenv("UGVR_TRICUBIC_EXTENSION");
  if (extension && *extension) extension_ = std::max(0, std::atoi(extension));
  const char* fill = std::getenv("UGVR_TRICUBIC_FILL");
  if (fill && *fill) fill_ = std::atoi(fill) != 0;
  const char* level_blend = std::getenv("UGVR_TRICUBIC_LEVEL_BLEND");
  if (level_blend && *level_blend) level_blend_ = std::atoi(level_blend) != 0;
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

BrickAtlas::CubicSlot BrickAtlas::cubic_slot(const uint16_t* texels, const CubicNeighbourhood* neighbours,
                                             const CubicLevelBlend* levels, bool fill_nearby) const {
  std::vector<double> coefficients;
  const bool prefiltered =
      cubic_coefficients(resolution_, texels, coefficients, neighbours, extension_, fill_, fill_nearby);
  return cubic_slot_of(texels, prefiltered ? &coefficients : nullptr, levels);
}

BrickAtlas::CubicSlot BrickAtlas::cubic_slot_of(const uint16_t* texels, const std::vector<double>* prefiltered,
                                                const CubicLevelBlend* levels) const {
  const size_t side = size_t(resolution_) + 2;
  std::vector<double> blended;
  const std::vector<double>* coefficients = prefiltered;
  if (prefiltered && levels && !levels->empty() && level_blend_) {
    blended = *prefiltered;
    blend_towards_coarser(resolution_, *levels, blended);
    coefficients = &blended;
  }
  // [-1/2, 3/2] to [0, 1] (brick_atlas.h); without the prefilter, the samples themselves.
  CubicSlot out;
  out.codes.resize(side * side * side);
  for (size_t i = 0; i < out.codes.size(); ++i) {
    const double c = coefficients ? (*coefficients)[i] : double(texels[2 * i]) / 65535.0;
    out.codes[i] = uint16_t(std::clamp(std::round((c + 0.5) * 0.5 * 65535.0), 0.0, 65535.0));
  }
  out.margin = no_bracket_ ? 1.0f : float(cubic_margin_code(resolution_, texels, coefficients)) / 65535.0f;
  return out;
}

void BrickAtlas::upload(uint64_t slot, const uint16_t* texels, const CubicNeighbourhood* neighbours,
                        const CubicLevelBlend* levels) {
  if (!has_coefficients()) return upload(slot, texels, static_cast<const CubicSlot*>(nullptr));
  const CubicSlot cubic = cubic_slot(texels, neighbours, levels);
  upload(slot, texels, &cubic);
}

void BrickAtlas::upload(uint64_t slot, const uint16_t* texels, const CubicSlot* cubic) {
  const int side = int(resolution_) + 2;
  const int x = int(slot % uint64_t(slots_[0])), y = int((slot / uint64_t(slots_[0])) % uint64_t(slots_[1]));
  const int z = int(slot / (uint64_t(slots_[0]) * slots_[1]));
  glTextureSubImage3D(texture_.id(), 0, x * side, y * side, z * side, side, side, side, GL_RG, GL_UNSIGNED_SHORT,
                      texels);
  if (!has_coefficients() || !cubic) return;  // the margin and coefficients serve tricubic frames only
  // Rows of one 16-bit channel are not 4-byte multiples for an odd side: unpack at 2-byte alignment.
  GLint alignment = 4;
  glGetIntegerv(GL_UNPACK_ALIGNMENT, &alignment);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
  glTextureSubImage3D(coefficients_.id(), 0, x * side, y * side, z * side, side, side, side, GL_RED, GL_UNSIGNED_SHORT,
                      cubic->codes.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, alignment);
  glNamedBufferSubData(margins_.id(), GLintptr(slot * sizeof(float)), sizeof(float), &cubic->margin);
}

}  // namespace ugvr
