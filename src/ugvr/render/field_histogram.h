// Value histograms: the viewer's transfer-function editor's (the scene message's fields[i].histogram) and the default
// transfer function's (default_transfer_function.h, every front end). Counts in
// `bins` equal bins over [lo, hi]. Values below lo or above hi count in the first or last bin (a Quant16 brick may
// decode a little beyond its field's range); non-finite values (NaN: no data) are skipped. When hi <= lo (a constant
// field) every counted value goes to the middle bin, bins / 2.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/grid/field.h"

namespace ugvr {

class BrickStoreReader;

inline constexpr int kMaxHistogramBins = 4096;
// The octree levels a store's histogram is read from when the shape of the distribution is all that is wanted: up to
// 585 bricks, a fraction of a second.
inline constexpr int kCoarseHistogramLevel = 3;

// Throws ugvr::Error for bins outside [1, kMaxHistogramBins] (all of these).
std::vector<uint64_t> value_histogram(std::span<const float> values, double lo, double hi, int bins);
std::vector<uint64_t> value_histogram(std::span<const double> values, double lo, double hi, int bins);
// One scalar of a grid field (component, or kMagnitude: the magnitude of a vector, the value itself for a scalar)
// over the field's range of that scalar.
std::vector<uint64_t> field_histogram(const Field& field, int component, int bins);
// The same over a given [lo, hi] (the whole data's range where `field` is a part of it: a rank's piece).
std::vector<uint64_t> field_histogram(const Field& field, int component, double lo, double hi, int bins);
// The valid samples (mask set, finite) of field `field` in the bricks of the store's nodes at levels <= max_level,
// over the field's global range (the store header's min, max). Reads and decodes those bricks: with max_level 3 or 4
// a few hundred bricks, enough for the shape of the distribution. Throws ugvr::Error for a bad field index.
std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, int bins, int max_level);
// The same over a given [lo, hi] (a time store's step range).
std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, double lo, double hi, int bins,
                                      int max_level);

}  // namespace ugvr
