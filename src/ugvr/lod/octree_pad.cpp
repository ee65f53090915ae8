#include "ugvr/lod/octree_pad.h"

#include <algorithm>
#include <vector>

namespace ugvr {

void pad_brick(uint32_t R, uint32_t F, float* values, const uint8_t* mask) {
  const size_t n = size_t(R) * R * R;
  const size_t data = size_t(std::count_if(mask, mask + n, [](uint8_t m) { return m != 0; }));
  if (data == 0 || data == n) return;  // nothing to grow from, or nowhere to grow
  // Samples within one step of data: the mask dilated by a 3x3x3 box, one axis at a time. Most samples of a
  // partial brick are far from the boundary, and this keeps the 27-neighbour loop below to the ones that need it.
  std::vector<uint8_t> near(n), pass(n);
  for (size_t s = 0; s < n; ++s) near[s] = mask[s] != 0;
  const size_t stride[3] = {1, R, size_t(R) * R};
  for (int a = 0; a < 3; ++a) {
    const size_t st = stride[a];
    for (uint32_t z = 0; z < R; ++z)
      for (uint32_t y = 0; y < R; ++y)
        for (uint32_t x = 0; x < R; ++x) {
          const size_t s = x + size_t(R) * (y + size_t(R) * z);
          const uint32_t c = a == 0 ? x : (a == 1 ? y : z);
          pass[s] = near[s] | (c > 0 ? near[s - st] : 0) | (c + 1 < R ? near[s + st] : 0);
        }
    near.swap(pass);
  }
  std::vector<double> sum(F);
  for (uint32_t z = 0; z < R; ++z)
    for (uint32_t y = 0; y < R; ++y)
      for (uint32_t x = 0; x < R; ++x) {
        const size_t s = x + size_t(R) * (y + size_t(R) * z);
        if (mask[s] || !near[s]) continue;
        std::fill(sum.begin(), sum.end(), 0.0);
        int count = 0;
        // Reads data samples only, never pad written earlier in this pass: one layer, independent of visiting order.
        for (uint32_t zz = z ? z - 1 : 0; zz <= std::min(z + 1, R - 1); ++zz)
          for (uint32_t yy = y ? y - 1 : 0; yy <= std::min(y + 1, R - 1); ++yy)
            for (uint32_t xx = x ? x - 1 : 0; xx <= std::min(x + 1, R - 1); ++xx) {
              const size_t t = xx + size_t(R) * (yy + size_t(R) * zz);
              if (!mask[t]) continue;
              ++count;
              for (uint32_t f = 0; f < F; ++f) sum[f] += values[f * n + t];
            }
        for (uint32_t f = 0; f < F; ++f) values[f * n + s] = float(sum[f] / count);
      }
}

}  // namespace ugvr
