#include "ugvr/grid/structured_grid.h"

#include <algorithm>

namespace ugvr {

Bounds StructuredGrid::bounds() const {
  Bounds b;
  const bool blank = has_iblank();
  for (size_t i = 0; i < points.size(); ++i) {
    if (!blank || iblank[i] != 0) b.add(to_double(points[i]));
  }
  return b;
}

Bounds ImageGrid::bounds() const {
  Bounds b;
  if (dims.point_count() == 0) return b;
  b.add(point(0, 0, 0));
  b.add(point(dims.points[0] - 1, dims.points[1] - 1, dims.points[2] - 1));
  return b;
}

Bounds RectilinearGrid::bounds() const {
  Bounds full;
  if (coords[0].empty() || coords[1].empty() || coords[2].empty()) return full;
  for (int a = 0; a < 3; ++a) {
    double lo = coords[a].front(), hi = coords[a].front();
    for (double v : coords[a]) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    full.lo[a] = lo;
    full.hi[a] = hi;
  }
  return full;
}

}  // namespace ugvr
