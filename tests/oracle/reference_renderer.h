// Test-only reference renderer ("oracle") for the exact engine. It shares nothing with the engine but the public
// vocabulary (Camera, TransferFunction, RenderSettings, Image): no face walking and no topology. Each ray is sampled
// densely and every sample is located independently in a bounding-volume hierarchy of the cells' boxes, then inverted
// in its cell (tetrahedra by barycentric coordinates, other cells by Newton on the isoparametric map), all in double
// precision. Being slow and simple is the point: its answers are easy to believe, so the engine is tested against it.
//
// Integration (emission-absorption): the midpoint rule over pieces of at most one step (default: bounds diagonal /
// 4000), halved adaptively while the field changes by more than 1/1000 of the transfer function's range across a
// piece (boundary layers of graded meshes are far thinner than a step); per piece alpha = 1 - exp(-tau * length),
// composited front to back with no early termination. Wherever the sample "key" changes between two neighbouring
// samples (entering or leaving the mesh; for cell data also a change of cell, where the field jumps) the piece is
// bisected until the change is located to ~1e-5 of a step, so boundaries and jumps cost no first-order error. The
// clip plane is applied analytically to the ray interval. MIP takes the maximum over all samples and refines the best
// one by a golden-section search; isosurfaces are found as sign changes between neighbouring samples, refined by
// bisection (within one piece of continuous data: per-cell data, constant in each cell, has no crossings here).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr::oracle {

// Parametric inside test tolerance: a point counts as inside a cell when its parametric coordinates are within
// this of the reference cell (shared faces belong to both neighbours, so no point of a conforming mesh is lost).
inline constexpr double kParametricTolerance = 1e-9;

// Shape functions in VTK's parametric coordinates and vertex order (cell_type.h): tetra barycentric
// (N0 = 1-r-s-t, N1 = r, N2 = s, N3 = t); hexahedron trilinear over the unit cube; wedge N0 = (1-r-s)(1-t),
// N1 = r(1-t), N2 = s(1-t), N3 = (1-r-s)t, N4 = rt, N5 = st; pyramid N0 = (1-r)(1-s)(1-t), N1 = r(1-s)(1-t),
// N2 = rs(1-t), N3 = (1-r)s(1-t), N4 = t. Writes cell_vertex_count(type) weights.
void shape_functions(CellType type, const std::array<double, 3>& rst, double* weights);

// Inverts the isoparametric map of one cell: the parametric coordinates of `p` when it lies inside (within
// kParametricTolerance), nullopt otherwise. `corners` holds cell_vertex_count(type) positions in VTK order.
// `start` seeds Newton (ignored for tetrahedra); pass a previous answer for the same cell to save iterations.
std::optional<std::array<double, 3>> locate_in_cell(CellType type, const Vec3d* corners, Vec3d p,
                                                    const std::array<double, 3>* start = nullptr);

// The transfer function's colour, opacity and extinction (transfer_function.h), evaluated here rather than through
// TransferFunction: the oracle calls them once per sample, and the tests' sanitizer build compiles the library
// without optimisation while this file is optimised (tests/CMakeLists.txt), so the library's calls would dominate.
// The self-test checks it against TransferFunction.
class TransferEval {
 public:
  explicit TransferEval(const TransferFunction& tf);
  Vec3d color(double s) const;
  double opacity(double s) const;
  double extinction(double s) const;
  double range_min() const { return color_x_.front(); }
  double range_max() const { return color_x_.back(); }

 private:
  std::vector<double> color_x_, opacity_x_, opacity_;
  std::vector<Vec3d> color_;
  Vec3d nan_color_;
  double unit_distance_;
};

struct Location {
  uint64_t cell = 0;  // index over all blocks' cells, in block order
  std::array<double, 3> rst{};
  double value = 0;
  bool per_cell = false;  // the cell's block carries the field per cell (constant in the cell, jumps at its faces)
};

class ReferenceRenderer {
 public:
  // Gathers every block's cells (structured blocks as trilinear hexahedra) with the scalar `selector` (a
  // FieldSet selector present in every block) and builds the point-location hierarchy.
  ReferenceRenderer(const Dataset& dataset, std::string_view selector);

  // The scalar at p, or nullopt when p lies in no cell. `hint` is a cell to try first (the previous sample's
  // cell along a ray, which nearly always still holds the point); pass nullptr for none.
  std::optional<Location> locate(Vec3d p, const Location* hint = nullptr) const;
  std::optional<double> sample(Vec3d p) const {
    const auto loc = locate(p);
    return loc ? std::optional<double>(loc->value) : std::nullopt;
  }

  // Renders settings.width x settings.height as described above. early_termination_opacity, sample_step,
  // lighting and volume_lighting are ignored: there is no termination, the step is set_step's, and isosurfaces are
  // unshaded (tests compare with lighting off).
  Image render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings) const;

  // World-space distance between the regular samples (0 = bounds diagonal / 4000).
  void set_step(double step) { step_ = step; }
  double step() const;
  Bounds bounds() const { return bounds_; }
  uint64_t cell_count() const { return types_.size(); }
  double field_min() const { return field_min_; }
  double field_max() const { return field_max_; }

 private:
  Vec3d corner(uint64_t cell, int i) const { return points_[connectivity_[offsets_[cell] + uint64_t(i)]]; }
  bool test_cell(uint64_t cell, Vec3d p, const std::array<double, 3>* start, Location& out) const;
  void shade_ray(const Ray& ray, const TransferEval& tf, const RenderSettings& settings, double out[4]) const;

  std::vector<Vec3d> points_;         // all blocks' vertices, concatenated
  std::vector<double> point_values_;  // per vertex (NaN where the block's field is per cell)
  std::vector<CellType> types_;
  std::vector<uint64_t> offsets_;  // into connectivity_, size cells + 1
  std::vector<uint32_t> connectivity_;
  std::vector<double> cell_values_;                // per cell for cell fields; unused (NaN) for vertex fields
  std::vector<uint8_t> cell_data_;                 // 1 when the cell's block carries the field per cell
  std::vector<std::array<double, 6>> cell_boxes_;  // lo xyz, hi xyz, slightly padded
  // Per tetrahedron: the inverse of [p1-p0 p2-p0 p3-p0] (row-major) and p0, so barycentric coordinates cost one
  // matrix product (tetrahedra dominate the location cost). Unused for other cells.
  std::vector<std::array<double, 12>> tet_inverse_;

  Bounds bounds_;
  struct BvhNode {
    std::array<double, 6> box{};    // lo xyz, hi xyz of the cells below
    uint32_t first = 0, count = 0;  // leaf: bvh_cells_[first, first + count); count 0: inner node
    uint32_t right = 0;             // inner node: the right child (the left one is the next node)
  };
  std::vector<BvhNode> bvh_;
  std::vector<uint32_t> bvh_cells_;
  double step_ = 0;
  double field_min_ = 0, field_max_ = 0;
};

// ---- Helpers shared by the tests built on the oracle ----

// RGB differences of two images of the same size (alpha ignored), computed here so the tests do not depend on
// compare_images.
struct RgbDifference {
  double rms = 0;
  double max_abs = 0;
  uint64_t pixels_over = 0;  // pixels with any channel differing by more than the threshold given
};
RgbDifference rgb_difference(const Image& a, const Image& b, double pixel_threshold = 1e-3);

// A uniform box [lo, hi] of cells[0] x cells[1] x cells[2] hexahedra (or one of their tetrahedral splits) as one
// unstructured block with the vertex field "f" = field(vertex position), stored as Float64. The field is evaluated at
// the float32 positions the mesh stores, so it is exactly the function the renderers see.
Dataset box_dataset(Vec3d lo, Vec3d hi, std::array<uint32_t, 3> cells, StructuredCellShape shape,
                    const std::function<double(Vec3d)>& field);

// ---- Scenes with closed-form images ----
// Small boxes whose images are known analytically, per pixel, from the rays alone: the same scenes check the oracle
// (test_oracle_selftest.cpp, tightly) and the exact engine (test_exact_analytic.cpp). Every scene uses the unit box
// [0, 1]^3, early_termination_opacity = 1, lighting off and an opaque background.
//  "constant":    constant field, constant colour and opacity: c (1 - e^-tau L) + e^-tau L bg, L = path length in
//                 the box (after the clip plane when there is one);
//  "linear-slab": s = z, colour linear in s, constant opacity (linear_slab_radiance);
//  "cell-layers": per-cell data, 0 below z = 0.5 and 1 above: two constant slabs in ray order;
//  "mip":         s = z, MIP: colour(s_max) at alpha opacity(s_max), s_max = the highest z on the (clipped) path;
//  "iso":         s = x, iso values 0.3 and 0.7 at opacity 0.5: each crossing inside the box composites colour(v).
struct ClosedFormScene {
  std::string name;  // family, cell shape, camera, options: for failure messages
  std::shared_ptr<const Dataset> dataset;
  std::string field;
  Camera camera;
  TransferFunction tf;
  RenderSettings settings;
  Image expected;
  // 1 where the pixel's ray passes within ~1e-4 of an ambiguous spot (an isosurface meeting the box's edge), so
  // neither renderer can be held to the closed form there.
  std::vector<uint8_t> skip;
};
std::vector<ClosedFormScene> closed_form_scenes(std::string_view family);

// Largest difference over RGBA between `image` and the scene's expected image, skipped pixels left out, and where.
struct SceneError {
  double max_abs = 0;
  int x = -1, y = -1;
};
SceneError scene_error(const ClosedFormScene& scene, const Image& image);

// Ray interval inside the box [lo, hi] with t >= 0, cut by the clip plane (kept side) when there is one.
bool segment_in_box(const Ray& ray, Vec3d lo, Vec3d hi, const std::optional<ClipPlane>& clip, double& t0, double& t1);

// s = z through a slab, colour linear in s, constant extinction tau: along a path of length L the colour is linear
// in the distance u from the entry, c(u) = c_in + (c_out - c_in) u / L, and
//   I = integral_0^L c(u) tau e^(-tau u) du = c_in (1 - E) + (c_out - c_in) ((1 - E) / tau - L E) / L,  E = e^(-tau L).
Vec3d linear_slab_radiance(Vec3d c_in, Vec3d c_out, double tau, double length);

}  // namespace ugvr::oracle
