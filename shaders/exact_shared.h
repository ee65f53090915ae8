// The contract between the GPU exact engine (src/ugvr/render/exact/exact_gpu_engine.cpp) and its ray caster
// (shaders/exact_walk.comp), read by both compilers as lod_shared.h is (see there for why it lives in shaders/).
//
// Storage buffers (std430), all read-only but the counters:
//   points        float[3 * points]              vertex positions, the walk mesh's float32 (walk_mesh.h)
//   connectivity  uint[], split over EXACT_CHUNKS buffers of 2^chunk_shift elements: the walk mesh's connectivity
//   neighbors     uint[], split the same way: the walk mesh's packed neighbours (cell << 3 | face, or ~0u)
//   quad_split    uint[]: the walk mesh's quad_split bytes, four to a uint (byte i at bits 8 (i & 3))
//   values        float[]: the bound field per vertex or per cell (engine order)
//   boundary      uvec2 per boundary triangle: (cell << 3 | local face, corner0 | corner1 << 2 | corner2 << 4)
//   boxes         uvec2 per boundary triangle this frame: pixel box (x0 | x1 << 16, y0 | y1 << 16); x0 > x1: none
//   tiles         uint[]: per screen tile + 1 where the tile's triangles start (counted from the start of this
//                 buffer), then the boundary triangle ids grouped by tile (boundary_bins.h bins them on the CPU)
//   counters      uint[EXACT_COUNTER_COUNT]: statistics, zeroed per frame
// The optical table (shaders/optical.glsl) at EXACT_OPTICAL_BINDING; the transfer function's colour and opacity as a
// 1D texture at EXACT_TF_TEXTURE_BINDING (isosurface and MIP colours, which use the transfer function itself).
#ifndef UGVR_EXACT_SHARED_H
#define UGVR_EXACT_SHARED_H

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>

namespace ugvr::exact_gpu {

using uint = std::uint32_t;
struct dvec4 {
  double x, y, z, w;
};
struct vec4 {
  float x, y, z, w;
};
struct ivec4 {
  std::int32_t x, y, z, w;
};
struct uvec4 {
  std::uint32_t x, y, z, w;
};
#endif

#define EXACT_MODE_EA 0
#define EXACT_MODE_MIP 1
#define EXACT_MODE_ISO 2

const int EXACT_WORKGROUP_SIZE = 8;
// The explicit location of `uniform ivec2 u_band_origin` (as lod_shared.h's BAND_ORIGIN_LOCATION).
const int EXACT_BAND_ORIGIN_LOCATION = 0;
const int EXACT_CHUNKS = 4;  // buffers the connectivity and the neighbours may each be split over

const int EXACT_OUT_IMAGE_BINDING = 0;  // image2D rgba32f: premultiplied radiance, transmittance per pixel
const int EXACT_TF_TEXTURE_BINDING = 1;
const int EXACT_POINTS_BINDING = 2;
const int EXACT_CONN_BINDING = 3;  // 3 .. 3 + EXACT_CHUNKS - 1
const int EXACT_NBR_BINDING = 7;   // 7 .. 7 + EXACT_CHUNKS - 1
const int EXACT_QUAD_SPLIT_BINDING = 11;
const int EXACT_VALUES_BINDING = 12;
const int EXACT_BOUNDARY_BINDING = 13;
const int EXACT_BOXES_BINDING = 14;
const int EXACT_TILES_BINDING = 15;
const int EXACT_COUNTERS_BINDING = 16;
const int EXACT_OPTICAL_BINDING = 17;  // 16 storage blocks in all: the most GL guarantees a compute shader
const int EXACT_FRAME_BLOCK_BINDING = 18;
// Slices (SLICES variants; render_settings.h Slice): one row of EXACT_SLICE_TEXELS colours per slice over its range,
// rgba32f, linear along a row. EXACT_MAX_SLICES is render_settings.h's kMaxSlices (a macro: it sizes block arrays).
const int EXACT_SLICE_TEXTURE_BINDING = 19;
const int EXACT_SLICE_TEXELS = 1024;
#define EXACT_MAX_SLICES 8

const int EXACT_COUNTER_RAYS_HIT = 0;
const int EXACT_COUNTER_STEPS_LO = 1;  // cell steps, 64 bits in two words
const int EXACT_COUNTER_STEPS_HI = 2;
const int EXACT_COUNTER_REENTRIES = 3;
const int EXACT_COUNTER_NONLINEAR = 4;
const int EXACT_COUNTER_LOST = 5;
const int EXACT_COUNTER_CUT = 6;  // rays llvmpipe's loop limit cut short (loop_limit_probe.glsl), traced on the CPU
const int EXACT_COUNTER_COUNT = 7;

const int EXACT_TF_TEXELS = 4096;
const int EXACT_MAX_ISO = 16;
const uint EXACT_BOUNDARY = 0xFFFFFFFFu;

// The per-frame parameters, one std140 block. Doubles first (std140 aligns a dvec4 to 32 bytes): the camera and the
// ray parameters are double as on the CPU, so that rays hit the same cells; EXACT_DOUBLE (a define) chooses whether
// the walk itself computes in double (the reference's arithmetic) or float.
#ifdef __cplusplus
struct alignas(32) ExactFrame {
#else
layout(std140, binding = EXACT_FRAME_BLOCK_BINDING) uniform ExactFrame {
#endif
  dvec4 u_eye;         //   0 xyz camera position; w: 1 for a parallel projection
  dvec4 u_forward;     //  32 xyz; w: half width of the image plane (at unit distance, or world units if parallel)
  dvec4 u_right;       //  64 xyz; w: half height
  dvec4 u_up;          //  96 xyz; w: distance within which a re-entry continues where the ray left
  dvec4 u_clip;        // 128 xyz: clip range [t_lo, t_hi] is computed per ray from normal xyz and w = dot(n, point)
  dvec4 u_tolerance;   // 160 x: nonlinear tolerance in scalar units
  uvec4 u_type_begin;  // 192 first cell of each type (tetra, pyramid, wedge, hexahedron)
  uvec4 u_conn_begin;  // 208 where each type's connectivity starts
  uvec4 u_face_begin;  // 224 where each type's neighbours start
  ivec4 u_size;        // 240 width, height, tiles per row, tile size
  ivec4 u_flags;       // 256 per-cell data, clip plane on, surface lighting, volume lighting
  ivec4 u_counts;      // 272 cell count, iso count, chunk shift, loop-limit probe count (loop_limit_probe.glsl)
  vec4 u_params;       // 288 overlay opacity, iso opacity, 1 - early-termination opacity, -
  vec4 u_tf_map;       // 304 x, y: TF texture coordinate = value x + y
  vec4 u_iso[EXACT_MAX_ISO / 4];          // 320 isovalues, ascending
  ivec4 u_slice_info;                     // 384 x: slice count, y: hide_volume (0 none, 1 front, 2 back, 3 all)
  vec4 u_slice_map[EXACT_MAX_SLICES];     // 400 x, y: slice i's colour-table coordinate = value x + y; z: opacity
  ivec4 u_slice_pad;                      // 528 (u_slice_plane starts on 32 bytes)
  dvec4 u_slice_plane[EXACT_MAX_SLICES];  // 544 xyz: unit normal, w: dot(normal, point)
};

#ifdef __cplusplus
static_assert(sizeof(dvec4) == 32 && sizeof(vec4) == 16 && sizeof(uvec4) == 16 && sizeof(ivec4) == 16);
static_assert(offsetof(ExactFrame, u_type_begin) == 192 && offsetof(ExactFrame, u_iso) == 320);
static_assert(offsetof(ExactFrame, u_slice_info) == 384 && offsetof(ExactFrame, u_slice_map) == 400);
static_assert(offsetof(ExactFrame, u_slice_plane) == 544 && sizeof(ExactFrame) == 800);

}  // namespace ugvr::exact_gpu
#endif

#endif  // UGVR_EXACT_SHARED_H
