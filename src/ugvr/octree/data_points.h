// The mesh's data points: where its values are actually given. The octree builder decides splits on them (a node
// splits while two of them that differ fall into one voxel, octree/split.h) and measures each node's error at them
// (octree/node_error.h), so both look at the data itself rather than at the sampled lattice.
//
// A vertex field is given at the vertices. A cell field is one value per cell; its data point is the cell's centroid
// (the mean of its vertices): the field is constant over the cell and jumps at every face, so the vertices, each
// shared by cells of different values, would tell nothing.
//
// Point ids: vertex v is point v, the centroid of cell c is point vertex_count + c (so sorting ids sorts vertices
// before centroids and a set of points is a sorted vector of integers).
//
// Degenerate cells. The paper excludes nearly flat tetrahedra from the split criterion: two vertices of a sliver can
// be arbitrarily close, and separating them would refine without bound. A cell is flat here when its volume is below
// kFlatCell times the cube of its bounding-box diagonal (a regular tetrahedron has 0.065, a cube 0.19, a 1000:1:1
// needle 1e-6, so thin but real boundary-layer cells still count); a vertex takes part in the criterion when any of
// its cells is not flat, a centroid when its cell is not. Every point still counts for the error measure.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/field.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

inline constexpr double kFlatCell = 1e-7;

// Whether a cell of the mesh is flat (see above).
bool is_flat_cell(const UnstructuredMesh& mesh, uint64_t cell);

class OctreeDataPoints {
 public:
  // Copies the scalars as float32 (the precision of the samples): one array per scalar, per vertex or per cell.
  // Parallel. The mesh must outlive this.
  OctreeDataPoints(const UnstructuredMesh& mesh, std::span<const ScalarRef> scalars);

  const UnstructuredMesh& mesh() const { return mesh_; }
  size_t field_count() const { return values_.size(); }
  bool has_vertex_fields() const { return vertex_fields_; }
  bool has_cell_fields() const { return cell_fields_; }
  Association association(size_t field) const { return associations_[field]; }

  bool is_vertex(uint64_t point) const { return point < vertex_count_; }
  Vec3d position(uint64_t point) const;
  // The value of scalar `field` at `point`; NaN where the point carries none (a vertex for a cell field, a centroid
  // for a vertex field).
  float value(uint64_t point, size_t field) const {
    const bool vertex = is_vertex(point);
    if (vertex != (associations_[field] == Association::Vertex)) return NAN;
    return values_[field][vertex ? point : point - vertex_count_];
  }
  // Whether the point takes part in the split criterion (see above).
  bool splits(uint64_t point) const {
    return is_vertex(point) ? vertex_splits_[point] != 0 : cell_flat_[point - vertex_count_] == 0;
  }

  // Whether cell `cell` is flat (see above).
  bool cell_flat(uint64_t cell) const { return cell_flat_[cell] != 0; }

  // Calls f(point id) for each data point of `cell`: its vertices when a vertex field is selected, its centroid when
  // a cell field is.
  template <class F>
  void for_each_point(uint64_t cell, F&& f) const {
    if (vertex_fields_)
      for (uint32_t v : mesh_.cell(cell)) f(uint64_t(v));
    if (cell_fields_) f(vertex_count_ + cell);
  }

  // The data points of `cells` that lie in `box` (closed), sorted, each once; replaces `out`.
  void points_inside(std::span<const uint64_t> cells, const Bounds& box, std::vector<uint64_t>& out) const;

 private:
  const UnstructuredMesh& mesh_;
  uint64_t vertex_count_ = 0;
  std::vector<std::vector<float>> values_;
  std::vector<Association> associations_;
  std::vector<uint8_t> vertex_splits_;  // per vertex: 1 if some cell of it is not flat
  std::vector<uint8_t> cell_flat_;      // per cell: 1 if flat
  bool vertex_fields_ = false, cell_fields_ = false;
};

inline bool box_contains(const Bounds& b, Vec3d p) {
  return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

}  // namespace ugvr
