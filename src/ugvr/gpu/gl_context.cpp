#include "ugvr/gpu/gl_context.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <cstdio>
#include <cstring>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

[[noreturn]] void fail_gl(const std::string& what) { fail_in("OpenGL", what); }

std::string egl_error_name(EGLint e) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "EGL error 0x%04x", unsigned(e));
  return buf;
}

bool client_extension(const char* name) { return epoxy_has_egl_extension(EGL_NO_DISPLAY, name); }

std::vector<EGLDeviceEXT> egl_devices() {
  std::vector<EGLDeviceEXT> devices;
  if (!client_extension("EGL_EXT_device_enumeration") && !client_extension("EGL_EXT_device_base")) return devices;
  EGLint n = 0;
  if (!eglQueryDevicesEXT(0, nullptr, &n) || n <= 0) return devices;
  devices.resize(size_t(n));
  if (!eglQueryDevicesEXT(n, devices.data(), &n)) return {};
  devices.resize(size_t(n));
  return devices;
}

GpuDevice describe(EGLDeviceEXT device, int index) {
  GpuDevice d;
  d.index = index;
  const char* ext = eglQueryDeviceStringEXT(device, EGL_EXTENSIONS);
  const std::string extensions = ext ? ext : "";
  d.software = extensions.find("EGL_MESA_device_software") != std::string::npos;
  const char* node = nullptr;
#ifdef EGL_DRM_RENDER_NODE_FILE_EXT
  if (extensions.find("EGL_EXT_device_drm_render_node") != std::string::npos)
    node = eglQueryDeviceStringEXT(device, EGL_DRM_RENDER_NODE_FILE_EXT);
#endif
  if (!node && extensions.find("EGL_EXT_device_drm") != std::string::npos)
    node = eglQueryDeviceStringEXT(device, EGL_DRM_DEVICE_FILE_EXT);
  d.name = node ? node : (d.software ? "software" : "device " + std::to_string(index));
  return d;
}

std::string device_list_text() {
  std::string s;
  for (const GpuDevice& d : list_gpu_devices())
    s += (s.empty() ? "" : ", ") + std::to_string(d.index) + ": " + d.name + (d.software ? " (software)" : "");
  return s.empty() ? "none reported" : s;
}

}  // namespace

std::vector<GpuDevice> list_gpu_devices() {
  std::vector<GpuDevice> out;
  const std::vector<EGLDeviceEXT> devices = egl_devices();
  for (size_t i = 0; i < devices.size(); ++i) out.push_back(describe(devices[i], int(i)));
  return out;
}

struct GlContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  std::string renderer, version, vendor;
  bool software = false;
  int max_3d = 0;
};

GlContext::GlContext(const std::string& device) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  const std::vector<EGLDeviceEXT> devices = egl_devices();
  int chosen = -1;
  if (device == "auto" || device.empty()) {
    for (size_t i = 0; i < devices.size() && chosen < 0; ++i)
      if (!describe(devices[i], int(i)).software) chosen = int(i);
    if (chosen < 0 && !devices.empty()) chosen = 0;
  } else {
    char* end = nullptr;
    const long v = std::strtol(device.c_str(), &end, 10);
    if (end == device.c_str() || *end != '\0' || v < 0 || v >= long(devices.size()))
      fail_gl("--gpu \"" + device + "\": not a device index (devices: " + device_list_text() + ")");
    chosen = int(v);
  }

  if (chosen >= 0 && client_extension("EGL_EXT_platform_device"))
    I.display = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[size_t(chosen)], nullptr);
  if (I.display == EGL_NO_DISPLAY && client_extension("EGL_MESA_platform_surfaceless"))
    I.display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (I.display == EGL_NO_DISPLAY)
    fail_gl("no EGL display: neither the device platform nor Mesa's surfaceless platform is available (devices: " +
            device_list_text() + ")");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(I.display, &major, &minor))
    fail_gl("eglInitialize failed (" + egl_error_name(eglGetError()) + ")");
  if (!epoxy_has_egl_extension(I.display, "EGL_KHR_surfaceless_context"))
    fail_gl("the EGL display lacks EGL_KHR_surfaceless_context (needed to render without a window)");
  if (!eglBindAPI(EGL_OPENGL_API)) fail_gl("eglBindAPI(EGL_OPENGL_API) failed: no desktop OpenGL");

  // EGL_KHR_no_config_context spares us choosing a config for a context that never draws to a surface.
  EGLConfig config = EGL_NO_CONFIG_KHR;
  if (!epoxy_has_egl_extension(I.display, "EGL_KHR_no_config_context")) {
    const EGLint attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_NONE};
    EGLint n = 0;
    if (!eglChooseConfig(I.display, attribs, &config, 1, &n) || n < 1) fail_gl("no EGL config for desktop OpenGL");
  }
  const EGLint context_attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  I.context = eglCreateContext(I.display, config, EGL_NO_CONTEXT, context_attribs);
  if (I.context == EGL_NO_CONTEXT) {
    const EGLint e = eglGetError();
    fail_gl("could not create an OpenGL 4.5 core context (" + egl_error_name(e) + ")");
  }
  make_current();
  auto str = [](GLenum name) {
    const GLubyte* s = glGetString(name);
    return std::string(s ? reinterpret_cast<const char*>(s) : "");
  };
  I.renderer = str(GL_RENDERER);
  I.version = str(GL_VERSION);
  I.vendor = str(GL_VENDOR);
  I.software = I.renderer.find("llvmpipe") != std::string::npos || I.renderer.find("softpipe") != std::string::npos ||
               (chosen >= 0 && describe(devices[size_t(chosen)], chosen).software);
  glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &I.max_3d);
  if (epoxy_gl_version() < 45) fail_gl("the context is OpenGL " + I.version + ", 4.5 is needed");
}

// The display is not terminated: EGL hands every caller asking for the same device the same display, so terminating
// it would pull it from under any other context of the process; it lives as long as the process (and the driver
// stays loaded, which also lets LeakSanitizer attribute the driver's own lifetime allocations to it).
GlContext::~GlContext() {
  if (impl_->display != EGL_NO_DISPLAY && impl_->context != EGL_NO_CONTEXT) {
    if (eglGetCurrentContext() == impl_->context)
      eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(impl_->display, impl_->context);
  }
}

void GlContext::make_current() const {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context))
    fail_gl("eglMakeCurrent failed (" + egl_error_name(eglGetError()) + ")");
}

const std::string& GlContext::renderer() const { return impl_->renderer; }
const std::string& GlContext::version() const { return impl_->version; }
const std::string& GlContext::vendor() const { return impl_->vendor; }
bool GlContext::software() const { return impl_->software; }
int GlContext::max_3d_texture_size() const { return impl_->max_3d; }

}  // namespace ugvr
