// The exact engine: CPU ray casting of unstructured meshes by walking from cell to cell across shared faces
// (Garrity 1990, Bunyk et al. 1997, Marmitt & Slusallek 2006), natively over tetrahedra, pyramids, wedges and
// hexahedra. It is the quality reference every other engine is measured against. Design notes: docs/exact-engine.md.
//
// Geometry and values are separate: constructing the engine builds the walk mesh (type-sorted cells, neighbours,
// boundary) once; set_field binds one scalar (cheap: a copy of the values); render() takes the camera, transfer
// function and settings and touches neither. Rendering is parallel over image tiles (oneTBB) and deterministic:
// the same inputs give the same bits for any thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

struct WalkMesh;

struct ExactRenderStats {
  double render_seconds = 0;       // wall time of render()
  uint64_t rays = 0;               // primary rays (pixels)
  uint64_t rays_hit = 0;           // rays that entered the mesh at least once
  uint64_t cell_steps = 0;         // cells entered, summed over rays
  uint64_t reentries = 0;          // times a ray entered the mesh again after leaving it (non-convex meshes, holes)
  uint64_t nonlinear_samples = 0;  // interior field evaluations in non-tetrahedral cells (error-bounded integration)
  uint64_t lost_rays = 0;          // rays abandoned on a degenerate walk (should be 0; counted, never silent)
  // GPU engine: rays that llvmpipe's loop limit cut short (shaders/loop_limit_probe.glsl), traced again on the CPU
  // (trace_exact_pixels); 0 on a hardware GPU.
  uint64_t cpu_traced_rays = 0;
  int threads = 0;
};

class ExactEngine {
 public:
  // Builds the walk mesh from every block of the dataset (structured blocks as hexahedra: see docs). Throws
  // ugvr::Error for an empty dataset or more than 2^29 - 1 cells (the walk mesh packs cell and face in 32 bits).
  explicit ExactEngine(const Dataset& dataset);
  ~ExactEngine();
  ExactEngine(ExactEngine&&) noexcept;
  ExactEngine& operator=(ExactEngine&&) noexcept;

  // Binds the scalar to render: a FieldSet selector ("NAME", "NAME:x", ...; empty = the first field of the first
  // block) present in every block of `dataset` (the same dataset the engine was built from). Throws ugvr::Error.
  void set_field(const Dataset& dataset, std::string_view selector);
  // Name of the bound scalar and its range over the data (NaN values excluded).
  const std::string& field_name() const;
  double field_min() const;
  double field_max() const;

  // Renders one image of settings.width x settings.height. settings.field is ignored here (bind with set_field);
  // settings.sample_step is ignored (integration is exact per cell; nonlinear cells use `nonlinear_tolerance`).
  Image render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
               ExactRenderStats* stats = nullptr) const;

  // Largest deviation, in scalar units relative to the transfer function's range, allowed between the field along
  // a ray inside a non-tetrahedral cell and the piecewise-linear function the integrator uses. Default 1e-3.
  void set_nonlinear_tolerance(double relative);

  // Data-parallel rendering (src/ugvr/mpi, docs/mpi.md): only the stretch of each ray inside `box` is integrated (and
  // surfaces drawn), so the images of boxes that tile space compose front to back into the whole image. Faces may be
  // infinite (an outer box of a kd-tree). Not a user setting: the renderer interface does not carry it. nullopt (the
  // default): whole rays.
  void set_clip_box(std::optional<Bounds> box);
  const std::optional<Bounds>& clip_box() const;
  // Interactive front ends (FrameRequest::keep_going, renderer.h): from the next frame on, each tile of the image asks
  // `keep_going` before it is traced, and a frame it stops throws FrameInterrupted once the tiles under way are done.
  // Empty: every tile is traced.
  void set_keep_going(std::function<bool()> keep_going);
  // Data-parallel rendering with a part of the mesh: keeps only the cells whose bounding boxes meet `box`
  // (restrict_walk_mesh in walk_mesh.h; the faces where the mesh was cut become faces rays enter through) and sets
  // the clip box to `box`, so the image is the whole mesh's clipped to the box while the rays walk only this part.
  // The bound field (and any set_field after) keeps the whole mesh's range, so every part maps colours alike; bounds()
  // stays the whole mesh's. Once per engine; throws ugvr::Error on a second call.
  void restrict_to_box(const Bounds& box);

  Bounds bounds() const;
  uint64_t cell_count() const;
  uint64_t point_count() const;
  // Bytes held by the engine's structures (points, connectivity, neighbours, boundary, bound field).
  uint64_t memory_bytes() const;
  // Seconds spent building the walk mesh (topology included) in the constructor.
  double build_seconds() const;

  // What the GPU engine (exact_gpu_engine.h) uploads: the walk mesh, the bound values (per vertex, or per cell in
  // engine order) and the nonlinear tolerance in scalar units for a transfer function.
  const WalkMesh& walk_mesh() const;
  const std::vector<float>& bound_values() const;
  bool per_cell() const;
  double tolerance_abs(const TransferFunction& tf) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The CPU walk of the listed pixels (y * width + x, ascending) of the image that `settings` describes, written over
// those pixels of `image` (settings.width x settings.height): what the GPU engine does with the rays that llvmpipe's
// loop limit cut short (shaders/loop_limit_probe.glsl). `values` and `per_cell` as bound to the walk mesh; `stats`
// gains the cells they walked. Throws ugvr::Error for a pixel outside the image.
void trace_exact_pixels(const WalkMesh& mesh, const std::vector<float>& values, bool per_cell, const Camera& camera,
                        const TransferFunction& tf, const RenderSettings& settings, double tolerance_abs,
                        std::span<const uint32_t> pixels, Image& image, ExactRenderStats* stats);

}  // namespace ugvr
