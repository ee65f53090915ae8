#include "ugvr/render/optical_table.h"

#include <algorithm>
#include <cmath>

namespace ugvr {
namespace {

double lerp(double a, double b, double f) { return a + (b - a) * f; }
Vec3d lerp(Vec3d a, Vec3d b, double f) { return a + (b - a) * f; }

// Exponent at which the transmittance is negligible (exp(-40) < 5e-18).
constexpr double kNegligibleDepth = 40;

}  // namespace

double segment_transmittance_mean(double a, double b) {
  const double depth = 0.5 * (a + b);
  const double k = 0.5 * (b - a);  // exponent f(u) = a u + k u^2, increasing from 0 to depth since a, b >= 0
  if (depth <= 0.1) {
    // Moments of f over [0, 1]; |f| <= depth so the series truncation is below depth^5 / 120. (Multiplications by
    // constant reciprocals, not divisions: this runs once per cell a ray crosses.)
    constexpr double r3 = 1.0 / 3, r5 = 1.0 / 5, r7 = 1.0 / 7, r9 = 1.0 / 9, r6 = 1.0 / 6, r24 = 1.0 / 24;
    const double a2 = a * a, k2 = k * k, ak = a * k;
    const double m1 = 0.5 * a + r3 * k;
    const double m2 = r3 * a2 + 0.5 * ak + r5 * k2;
    const double m3 = a * (0.25 * a2 + 0.6 * ak + 0.5 * k2) + r7 * k2 * k;
    const double m4 = a2 * (r5 * a2 + (2 * r3) * a * k + (6 * r7) * k2) + k2 * (0.5 * ak + r9 * k2);
    return (1 - m1) + (0.5 * m2 - r6 * m3) + r24 * m4;
  }
  if (std::abs(k) <= 1e-12 * depth) return -std::expm1(-depth) / depth;
  // Composite 4-point Gauss-Legendre over pieces [u_{j-1}, u_j] with f(u_j) = j / 2: the integrand exp(-f) changes by
  // at most a factor e^0.5 per piece, where 4 nodes are accurate to ~1e-9 relative (a factor e per piece leaves
  // ~5e-7 where f starts flat, a = 0).
  static constexpr double kNode[2] = {0.3399810435848563, 0.8611363115940526};
  static constexpr double kWeight[2] = {0.6521451548625461, 0.3478548451374538};
  double sum = 0, u0 = 0;
  const double last = std::min(depth, kNegligibleDepth);
  for (double target = 0.5;; target += 0.5) {
    const double f = std::min(target, last);
    // Root of k u^2 + a u - f = 0 in [0, 1], in the form that stays accurate when k is small or negative.
    const double u1 = f >= depth ? 1.0 : 2 * f / (a + std::sqrt(std::max(0.0, a * a + 4 * k * f)));
    const double mid = 0.5 * (u0 + u1), half = 0.5 * (u1 - u0);
    double piece = 0;
    for (int i = 0; i < 2; ++i)
      for (double sign : {-1.0, 1.0}) {
        const double u = mid + sign * half * kNode[i];
        piece += kWeight[i] * std::exp(-(a * u + k * u * u));
      }
    sum += piece * half;
    u0 = u1;
    if (f >= last) break;
  }
  return sum;
}

OpticalTable::OpticalTable(const TransferFunction& tf) {
  std::vector<double> xs;
  for (const ColorPoint& p : tf.color_points) xs.push_back(p.x);
  for (const OpacityPoint& p : tf.opacity_points) xs.push_back(p.x);
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  if (xs.empty()) xs.push_back(0);

  const double unit = tf.opacity_unit_distance;
  auto add = [&](double s) {
    x_.push_back(s);
    rgb_.push_back(tf.color(s));
    tau_.push_back(tf.extinction(s));
  };
  // Inserts midpoints into (lo, hi) until linear extinction matches the table's opacity (see the header).
  auto refine = [&](auto&& self, double lo, double tau_lo, double hi, double tau_hi, int depth) -> void {
    const double mid = 0.5 * (lo + hi);
    if (depth >= 24 || !(mid > lo && mid < hi)) return;
    const double tau_mid = tf.extinction(mid);
    const double error = std::abs(std::exp(-0.5 * (tau_lo + tau_hi) * unit) - std::exp(-tau_mid * unit));
    if (error <= kOpacityTolerance) return;
    self(self, lo, tau_lo, mid, tau_mid, depth + 1);
    add(mid);
    self(self, mid, tau_mid, hi, tau_hi, depth + 1);
  };
  add(xs[0]);
  for (size_t i = 1; i < xs.size(); ++i) {
    refine(refine, xs[i - 1], tf.extinction(xs[i - 1]), xs[i], tf.extinction(xs[i]), 0);
    add(xs[i]);
  }
  inv_width_.resize(x_.size());
  for (size_t i = 0; i + 1 < x_.size(); ++i) inv_width_[i] = 1 / (x_[i + 1] - x_[i]);
}

std::ptrdiff_t OpticalTable::interval(double s) const {
  return std::ptrdiff_t(std::upper_bound(x_.begin(), x_.end(), s) - x_.begin()) - 1;
}

std::ptrdiff_t OpticalTable::interval(double s, std::ptrdiff_t hint) const {
  const std::ptrdiff_t n = std::ptrdiff_t(x_.size());
  if (hint >= 0 && hint + 1 < n && x_[hint] <= s && s < x_[hint + 1]) return hint;
  if (hint + 2 < n && hint + 1 >= 0 && x_[hint + 1] <= s && s < x_[hint + 2]) return hint + 1;
  if (hint >= 1 && hint < n && x_[hint - 1] <= s && s < x_[hint]) return hint - 1;
  return interval(s);
}

Vec3d OpticalTable::color_at(double s) const {
  const std::ptrdiff_t i = interval(s);
  if (i < 0) return rgb_.front();
  if (size_t(i) + 1 >= x_.size()) return rgb_.back();
  return lerp(rgb_[i], rgb_[i + 1], (s - x_[i]) / (x_[i + 1] - x_[i]));
}

double OpticalTable::extinction_at(double s) const {
  const std::ptrdiff_t i = interval(s);
  if (i < 0) return tau_.front();
  if (size_t(i) + 1 >= x_.size()) return tau_.back();
  return lerp(tau_[i], tau_[i + 1], (s - x_[i]) / (x_[i + 1] - x_[i]));
}

void OpticalTable::integrate_piece(double tau0, double tau1, Vec3d c0, Vec3d c1, double h, double shade,
                                   RayAccumulator& acc) const {
  const double a = tau0 * h, b = tau1 * h;
  if (a == 0 && b == 0) return;
  const double depth = 0.5 * (a + b);
  // exp(-depth) by its series where that is exact to 1.4e-9 (depth^6 / 720): most pieces are optically thin.
  double t;
  if (depth <= 0.1) {
    const double d2 = depth * depth;  // Estrin's scheme: short dependency chains
    t = (1 - depth) + d2 * ((0.5 - (1.0 / 6) * depth) + d2 * ((1.0 / 24) - (1.0 / 120) * depth));
  } else {
    t = std::exp(-depth);
  }
  Vec3d radiance;
  if (c0 == c1) {
    radiance = c0 * (1 - t);
  } else {
    const double psi = segment_transmittance_mean(a, b);
    radiance = c0 - c1 * t + (c1 - c0) * psi;
  }
  acc.radiance = acc.radiance + radiance * (acc.transmittance * shade);
  acc.transmittance *= t;
}

void OpticalTable::integrate_linear_segment(double s0, double s1, double length, RayAccumulator& acc) const {
  integrate_linear_segment(s0, s1, length, 1.0, acc);
}

void OpticalTable::integrate_linear_segment(double s0, double s1, double length, double shade,
                                            RayAccumulator& acc) const {
  if (!(length > 0) || std::isnan(s0) || std::isnan(s1)) return;
  const std::ptrdiff_t n = std::ptrdiff_t(x_.size());
  // Values at s inside interval j (constant extension outside the table).
  auto values = [&](std::ptrdiff_t j, double s, double& tau, Vec3d& c) {
    if (j < 0) {
      tau = tau_.front(), c = rgb_.front();
    } else if (j + 1 >= n) {
      tau = tau_.back(), c = rgb_.back();
    } else {
      const double f = (s - x_[j]) * inv_width_[j];
      tau = lerp(tau_[j], tau_[j + 1], f), c = lerp(rgb_[j], rgb_[j + 1], f);
    }
  };
  std::ptrdiff_t j = interval(s0, acc.interval_hint);
  const std::ptrdiff_t j_end = interval(s1, j);
  acc.interval_hint = j_end;
  double tau_a;
  Vec3d c_a;
  values(j, s0, tau_a, c_a);
  if (j == j_end) {
    double tau_b;
    Vec3d c_b;
    values(j, s1, tau_b, c_b);
    integrate_piece(tau_a, tau_b, c_a, c_b, length, shade, acc);
    return;
  }
  // Walk the breakpoints between s0 and s1; each piece lies inside one interval of the table.
  const double inv_ds = 1.0 / (s1 - s0);
  double pos = 0;  // fraction of the segment done
  const bool ascending = s1 > s0;
  while (j != j_end && acc.transmittance > 1e-12) {
    const std::ptrdiff_t next_j = ascending ? j + 1 : j - 1;
    const double breakpoint = ascending ? x_[j + 1] : x_[j];
    const double f = std::clamp((breakpoint - s0) * inv_ds, pos, 1.0);
    double tau_b;
    Vec3d c_b;
    values(j, breakpoint, tau_b, c_b);
    integrate_piece(tau_a, tau_b, c_a, c_b, (f - pos) * length, shade, acc);
    pos = f;
    j = next_j;
    values(j, breakpoint, tau_a, c_a);
  }
  if (acc.transmittance > 1e-12) {
    double tau_b;
    Vec3d c_b;
    values(j, s1, tau_b, c_b);
    integrate_piece(tau_a, tau_b, c_a, c_b, (1 - pos) * length, shade, acc);
  }
}

std::vector<float> OpticalTable::pack_for_gpu() const {
  std::vector<float> out;
  out.reserve(x_.size() * 8);
  for (size_t i = 0; i < x_.size(); ++i) {
    const float inv = i + 1 < x_.size() ? float(inv_width_[i]) : 0.0f;
    out.insert(out.end(), {float(x_[i]), inv, 0.0f, 0.0f});
    out.insert(out.end(), {float(rgb_[i].x), float(rgb_[i].y), float(rgb_[i].z), float(tau_[i])});
  }
  return out;
}

}  // namespace ugvr
