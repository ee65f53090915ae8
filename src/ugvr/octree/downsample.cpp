#include "ugvr/octree/downsample.h"

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
    for (uint32_t y = 0; y < R; ++y) {
      const Source &sy = sources[y], &sz = sources[z];
      if (sy.count == 1 && sz.count == 1) {
        // The common case (every sample when R - 1 is odd): one child row per half along x.
        const size_t row = size_t(R) * (y + size_t(R) * z);
        const size_t from_row = size_t(R) * (sy.local[0] + size_t(R) * sz.local[0]);
        for (uint32_t x = 0; x < R; ++x) {
          const Source& sx = sources[x];
          if (sx.count != 1) continue;  // on the face the x halves share: below
          const BrickSamples* child = children[sx.half[0] | sy.half[0] << 1 | sz.half[0] << 2];
          if (!child) continue;
          const size_t from = from_row + sx.local[0];
          if (!child->mask[from]) continue;
          const size_t to = row + x;
          parent.mask[to] = 1;
          ++parent.valid;
          for (uint32_t f = 0; f < F; ++f) parent.values[f * n + to] = child->values[f * n + from];
        }
        if ((R - 1) % 2 == 1) continue;  // no shared face along x: the row is done
      }
      for (uint32_t x = 0; x < R; ++x) {
        const Source& sx = sources[x];
        if (sx.count == 1 && sy.count == 1 && sz.count == 1) continue;  // done above
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
}

}  // namespace ugvr
