#include "ugvr/octree/data_points.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "ugvr/grid/cell_interpolation.h"

namespace ugvr {

OctreeDataPoints::OctreeDataPoints(const UnstructuredMesh& mesh, std::span<const ScalarRef> scalars)
    : mesh_(mesh), vertex_count_(mesh.point_count()) {
  for (const ScalarRef& s : scalars) {
    const Field& f = *s.field;
    associations_.push_back(f.association());
    (f.association() == Association::Vertex ? vertex_fields_ : cell_fields_) = true;
    std::vector<float>& v = values_.emplace_back(f.tuples());
    f.data().visit([&](auto data) {
      const int n = f.components();
      tbb::parallel_for(tbb::blocked_range<uint64_t>(0, v.size()), [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t t = r.begin(); t != r.end(); ++t) {
          if (n == 1) {
            v[t] = float(data[t]);
          } else if (s.component >= 0) {
            v[t] = float(data[t * uint64_t(n) + uint64_t(s.component)]);
          } else {
            double sum = 0;
            for (int c = 0; c < n; ++c) sum += double(data[t * uint64_t(n) + uint64_t(c)]) * data[t * uint64_t(n) + c];
            v[t] = float(std::sqrt(sum));
          }
        }
      });
    });
  }

  cell_flat_.assign(mesh.cell_count(), 0);
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, mesh.cell_count()), [&](const tbb::blocked_range<uint64_t>& r) {
    for (uint64_t c = r.begin(); c != r.end(); ++c) cell_flat_[c] = is_flat_cell(mesh, c);
  });
  // Serial: a vertex is shared by many cells, and this is a few memory passes.
  vertex_splits_.assign(vertex_count_, 0);
  for (uint64_t c = 0; c < mesh.cell_count(); ++c) {
    if (cell_flat_[c]) continue;
    for (uint32_t v : mesh.cell(c)) vertex_splits_[v] = 1;
  }
}

bool is_flat_cell(const UnstructuredMesh& mesh, uint64_t cell) {
  Vec3d v[kMaxCellVertices];
  const int n = gather_cell_vertices(mesh, cell, v);
  Bounds bb;
  for (int i = 0; i < n; ++i) bb.add(v[i]);
  const double d = length(bb.size());
  return !(std::abs(cell_volume(mesh, cell)) > kFlatCell * d * d * d);
}

Vec3d OctreeDataPoints::position(uint64_t point) const {
  if (is_vertex(point)) return to_double(mesh_.points[point]);
  const std::span<const uint32_t> ids = mesh_.cell(point - vertex_count_);
  Vec3d sum{};
  for (uint32_t v : ids) sum = sum + to_double(mesh_.points[v]);
  return sum * (1.0 / double(ids.size()));
}

void OctreeDataPoints::points_inside(std::span<const uint64_t> cells, const Bounds& box,
                                     std::vector<uint64_t>& out) const {
  out.clear();
  for (uint64_t c : cells) {
    for_each_point(c, [&](uint64_t p) {
      if (box_contains(box, position(p))) out.push_back(p);
    });
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

}  // namespace ugvr
