#include "ugvr/gpu/gl_program.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "ugvr/core/error.h"

#ifndef UGVR_SHADER_DIR
#define UGVR_SHADER_DIR "shaders"
#endif

namespace ugvr {

std::string shader_directory() {
  const char* env = std::getenv("UGVR_SHADER_DIR");
  return env && *env ? env : UGVR_SHADER_DIR;
}

namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail_in(path, "cannot open shader (set UGVR_SHADER_DIR to the repository's shaders/ directory)");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `#include "name"` (spaces allowed around '#' and the name, a // comment after it): sets name.
bool include_target(const std::string& line, std::string& name) {
  size_t i = line.find_first_not_of(" \t");
  if (i == std::string::npos || line[i] != '#') return false;
  i = line.find_first_not_of(" \t", i + 1);
  if (i == std::string::npos || line.compare(i, 7, "include") != 0) return false;
  const size_t open = line.find('"', i + 7), close = open == std::string::npos ? open : line.find('"', open + 1);
  if (close == std::string::npos) return false;
  name = line.substr(open + 1, close - open - 1);
  const size_t rest = line.find_first_not_of(" \t\r", close + 1);
  return !name.empty() && (rest == std::string::npos || line.compare(rest, 2, "//") == 0);
}

// File k's line n is line k·kLinesPerFile + n of the expanded source, besides being line n of source string k: Mesa
// reports source string 0 for most errors whatever #line said (its parser's YYLLOC_DEFAULT resets the source number
// for every rule spanning several tokens, i.e. expressions), so the line number alone must say which file it is.
constexpr uint64_t kLinesPerFile = 100000;

std::string line_directive(int file, int line) {
  return "#line " + std::to_string(uint64_t(file) * kLinesPerFile + uint64_t(line)) + " " + std::to_string(file) + "\n";
}

// Digits at `i`; advances i past them.
bool read_digits(const std::string& s, size_t& i, std::string& out) {
  const size_t start = i;
  while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
  out = s.substr(start, i - start);
  return i > start && i - start < 9;
}

// Line `line_no` of `path` includes `name`: an error there names that line (a missing file, a cycle).
void check_include(const std::string& path, int line_no, const std::string& dir, const std::string& name,
                   const std::vector<std::string>& stack) {
  for (const std::string& open : stack)
    if (open == name) fail_at_line(path, uint64_t(line_no), "include cycle through \"" + name + "\"");
  if (!std::ifstream(dir + "/" + name))
    fail_at_line(path, uint64_t(line_no), "cannot open the included shader file " + dir + "/" + name);
}

void expand(const std::string& dir, const std::string& name, std::vector<std::string>& files,
            std::vector<std::string>& stack, std::string& out) {
  for (size_t i = 0; i < files.size(); ++i)
    if (files[i] == dir + "/" + name && !stack.empty()) return;  // included once
  const std::string path = dir + "/" + name;
  const std::string text = read_text(path);
  const int number = int(files.size());
  files.push_back(path);
  if (!stack.empty()) out += line_directive(number, 1);
  stack.push_back(name);
  std::istringstream lines(text);
  std::string line;
  int line_no = 0;
  while (std::getline(lines, line)) {
    if (++line_no >= int(kLinesPerFile))
      fail_in(path, "more than 99999 lines (the loader numbers each file's lines apart)");
    std::string included;
    if (include_target(line, included)) {
      check_include(path, line_no, dir, included, stack);
      expand(dir, included, files, stack, out);
      out += line_directive(number, line_no + 1);
    } else {
      out += line;
      out += '\n';
    }
  }
  stack.pop_back();
}

}  // namespace

std::string preprocess_shader(const std::string& name, const std::vector<std::pair<std::string, std::string>>& defines,
                              std::vector<std::string>& files) {
  const std::string dir = shader_directory();
  files.clear();
  std::string body;
  std::vector<std::string> stack;
  expand(dir, name, files, stack, body);
  // The #version line must come first; defines go right after it, then a #line resets the numbering.
  const size_t version_end = body.find('\n');
  if (body.compare(0, 8, "#version") != 0 || version_end == std::string::npos)
    fail_at_line(files[0], 1, "a shader must start with #version");
  std::string out = body.substr(0, version_end + 1);
  for (const auto& [k, v] : defines) out += "#define " + k + " " + v + "\n";
  out += line_directive(0, 2);
  out += body.substr(version_end + 1);
  return out;
}

std::string map_shader_log(const std::string& log, const std::vector<std::string>& files) {
  // Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error ...".
  std::istringstream in(log);
  std::string line, out;
  while (std::getline(in, line)) {
    size_t i = 0;
    std::string source, row, column;
    // "file:line" of a source string and line number; a line number past kLinesPerFile names the file itself.
    auto file_of = [&](const std::string& n, const std::string& r) {
      uint64_t k = std::stoul(n), l = std::stoul(r);
      if (l >= kLinesPerFile) k = l / kLinesPerFile, l %= kLinesPerFile;
      return (k < files.size() ? files[k] : "source " + std::to_string(k)) + ":" + std::to_string(l);
    };
    if (read_digits(line, i, source) && i < line.size()) {
      if (line[i] == ':' && read_digits(line, ++i, row) && i < line.size() && line[i] == '(' &&
          read_digits(line, ++i, column) && i < line.size() && line[i] == ')')
        line = file_of(source, row) + ":" + column + line.substr(i + 1);
      else if (i = source.size(); line[i] == '(' && read_digits(line, ++i, row) && i < line.size() && line[i] == ')')
        line = file_of(source, row) + line.substr(i + 1);
    }
    out += line + "\n";
  }
  return out;
}

ComputeProgram::ComputeProgram(const std::string& name, const std::vector<std::pair<std::string, std::string>>& defines)
    : name_(name) {
  std::vector<std::string> files;
  const std::string source = preprocess_shader(name, defines, files);
  const GLuint shader = glCreateShader(GL_COMPUTE_SHADER);
  const char* text = source.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  auto log_of = [](GLuint object, bool program) {
    GLint n = 0;
    program ? glGetProgramiv(object, GL_INFO_LOG_LENGTH, &n) : glGetShaderiv(object, GL_INFO_LOG_LENGTH, &n);
    std::string log(size_t(std::max(n, 1)), '\0');
    program ? glGetProgramInfoLog(object, n, nullptr, log.data()) : glGetShaderInfoLog(object, n, nullptr, log.data());
    log.resize(std::strlen(log.c_str()));
    return log;
  };
  if (!ok) {
    const std::string log = map_shader_log(log_of(shader, false), files);
    glDeleteShader(shader);
    fail_in(files[0], "compile error:\n" + log);
  }
  id_ = glCreateProgram();
  glAttachShader(id_, shader);
  glLinkProgram(id_);
  glDeleteShader(shader);
  glGetProgramiv(id_, GL_LINK_STATUS, &ok);
  if (!ok) {
    const std::string log = map_shader_log(log_of(id_, true), files);
    glDeleteProgram(id_);
    id_ = 0;
    fail_in(files[0], "link error:\n" + log);
  }
}

GLint ComputeProgram::uniform_block_size(const char* block) const {
  const GLuint index = glGetProgramResourceIndex(id_, GL_UNIFORM_BLOCK, block);
  if (index == GL_INVALID_INDEX) return -1;
  const GLenum property = GL_BUFFER_DATA_SIZE;
  GLint size = -1;
  glGetProgramResourceiv(id_, GL_UNIFORM_BLOCK, index, 1, &property, 1, nullptr, &size);
  return size;
}

ComputeProgram::~ComputeProgram() {
  if (id_) glDeleteProgram(id_);
}

ComputeProgram& ComputeProgram::operator=(ComputeProgram&& o) noexcept {
  if (id_) glDeleteProgram(id_);
  id_ = std::exchange(o.id_, 0);
  name_ = std::move(o.name_);
  return *this;
}

void GlBuffer::upload(const void* data, size_t bytes) {
  if (!id_ || bytes > size_) {
    reset();
    glCreateBuffers(1, &id_);
    size_ = std::max<size_t>(bytes, 16);
    glNamedBufferStorage(id_, GLsizeiptr(size_), nullptr, GL_DYNAMIC_STORAGE_BIT);
    check_gl("allocating a buffer");
  }
  if (bytes) glNamedBufferSubData(id_, 0, GLsizeiptr(bytes), data);
}

void GlBuffer::reserve_readback(size_t bytes) {
  if (id_ && bytes <= size_) return;
  reset();
  glCreateBuffers(1, &id_);
  size_ = std::max<size_t>(bytes, 16);
  glNamedBufferStorage(id_, GLsizeiptr(size_), nullptr, GL_MAP_READ_BIT | GL_CLIENT_STORAGE_BIT);
  check_gl("allocating a readback buffer");
}

void GlBuffer::reset() {
  if (id_) glDeleteBuffers(1, &id_);
  id_ = 0;
  size_ = 0;
}

void check_gl(const char* what) {
  const GLenum e = glGetError();
  if (e == GL_NO_ERROR) return;
  while (glGetError() != GL_NO_ERROR) {
  }
  const char* name = e == GL_OUT_OF_MEMORY       ? "out of GPU memory"
                     : e == GL_INVALID_VALUE     ? "GL_INVALID_VALUE"
                     : e == GL_INVALID_OPERATION ? "GL_INVALID_OPERATION"
                     : e == GL_INVALID_ENUM      ? "GL_INVALID_ENUM"
                                                 : "GL error";
  fail_in("OpenGL", std::string(what) + ": " + name);
}

}  // namespace ugvr
