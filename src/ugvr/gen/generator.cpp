// Synthetic dataset generator; the geometry, cells and fields are described in generator.h.
//
// Everything is an analytic function of the index (i, j, k), evaluated from per-axis tables:
//   point(i,j,k) = ( shift(z) * (1 - w_j) + lambda * c0 cosh(mu_j) cos(theta_i),
//                                           lambda * c0 sinh(mu_j) sin(theta_i),  z_k )
//   lambda = s(z) + (1 - s(z)) * w_j
// where (mu, theta) are elliptic coordinates of focal distance c0 (the wall is mu = mu0, the root section's ellipse),
// s(z) the taper, shift(z) the sweep, and w_j a smoothstep of the wall distance from 0 at the wall to 1 at the far
// field, so taper and sweep fade out and the far field is a circle. The blend is flat at the wall, where the grid is
// finest, so it never folds the grid (the Jacobian stays positive; the tests check every cell's volume).
#include "ugvr/gen/generator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <span>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/io/vtu_writer.h"

namespace ugvr {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// Body and domain, in root chords.
constexpr double kSemiChord = 0.5;            // root section semi-axes
constexpr double kSemiThickness = 0.12;       // 24% thick: a blunt fin
constexpr double kSpan = 2.0;                 // floor to top
constexpr double kTaper = 0.4;                // tip chord = 60% of the root chord
constexpr double kSweep = 20 * kDeg;          // leading edge moves downstream with height
constexpr double kFarField = 15.0;            // far-field radius
constexpr double kAlpha = 6 * kDeg;           // incidence of the free stream
constexpr double kFirstCell = 2e-5;           // wall spacing aimed for (reached on large grids)
constexpr double kMaxGrowth = 1.4;            // wall-normal growth ratio cap (small grids)
constexpr double kFloorClustering = 2.0;      // tanh stretching of z towards the floor
constexpr double kBoundaryLayerFloor = 0.08;  // floor boundary-layer thickness

// Sizes of the work units: bounded buffers whatever the grid.
constexpr uint64_t kPointChunk = uint64_t(1) << 17;  // points per chunk (1.5 MiB of positions)
constexpr uint64_t kCellChunk = uint64_t(1) << 15;   // structured cells per chunk (<= 6 MiB of Int64 ids)
constexpr uint64_t kMaxInMemoryCells = 50'000'000;

double smoothstep01(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// sin for the fluctuation waves: reduction to [-pi, pi] by rounding (adding and removing 1.5 * 2^52 rounds to an
// integer without a branch or a library call), then an odd degree-11 polynomial fitted to sin on [-pi, pi] (error
// below 1e-7, under float output precision). Branch-free and several times faster than std::sin.
inline double fast_sin(double x) {
  constexpr double kInvTwoPi = 1.0 / (2 * kPi), kRound = 6755399441055744.0;
  const double turns = (x * kInvTwoPi + kRound) - kRound;
  const double r = x - turns * (2 * kPi), r2 = r * r;
  return r * (0.9999996039120775 +
              r2 * (-0.16666553445064886 +
                    r2 * (0.008332407583984078 + r2 * (-0.00019808739777071177 +
                                                       r2 * (2.6998224802524118e-06 + r2 * -2.0366218100864586e-08)))));
}

// e^-x for x >= 0, skipping the call where the result is far below anything a float field can show.
inline double exp_neg(double x) { return x > 40 ? 0.0 : std::exp(-x); }

// splitmix64: a small, well-mixed, seedable sequence for the wave parameters.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)

 private:
  uint64_t state_;
};

Vec3d normalized(Vec3d v) { return v * (1.0 / length(v)); }

Vec3d random_unit(Rng& rng) {
  const double z = 2 * rng.uniform() - 1, phi = 2 * kPi * rng.uniform(), r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// ----------------------------------------------------------------------------------------------------------------
// Cells of one hexahedron of the index space, by wall-normal layer. Corners are numbered by bits (1 = +i, 2 = +j,
// 4 = +k); in a right-handed (i, j, k) frame these lists are positively oriented in VTK's convention.

enum class Layer : uint8_t { Hex, Tets, Prisms, Transition };

struct LayerCells {
  uint8_t count;  // cells per hexahedron
  uint8_t ids;    // connectivity entries per hexahedron
  std::array<CellType, 6> type;
  std::array<uint8_t, 6> size;
  std::array<std::array<uint8_t, 8>, 6> corner;
};

constexpr LayerCells kHexLayer = {1, 8, {CellType::Hexahedron}, {8}, {{{0, 1, 3, 2, 4, 5, 7, 6}}}};
// Kuhn split: the 6 monotone paths from corner 0 to corner 7 (as structured_cells.cpp).
constexpr LayerCells kTetLayer = {
    6,
    24,
    {CellType::Tetra, CellType::Tetra, CellType::Tetra, CellType::Tetra, CellType::Tetra, CellType::Tetra},
    {4, 4, 4, 4, 4, 4},
    {{{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7}, {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}}}};
// Two prisms: the (i,k) faces cut from corner 0 to corner 5, extruded along j (+2). The base triangles (0,1,5) and
// (0,5,4) wind so that their normal points to -j, away from the top triangle, as VTK wants.
constexpr LayerCells kPrismLayer = {
    2, 12, {CellType::Wedge, CellType::Wedge}, {6, 6}, {{{0, 1, 5, 2, 3, 7}, {0, 5, 4, 2, 7, 6}}}};
// Kuhn split with the two tets on the j+1 face, (0,3,2,7) and (0,2,6,7), merged into the pyramid (2,3,7,6; apex 0).
constexpr LayerCells kTransitionLayer = {
    5,
    21,
    {CellType::Pyramid, CellType::Tetra, CellType::Tetra, CellType::Tetra, CellType::Tetra},
    {5, 4, 4, 4, 4},
    {{{2, 3, 7, 6, 0}, {0, 1, 3, 7}, {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}}}};

const LayerCells& layer_cells(Layer l) {
  switch (l) {
    case Layer::Hex: return kHexLayer;
    case Layer::Tets: return kTetLayer;
    case Layer::Prisms: return kPrismLayer;
    case Layer::Transition: return kTransitionLayer;
  }
  return kHexLayer;
}

Layer layer_of(const GeneratePlan& p, uint32_t j) {
  switch (p.kind) {
    case GenCellKind::Hex: return Layer::Hex;
    case GenCellKind::Tet: return Layer::Tets;
    case GenCellKind::Mixed:
      if (j < p.wedge_layers) return Layer::Prisms;
      if (j < p.wedge_layers + p.tet_layers) return Layer::Tets;
      if (j == p.wedge_layers + p.tet_layers) return Layer::Transition;
      return Layer::Hex;
  }
  return Layer::Hex;
}

// Cells and connectivity entries before each row of structured cells. Row r = j + nj * k holds the ni hexahedra
// (i, j, k), i = 0..ni-1; rows are in file order.
class RowIndex {
 public:
  explicit RowIndex(const GeneratePlan& p) : p_(p), cells_(p.nj + 1, 0), ids_(p.nj + 1, 0) {
    for (uint32_t j = 0; j < p.nj; ++j) {
      const LayerCells& lc = layer_cells(layer_of(p, j));
      cells_[j + 1] = cells_[j] + lc.count;
      ids_[j + 1] = ids_[j] + lc.ids;
    }
  }
  uint64_t rows() const { return uint64_t(p_.nj) * p_.nk; }
  uint64_t cells_before(uint64_t r) const { return before(cells_, r); }
  uint64_t ids_before(uint64_t r) const { return before(ids_, r); }

 private:
  uint64_t before(const std::vector<uint64_t>& per_column, uint64_t r) const {
    const uint64_t j = r % p_.nj, k = r / p_.nj;
    return uint64_t(p_.ni) * (k * per_column[p_.nj] + per_column[j]);
  }
  const GeneratePlan& p_;
  std::vector<uint64_t> cells_, ids_;  // per (i,k) column, before layer j
};

// ----------------------------------------------------------------------------------------------------------------
// Geometry and flow.

struct Wave {
  Vec3d k;  // wave vector
  Vec3d a;  // velocity amplitude, perpendicular to k (divergence-free)
  double phase;
  double p;  // pressure amplitude
};

struct FlowSample {
  double cp;
  Vec3d velocity;
};

class Model {
 public:
  Model(const GeneratePlan& plan, uint64_t seed, double time) : p_(plan), time_(time) {
    c0_ = std::sqrt(kSemiChord * kSemiChord - kSemiThickness * kSemiThickness);
    mu0_ = std::atanh(kSemiThickness / kSemiChord);
    cosh0_ = std::cosh(mu0_);
    sinh0_ = std::sinh(mu0_);
    build_i();
    build_j();
    build_k();
    build_waves(seed);
  }

  Vec3d point(uint32_t i, uint32_t j, uint32_t k) const {
    const double lam = scale_[k] + (1 - scale_[k]) * blend_[j];
    return {shift_[k] * (1 - blend_[j]) + lam * c0_ * cosh_[j] * cos_[i], lam * c0_ * sinh_[j] * sin_[i], z_[k]};
  }

  // Distance to the wing along the wall-normal grid line (exact at the wall, where it matters), or to the floor.
  double wall_distance(uint32_t i, uint32_t j, uint32_t k) const { return std::min(body_distance(i, j, k), z_[k]); }

  FlowSample flow(uint32_t i, uint32_t j, uint32_t k) const;

 private:
  double lambda(uint32_t j, uint32_t k) const { return scale_[k] + (1 - scale_[k]) * blend_[j]; }
  double body_distance(uint32_t i, uint32_t j, uint32_t k) const {
    const double dx = dcosh_[j] * cos_[i], dy = dsinh_[j] * sin_[i];
    return lambda(j, k) * std::sqrt(dx * dx + dy * dy);
  }

  void build_i() {
    cos_.resize(p_.ni);
    sin_.resize(p_.ni);
    for (uint32_t i = 0; i < p_.ni; ++i) {
      const double theta = -2 * kPi * double(i) / double(p_.ni);  // clockwise: right-handed (i, j, k)
      cos_[i] = std::cos(theta);
      sin_[i] = std::sin(theta);
    }
  }

  // Wall-normal stations: the distance from the wall (measured where the section is thickest, d = c0 (sinh mu -
  // sinh mu0)) grows geometrically, d_j = h1 (r^j - 1) / (r - 1), from h1 = kFirstCell up to the far field. On coarse
  // grids the ratio that would need exceeds kMaxGrowth; then the ratio is capped and the first cell grows instead.
  void build_j() {
    const uint32_t n = p_.nj;
    const double mu_far = std::acosh(kFarField / c0_);
    const double d_far = c0_ * (std::sinh(mu_far) - std::sinh(mu0_));
    auto total = [&](double r) { return kFirstCell * (std::pow(r, double(n)) - 1) / (r - 1); };
    double r = kMaxGrowth, h1 = kFirstCell;
    if (total(kMaxGrowth) <= d_far) {
      h1 = d_far * (kMaxGrowth - 1) / (std::pow(kMaxGrowth, double(n)) - 1);
    } else {
      double lo = 1 + 1e-12, hi = kMaxGrowth;
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        (total(mid) < d_far ? lo : hi) = mid;
      }
      r = 0.5 * (lo + hi);
    }
    const size_t m = size_t(n) + 1;
    cosh_.resize(m), sinh_.resize(m), blend_.resize(m), dcosh_.resize(m), dsinh_.resize(m);
    for (uint32_t j = 0; j <= n; ++j) {
      const double d = j == n ? d_far : h1 * (std::pow(r, double(j)) - 1) / (r - 1);
      const double mu = j == 0 ? mu0_ : std::asinh(std::sinh(mu0_) + d / c0_);  // exactly on the wall at j = 0
      cosh_[j] = std::cosh(mu);
      sinh_[j] = std::sinh(mu);
      blend_[j] = smoothstep01(d / d_far);
      dcosh_[j] = c0_ * (cosh_[j] - std::cosh(mu0_));
      dsinh_[j] = c0_ * (sinh_[j] - std::sinh(mu0_));
    }
  }

  void build_k() {
    const uint32_t n = p_.nk;
    z_.resize(size_t(n) + 1), scale_.resize(size_t(n) + 1), shift_.resize(size_t(n) + 1);
    for (uint32_t k = 0; k <= n; ++k) {
      const double t = double(k) / double(n);
      const double z = k == 0 ? 0.0 : kSpan * (1 + std::tanh(kFloorClustering * (t - 1)) / std::tanh(kFloorClustering));
      z_[k] = z;
      scale_[k] = 1 - kTaper * z / kSpan;
      shift_[k] = z * std::tan(kSweep);
    }
  }

  // Six octaves of two waves each, wavelengths 0.8 down to 0.025 chords. Velocity amplitudes fall as k^(-1/3) and
  // pressure amplitudes as k^(-2/3) (Kolmogorov scaling); both sums are normalised to unit rms.
  void build_waves(uint64_t seed) {
    Rng rng(seed * 0x2545F4914F6CDD1Dull + 0x1234567ull);
    double sum_a = 0, sum_p = 0;
    for (int octave = 0; octave < 6; ++octave) {
      for (int m = 0; m < 2; ++m) {
        Wave w;
        const double kmag = 2 * kPi / (0.8 * std::pow(0.5, octave));
        const Vec3d dir = random_unit(rng);
        Vec3d a = random_unit(rng);
        a = normalized(a - dir * dot(a, dir));
        const double amp = std::pow(2.0, -octave / 3.0);
        w.k = dir * kmag;
        w.a = a * amp;
        w.phase = 2 * kPi * rng.uniform();
        w.p = std::pow(2.0, -2.0 * octave / 3.0) * (rng.uniform() < 0.5 ? -1 : 1);
        sum_a += amp * amp / 2;
        sum_p += w.p * w.p / 2;
        waves_.push_back(w);
      }
    }
    for (Wave& w : waves_) {
      w.a = w.a * (1 / std::sqrt(sum_a));
      w.p /= std::sqrt(sum_p);
    }
    shedding_phase_ = 2 * rng.uniform();
  }

  const GeneratePlan& p_;
  double c0_ = 0, mu0_ = 0, cosh0_ = 0, sinh0_ = 0;
  std::vector<double> cos_, sin_;                            // per i
  std::vector<double> cosh_, sinh_, blend_, dcosh_, dsinh_;  // per j
  std::vector<double> z_, scale_, shift_;                    // per k
  std::vector<Wave> waves_;
  double shedding_phase_ = 0;
  double time_ = 0;
};

FlowSample Model::flow(uint32_t i, uint32_t j, uint32_t k) const {
  const double ca = std::cos(kAlpha), sa = std::sin(kAlpha);  // constants, folded by the compiler
  const Vec3d pos = point(i, j, k);
  const double z = z_[k], s = scale_[k];

  // Potential flow past the ellipse, from the complex potential w = U (a+b) cosh(zeta - mu0 - i alpha) - i G/(2 pi)
  // zeta in elliptic coordinates zeta = mu + i theta, z = c0 cosh(zeta), with the circulation G that puts the rear
  // stagnation point on the trailing edge: u - i v = (dw/dzeta) / (dz/dzeta).
  const double ct = cos_[i], st = sin_[i];
  const double sinh_rel = sinh_[j] * cosh0_ - cosh_[j] * sinh0_, cosh_rel = cosh_[j] * cosh0_ - sinh_[j] * sinh0_;
  const double cos_rel = ct * ca + st * sa, sin_rel = st * ca - ct * sa;
  const double ab = kSemiChord + kSemiThickness;
  const double n_re = ab * sinh_rel * cos_rel, n_im = ab * (cosh_rel * sin_rel + sa);
  const double dr = c0_ * sinh_[j] * ct, di = c0_ * cosh_[j] * st;
  const double den = dr * dr + di * di;
  const double u_pot = (n_re * dr + n_im * di) / den, v_pot = -(n_im * dr - n_re * di) / den;
  double cp = 1 - (u_pot * u_pot + v_pot * v_pot);

  // Boundary layers: no slip on the wing (thickening from leading to trailing edge) and on the floor.
  const double chord_pos = 0.5 * (1 + ct);  // 0 at the leading edge, 1 at the trailing edge
  const double delta = s * (0.004 + 0.03 * std::sqrt(chord_pos));
  const double eta_bl = body_distance(i, j, k) / delta;
  // e^(-eta/2) and its powers serve the profile e^(-3 eta), the cross-flow e^(-eta) and the turbulence envelope.
  const double bl_half = exp_neg(0.5 * eta_bl), bl_one = bl_half * bl_half, bl_three = bl_one * bl_one * bl_one;
  const double floor_half = exp_neg(0.5 * z / kBoundaryLayerFloor), floor_one = floor_half * floor_half;
  const double f_body = 1 - bl_three;
  const double f_floor = 1 - floor_one * floor_one * floor_one;
  const double no_slip = f_body * f_floor;  // every velocity term vanishes on the walls
  Vec3d vel = {u_pot * no_slip, v_pot * no_slip, 0};
  vel.z = 0.3 * std::sin(kSweep) * eta_bl * std::exp(1.0) * bl_one * f_floor;  // sweep-driven cross-flow

  // Wake frame: xi downstream of the trailing edge along the free stream, eta across it.
  const double rx = pos.x - (shift_[k] + s * kSemiChord), ry = pos.y;
  const double xi = rx * ca + ry * sa, eta = -rx * sa + ry * ca;
  const double on = smoothstep01((xi + 0.05) / 0.3);
  const double xi_p = std::max(xi, 0.0);
  const double half_width = 0.06 * s + 0.1 * std::sqrt(xi_p);
  const double deficit = on * 0.6 / std::sqrt(1 + 3 * xi_p) * exp_neg((eta / half_width) * (eta / half_width));
  vel.x -= deficit * ca * no_slip;
  vel.y -= deficit * sa * no_slip;

  // Karman street of Gaussian vortices. Vortex n sits at xi_n = xi_s + (n - phase(z)) spacing/2, alternately above
  // (clockwise) and below the wake centre line; the phase drifts with z (oblique shedding) and strengths fade in
  // after formation and decay downstream. A Gaussian vortex's influence is below 1e-9 of its peak beyond
  // sqrt(20) core radii, so only the vortices that near are summed (the cut is invisible in float output).
  const double spacing = 1.0 * s, xi_s = 0.5 * spacing;
  // Time moves every vortex downstream: a phase step of 2 is one pair spacing, so one unit of time is one period.
  const double phase = shedding_phase_ + 1.2 * z - 2 * time_;
  const double reach = std::sqrt(20.0) * 0.2 * spacing * (1 + 0.04 * kFarField);
  double u_xi = 0, u_eta = 0, cp_v = 0;
  if (xi > xi_s - spacing - reach && std::abs(eta) < 0.15 * spacing * (1 + 0.05 * kFarField) + reach) {
    const int64_t nc = int64_t(std::floor((xi - xi_s) / (spacing / 2) + phase));
    for (int64_t n = nc - 4; n <= nc + 5; ++n) {
      const double xn = xi_s + (double(n) - phase) * spacing / 2, xn_p = std::max(xn, 0.0);
      const bool upper = (n & 1) == 0;
      const double hs = 0.3 * spacing * (1 + 0.05 * xn_p);
      const double rc = 0.2 * spacing * (1 + 0.04 * xn_p);
      const double dx = xi - xn, dy = eta - (upper ? hs / 2 : -hs / 2), r2 = (dx * dx + dy * dy) / (rc * rc);
      if (r2 > 20) continue;
      const double strength =
          smoothstep01((xn - (xi_s - spacing / 2)) / spacing) * smoothstep01(13 - xn) * std::exp(-xn_p / 12);
      const double e = strength * std::exp(-r2);
      const double psi = (upper ? -1 : 1) * 0.3 * rc * e;  // stream function
      u_xi += -2 * dy / (rc * rc) * psi;
      u_eta += 2 * dx / (rc * rc) * psi;
      cp_v -= 0.36 * e;
    }
  }
  vel.x += (u_xi * ca - u_eta * sa) * no_slip;
  vel.y += (u_xi * sa + u_eta * ca) * no_slip;
  cp += cp_v * f_floor;

  // Multi-octave fluctuations, strongest in the wake and the boundary layers, vanishing at the walls.
  const double wake_width = half_width + 0.2 * spacing;
  const double wake_env = on * exp_neg((eta / wake_width) * (eta / wake_width) + xi_p / 25);
  const double bl_env = bl_half * (0.3 + 0.7 * chord_pos);
  const double floor_env = floor_half;
  const double intensity = 0.005 + 0.12 * wake_env + 0.08 * bl_env + 0.04 * floor_env;
  Vec3d up{};
  double pp = 0;
  for (const Wave& w : waves_) {
    const double sn = fast_sin(dot(w.k, pos) + w.phase);
    up = up + w.a * sn;
    pp += w.p * sn;
  }
  vel = vel + up * (intensity * no_slip);
  cp += 0.6 * intensity * pp;
  return {cp, vel};
}

// ----------------------------------------------------------------------------------------------------------------
// The passes. Arrays are emitted in file order, each in chunks.

enum ArrayId : size_t { kPoints, kConnectivity, kOffsets, kTypes, kPressure, kVelocity, kWallDistance, kArrayCount };

using Emit = std::function<void(size_t array, std::span<const std::byte> bytes)>;

struct Context {
  const GeneratePlan& plan;
  const Model& model;
  RowIndex rows;
  Emit emit;
};

template <class T>
void emit_values(const Context& c, size_t array, const std::vector<T>& values) {
  c.emit(array, std::as_bytes(std::span(values)));
}

// Runs `fill(i, j, k, T* tuple)` for every point in file order, chunk by chunk, in parallel within a chunk.
template <class T, int Components, class Fill>
void point_pass(const Context& c, size_t array, Fill fill) {
  const GeneratePlan& p = c.plan;
  std::vector<T> buf;
  for (uint64_t p0 = 0; p0 < p.points; p0 += kPointChunk) {
    const uint64_t n = std::min(kPointChunk, p.points - p0);
    buf.resize(size_t(n) * Components);
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, n, 4096), [&](const tbb::blocked_range<uint64_t>& r) {
      for (uint64_t q = r.begin(); q != r.end(); ++q) {
        const uint64_t id = p0 + q, row = id / p.ni;
        fill(uint32_t(id % p.ni), uint32_t(row % (p.nj + 1)), uint32_t(row / (p.nj + 1)), buf.data() + q * Components);
      }
    });
    emit_values(c, array, buf);
  }
}

// Runs `fill(row, T* out)` for every row of structured cells in file order; `before(row)` counts the values that
// precede the row in the array (cells or connectivity entries).
template <class T, class Before, class Fill>
void row_pass(const Context& c, size_t array, Before before, Fill fill) {
  const uint64_t rows = c.rows.rows();
  const uint64_t rows_per_chunk = std::max<uint64_t>(1, kCellChunk / c.plan.ni);
  std::vector<T> buf;
  for (uint64_t r0 = 0; r0 < rows; r0 += rows_per_chunk) {
    const uint64_t r1 = std::min(rows, r0 + rows_per_chunk), base = before(r0);
    buf.resize(size_t(before(r1) - base));
    tbb::parallel_for(r0, r1, [&](uint64_t r) { fill(r, buf.data() + (before(r) - base)); });
    emit_values(c, array, buf);
  }
}

// Point ids of the 8 corners of hexahedron (i, j, k), by corner bits; i wraps around (periodic).
std::array<uint64_t, 8> corner_ids(const GeneratePlan& p, uint32_t i, uint32_t j, uint32_t k) {
  std::array<uint64_t, 8> id{};
  const uint32_t i1 = i + 1 == p.ni ? 0 : i + 1;
  for (int b = 0; b < 8; ++b) {
    const uint64_t ii = (b & 1) ? i1 : i, jj = j + ((b >> 1) & 1), kk = k + ((b >> 2) & 1);
    id[size_t(b)] = ii + uint64_t(p.ni) * (jj + uint64_t(p.nj + 1) * kk);
  }
  return id;
}

// Runs `hex(i, j, k, lc, out)` for every hexahedron in file order: it writes the values of the lc.count cells the
// hexahedron is cut into (one per cell, or with `per_id`, one per connectivity entry) and advances `out` past them.
template <class T, class Hex>
void hex_pass(const Context& c, size_t array, bool per_id, Hex hex) {
  const GeneratePlan& p = c.plan;
  row_pass<T>(
      c, array, [&](uint64_t r) { return per_id ? c.rows.ids_before(r) : c.rows.cells_before(r); },
      [&](uint64_t r, T* out) {
        const uint32_t j = uint32_t(r % p.nj), k = uint32_t(r / p.nj);
        const LayerCells& lc = layer_cells(layer_of(p, j));
        for (uint32_t i = 0; i < p.ni; ++i) hex(i, j, k, lc, out);
      });
}

template <class Index>
void connectivity_pass(const Context& c) {
  hex_pass<Index>(c, kConnectivity, true, [&](uint32_t i, uint32_t j, uint32_t k, const LayerCells& lc, Index*& out) {
    const auto id = corner_ids(c.plan, i, j, k);
    for (int cell = 0; cell < lc.count; ++cell) {
      for (int v = 0; v < lc.size[size_t(cell)]; ++v) *out++ = Index(id[lc.corner[size_t(cell)][size_t(v)]]);
    }
  });
}

// Each cell's end in the connectivity: the entries of the rows and hexahedra before it, then its own.
void offsets_pass(const Context& c) {
  const GeneratePlan& p = c.plan;
  hex_pass<int64_t>(c, kOffsets, false, [&](uint32_t i, uint32_t j, uint32_t k, const LayerCells& lc, int64_t*& out) {
    int64_t end = int64_t(c.rows.ids_before(uint64_t(k) * p.nj + j) + uint64_t(i) * lc.ids);
    for (int cell = 0; cell < lc.count; ++cell) *out++ = (end += lc.size[size_t(cell)]);
  });
}

void types_pass(const Context& c) {
  hex_pass<uint8_t>(c, kTypes, false, [&](uint32_t, uint32_t, uint32_t, const LayerCells& lc, uint8_t*& out) {
    for (int cell = 0; cell < lc.count; ++cell) *out++ = uint8_t(lc.type[size_t(cell)]);
  });
}

// Cell wall distance: the mean of its vertices' distances.
void wall_distance_pass(const Context& c) {
  const GeneratePlan& p = c.plan;
  hex_pass<float>(c, kWallDistance, false, [&](uint32_t i, uint32_t j, uint32_t k, const LayerCells& lc, float*& out) {
    const uint32_t i1 = i + 1 == p.ni ? 0 : i + 1;
    std::array<double, 8> d{};
    for (int b = 0; b < 8; ++b) {
      d[size_t(b)] = c.model.wall_distance((b & 1) ? i1 : i, j + ((b >> 1) & 1), k + ((b >> 2) & 1));
    }
    for (int cell = 0; cell < lc.count; ++cell) {
      double sum = 0;
      for (int v = 0; v < lc.size[size_t(cell)]; ++v) sum += d[lc.corner[size_t(cell)][size_t(v)]];
      *out++ = float(sum / lc.size[size_t(cell)]);
    }
  });
}

void run_passes(const Context& c, ScalarType index_type) {
  point_pass<float, 3>(c, kPoints, [&](uint32_t i, uint32_t j, uint32_t k, float* out) {
    const Vec3d q = c.model.point(i, j, k);
    out[0] = float(q.x), out[1] = float(q.y), out[2] = float(q.z);
  });
  if (index_type == ScalarType::Int32)
    connectivity_pass<int32_t>(c);
  else
    connectivity_pass<int64_t>(c);
  offsets_pass(c);
  types_pass(c);
  point_pass<float, 1>(c, kPressure,
                       [&](uint32_t i, uint32_t j, uint32_t k, float* out) { *out = float(c.model.flow(i, j, k).cp); });
  point_pass<float, 3>(c, kVelocity, [&](uint32_t i, uint32_t j, uint32_t k, float* out) {
    const Vec3d v = c.model.flow(i, j, k).velocity;
    out[0] = float(v.x), out[1] = float(v.y), out[2] = float(v.z);
  });
  wall_distance_pass(c);
}

std::vector<VtuArraySpec> array_specs(const GeneratePlan& p, ScalarType index_type) {
  return {vtu_points_spec(p.points),
          vtu_connectivity_spec(p.connectivity, index_type),
          vtu_offsets_spec(p.cells),
          vtu_types_spec(p.cells),
          {"pressure", ScalarType::Float32, 1, p.points, VtuSection::PointData},
          {"velocity", ScalarType::Float32, 3, p.points, VtuSection::PointData},
          {"wall_distance", ScalarType::Float32, 1, p.cells, VtuSection::CellData}};
}

}  // namespace

std::string_view gen_cell_kind_name(GenCellKind kind) {
  switch (kind) {
    case GenCellKind::Hex: return "hex";
    case GenCellKind::Tet: return "tet";
    case GenCellKind::Mixed: return "mixed";
  }
  return "?";
}

std::optional<GenCellKind> parse_gen_cell_kind(std::string_view name) {
  for (GenCellKind k : {GenCellKind::Hex, GenCellKind::Tet, GenCellKind::Mixed}) {
    if (name == gen_cell_kind_name(k)) return k;
  }
  return std::nullopt;
}

// Proportions ni : nj : nk = 2 : 1 : 1 (around the body : wall-normal : span), with ni chosen last so that the cell
// count lands within half a row of i-columns of the target.
GeneratePlan plan_generation(const GenerateOptions& o) {
  if (o.cells < 1000 || o.cells > 10'000'000'000ull) {
    throw Error("generate: the cell count must be between 1000 and 10 billion, got " + std::to_string(o.cells));
  }
  GeneratePlan p;
  p.kind = o.kind;
  const double per_hex = o.kind == GenCellKind::Hex ? 1.0 : o.kind == GenCellKind::Tet ? 6.0 : 2.2;
  const double s = std::cbrt(double(o.cells) / per_hex / 2.0);
  p.nj = uint32_t(std::max(4.0, std::round(s)));
  p.nk = uint32_t(std::max(2.0, std::round(s)));
  if (o.kind == GenCellKind::Mixed) {
    p.wedge_layers = uint32_t(std::max(1.0, std::round(0.15 * p.nj)));
    p.tet_layers = uint32_t(std::max(1.0, std::round(0.10 * p.nj)));
  }
  uint64_t column_cells = 0, column_ids = 0;
  std::array<uint64_t, 4> column_by_layer{};
  for (uint32_t j = 0; j < p.nj; ++j) {
    const Layer l = layer_of(p, j);
    column_cells += layer_cells(l).count;
    column_ids += layer_cells(l).ids;
    ++column_by_layer[size_t(l)];
  }
  p.ni = uint32_t(std::max(8.0, std::round(double(o.cells) / double(column_cells * p.nk))));
  const uint64_t columns = uint64_t(p.ni) * p.nk;
  p.points = uint64_t(p.ni) * (p.nj + 1) * (p.nk + 1);
  p.cells = columns * column_cells;
  p.connectivity = columns * column_ids;
  p.hexahedron = columns * column_by_layer[size_t(Layer::Hex)];
  p.wedge = columns * 2 * column_by_layer[size_t(Layer::Prisms)];
  p.pyramid = columns * column_by_layer[size_t(Layer::Transition)];
  p.tetra = columns * (6 * column_by_layer[size_t(Layer::Tets)] + 4 * column_by_layer[size_t(Layer::Transition)]);
  return p;
}

GenerateStats generate_dataset(const GenerateOptions& options, const std::string& out_path) {
  const auto start = std::chrono::steady_clock::now();
  GenerateStats stats;
  stats.plan = plan_generation(options);
  const GeneratePlan& p = stats.plan;
  const Model model(p, options.seed, options.time);
  const ScalarType index_type = vtu_connectivity_type(p.points);
  const std::vector<VtuArraySpec> specs = array_specs(p, index_type);
  uint64_t total_bytes = 0;
  for (const VtuArraySpec& s : specs) total_bytes += s.byte_size();

  VtuStreamWriter writer(out_path, p.points, p.cells, specs, {options.codec, options.level});
  Progress progress("generate " + std::to_string(p.cells) + " cells", total_bytes);
  const Context ctx{p, model, RowIndex(p), [&](size_t, std::span<const std::byte> bytes) {
                      writer.write_bytes(bytes);
                      progress.add(bytes.size());
                    }};
  run_passes(ctx, index_type);
  stats.bytes = writer.commit();
  progress.finish();
  stats.cells = p.cells;
  stats.points = p.points;
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

Dataset generate_in_memory(const GenerateOptions& options) {
  const GeneratePlan p = plan_generation(options);
  if (p.cells > kMaxInMemoryCells) {
    throw Error("generate: " + std::to_string(p.cells) + " cells is too many to build in memory (at most " +
                std::to_string(kMaxInMemoryCells) + ")");
  }
  const Model model(p, options.seed, options.time);
  std::array<std::vector<std::byte>, kArrayCount> arrays;
  const Context ctx{p, model, RowIndex(p), [&](size_t a, std::span<const std::byte> bytes) {
                      arrays[a].insert(arrays[a].end(), bytes.begin(), bytes.end());
                    }};
  run_passes(ctx, ScalarType::Int32);

  auto values = [&](size_t a, auto type_tag) {
    using T = decltype(type_tag);
    std::vector<T> v(arrays[a].size() / sizeof(T));
    std::memcpy(v.data(), arrays[a].data(), v.size() * sizeof(T));
    return v;
  };
  UnstructuredMesh mesh;
  mesh.points.resize(p.points);
  std::memcpy(mesh.points.data(), arrays[kPoints].data(), arrays[kPoints].size());
  for (int32_t id : values(kConnectivity, int32_t{})) mesh.connectivity.push_back(uint32_t(id));
  for (int64_t end : values(kOffsets, int64_t{})) mesh.cell_offsets.push_back(uint64_t(end));
  for (uint8_t t : values(kTypes, uint8_t{})) mesh.cell_types.push_back(CellType(t));

  Block block{"generated", std::move(mesh), {}};
  block.fields.add(Field("pressure", Association::Vertex, DataArray::from(values(kPressure, float{}), 1)));
  block.fields.add(Field("velocity", Association::Vertex, DataArray::from(values(kVelocity, float{}), 3)));
  block.fields.add(Field("wall_distance", Association::Cell, DataArray::from(values(kWallDistance, float{}), 1)));
  Dataset ds;
  ds.format = "generated (" + std::string(gen_cell_kind_name(p.kind)) + ")";
  ds.blocks.push_back(std::move(block));
  return ds;
}

}  // namespace ugvr
