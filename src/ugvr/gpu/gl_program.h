// GLSL compute programs read from the repository's shaders/ directory at start-up, so a shader edit needs no rebuild
// and a compile error points at the file and line a person can open.
//
// Sources may `#include "name.glsl"` (relative to the shader directory, once per file and program). Each file gets
// its own GLSL source-string number and its own range of line numbers through `#line N S` directives (file k's line n
// is line k·100000 + n: Mesa reports source string 0 for most errors), and the driver's log ("0:12(5): error ..."
// from Mesa, "0(12) : error ..." from NVIDIA) is rewritten to "shaders/file.comp:12: error ..." before it is thrown.
// `defines` are inserted after the #version line as "#define NAME VALUE".
#pragma once

#include <epoxy/gl.h>

#include <string>
#include <utility>
#include <vector>

namespace ugvr {

// UGVR_SHADER_DIR from the environment, else the shaders/ directory of the source tree this binary was built from.
std::string shader_directory();

// Expands includes and adds #line directives; `files` receives the file of each source-string number. Throws
// ugvr::Error for a missing file or an include cycle, naming the line that includes it.
std::string preprocess_shader(const std::string& name, const std::vector<std::pair<std::string, std::string>>& defines,
                              std::vector<std::string>& files);
// Rewrites source-string numbers in a driver log to file names.
std::string map_shader_log(const std::string& log, const std::vector<std::string>& files);

class ComputeProgram {
 public:
  ComputeProgram() = default;
  // Compiles and links shaders/<name>; throws ugvr::Error with the mapped log on failure.
  explicit ComputeProgram(const std::string& name,
                          const std::vector<std::pair<std::string, std::string>>& defines = {});
  ~ComputeProgram();
  ComputeProgram(ComputeProgram&& o) noexcept : id_(std::exchange(o.id_, 0)), name_(std::move(o.name_)) {}
  ComputeProgram& operator=(ComputeProgram&& o) noexcept;

  GLuint id() const { return id_; }
  const std::string& name() const { return name_; }
  // Size in bytes of a uniform block as the driver lays it out; -1 where the program has no active block of that name.
  GLint uniform_block_size(const char* block) const;

 private:
  GLuint id_ = 0;
  std::string name_;
};

// Owning handles for GL buffers and textures (the context must be current when they are destroyed).
class GlBuffer {
 public:
  GlBuffer() = default;
  ~GlBuffer() { reset(); }
  GlBuffer(GlBuffer&& o) noexcept : id_(std::exchange(o.id_, 0)), size_(std::exchange(o.size_, 0)) {}
  GlBuffer& operator=(GlBuffer&& o) noexcept {
    reset();
    id_ = std::exchange(o.id_, 0), size_ = std::exchange(o.size_, 0);
    return *this;
  }
  // (Re)allocates when `bytes` exceeds the current size, then uploads.
  void upload(const void* data, size_t bytes);
  // (Re)allocates, when `bytes` exceeds the current size, a buffer the CPU maps for reading (a pixel-pack target:
  // the driver fills it by DMA, where a read into client memory goes through a slow staging copy).
  void reserve_readback(size_t bytes);
  GLuint id() const { return id_; }
  void reset();

 private:
  GLuint id_ = 0;
  size_t size_ = 0;
};

// A GL_TIME_ELAPSED query: the GPU's own time for the commands between begin() and end(), without the CPU's
// submission and synchronisation overheads (ARB_timer_query, core since OpenGL 3.3; llvmpipe implements it too).
class GlTimerQuery {
 public:
  GlTimerQuery() { glCreateQueries(GL_TIME_ELAPSED, 1, &id_); }
  ~GlTimerQuery() {
    if (id_) glDeleteQueries(1, &id_);
  }
  GlTimerQuery(const GlTimerQuery&) = delete;
  GlTimerQuery& operator=(const GlTimerQuery&) = delete;
  void begin() { glBeginQuery(GL_TIME_ELAPSED, id_); }
  void end() { glEndQuery(GL_TIME_ELAPSED); }
  // Waits for the result.
  double seconds() const {
    GLuint64 ns = 0;
    glGetQueryObjectui64v(id_, GL_QUERY_RESULT, &ns);
    return double(ns) * 1e-9;
  }

 private:
  GLuint id_ = 0;
};

class GlTexture {
 public:
  GlTexture() = default;
  explicit GlTexture(GLenum target) { glCreateTextures(target, 1, &id_); }
  ~GlTexture() { reset(); }
  GlTexture(GlTexture&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  GlTexture& operator=(GlTexture&& o) noexcept {
    reset();
    id_ = std::exchange(o.id_, 0);
    return *this;
  }
  GLuint id() const { return id_; }
  void reset() {
    if (id_) glDeleteTextures(1, &id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

// Throws ugvr::Error naming `what` if GL reports an error (GL_OUT_OF_MEMORY above all).
void check_gl(const char* what);

}  // namespace ugvr
