// Value histograms: the viewer's transfer-function editor's (the scene message's fields[i].histogram) and the default
// transfer function's (default_transfer_function.h, every front end). Counts in
// `bins` equal bins over [lo, hi]. Values below lo or above hi count in the first or last bin (a Quant16 brick may
// decode a little beyond its field's range); non-finite values (NaN: no data) are skipped. When hi <= lo (a constant
// field) every counted value goes to the middle bin, bins / 2.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/grid/dataset.h"
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
// Volume-weighted histograms of a grid's field: what the default transfer function (default_transfer_function.h)
// and the viewer's editor use for a mesh (docs/first-look.md).
//
// Why: a mesh's points crowd where the flow is interesting (a curvilinear grid packs them near a wall), so counting
// points says more about the grid than about the flow; the free stream that fills most of the volume can be a thin
// plateau of few points. Weighting by volume counts what a ray crosses (a store's lattice samples are already so).
//
// The weights: a cell field counts each cell with its volume; a vertex field counts each of a cell's corners with the
// cell's volume / its corner count (a point's weight is its share of its cells' volumes). Volumes are absolute
// (cell_volume: a left-handed curvilinear grid's cells count as much as right-handed ones). A structured grid's cells
// are its hexahedra (a cell with an IBLANKed corner does not exist and counts nothing), a 2-D grid has none.
//
// The counts stay integers (std::vector<uint64_t>, so that nothing downstream changes): the weights in each bin are
// scaled so that all bins together hold the number of values the unweighted histogram counts (each bin rounded to
// the nearest integer, so the total is that number within bins / 2). The histogram of a mesh of equal cells is thus
// about its unweighted one. No volume at all (a 2-D grid, flat cells): the unweighted counts.
// Every cell is visited once (a vertex field's bins found once per point first), in parallel, with a deterministic
// sum (the same counts on every run and every rank).
//
// The weights in `bins` equal bins over [lo, hi] (binned as value_histogram); for several blocks add them, and the
// unweighted counts, before scaling once (weighted_counts). Throws ugvr::Error naming the field when its tuple count
// is not the grid's point count (a vertex field) or cell count (a cell field).
std::vector<double> volume_weights(const Grid& grid, const Field& field, int component, double lo, double hi, int bins);
std::vector<double> volume_weights(const UnstructuredMesh& mesh, const Field& field, int component, double lo,
                                   double hi, int bins);
// The weights scaled to integer counts whose total is that of `unweighted` (the rule above).
std::vector<uint64_t> weighted_counts(std::span<const double> weights, std::span<const uint64_t> unweighted);
// One grid's volume-weighted histogram over [lo, hi], or over the field's range.
std::vector<uint64_t> volume_histogram(const Grid& grid, const Field& field, int component, double lo, double hi,
                                       int bins);
std::vector<uint64_t> volume_histogram(const UnstructuredMesh& mesh, const Field& field, int component, int bins);

// The valid samples (mask set, finite) of field `field` in the bricks of the store's nodes at levels <= max_level,
// over the field's global range (the store header's min, max). Reads and decodes those bricks: with max_level 3 or 4
// a few hundred bricks, enough for the shape of the distribution. Throws ugvr::Error for a bad field index.
std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, int bins, int max_level);
// The same over a given [lo, hi] (a time store's step range).
std::vector<uint64_t> store_histogram(const BrickStoreReader& store, uint32_t field, double lo, double hi, int bins,
                                      int max_level);

}  // namespace ugvr
