// Headless OpenGL 4.5 core contexts through EGL, with no window system: the same code drives an NVIDIA GPU on a
// remote machine and Mesa's llvmpipe (software) in CI.
//
// Device choice. EGL_EXT_device_enumeration lists the devices EGL can drive; each is opened on the device platform
// (EGL_EXT_platform_device). "auto" takes the first hardware device and otherwise the first software one (Mesa lists
// llvmpipe as a device with EGL_MESA_device_software); where device enumeration is missing, Mesa's surfaceless
// platform is the fallback. The context renders into textures only (EGL_KHR_surfaceless_context): no surface.
//
// Functions come from libepoxy, which resolves GL entry points for whatever context is current (GLEW needs GLX).
// A context is current on the thread that created it; make_current() moves it to another thread.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace ugvr {

struct GpuDevice {
  int index = 0;          // position in EGL's device list (what --gpu takes)
  std::string name;       // DRM render node or device extensions, for messages
  bool software = false;  // EGL_MESA_device_software (llvmpipe)
};

// The devices EGL reports (empty where device enumeration is unsupported). Never throws.
std::vector<GpuDevice> list_gpu_devices();

class GlContext {
 public:
  // device: "auto", or a device index from list_gpu_devices(). Throws ugvr::Error saying what is missing (no EGL,
  // no device, no OpenGL 4.5 core context) and listing the devices.
  explicit GlContext(const std::string& device = "auto");
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void make_current() const;

  const std::string& renderer() const;  // GL_RENDERER, e.g. "NVIDIA H100 80GB HBM3/PCIe/SSE2", "llvmpipe (LLVM 15...)"
  const std::string& version() const;   // GL_VERSION
  const std::string& vendor() const;    // GL_VENDOR
  bool software() const;                // llvmpipe or another software rasteriser
  int max_3d_texture_size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ugvr
