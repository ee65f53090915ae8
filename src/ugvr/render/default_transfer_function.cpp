#include "ugvr/render/default_transfer_function.h"

#include <algorithm>
#include <cmath>

namespace ugvr {
namespace {

uint64_t total_of(std::span<const uint64_t> counts) {
  uint64_t total = 0;
  for (uint64_t c : counts) total += c;
  return total;
}

// The bins around `peak` that hold at least kBumpEdgeFraction of its count.
ModeBump bump_around(std::span<const uint64_t> counts, size_t peak) {
  const double edge = kBumpEdgeFraction * double(counts[peak]);
  size_t first = peak, last = peak;
  while (first > 0 && double(counts[first - 1]) >= edge) --first;
  while (last + 1 < counts.size() && double(counts[last + 1]) >= edge) ++last;
  uint64_t inside = 0;
  for (size_t i = first; i <= last; ++i) inside += counts[i];
  return {int(first), int(last), double(inside) / double(total_of(counts))};
}

std::vector<OpacityPoint> ramp(double lo, double hi) { return {{lo, 0.0}, {hi, 1.0}}; }

}  // namespace

std::optional<ModeBump> dominant_mode(std::span<const uint64_t> counts) {
  if (counts.size() < 2 || total_of(counts) == 0) return std::nullopt;
  const size_t peak = size_t(std::max_element(counts.begin(), counts.end()) - counts.begin());
  const ModeBump bump = bump_around(counts, peak);
  const double width = double(bump.last - bump.first + 1) / double(counts.size());
  if (bump.share < kDominantShare || width > kMaxBumpWidth) return std::nullopt;
  uint64_t rest = 0;
  for (size_t i = 0; i < counts.size(); ++i)
    if (int(i) < bump.first || int(i) > bump.last) rest = std::max(rest, counts[i]);
  if (double(counts[peak]) < kPeakOverRest * double(rest)) return std::nullopt;
  return bump;
}

std::vector<OpacityPoint> auto_opacity_points(std::span<const uint64_t> counts, double lo, double hi) {
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi)) return ramp(0, 1);
  const std::optional<ModeBump> mode = dominant_mode(counts);
  if (!mode) return ramp(lo, hi);
  const double bin = (hi - lo) / double(counts.size());
  const double from = lo + bin * mode->first, to = lo + bin * (mode->last + 1);
  std::vector<OpacityPoint> points;
  if (mode->first > 0) points.push_back({lo, 1.0});
  points.push_back({mode->first > 0 ? from : lo, 0.0});
  if (size_t(mode->last) + 1 < counts.size()) {
    points.push_back({to, 0.0});
    points.push_back({hi, 1.0});
  } else {
    points.push_back({hi, 0.0});
  }
  return points;
}

TransferFunction auto_transfer_function(std::span<const uint64_t> counts, double lo, double hi, const Bounds& bounds) {
  TransferFunction tf = default_transfer_function(lo, hi, bounds);
  tf.name = "auto";
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi) || !dominant_mode(counts)) return tf;
  tf.opacity_points = auto_opacity_points(counts, lo, hi);
  tf.opacity_unit_distance *= kHiddenModeUnitDistanceScale;
  return tf;
}

TransferFunction auto_transfer_function(const Renderer& renderer, double lo, double hi, const Bounds& bounds) {
  // Asked even for a range the rule cannot use: under MPI this is a collective call that every rank must make.
  const std::vector<uint64_t> counts = renderer.value_histogram(lo, hi, kAutoTfBins);
  return auto_transfer_function(counts, lo, hi, bounds);
}

}  // namespace ugvr
