// The default transfer function, "auto": what `ugvr render` without --tf, ugvr::default_request, ugvr.render() and
// `mpirun ugvr render` draw with (docs/first-look.md).
//
// Why: a monotone opacity ramp over the field's range draws the most common value at the opacity of its place in the
// range. On the typical CFD field that value is the free stream (the histogram's mode), often in the upper half of
// the range, so it fills the volume with a translucent haze and the few cells that differ (the wing, its wake) hardly
// show. The rule makes the mode transparent when there is one, and keeps the ramp when there is none.
//
// The rule, on a histogram of the field (counts in equal bins over [lo, hi], kAutoTfBins of them):
//  - the mode's bump: the most populated bin, extended to both sides while a bin holds at least kBumpEdgeFraction of
//    the peak's count (a quarter: the skirt below it is left to the ramp, which starts at 0 at the bump's edges);
//  - it is dominant when it holds at least kDominantShare of all counted values, spans at most kMaxBumpWidth of the
//    range and its peak is at least kPeakOverRest times any bin outside it: a narrow bump that holds much of the
//    data and stands out (a field of a few values equally common, or two modes of about one height, has none: which
//    one to hide would be a guess). A flat histogram has none, nor has a smooth analytic field
//    (a sine sampled evenly piles up at its ends, 7x the mean bin, but that bump holds 13 %), a single bin or no
//    counts at all;
//  - dominant: opacity 0 over the bump, rising linearly from its edges to 1 at lo and at hi (a bump at an end of the
//    range rises on the other side only), and the opacity unit distance a tenth of the ramp's (the bounds' diagonal
//    / 100): the ramp's long unit distance is there so that the common values do not make an opaque slab, and with
//    them transparent what is left is a few cells (a wing among 200,000) that the long one draws as a faint ghost;
//  - otherwise: viridis's ramp, 0 at lo to 1 at hi, as before (`--tf viridis` draws that always).
// Colours are viridis over [lo, hi] in both cases. Everything here is a pure function of the counts except
// auto_transfer_function(const Renderer&, ...), which asks the renderer for them (under MPI a collective call whose
// counts are the same on every rank, so that every rank draws with one transfer function).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "ugvr/render/renderer.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

inline constexpr int kAutoTfBins = 128;
inline constexpr double kBumpEdgeFraction = 0.25;
inline constexpr double kDominantShare = 0.3;
inline constexpr double kMaxBumpWidth = 0.3;
inline constexpr double kPeakOverRest = 2;
inline constexpr double kHiddenModeUnitDistanceScale = 0.1;

// The bins [first, last] of the dominant mode's bump and the share of the counted values it holds.
struct ModeBump {
  int first = 0, last = 0;
  double share = 0;
};

// The dominant mode of `counts` by the rule above; nullopt when there is none.
std::optional<ModeBump> dominant_mode(std::span<const uint64_t> counts);

// The rule's opacity points over [lo, hi] (x strictly increasing): the bump transparent, or the ramp when there is
// no dominant mode or [lo, hi] is not a finite, non-empty range.
std::vector<OpacityPoint> auto_opacity_points(std::span<const uint64_t> counts, double lo, double hi);

// "auto": viridis over [lo, hi] with auto_opacity_points, opacity unit distance default_unit_distance(bounds), times
// kHiddenModeUnitDistanceScale when the mode is hidden. An all-NaN field (lo or hi not finite) keeps viridis on
// [0, 1], as default_transfer_function.
TransferFunction auto_transfer_function(std::span<const uint64_t> counts, double lo, double hi, const Bounds& bounds);
// The same from the renderer's histogram of its bound field over [lo, hi] (Renderer::value_histogram).
TransferFunction auto_transfer_function(const Renderer& renderer, double lo, double hi, const Bounds& bounds);

}  // namespace ugvr
