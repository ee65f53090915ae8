// The shader loader's #include (src/ugvr/gpu/gl_program.h) and the LOD engine's CPU/GPU contract (shaders/lod_shared.h,
// included by C++ and GLSL): errors in an included file name that file, and the driver lays out the per-frame uniform
// block exactly as the C++ struct does. GL tests run wherever EGL gives an OpenGL 4.5 context (llvmpipe in CI).
// (The loader's first tests, log mapping and #line numbering, are GlPrograms.* in test_lod_engine.cpp.)
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "gl_test_support.h"
#include "lod_shared.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/gpu/gl_program.h"

namespace ugvr {
namespace {

struct Gl {
  std::unique_ptr<GlContext> context;
  std::string error;
};

const Gl& gl() {
  static const Gl g = [] {
    Gl r;
    r.context = test::open_gl_context(r.error);
    return r;
  }();
  return g;
}

#define REQUIRE_GL()                                   \
  do {                                                 \
    UGVR_REQUIRE_GL_CONTEXT(gl().context, gl().error); \
    gl().context->make_current();                      \
  } while (0)

// Shader files in a scratch directory that the loader reads instead of shaders/ while the object lives.
class ShaderDir {
 public:
  ShaderDir() { setenv("UGVR_SHADER_DIR", dir_.file("").c_str(), 1); }
  ~ShaderDir() { unsetenv("UGVR_SHADER_DIR"); }
  void write(const std::string& name, const std::string& text) const { std::ofstream(dir_.file(name)) << text; }

 private:
  test::ScratchDir dir_;
};

// The message of the error compiling `name` throws ("" if it compiles).
std::string compile_error(const std::string& name) {
  try {
    ComputeProgram p(name);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

const char* const kMain =
    "#version 450\n"
    "layout(local_size_x = 1) in;\n"
    "#include \"common.h\"\n"
    "void main() { float y = twice(1.0); %s }\n";

std::string main_with(const std::string& statement) {
  std::string s = kMain;
  return s.replace(s.find("%s"), 2, statement);
}

TEST(GlProgramIncludes, ErrorInAnIncludedFileNamesThatFileAndLine) {
  REQUIRE_GL();
  ShaderDir dir;
  dir.write("main.comp", main_with(""));
  dir.write("common.h", "// helpers\nfloat twice(float x) { return 2.0 * undeclared_name; }\n");
  const std::string e = compile_error("main.comp");
  EXPECT_NE(e.find("common.h:2"), std::string::npos) << e;
  EXPECT_EQ(e.find("main.comp:2"), std::string::npos) << e;
}

TEST(GlProgramIncludes, ErrorAfterAnIncludeNamesTheIncludingFileAndLine) {
  REQUIRE_GL();
  ShaderDir dir;
  dir.write("main.comp", main_with("undeclared_name = y;"));
  dir.write("common.h", "// helpers\n// more\n// and more\nfloat twice(float x) { return 2.0 * x; }\n");
  const std::string e = compile_error("main.comp");
  EXPECT_NE(e.find("main.comp:4"), std::string::npos) << e;
  EXPECT_EQ(e.find("common.h:"), std::string::npos) << e;
}

TEST(GlProgramIncludes, NestedIncludesExpandOnceWithTheirOwnSourceNumbers) {
  ShaderDir dir;
  dir.write("main.comp", "#version 450\n#include \"a.h\"  // a comment after it\n#include \"b.h\"\nvoid main() {}\n");
  dir.write("a.h", "#include \"b.h\"\nfloat a() { return b(); }\n");
  dir.write("b.h", "float b() { return 1.0; }\n");
  std::vector<std::string> files;
  const std::string src = preprocess_shader("main.comp", {}, files);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_NE(files[1].find("a.h"), std::string::npos);
  EXPECT_NE(files[2].find("b.h"), std::string::npos);
  // b.h inside a.h (file 2), then back to a.h's line 2 (file 1), then main.comp's line 3 (b.h again: nothing) and 4.
  // File k's line n is numbered k·100000 + n.
  EXPECT_NE(src.find("#line 100001 1\n#line 200001 2\nfloat b()"), std::string::npos) << src;
  EXPECT_NE(src.find("#line 100002 1\nfloat a()"), std::string::npos) << src;
  EXPECT_NE(src.find("#line 3 0\n#line 4 0\nvoid main()"), std::string::npos) << src;
  EXPECT_EQ(src.find("float b()"), src.rfind("float b()")) << src;
}

// Mesa reports source string 0 for errors inside expressions, whatever #line said: the line number tells the file.
TEST(GlProgramIncludes, LogLineNumbersNameTheIncludedFile) {
  const std::vector<std::string> files = {"shaders/a.comp", "shaders/b.h", "shaders/c.h"};
  EXPECT_EQ(map_shader_log("0:100002(37): error: `x' undeclared\n", files),
            "shaders/b.h:2:37: error: `x' undeclared\n");
  EXPECT_EQ(map_shader_log("1:100002(5): error: y\n", files), "shaders/b.h:2:5: error: y\n");
  EXPECT_EQ(map_shader_log("0(200007) : error C1008: z\n", files), "shaders/c.h:7 : error C1008: z\n");
  EXPECT_EQ(map_shader_log("0:300001(1): error: w\n", files), "source 3:1:1: error: w\n");
}

TEST(GlProgramIncludes, MissingIncludeOrCycleNamesTheIncludingLine) {
  ShaderDir dir;
  dir.write("main.comp", "#version 450\n// one\n#include \"absent.h\"\n");
  dir.write("cycle.comp", "#version 450\n#include \"x.h\"\n");
  dir.write("x.h", "// x\n#include \"y.h\"\n");
  dir.write("y.h", "#include \"x.h\"\n");
  std::vector<std::string> files;
  try {
    preprocess_shader("main.comp", {}, files);
    ADD_FAILURE() << "no error for a missing include";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("main.comp:3: cannot open the included shader file"), std::string::npos)
        << e.what();
  }
  try {
    preprocess_shader("cycle.comp", {}, files);
    ADD_FAILURE() << "no error for an include cycle";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("y.h:1: include cycle"), std::string::npos) << e.what();
  }
}

// The real ray caster, with the shared header as its source string 1 (the engine's compile errors name it) and the
// slices' contour lines (shared with the exact engine) as 2, the cell walk it shares with the exact engine (HYBRID
// variants) as string 3, the exact engine's optical table as 4.
TEST(LodGpuContract, RayCasterIncludesTheSharedHeader) {
  std::vector<std::string> files;
  const std::string src = preprocess_shader("lod_raycast.comp", {{"MODE", "2"}}, files);
  ASSERT_EQ(files.size(), 6u);  // and optical.glsl, which the cells integrate with
  EXPECT_NE(files[1].find("lod_shared.h"), std::string::npos) << files[1];
  EXPECT_NE(files[2].find("loop_limit_probe.glsl"), std::string::npos) << files[2];
  EXPECT_NE(files[3].find("slice_contours.glsl"), std::string::npos) << files[3];
  EXPECT_NE(files[4].find("cell_walk.glsl"), std::string::npos) << files[4];
  EXPECT_NE(files[5].find("optical.glsl"), std::string::npos) << files[5];
  EXPECT_NE(src.find("uniform LodFrame {"), std::string::npos);
}

struct Member {
  const char* name;  // as the driver lists it
  size_t offset;     // in the C++ struct
};

#define UGVR_MEMBER(m) \
  Member { #m, offsetof(lod_gpu::LodFrame, m) }

// Every member where the C++ struct has it, by the driver's own account of the std140 block, in every shader variant
// (a member a variant leaves unused stays in the layout: std140).
TEST(LodGpuContract, DriverLaysOutTheFrameBlockAsTheCppStruct) {
  REQUIRE_GL();
  const std::vector<Member> members = {UGVR_MEMBER(u_eye),
                                       UGVR_MEMBER(u_step0),
                                       UGVR_MEMBER(u_forward),
                                       UGVR_MEMBER(u_nudge),
                                       UGVR_MEMBER(u_right),
                                       UGVR_MEMBER(u_unit_distance),
                                       UGVR_MEMBER(u_up),
                                       UGVR_MEMBER(u_iso_opacity),
                                       UGVR_MEMBER(u_root_size),
                                       UGVR_MEMBER(u_min_transmittance),
                                       UGVR_MEMBER(u_atlas_inv),
                                       UGVR_MEMBER(u_overlay_opacity),
                                       UGVR_MEMBER(u_slots),
                                       UGVR_MEMBER(u_resolution),
                                       UGVR_MEMBER(u_clip_plane),
                                       UGVR_MEMBER(u_size),
                                       UGVR_MEMBER(u_half),
                                       UGVR_MEMBER(u_tf_map),
                                       UGVR_MEMBER(u_iso_count),
                                       UGVR_MEMBER(u_parallel),
                                       UGVR_MEMBER(u_fixed_step),
                                       UGVR_MEMBER(u_lighting),
                                       UGVR_MEMBER(u_clip),
                                       UGVR_MEMBER(u_loop_probe),
                                       Member{"u_iso[0]", offsetof(lod_gpu::LodFrame, u_iso)},
                                       Member{"u_slice_plane[0]", offsetof(lod_gpu::LodFrame, u_slice_plane)},
                                       Member{"u_slice_map[0]", offsetof(lod_gpu::LodFrame, u_slice_map)},
                                       UGVR_MEMBER(u_slice_count),
                                       UGVR_MEMBER(u_hide_volume),
                                       UGVR_MEMBER(u_cell_tolerance),
                                       UGVR_MEMBER(u_cell_data),
                                       UGVR_MEMBER(u_box_lo),
                                       UGVR_MEMBER(u_box_hi),
                                       UGVR_MEMBER(u_context),
                                       Member{"u_focus[0]", offsetof(lod_gpu::LodFrame, u_focus)},
                                       UGVR_MEMBER(u_focus_map)};
  const std::vector<std::vector<std::pair<std::string, std::string>>> variants = {
      {{"MODE", "0"}, {"VOLUME_LIGHTING", "0"}, {"OVERLAY", "0"}},
      {{"MODE", "0"}, {"VOLUME_LIGHTING", "1"}, {"OVERLAY", "1"}},
      {{"MODE", "1"}, {"VOLUME_LIGHTING", "0"}, {"OVERLAY", "0"}},
      {{"MODE", "2"}, {"VOLUME_LIGHTING", "0"}, {"OVERLAY", "1"}},
      {{"MODE", "0"}, {"VOLUME_LIGHTING", "0"}, {"OVERLAY", "1"}, {"SLICES", "1"}},
      {{"MODE", "1"}, {"VOLUME_LIGHTING", "0"}, {"OVERLAY", "0"}, {"SLICES", "1"}},
      {{"MODE", "0"}, {"VOLUME_LIGHTING", "0"}, {"OVERLAY", "0"}, {"FOCUS_WINDOWS", "2"}}};
  for (const auto& defines : variants) {
    SCOPED_TRACE("MODE " + defines[0].second + " OVERLAY " + defines[2].second);
    const ComputeProgram p("lod_raycast.comp", defines);
    EXPECT_EQ(p.uniform_block_size("LodFrame"), GLint(sizeof(lod_gpu::LodFrame)));
    const GLuint block = glGetProgramResourceIndex(p.id(), GL_UNIFORM_BLOCK, "LodFrame");
    ASSERT_NE(block, GL_INVALID_INDEX);
    const GLenum binding_property = GL_BUFFER_BINDING;
    GLint binding = -1;
    glGetProgramResourceiv(p.id(), GL_UNIFORM_BLOCK, block, 1, &binding_property, 1, nullptr, &binding);
    EXPECT_EQ(binding, lod_gpu::FRAME_BLOCK_BINDING);
    GLint local[3] = {0, 0, 0};
    glGetProgramiv(p.id(), GL_COMPUTE_WORK_GROUP_SIZE, local);
    EXPECT_EQ(local[0], lod_gpu::WORKGROUP_SIZE);
    EXPECT_EQ(local[1], lod_gpu::WORKGROUP_SIZE);
    for (const Member& m : members) {
      const GLuint index = glGetProgramResourceIndex(p.id(), GL_UNIFORM, m.name);
      ASSERT_NE(index, GL_INVALID_INDEX) << m.name;
      const GLenum properties[3] = {GL_OFFSET, GL_BLOCK_INDEX, GL_ARRAY_STRIDE};
      GLint values[3] = {-1, -1, -1};
      glGetProgramResourceiv(p.id(), GL_UNIFORM, index, 3, properties, 3, nullptr, values);
      EXPECT_EQ(values[0], GLint(m.offset)) << m.name;
      EXPECT_EQ(values[1], GLint(block)) << m.name;
      if (std::string(m.name).ends_with("[0]")) {  // the vec4 arrays: u_iso, u_slice_plane, u_slice_map, u_focus
        EXPECT_EQ(values[2], GLint(sizeof(lod_gpu::vec4)));
      }
    }
  }
}

}  // namespace
}  // namespace ugvr
