#include "ugvr/lod/octree_downsample.h"

#include <vector>

namespace ugvr {

void downsample_children(uint32_t R, uint32_t F, const std::array<const BrickSamples*, 8>& children,
                         BrickSamples& parent) {
  const size_t n = size_t(R) * R * R;
  parent.resolution = R;
  parent.field_count = F;
  parent.values.assign(size_t(F) * n, 0.0f);
  parent.mask.assign(n, 0);
  parent.valid = 0;

  // Along one axis, parent sample x is fine line 2x: the child half (0/1) and its local sample, two candidates where
  // the line is the face the two halves share.
  struct Source {
    int count = 0;
    uint32_t half[2] = {0, 0}, local[2] = {0, 0};
  };
  std::vector<Source> sources(R);
  for (uint32_t x = 0; x < R; ++x) {
    const uint32_t f = 2 * x;
    Source& s = sources[x];
    if (f <= R - 1) s.half[s.count] = 0, s.local[s.count] = f, ++s.count;
    if (f >= R - 1) s.half[s.count] = 1, s.local[s.count] = f - (R - 1), ++s.count;
  }

  for (uint32_t z = 0; z < R; ++z)
    for (uint32_t y = 0; y < R; ++y)
      for (uint32_t x = 0; x < R; ++x) {
        const Source &sx = sources[x], &sy = sources[y], &sz = sources[z];
        const BrickSamples* child = nullptr;
        size_t from = 0;
        for (int c = 0; c < sz.count && !child; ++c)
          for (int b = 0; b < sy.count && !child; ++b)
            for (int a = 0; a < sx.count && !child; ++a) {
              const uint32_t octant = sx.half[a] | sy.half[b] << 1 | sz.half[c] << 2;
              if (!children[octant]) continue;
              child = children[octant];
              from = sx.local[a] + size_t(R) * (sy.local[b] + size_t(R) * sz.local[c]);
            }
        if (!child || !child->mask[from]) continue;
        const size_t to = x + size_t(R) * (y + size_t(R) * z);
        parent.mask[to] = 1;
        ++parent.valid;
        for (uint32_t f = 0; f < F; ++f) parent.values[f * n + to] = child->values[f * n + from];
      }
}

}  // namespace ugvr
