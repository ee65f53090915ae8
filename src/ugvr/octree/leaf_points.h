// The data points of an out-of-core leaf sampled in pieces (octree/out_of_core.h), each measured once, as in core.
//
// Such a leaf's brick is complete only after its last piece, but each piece's cells are in memory only while that
// piece is sampled. So each piece writes the data points it owns (octree/data_points.h: vertices, cell centroids),
// welded by id so each once, to the leaf's point file, and the leaf measures its error from that file once its brick
// is whole and padded. A point belongs to exactly one piece: the pieces' regions, taken half-open ([lo, hi) on each
// axis, closed where the region reaches the leaf's upper face), tile the leaf's closed box. So the leaf measures the
// same points as in core, each once: the same max, rms and transfer-function error entry at any memory budget (only
// the order of their sums differs).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "ugvr/core/file.h"
#include "ugvr/core/vec.h"

namespace ugvr {

// The points a piece owns: `box` half-open per axis, closed at hi where closed_hi says so.
struct OwnedRegion {
  Bounds box;
  std::array<bool, 3> closed_hi = {true, true, true};  // the leaf's own box: closed on every side

  bool contains(Vec3d p) const {
    for (int a = 0; a < 3; ++a) {
      if (p[a] < box.lo[a] || p[a] > box.hi[a]) return false;
      if (p[a] == box.hi[a] && !closed_hi[a]) return false;
    }
    return true;
  }
  // The region of octant o (bit a set: the upper half on axis a) when the piece is halved at `mid`: the lower half
  // ends open at mid, the upper half keeps this region's upper end.
  OwnedRegion octant(uint32_t o, Vec3d mid) const {
    OwnedRegion r = *this;
    for (int a = 0; a < 3; ++a) {
      if (o >> a & 1) {
        r.box.lo[a] = mid[a];
      } else {
        r.box.hi[a] = mid[a];
        r.closed_hi[size_t(a)] = false;
      }
    }
    return r;
  }
};

// A leaf's point file: per point its position (3 doubles) and one float per field (NaN: not given there), native
// byte order (a temporary file of the build's scratch folder). Throws ugvr::Error naming the file on failure.
class LeafPointWriter {
 public:
  LeafPointWriter(std::string path, uint32_t field_count);

  void add(Vec3d position, const float* values);
  // Flushes and closes; the destructor closes without reporting errors.
  void close() { file_.close(); }
  uint64_t points() const { return points_; }

 private:
  BufferedFileWriter file_;
  uint32_t field_count_;
  uint64_t points_ = 0;
};

// Calls f(position, values) for each point of the file, in the order written. Throws ugvr::Error naming the file
// when it cannot be read or does not hold whole points.
void for_each_leaf_point(const std::string& path, uint32_t field_count,
                         const std::function<void(Vec3d, const float*)>& f);

}  // namespace ugvr
