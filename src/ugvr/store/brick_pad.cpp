#include "ugvr/store/brick_pad.h"

#include <algorithm>
#include <cstring>
#include <vector>

namespace ugvr {

void pad_brick(uint32_t R, uint32_t F, float* values, const uint8_t* mask) {
  const size_t n = size_t(R) * R * R, row = R, plane = size_t(R) * R;
  const size_t data = size_t(std::count_if(mask, mask + n, [](uint8_t m) { return m != 0; }));
  if (data == 0 || data == n) return;  // nothing to grow from, or nowhere to grow
  // Samples within one step of data: the mask dilated by a 3x3x3 box, one axis at a time, each pass a run of byte
  // ORs along whole rows (x) or between whole rows (y) and planes (z), which the compiler vectorizes. Most samples of
  // a partial brick are far from the boundary, and this keeps the 27-neighbour loop below to the ones that need it.
  std::vector<uint8_t> along_x(n), along_xy(n);
  if (R == 1) {
    std::memcpy(along_x.data(), mask, n);
  } else {
    for (size_t r = 0; r < n; r += row) {
      const uint8_t* m = mask + r;
      uint8_t* o = along_x.data() + r;
      o[0] = m[0] | m[1];
      for (size_t x = 1; x + 1 < R; ++x) o[x] = m[x - 1] | m[x] | m[x + 1];
      o[R - 1] = m[R - 2] | m[R - 1];
    }
  }
  for (size_t p = 0; p < n; p += plane)
    for (size_t y = 0; y < R; ++y) {
      const uint8_t* a = along_x.data() + p + y * row;
      const uint8_t* below = y > 0 ? a - row : a;
      const uint8_t* above = y + 1 < R ? a + row : a;
      uint8_t* o = along_xy.data() + p + y * row;
      for (size_t x = 0; x < R; ++x) o[x] = a[x] | below[x] | above[x];
    }
  uint8_t* near = along_x.data();  // the x pass is no longer needed: the z pass writes over it
  for (size_t z = 0; z < R; ++z) {
    const uint8_t* a = along_xy.data() + z * plane;
    const uint8_t* below = z > 0 ? a - plane : a;
    const uint8_t* above = z + 1 < R ? a + plane : a;
    uint8_t* o = near + z * plane;
    for (size_t i = 0; i < plane; ++i) o[i] = a[i] | below[i] | above[i];
  }
  std::vector<double> sum(F);
  for (uint32_t z = 0; z < R; ++z)
    for (uint32_t y = 0; y < R; ++y) {
      const size_t r0 = size_t(R) * (y + size_t(R) * z);
      // Most rows have no sample to pad: find out with one pass over the row's bytes.
      uint8_t any = 0;
      for (size_t x = 0; x < R; ++x) any |= uint8_t(near[r0 + x] & (mask[r0 + x] == 0));
      if (!any) continue;
      for (uint32_t x = 0; x < R; ++x) {
        const size_t s = r0 + x;
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
}

}  // namespace ugvr
