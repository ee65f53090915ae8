#include "ugvr/render/exact/exact_gpu_engine.h"

#include <epoxy/gl.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <tuple>

#include "exact_shared.h"  // shaders/exact_shared.h: what the engine and shaders/exact_walk.comp agree on
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/gpu/gl_program.h"
#include "ugvr/render/banded_dispatch.h"
#include "ugvr/render/exact/boundary_bins.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/gpu_readback.h"
#include "ugvr/render/optical_table.h"
#include "ugvr/render/renderer.h"

namespace ugvr {
namespace {

constexpr int kTileSize = 16;                      // the CPU engine's tiles: the same bins serve both
constexpr GLenum kGpuMemoryAvailableNvx = 0x9049;  // GL_GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX, KiB

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

exact_gpu::dvec4 d4(Vec3d v, double w) { return {v.x, v.y, v.z, w}; }

// Device memory free for us: NVIDIA reports it (GL_NVX_gpu_memory_info); elsewhere (llvmpipe: system memory) 0 =
// unknown.
uint64_t available_device_bytes() {
  if (!epoxy_has_gl_extension("GL_NVX_gpu_memory_info")) return 0;
  GLint kib = 0;
  glGetIntegerv(kGpuMemoryAvailableNvx, &kib);
  glGetError();
  return uint64_t(std::max(kib, 0)) * 1024;
}

void check_contract(const ComputeProgram& program) {
  const GLint block = program.uniform_block_size("ExactFrame");
  GLint local[3] = {0, 0, 0};
  glGetProgramiv(program.id(), GL_COMPUTE_WORK_GROUP_SIZE, local);
  if (block != GLint(sizeof(exact_gpu::ExactFrame)) || local[0] != exact_gpu::EXACT_WORKGROUP_SIZE)
    fail_in(shader_directory() + "/exact_shared.h",
            "the shader sees a uniform block of " + std::to_string(block) + " bytes, this program was built for " +
                std::to_string(sizeof(exact_gpu::ExactFrame)) + " (rebuild after editing the file)");
}

}  // namespace

uint64_t exact_gpu_bytes_needed(const WalkMesh& mesh, bool per_cell_field) {
  const uint64_t field = per_cell_field ? uint64_t(mesh.cell_count()) : uint64_t(mesh.points.size());
  return mesh.connectivity.size() * 4 + mesh.neighbors.size() * 4 + mesh.quad_split.size() + mesh.points.size() * 12 +
         field * 4 + mesh.boundary.size() * (8 + 8 + 8);  // boundary, boxes, tile lists (about 2 tiles each)
}

struct ExactGpuEngine::Impl {
  const WalkMesh& mesh;
  std::shared_ptr<const GlContext> gl;
  ExactGpuOptions options;
  std::function<bool()> keep_going;  // set_keep_going
  int chunk_shift = 30;
  std::vector<GlBuffer> conn, nbr;
  GlBuffer points, quad_split, values, boundary, boxes, tiles, counters, optical, frame_block, readback;
  GlTexture tf_texture, out_texture;
  GlTexture slice_texture;  // the slices' colour tables (EXACT_SLICE_TEXTURE_BINDING), created on first use
  int out_w = 0, out_h = 0;
  bool per_cell = false, have_values = false;
  // The bound field on the host too: rays llvmpipe's loop limit cut short are traced on the CPU (trace_exact_pixels).
  std::vector<float> host_values;
  std::vector<uint32_t> cut_pixels;
  uint64_t mesh_bytes = 0, frame_bytes = 0, values_bytes = 0, tf_bytes = 0;
  std::optional<TransferFunction> uploaded_tf;                    // what the optical table and the TF texture hold
  std::map<std::tuple<int, bool, int>, ComputeProgram> programs;  // by (mode, volume lighting, slices)
  std::unique_ptr<GlTimerQuery> timer;
  double bin_seconds = 0, gpu_seconds = 0;

  Impl(const WalkMesh& m, std::shared_ptr<const GlContext> g, ExactGpuOptions o)
      : mesh(m), gl(std::move(g)), options(o) {}

  // slices: 0 none, 1 slices, 2 slices with contour lines (SLICE_CONTOURS: llvmpipe compiles their gradient code for
  // a minute or more, which frames without lines need not wait for).
  ComputeProgram& program_for(int mode, bool volume_lighting, int slices = 0) {
    auto it = programs.find({mode, volume_lighting, slices});
    if (it == programs.end()) {
      const bool tets_only = mesh.type_begin[1] == mesh.cell_count();
      ComputeProgram p("exact_walk.comp", {{"MODE", std::to_string(mode)},
                                           {"EXACT_DOUBLE", options.double_precision ? "1" : "0"},
                                           {"TETS_ONLY", tets_only ? "1" : "0"},
                                           {"VOLUME_LIGHTING", volume_lighting ? "1" : "0"},
                                           {"SLICES", slices ? "1" : "0"},
                                           {"SLICE_CONTOURS", slices == 2 ? "1" : "0"}});
      check_contract(p);
      it = programs.emplace(std::make_tuple(mode, volume_lighting, slices), std::move(p)).first;
    }
    return it->second;
  }

  // Splits `data` over buffers of 2^chunk_shift elements.
  void upload_chunks(const std::vector<uint32_t>& data, std::vector<GlBuffer>& out) {
    const uint64_t chunk = uint64_t(1) << chunk_shift;
    const uint64_t n = std::max<uint64_t>(1, (data.size() + chunk - 1) / chunk);
    out.clear();
    out.resize(size_t(n));
    for (uint64_t c = 0; c < n; ++c) {
      const uint64_t begin = c * chunk, count = std::min<uint64_t>(chunk, data.size() - std::min(begin, data.size()));
      out[c].upload(count ? data.data() + begin : nullptr, count * 4);
    }
  }
};

ExactGpuEngine::ExactGpuEngine(const WalkMesh& mesh, std::shared_ptr<const GlContext> gl, ExactGpuOptions options)
    : impl_(std::make_unique<Impl>(mesh, std::move(gl), options)) {
  Impl& I = *impl_;
  I.gl->make_current();
  GLint64 max_block = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_block);
  uint64_t limit = uint64_t(std::max<GLint64>(max_block, 1 << 20));
  if (options.max_buffer_bytes) limit = std::min(limit, options.max_buffer_bytes);
  I.chunk_shift = 2;
  while (I.chunk_shift < 30 && (uint64_t(4) << (I.chunk_shift + 1)) <= limit) ++I.chunk_shift;
  const uint64_t chunk = uint64_t(1) << I.chunk_shift;
  const uint64_t largest = std::max(mesh.connectivity.size(), mesh.neighbors.size());
  const uint64_t needed = exact_gpu_bytes_needed(mesh, false);
  const std::string advice =
      " — for meshes larger than the GPU, build a brick store (`ugvr build MESH -o X.ugvr`) and "
      "render it with the level-of-detail engine, or use `--device cpu`";
  if ((largest + chunk - 1) / chunk > uint64_t(exact_gpu::EXACT_CHUNKS) || mesh.points.size() * 12 > limit ||
      mesh.connectivity.size() >= (uint64_t(1) << 32) || mesh.neighbors.size() >= (uint64_t(1) << 32))
    fail_in("exact engine (GPU)", "the mesh needs storage buffers of " + format_bytes(largest * 4) +
                                      " but the GPU allows " + format_bytes(limit) + " per buffer" + advice);
  if (const uint64_t available = available_device_bytes(); available && needed > available * 9 / 10)
    fail_in("exact engine (GPU)", "the mesh needs " + format_bytes(needed) + " of GPU memory, " +
                                      format_bytes(available) + " are free on " + I.gl->renderer() + advice);

  I.program_for(EXACT_MODE_EA, false);  // compile errors surface here, not at the first frame
  I.upload_chunks(mesh.connectivity, I.conn);
  I.upload_chunks(mesh.neighbors, I.nbr);
  I.points.upload(mesh.points.data(), mesh.points.size() * sizeof(Vec3f));
  std::vector<uint8_t> split(mesh.quad_split);
  split.resize((split.size() + 3) / 4 * 4);
  I.quad_split.upload(split.data(), split.size());
  std::vector<uint32_t> tris(mesh.boundary.size() * 2);
  for (size_t i = 0; i < mesh.boundary.size(); ++i) {
    const BoundaryTriangle& b = mesh.boundary[i];
    tris[2 * i] = b.cell << 3 | b.local_face;
    tris[2 * i + 1] = uint32_t(b.corners[0]) | uint32_t(b.corners[1]) << 2 | uint32_t(b.corners[2]) << 4;
  }
  I.boundary.upload(tris.data(), tris.size() * 4);
  I.tf_texture = GlTexture(GL_TEXTURE_1D);
  glTextureStorage1D(I.tf_texture.id(), 1, GL_RGBA32F, exact_gpu::EXACT_TF_TEXELS);
  glTextureParameteri(I.tf_texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(I.tf_texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(I.tf_texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glFinish();
  check_gl("uploading the mesh for the GPU exact engine");
  I.mesh_bytes = mesh.connectivity.size() * 4 + mesh.neighbors.size() * 4 + split.size() +
                 mesh.points.size() * sizeof(Vec3f) + tris.size() * 4;
}

ExactGpuEngine::~ExactGpuEngine() {
  if (impl_) impl_->gl->make_current();  // GL objects are deleted with the context current
}

void ExactGpuEngine::set_values(const std::vector<float>& values, bool per_cell) {
  Impl& I = *impl_;
  I.gl->make_current();
  I.values.upload(values.data(), values.size() * sizeof(float));
  check_gl("uploading the field");
  I.values_bytes = values.size() * sizeof(float);
  I.host_values = values;
  I.per_cell = per_cell;
  I.have_values = true;
}

const GlContext& ExactGpuEngine::gl() const { return *impl_->gl; }
void ExactGpuEngine::set_keep_going(std::function<bool()> keep_going) { impl_->keep_going = std::move(keep_going); }
uint64_t ExactGpuEngine::mesh_device_bytes() const { return impl_->mesh_bytes + impl_->values_bytes; }
uint64_t ExactGpuEngine::device_bytes() const { return mesh_device_bytes() + impl_->frame_bytes; }
double ExactGpuEngine::last_bin_seconds() const { return impl_->bin_seconds; }
double ExactGpuEngine::last_gpu_seconds() const { return impl_->gpu_seconds; }

Image ExactGpuEngine::render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                             double tolerance_abs, ExactRenderStats* stats) {
  Impl& I = *impl_;
  if (!I.have_values) fail_in("exact engine (GPU)", "no field bound");
  settings.validate("render settings");
  tf.validate("transfer function");
  if (settings.iso_values.size() > size_t(exact_gpu::EXACT_MAX_ISO))
    fail_in("exact engine (GPU)", "at most " + std::to_string(exact_gpu::EXACT_MAX_ISO) + " isovalues");
  const auto t0 = std::chrono::steady_clock::now();
  I.gl->make_current();
  const int w = settings.width, h = settings.height;
  if (w > 65535 || h > 65535) fail_in("exact engine (GPU)", "images up to 65535 pixels a side");

  // Where rays enter: the boundary binned per tile on the CPU (the same bins as the CPU engine).
  const auto tb = std::chrono::steady_clock::now();
  const BoundaryBins bins(I.mesh, camera, w, h, kTileSize);
  const size_t n_tri = I.mesh.boundary.size();
  std::vector<uint32_t> boxes(std::max<size_t>(n_tri, 1) * 2);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n_tri, 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const PixelBox& b = bins.box(uint32_t(i));
      if (b.x0 > b.x1 || b.y0 > b.y1) {
        boxes[2 * i] = 1, boxes[2 * i + 1] = 1;  // x0 = 1 > x1 = 0: empty
        continue;
      }
      boxes[2 * i] = uint32_t(b.x0) | uint32_t(b.x1) << 16;
      boxes[2 * i + 1] = uint32_t(b.y0) | uint32_t(b.y1) << 16;
    }
  });
  // One buffer: the tiles' start offsets, then their triangle lists (exact_shared.h).
  const int tiles = bins.tiles_x() * bins.tiles_y();
  std::vector<uint32_t> list(size_t(tiles) + 1);
  {
    uint64_t total = list.size();
    for (int t = 0; t < tiles; ++t) total += bins.tile_triangles(t).size();
    if (total >= (uint64_t(1) << 32)) fail_in("exact engine (GPU)", "too many boundary triangles per tile");
    list.reserve(size_t(total));
    for (int t = 0; t < tiles; ++t) {
      list[size_t(t)] = uint32_t(list.size());
      const auto span = bins.tile_triangles(t);
      list.insert(list.end(), span.begin(), span.end());
    }
    list[size_t(tiles)] = uint32_t(list.size());
  }
  I.bin_seconds = seconds_since(tb);
  I.boxes.upload(boxes.data(), boxes.size() * 4);
  I.tiles.upload(list.data(), list.size() * 4);

  // The optical table (emission-absorption) and the transfer function's colour and opacity (isosurfaces, MIP): made
  // again only when the transfer function changes, not every frame of a camera move.
  const int texels = exact_gpu::EXACT_TF_TEXELS;
  const double lo = tf.range_min(), hi = tf.range_max();
  if (!I.uploaded_tf || !(*I.uploaded_tf == tf)) {
    const std::vector<float> packed = OpticalTable(tf).pack_for_gpu();
    I.optical.upload(packed.data(), packed.size() * sizeof(float));
    std::vector<float> tf_table(size_t(texels) * 4);
    for (int i = 0; i < texels; ++i) {
      const double s = lo + (hi - lo) * double(i) / double(texels - 1);
      const Vec3d c = tf.color(s);
      tf_table[size_t(i) * 4 + 0] = float(c.x), tf_table[size_t(i) * 4 + 1] = float(c.y);
      tf_table[size_t(i) * 4 + 2] = float(c.z), tf_table[size_t(i) * 4 + 3] = float(tf.opacity(s));
    }
    glTextureSubImage1D(I.tf_texture.id(), 0, 0, texels, GL_RGBA, GL_FLOAT, tf_table.data());
    I.tf_bytes = (packed.size() + tf_table.size()) * sizeof(float);
    I.uploaded_tf = tf;
  }

  if (w != I.out_w || h != I.out_h) {
    I.out_texture = GlTexture(GL_TEXTURE_2D);
    glTextureStorage2D(I.out_texture.id(), 1, GL_RGBA32F, w, h);
    check_gl("allocating the image");
    I.out_w = w, I.out_h = h;
  }

  // The frame's parameters.
  exact_gpu::ExactFrame f{};
  const CameraRays rays(camera, w, h);
  f.u_eye = d4(camera.position, camera.parallel_projection ? 1.0 : 0.0);
  f.u_forward = d4(rays.forward(), rays.half_width());
  f.u_right = d4(rays.right(), rays.half_height());
  f.u_up = d4(rays.up(), 1e-7 * length(I.mesh.bounds.size()));
  if (settings.clip_plane)
    f.u_clip = d4(settings.clip_plane->normal, dot(settings.clip_plane->normal, settings.clip_plane->point));
  f.u_tolerance = {tolerance_abs, 0, 0, 0};
  const auto& tb4 = I.mesh.type_begin;
  f.u_type_begin = {tb4[0], tb4[1], tb4[2], tb4[3]};
  f.u_conn_begin = {uint32_t(I.mesh.conn_begin[0]), uint32_t(I.mesh.conn_begin[1]), uint32_t(I.mesh.conn_begin[2]),
                    uint32_t(I.mesh.conn_begin[3])};
  f.u_face_begin = {uint32_t(I.mesh.face_begin[0]), uint32_t(I.mesh.face_begin[1]), uint32_t(I.mesh.face_begin[2]),
                    uint32_t(I.mesh.face_begin[3])};
  f.u_size = {w, h, bins.tiles_x(), kTileSize};
  f.u_flags = {I.per_cell ? 1 : 0, settings.clip_plane ? 1 : 0, settings.lighting ? 1 : 0,
               settings.volume_lighting ? 1 : 0};
  std::vector<double> iso = settings.iso_values;
  std::sort(iso.begin(), iso.end());
  f.u_counts = {int(I.mesh.cell_count()), int(iso.size()), I.chunk_shift, 2};  // .w: loop_limit_reached's count
  f.u_params = {settings.mode == RenderMode::Mip ? 0.0f : float(settings.boundary_overlay_opacity),
                float(settings.iso_opacity), float(1 - settings.early_termination_opacity), 0};
  f.u_tf_map = {hi > lo ? float(1 / (hi - lo)) : 0.0f, hi > lo ? float(-lo / (hi - lo)) : 0.0f, 0, 0};
  float iso_f[exact_gpu::EXACT_MAX_ISO] = {};
  for (size_t i = 0; i < iso.size(); ++i) iso_f[i] = float(iso[i]);
  std::memcpy(f.u_iso, iso_f, sizeof iso_f);
  // Slices: unit normals (the CPU engine's planes, so that both find the same crossings), a colour table each over
  // its range (the volume's transfer function or a built-in preset).
  static_assert(EXACT_MAX_SLICES == kMaxSlices);
  const bool slices = !settings.slices.empty() || settings.hide_volume != HideVolume::None;
  f.u_slice_info = {int(settings.slices.size()), int(settings.hide_volume), 0, 0};
  if (slices && !I.slice_texture.id()) {
    I.slice_texture = GlTexture(GL_TEXTURE_2D);
    // Rows 0..7 the colour tables, 8..15 the contour lines (shaders/slice_contours.glsl).
    glTextureStorage2D(I.slice_texture.id(), 1, GL_RGBA32F, exact_gpu::EXACT_SLICE_TEXELS, 2 * EXACT_MAX_SLICES);
    glTextureParameteri(I.slice_texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(I.slice_texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(I.slice_texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(I.slice_texture.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  for (size_t i = 0; i < settings.slices.size(); ++i) {
    const Slice& sl = settings.slices[i];
    const Vec3d n = sl.normal * (1 / length(sl.normal));
    f.u_slice_plane[i] = d4(n, dot(n, sl.point));
    TransferFunction colors = sl.color_map.empty() ? tf : builtin_preset(sl.color_map);
    const double r_lo = sl.range ? (*sl.range)[0] : lo, r_hi = sl.range ? (*sl.range)[1] : hi;
    if (!sl.color_map.empty() || sl.range) colors.rescale(r_lo, r_hi);
    f.u_slice_map[i] = {r_hi > r_lo ? float(1 / (r_hi - r_lo)) : 0.0f,
                        r_hi > r_lo ? float(-r_lo / (r_hi - r_lo)) : 0.0f, float(sl.opacity), 0};
    const int n_texels = exact_gpu::EXACT_SLICE_TEXELS;
    std::vector<float> row(size_t(n_texels) * 4);
    for (int t = 0; t < n_texels; ++t) {
      const Vec3d c = colors.color(r_lo + (r_hi - r_lo) * double(t) / double(n_texels - 1));
      row[size_t(t) * 4 + 0] = float(c.x), row[size_t(t) * 4 + 1] = float(c.y);
      row[size_t(t) * 4 + 2] = float(c.z), row[size_t(t) * 4 + 3] = 1.0f;
    }
    glTextureSubImage2D(I.slice_texture.id(), 0, 0, GLint(i), n_texels, 1, GL_RGBA, GL_FLOAT, row.data());
    const std::vector<float> lines = slice_contour_row(sl, slice_contour_values(sl, lo, hi), 1, 0);
    glTextureSubImage2D(I.slice_texture.id(), 0, 0, GLint(EXACT_MAX_SLICES + i), GLsizei(lines.size() / 4), 1, GL_RGBA,
                        GL_FLOAT, lines.data());
  }
  I.frame_block.upload(&f, sizeof f);

  const int mode = settings.mode == RenderMode::Mip          ? EXACT_MODE_MIP
                   : settings.mode == RenderMode::Isosurface ? EXACT_MODE_ISO
                                                             : EXACT_MODE_EA;
  bool contours = false;
  for (const Slice& sl : settings.slices) contours = contours || sl.contours > 0 || !sl.contour_values.empty();
  const ComputeProgram& program =
      I.program_for(mode, mode == EXACT_MODE_EA && settings.volume_lighting, slices ? (contours ? 2 : 1) : 0);
  if (slices) glBindTextureUnit(exact_gpu::EXACT_SLICE_TEXTURE_BINDING, I.slice_texture.id());
  glUseProgram(program.id());
  glBindBufferBase(GL_UNIFORM_BUFFER, exact_gpu::EXACT_FRAME_BLOCK_BINDING, I.frame_block.id());
  glBindImageTexture(exact_gpu::EXACT_OUT_IMAGE_BINDING, I.out_texture.id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
  glBindTextureUnit(exact_gpu::EXACT_TF_TEXTURE_BINDING, I.tf_texture.id());
  for (int c = 0; c < exact_gpu::EXACT_CHUNKS; ++c) {
    // Unused chunk bindings get the first chunk: the shader never reads them, but every binding holds a buffer.
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_CONN_BINDING + c,
                     I.conn[size_t(c) < I.conn.size() ? size_t(c) : 0].id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_NBR_BINDING + c,
                     I.nbr[size_t(c) < I.nbr.size() ? size_t(c) : 0].id());
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_POINTS_BINDING, I.points.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_QUAD_SPLIT_BINDING, I.quad_split.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_VALUES_BINDING, I.values.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_BOUNDARY_BINDING, I.boundary.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_BOXES_BINDING, I.boxes.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_TILES_BINDING, I.tiles.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_OPTICAL_BINDING, I.optical.id());
  const uint32_t zero[exact_gpu::EXACT_COUNTER_COUNT] = {};
  I.counters.upload(zero, sizeof zero);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, exact_gpu::EXACT_COUNTERS_BINDING, I.counters.id());
  check_gl("binding the GPU exact engine's buffers");

  if (!I.timer) I.timer = std::make_unique<GlTimerQuery>();
  glFinish();  // the uploads above are not the walk's time
  const auto tw = std::chrono::steady_clock::now();
  I.timer->begin();
  try {
    dispatch_image(w, h, exact_gpu::EXACT_WORKGROUP_SIZE, exact_gpu::EXACT_BAND_ORIGIN_LOCATION, I.keep_going);
  } catch (const FrameInterrupted&) {
    I.timer->end();
    throw;
  }
  I.timer->end();
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  glFinish();
  // The GPU's own clock where it has one (llvmpipe's timer queries read ~0): else the wall time of the dispatch.
  I.gpu_seconds = std::max(I.timer->seconds(), 0.0);
  if (I.gpu_seconds < 1e-6) I.gpu_seconds = seconds_since(tw);
  check_gl("ray casting (GPU exact engine)");
  uint32_t counted[exact_gpu::EXACT_COUNTER_COUNT] = {};
  glGetNamedBufferSubData(I.counters.id(), 0, sizeof counted, counted);

  Image image =
      read_back_composited(I.readback, I.out_texture, w, h, settings.background, "exact engine (GPU)", &I.cut_pixels);
  // Rays llvmpipe's loop limit cut short (shaders/loop_limit_probe.glsl; none on a hardware GPU): the CPU's walk.
  ExactRenderStats cpu;
  trace_exact_pixels(I.mesh, I.host_values, I.per_cell, camera, tf, settings, tolerance_abs, I.cut_pixels, image, &cpu);
  const size_t bytes = size_t(w) * size_t(h) * 4 * sizeof(float);
  I.frame_bytes = boxes.size() * 4 + list.size() * 4 + I.tf_bytes + bytes * 2;
  if (stats) {
    stats->render_seconds = seconds_since(t0);
    stats->rays = uint64_t(w) * uint64_t(h);
    stats->rays_hit = counted[exact_gpu::EXACT_COUNTER_RAYS_HIT];
    stats->cell_steps =
        uint64_t(counted[exact_gpu::EXACT_COUNTER_STEPS_HI]) << 32 | counted[exact_gpu::EXACT_COUNTER_STEPS_LO];
    stats->reentries = counted[exact_gpu::EXACT_COUNTER_REENTRIES];
    stats->nonlinear_samples = counted[exact_gpu::EXACT_COUNTER_NONLINEAR];
    stats->lost_rays = counted[exact_gpu::EXACT_COUNTER_LOST] + cpu.lost_rays;
    stats->rays_hit += cpu.rays_hit;
    stats->reentries += cpu.reentries;
    stats->cell_steps += cpu.cell_steps;
    stats->nonlinear_samples += cpu.nonlinear_samples;
    stats->cpu_traced_rays = I.cut_pixels.size();
    stats->threads = 0;
  }
  return image;
}

}  // namespace ugvr
