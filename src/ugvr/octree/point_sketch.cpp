#include "ugvr/octree/point_sketch.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/octree/coarse_preview.h"

namespace ugvr {

int point_sketch_depth(uint64_t points, uint32_t resolution, int max_depth) {
  int depth = 0;
  for (int K = 1; K <= std::min(max_depth, kMaxPreviewDepth); ++K) {
    const uint64_t side = (uint64_t(resolution) - 1) * (uint64_t(1) << K) + 1;
    if (side * side * side * 4 <= points) depth = K;
  }
  return depth;
}

bool point_sketch_possible(std::span<const VtuCellSource::Slot> slots) {
  return std::all_of(slots.begin(), slots.end(),
                     [](const VtuCellSource::Slot& s) { return s.association == Association::Vertex; });
}

PointSketchStats write_point_sketch(const VtuCellSource& source, const BrickLattice& lattice,
                                    const BrickStoreLayout& layout, int K, uint64_t slice_bytes,
                                    const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  if (K < 1 || K > kMaxPreviewDepth)
    throw Error("point sketch depth " + std::to_string(K) + " is out of range 1.." + std::to_string(kMaxPreviewDepth));
  if (!point_sketch_possible(source.slots()))
    throw Error("point sketch: a selected field is a cell field (the sketch needs values at the points)");
  const uint32_t R = lattice.resolution, F = uint32_t(layout.fields.size());
  if (source.slots().size() != F) throw Error("point sketch: the store's fields are not the source's");
  const uint64_t G = (uint64_t(R) - 1) * (uint64_t(1) << K) + 1;  // lattice lines per axis at level K
  const size_t lattice_points = size_t(G * G * G);
  PointSketchStats stats;
  stats.depth = K;
  stats.lattice_points = lattice_points;

  // Sums and counts per lattice point: each point to the nearest.
  std::vector<double> sum(size_t(F) * lattice_points, 0.0);
  std::vector<uint32_t> count(lattice_points, 0);
  source.for_each_point_slice(slice_bytes, [&](uint64_t, std::span<const Vec3f> pos, std::span<const float> val) {
    const size_t n = pos.size();
    for (size_t p = 0; p < n; ++p) {
      size_t m[3];
      for (int a = 0; a < 3; ++a) {
        const double lo = lattice.root.lo[a], size = lattice.root.hi[a] - lo;
        const double t = size > 0 ? (double(pos[p][a]) - lo) / size : 0.0;
        m[a] = size_t(std::clamp(std::lround(t * double(G - 1)), 0L, long(G - 1)));
      }
      const size_t at = m[0] + G * (m[1] + G * m[2]);
      ++count[at];
      for (uint32_t f = 0; f < F; ++f) sum[f * lattice_points + at] += val[source.slots()[f].index * n + p];
    }
    stats.points += n;
  });
  std::vector<uint8_t> valid(lattice_points, 0);
  for (size_t i = 0; i < lattice_points; ++i) {
    if (!count[i]) continue;
    valid[i] = 1;
    ++stats.hit;
    for (uint32_t f = 0; f < F; ++f) sum[f * lattice_points + i] /= double(count[i]);
  }
  std::vector<uint32_t>().swap(count);

  // Holes: runs of at most kSketchGapFill empty points between two filled ones, filled linearly, axis by axis.
  const size_t stride[3] = {1, size_t(G), size_t(G * G)};
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    for (size_t v = 0; v < G; ++v)
      for (size_t u = 0; u < G; ++u) {
        const size_t base = u * stride[b] + v * stride[c];
        long last = -1;  // the last filled point on the line
        for (size_t s = 0; s < G; ++s) {
          const size_t at = base + s * stride[a];
          if (!valid[at]) continue;
          const long gap = long(s) - last - 1;
          if (last >= 0 && gap > 0 && gap <= long(kSketchGapFill)) {
            const size_t from = base + size_t(last) * stride[a];
            for (long g = 1; g <= gap; ++g) {
              const size_t to = base + (size_t(last) + size_t(g)) * stride[a];
              const double w = double(g) / double(gap + 1);
              for (uint32_t f = 0; f < F; ++f)
                sum[f * lattice_points + to] =
                    (1 - w) * sum[f * lattice_points + from] + w * sum[f * lattice_points + at];
              valid[to] = 1;
              ++stats.filled;
            }
          }
          last = long(s);
        }
      }
  }

  // The level-K bricks: node (i, j, k) holds lattice lines i (R - 1) .. i (R - 1) + R - 1 (neighbours share borders).
  const uint32_t side = uint32_t(1) << K;
  const size_t per_brick = size_t(R) * R * R;
  std::vector<std::unique_ptr<BrickSamples>> deepest(size_t(side) * side * side);
  tbb::parallel_for(size_t(0), deepest.size(), [&](size_t node) {
    const size_t i = node % side, j = (node / side) % side, k = node / (size_t(side) * side);
    auto b = std::make_unique<BrickSamples>();
    b->resolution = R, b->field_count = F;
    b->values.assign(F * per_brick, 0.0f);
    b->mask.assign(per_brick, 0);
    for (uint32_t z = 0; z < R; ++z)
      for (uint32_t y = 0; y < R; ++y)
        for (uint32_t x = 0; x < R; ++x) {
          const size_t at = (i * (R - 1) + x) + G * ((j * (R - 1) + y) + G * (k * (R - 1) + z));
          if (!valid[at]) continue;
          const size_t s = x + size_t(R) * (y + size_t(R) * z);
          b->mask[s] = 1;
          ++b->valid;
          for (uint32_t f = 0; f < F; ++f) b->values[f * per_brick + s] = float(sum[f * lattice_points + at]);
        }
    if (b->valid) deepest[node] = std::move(b);
  });
  std::vector<double>().swap(sum);
  stats.nodes = write_level_store(std::move(deepest), K, layout, path);
  stats.store_bytes = std::filesystem::file_size(path);
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

}  // namespace ugvr
