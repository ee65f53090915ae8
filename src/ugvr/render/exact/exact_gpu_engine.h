// The exact engine on the GPU: the CPU engine's walk (exact_engine.h) in an OpenGL 4.5 compute shader
// (shaders/exact_walk.comp) through the headless EGL context the LOD engine uses, so it runs on an NVIDIA GPU and, in
// CI, on Mesa's llvmpipe. Same walk mesh, same closed-form integration, same modes; images agree with the CPU
// engine's to within rounding (tests/test_exact_gpu.cpp: PSNR >= 60 dB on every dataset and mode).
//
// Device memory: the walk mesh as it is (connectivity, neighbours, quad-diagonal bits, float32 points), the bound
// field, the boundary triangles (8 bytes each) and, per frame, their pixel boxes and tile lists (boundary_bins.h,
// binned on the CPU). A tetrahedral mesh costs 32 bytes per cell + 16 per vertex, about 36 bytes per tetrahedron.
// The connectivity and the neighbours are split over up to four storage buffers each where one buffer may not hold
// them (GL_MAX_SHADER_STORAGE_BLOCK_SIZE: 128 MiB on llvmpipe, 2 GiB or more on NVIDIA).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ugvr/gpu/gl_context.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/image.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {

struct WalkMesh;

struct ExactGpuOptions {
  // Walk arithmetic in double (as the CPU reference) or float (faster on GPUs with slow fp64). Rays and the camera
  // are double either way.
  bool double_precision = true;
  // Largest storage buffer to use, bytes; 0 = the driver's limit. Tests set it small to exercise the split.
  uint64_t max_buffer_bytes = 0;
};

// What the mesh needs on the device, before anything is allocated (for "does it fit").
uint64_t exact_gpu_bytes_needed(const WalkMesh& mesh, bool per_cell_field);

class ExactGpuEngine {
 public:
  // Uploads the walk mesh (which must outlive the engine: the boundary is binned from it each frame). Throws
  // ugvr::Error when the mesh does not fit (the message names the memory needed and the LOD path) or GL fails.
  ExactGpuEngine(const WalkMesh& mesh, std::shared_ptr<const GlContext> gl, ExactGpuOptions options = {});
  ~ExactGpuEngine();
  ExactGpuEngine(const ExactGpuEngine&) = delete;
  ExactGpuEngine& operator=(const ExactGpuEngine&) = delete;

  // Binds the field (per vertex of the walk mesh's points, or per engine cell).
  void set_values(const std::vector<float>& values, bool per_cell);
  // As ExactEngine::render; `tolerance_abs` is the nonlinear tolerance in scalar units.
  Image render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings, double tolerance_abs,
               ExactRenderStats* stats = nullptr);

  const GlContext& gl() const;
  // Bytes allocated on the device (mesh, field, this frame's bins and image).
  uint64_t device_bytes() const;
  // Bytes of the mesh and field alone (what grows with the mesh), per cell in --stats.
  uint64_t mesh_device_bytes() const;
  // Seconds of the last frame spent binning the boundary on the CPU and on the GPU's own clock.
  double last_bin_seconds() const;
  double last_gpu_seconds() const;
  // As LodEngine::set_keep_going: from the next frame on, the walk is dispatched in bands of rows that `keep_going`
  // may stop (FrameInterrupted). Empty: one dispatch.
  void set_keep_going(std::function<bool()> keep_going);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ugvr
