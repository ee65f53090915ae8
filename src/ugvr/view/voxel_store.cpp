#include "ugvr/view/voxel_store.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <variant>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/view/view_store.h"

namespace ugvr::view {
namespace {

// Bricks of at most 33 samples where the lattice allows: the builder's default size, and the lod engine's upload
// batches and neighbourhood prefilter are sized for them (docs/tricubic.md, "Seams").
constexpr uint64_t kLargestBrickIntervals = 32;
// An odd number of intervals cannot be split: one brick keeps the samples up to this many; beyond, the volume is
// resampled. Measured (llvmpipe, 128² sphere): one brick of 64³ takes an atlas of 105 MiB and 1.06 s for the first
// frame (8 bricks of 33³ for 65³: 15.7 MiB, 1.10 s); one of 100³ took 389 MiB and 2.9 s.
constexpr uint64_t kLargestSingleBrickIntervals = 64;
// Bricks of 17 to 33 samples when resampling: the coarsest such lattice not coarser than the data.
constexpr uint64_t kSmallestResampledIntervals = 16;
// Spacing ratios closer than this to an integer are that integer (spacings written in decimal).
constexpr double kRatioTolerance = 1e-6;

bool near_integer(double x) { return std::abs(x - std::round(x)) <= kRatioTolerance * std::max(1.0, std::abs(x)); }

std::string axis_list(const ImageGrid& g) {
  char s[160];
  std::snprintf(s, sizeof s, "%llu x %llu x %llu samples, spacing %g %g %g",
                static_cast<unsigned long long>(g.dims.points[0]), static_cast<unsigned long long>(g.dims.points[1]),
                static_cast<unsigned long long>(g.dims.points[2]), g.spacing.x, g.spacing.y, g.spacing.z);
  return s;
}

// The lattice of M intervals across the root that keeps every sample, split into bricks of at most 33 samples where
// M has the factors of two for it.
VoxelLattice exact_lattice(uint64_t intervals) {
  VoxelLattice l;
  l.keeps_samples = true;
  while (intervals > kLargestBrickIntervals && intervals % 2 == 0 && l.depth < kMaxOctreeLevel) {
    intervals /= 2;
    ++l.depth;
  }
  l.resolution = uint32_t(intervals + 1);
  return l;
}

// The coarsest lattice of bricks of 17 to 33 samples with at least `needed` intervals across the root.
VoxelLattice resampled_lattice(double needed) {
  VoxelLattice best;
  uint64_t best_intervals = UINT64_MAX;
  for (int depth = 0; depth <= kMaxOctreeLevel; ++depth) {
    const double per_brick = std::ceil(needed / std::ldexp(1.0, depth) - kRatioTolerance);
    const uint64_t r = std::max<uint64_t>(uint64_t(std::max(per_brick, 1.0)), kSmallestResampledIntervals);
    if (r > kLargestBrickIntervals) continue;
    const uint64_t total = r << depth;
    if (total < best_intervals) best_intervals = total, best.resolution = uint32_t(r + 1), best.depth = depth;
    if (r == kSmallestResampledIntervals) break;  // deeper only doubles the lattice
  }
  return best;
}

}  // namespace

VoxelLattice voxel_lattice(const ImageGrid& grid) {
  const double h[3] = {std::abs(grid.spacing.x), std::abs(grid.spacing.y), std::abs(grid.spacing.z)};
  double extent = 0, finest = INFINITY;
  for (int a = 0; a < 3; ++a) {
    if (grid.dims.points[a] < 2) continue;
    extent = std::max(extent, double(grid.dims.points[a] - 1) * h[a]);
    finest = std::min(finest, h[a]);
  }
  if (!(extent > 0) || !(finest > 0) || !std::isfinite(extent))
    throw Error("a voxel volume of " + axis_list(grid) + " has no extent to build a store of");
  const double needed = extent / finest;  // intervals of the finest spacing across the root cube
  bool whole = near_integer(needed) && std::round(needed) <= double(UINT32_MAX);
  for (int a = 0; a < 3 && whole; ++a)
    if (grid.dims.points[a] > 1) whole = near_integer(h[a] / finest);
  if (whole) {
    const VoxelLattice exact = exact_lattice(uint64_t(std::llround(needed)));
    if (exact.resolution <= kLargestSingleBrickIntervals + 1) return exact;
  }
  VoxelLattice l = resampled_lattice(needed);
  char note[320];
  const double spacing = extent / (double(l.resolution - 1) * std::ldexp(1.0, l.depth));
  std::snprintf(note, sizeof note,
                "the samples (%s) are resampled onto the store's lattice of spacing %g (%s): no brick of %u to "
                "%u samples at any depth puts a lattice point on every sample",
                axis_list(grid).c_str(), spacing,
                whole ? "their count across the largest extent is odd and above 64"
                      : "the spacings are not whole multiples of the smallest, or the extent not of it",
                unsigned(kMinBrickResolution), unsigned(kLargestSingleBrickIntervals + 1));
  l.note = note;
  return l;
}

bool is_voxel_volume_input(std::span<const std::string> inputs) {
  if (inputs.size() != 1) return false;
  const std::string ext = extension_lower(inputs[0]);
  return ext == ".nrrd" || ext == ".nhdr" || ext == ".raw" || ext == ".vti" || ext == ".pvti";
}

namespace {

// What the store is built from: the files as they are now, and what else decides the samples (the raw layout, the
// time step, the lattice rule). The lattice itself follows from the file, so the key needs no read.
std::string voxel_store_key(std::span<const std::string> inputs, const ReadOptions& read) {
  nlohmann::json key = {
      {"files", files_identity(inputs)}, {"lattice", "tricubic voxel lattice 1"}, {"time_step", read.time_step}};
  if (extension_lower(inputs[0]) == ".raw")
    key["raw"] = {read.raw.dims,   read.raw.type,       read.raw.spacing,
                  read.raw.origin, read.raw.big_endian, read.raw.header_bytes};
  return key.dump();
}

}  // namespace

VoxelStore voxel_store_for_tricubic(std::span<const std::string> inputs, const ReadOptions& read,
                                    const std::string& field, bool say) {
  if (inputs.empty()) throw Error("no input to build a voxel store of");
  const std::vector<std::string> fields = field.empty() ? std::vector<std::string>{} : std::vector<std::string>{field};
  OctreeBuildOptions key_options;  // R and D follow from the file (the key's lattice rule): left out of the name
  key_options.error = 0;
  key_options.resolution = 0;
  key_options.max_depth = 0;
  VoxelStore out;
  out.path = cached_store_path(std::filesystem::path(inputs[0]).stem().string() + "-tricubic",
                               voxel_store_key(inputs, read), fields, key_options);
  if (store_opens(out.path)) {  // one that exists but does not open is built again
    if (say) std::fprintf(stderr, "tricubic: drawing the store built earlier, %s\n", out.path.c_str());
    return out;
  }
  const Dataset ds = read_dataset(inputs, read);
  if (ds.blocks.size() != 1 || !std::holds_alternative<ImageGrid>(ds.blocks[0].grid))
    fail_in(inputs[0], "is not one voxel volume (an image grid): tricubic isosurfaces of a " +
                           std::string(ds.blocks.empty() ? "dataset without blocks"
                                                         : std::string(grid_kind_name(ds.blocks[0].grid)) + " grid") +
                           " are drawn from a store built with `ugvr build`");
  for (const std::string& w : ds.warnings)
    if (say) std::fprintf(stderr, "warning: %s\n", w.c_str());
  const ImageGrid& grid = std::get<ImageGrid>(ds.blocks[0].grid);
  try {
    out.lattice = voxel_lattice(grid);
  } catch (const Error& e) {
    fail_in(inputs[0], e.what());
  }
  // The note is the user's to see even when quiet: the samples drawn are not the file's.
  if (!out.lattice.note.empty()) std::fprintf(stderr, "note: %s: %s\n", inputs[0].c_str(), out.lattice.note.c_str());
  const OctreeInput input = prepare_octree_input(ds, fields);
  OctreeBuildOptions build;
  build.resolution = out.lattice.resolution;
  build.max_depth = out.lattice.depth;
  build.error = 0;  // the tree the geometry asks for: every leaf at depth D
  build.inputs = std::vector<std::string>(inputs.begin(), inputs.end());
  std::filesystem::create_directories(std::filesystem::path(out.path).parent_path());
  if (say)
    std::fprintf(stderr, "tricubic: building the store of %s (bricks of %u samples, depth %d: %s) into %s\n",
                 inputs[0].c_str(), out.lattice.resolution, out.lattice.depth,
                 out.lattice.keeps_samples ? "the leaves' lattice is the volume's samples" : "resampled",
                 out.path.c_str());
  build_octree(input, build, out.path);  // atomic: a failed or interrupted build leaves no store there
  out.built = true;
  return out;
}

}  // namespace ugvr::view
