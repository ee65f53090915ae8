// The contract between the LOD engine (src/ugvr/render/lod/lod_engine.cpp) and its ray caster
// (shaders/lod_raycast.comp): one file that both compilers read. The engine includes it as C++ when it is built; the
// shader as GLSL when the engine starts (the shader loader expands #include, src/ugvr/gpu/gl_program.h). It lives
// here, not under src/, because the loader reads shaders/ at run time (UGVR_SHADER_DIR) while the C++ build can
// include from any directory.
//
// Written in what both languages accept: #define where the preprocessor must see a value (#if MODE == ...) or where
// a literal must stay a float in GLSL and a double in C++; `const` for typed constants (namespace ugvr::lod_gpu in
// C++); one struct, the per-frame parameters, which GLSL sees as a std140 uniform block and C++ as a plain struct.
// The __cplusplus blocks supply C++ stand-ins for the GLSL types and check the layout. Editing this file changes
// both sides: rebuild, or the engine refuses the shader (it compares the block's size with sizeof(LodFrame)).
#ifndef UGVR_LOD_SHARED_H
#define UGVR_LOD_SHARED_H

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>

namespace ugvr::lod_gpu {

// The GLSL types as a std140 block stores them. Every one has alignment 4 in C++, so members follow each other with
// no padding; the asserts at the end check that each one sits where std140 puts it.
using uint = std::uint32_t;
using bool32 = std::uint32_t;  // a GLSL bool in a block: 4 bytes, nonzero is true
struct vec2 {
  float x, y;
};
struct vec3 {
  float x, y, z;
};
struct vec4 {
  float x, y, z, w;
};
struct ivec2 {
  std::int32_t x, y;
};
struct ivec3 {
  std::int32_t x, y, z;
};
#else
#define bool32 bool
#endif

// Rendering modes, compile-time variants of the shader (the engine defines MODE; lod_engine.cpp program_for).
// Macros, as #if tests them (an undefined name would read as 0 there).
#define LOD_MODE_EA 0
#define LOD_MODE_MIP 1
#define LOD_MODE_ISO 2

// Invocations per work group along x and y: one per pixel, WORKGROUP_SIZE² pixels per group.
const int WORKGROUP_SIZE = 8;
// The explicit location of `uniform ivec2 u_band_origin`: the pixel the dispatch's first invocation draws. (0, 0)
// for a whole image in one dispatch; an interruptible frame is drawn in bands of rows (render/banded_dispatch.h).
const int BAND_ORIGIN_LOCATION = 0;

// Binding points. GL numbers images, textures, storage and uniform buffers separately; these are numbered apart all
// the same, so that a number names one thing.
const int OUT_IMAGE_BINDING = 0;        // image2D rgba32f: premultiplied radiance, transmittance per pixel
const int ATLAS_TEXTURE_BINDING = 1;    // sampler3D RG16: value in the field range, validity stencil (brick_atlas.h)
const int TF_TEXTURE_BINDING = 2;       // sampler1D rgba32f: rgb colour, a = extinction per world unit
const int TREE_BUFFER_BINDING = 3;      // uvec2 per store node: first child id, child mask | level << TREE_LEVEL_SHIFT
const int STATE_BUFFER_BINDING = 4;     // uint per store node this frame: a cut node's atlas slot, or NODE_*
const int COUNTERS_BUFFER_BINDING = 5;  // uint[COUNTER_COUNT], zeroed per frame, read back for --stats
const int FRAME_BLOCK_BINDING = 6;      // uniform block LodFrame (below)
const int PREINT_TEXTURE_BINDING = 7;   // sampler1D rgba32f: the transfer function's integrals (pre-integration)
// The mesh's boundary faces (FACES variants; store/brick_store_format.h BoundaryHeaderRecord):
const int FACE_NODE_BUFFER_BINDING = 8;  // uvec2 per store node: first reference, count (0: none; FACE_OVERFLOW:
                                         // more than the cap, none listed: the node's descendants have them;
                                         // FACE_PLANE: first is where the node's plane lies in the triangle buffer)
const int FACE_REF_BUFFER_BINDING = 9;   // uint per reference: a triangle index
const int FACE_TRI_BUFFER_BINDING = 10;  // float[9] per triangle: corners in normalised coordinates, outward order;
                                         // after the triangles, float[4] per plane: n.xyz, w (n·p = w, n outward)
const uint FACE_OVERFLOW = 0xFFFFFFFFu;  // store_format::kBoundaryOverflow
// All the faces the node reaches lie on one plane and cover its section of the node (octree/boundary_faces.h
// boundary_face_planes; set by the engine, not stored): one ray-plane test stands for the triangles and the walk.
const uint FACE_PLANE = 0xFFFFFFFEu;
const int MAX_FACE_HITS = 8;  // face crossings kept per ray and node (more: the rest of the node is lost to the state)
// Slices (SLICES variants; render_settings.h Slice): their colour tables, one row of SLICE_TEXELS per slice over the
// slice's own range (texel i at u = i / (SLICE_TEXELS - 1)), rgba32f, linear along a row. LOD_MAX_SLICES is
// render_settings.h's kMaxSlices, a macro so that it sizes the block's arrays in both languages.
const int SLICE_TEXTURE_BINDING = 11;
const int SLICE_TEXELS = 1024;
#define LOD_MAX_SLICES 8

// Hybrid rendering (HYBRID variants, MODE LOD_MODE_EA; docs/hybrid.md): the cells of the cut nodes granted an exact
// representation, as render/lod/cell_cache.h lays them out (CellNodeRecord per resident node; the walk's arrays).
const int CELL_NODE_BUFFER_BINDING = 12;   // uvec4 × CELL_NODE_UVEC4S per resident node: cell_cache.h CellNodeRecord
const int CELL_INT_BUFFER_BINDING = 13;    // uint: connectivity, neighbours, quad splits, entry triangles
const int CELL_FLOAT_BUFFER_BINDING = 14;  // float: points (normalised coordinates), values (the field's own)
const int CELL_NODE_UVEC4S = 6;
const int CELL_OPTICAL_BUFFER_BINDING = 15;  // the exact engine's optical table (shaders/optical.glsl) for the cells
// sampler3D R16: the interpolating spline's coefficients per atlas texel (TRICUBIC variants; brick_atlas.h)
const int COEF_TEXTURE_BINDING = 16;
const int MARGIN_BUFFER_BINDING = 17;  // float per atlas slot: its cubic margin (TRICUBIC variants; brick_atlas.h)
// A node state with this bit set (and below NODE_DESCEND) is a cut node drawn by its cells; the bits below are its
// entry in the cell cache.
const uint NODE_EXACT = 0x80000000u;
// Focus+context (Muigg 2007, eq. 3.15; docs/hybrid.md): a resampled cut node's state (an atlas slot) with this bit set
// is context, of zero interest under the focus or region of interest: its samples are drawn desaturated and faint
// (LodFrame u_context). Atlas slots stay far below it (lod_engine.cpp checks), and exact nodes never carry it.
const uint NODE_CONTEXT = 0x40000000u;
// Smooth brush edges (docs/hybrid.md): the focus ranges the shader windows per sample (LodFrame u_focus) at most.
// A macro, as it sizes the block's array in both languages.
#define LOD_MAX_FOCUS_WINDOWS 4

const uint TREE_CHILD_MASK = 0xFFu;  // the child mask in a tree entry's y
const uint TREE_LEVEL_SHIFT = 8u;    // the node's level above it

// Node states besides atlas slots (slots are below both, lod_engine.cpp checks the node count).
const uint NODE_DESCEND = 0xFFFFFFFEu;  // an ancestor of cut nodes: descend to the child at the ray's position
const uint NODE_SKIP = 0xFFFFFFFFu;     // neither drawn nor an ancestor: culled or empty, the ray passes

const int COUNTER_SAMPLES = 0;      // texture samples of the volume, summed over rays
const int COUNTER_BRICKS = 1;       // node traversals (bricks entered), summed over rays
const int COUNTER_CELL_STEPS = 2;   // cells walked in exact nodes (HYBRID), summed over rays
const int COUNTER_LOOP_LIMIT = 3;   // rays llvmpipe's loop limit cut short (shaders/loop_limit_probe.glsl)
const int COUNTER_FACE_PASSES = 4;  // FACES: face passes (a node's faces intersected, node_faces), summed over rays
const int COUNTER_COUNT = 5;

// Texels of the transfer-function table and of its integrals, over the transfer function's own range: texel i at
// u = i / (TF_TEXELS - 1) of it. The integrals' texel i holds (∫ c·τ du, ∫ τ du) from u = 0 to u_i (lod_engine.cpp).
const int TF_TEXELS = 4096;
const int MAX_ISO = 16;  // isosurface values at most (a multiple of 4: they are stored as vec4s)

// Surface shading (isosurfaces, the boundary overlay; the ambient and diffuse terms for --volume-lighting): the exact
// engine's kAmbient... (render/exact/exact_engine.cpp), so that the engines compare. Macros so that each language
// reads the literal in its own precision: float in GLSL (as the shader always had), double in C++.
#define LOD_AMBIENT 0.2
#define LOD_DIFFUSE 0.8
#define LOD_SPECULAR 0.25
#define LOD_SHININESS 32.0
#define LOD_OVERLAY_GREY 0.85  // the boundary overlay's colour, grey (kOverlayColor)

// The per-frame parameters: one std140 uniform block, written with one buffer update per frame. "Normalised"
// coordinates are the root cell's, [0, 1]³; distances and directions are world ones unless they say so. Members keep
// the names the separate uniforms had. Byte offsets on the right: std140 aligns vec3 and vec4 to 16 bytes and vec2 to
// 8, and a scalar after a vec3 fills its last 4 bytes.
#ifdef __cplusplus
struct alignas(16) LodFrame {
#else
layout(std140, binding = FRAME_BLOCK_BINDING) uniform LodFrame {
#endif
  vec3 u_eye;                 //   0 camera position, normalised
  float u_step0;              //  12 world sample step at level 0
  vec3 u_forward;             //  16 camera frame, world
  float u_nudge;              //  28 world distance past a node's exit where the next node is looked up
  vec3 u_right;               //  32
  float u_unit_distance;      //  44 the transfer function's opacity unit distance (MIP)
  vec3 u_up;                  //  48
  float u_iso_opacity;        //  60
  vec3 u_root_size;           //  64 world size of the root cell per axis
  float u_min_transmittance;  //  76 1 - early termination opacity
  vec3 u_atlas_inv;           //  80 1 / atlas texels per axis
  float u_overlay_opacity;    //  92 the boundary overlay's alpha (OVERLAY variants)
  ivec3 u_slots;              //  96 atlas slots per axis
  int u_resolution;           // 108 samples per brick axis
  vec4 u_clip_plane;          // 112 keep dot(xyz, p) + w >= 0, p normalised (read only with u_clip)
  ivec2 u_size;               // 128 image size in pixels
  vec2 u_half;                // 136 half width, half height of the image plane (tan or parallel scale)
  vec2 u_tf_map;              // 144 TF coordinate = value · x + y (value normalised to the field range)
  int u_iso_count;            // 152
  bool32 u_parallel;          // 156
  bool32 u_fixed_step;        // 160 one world step at every level
  bool32 u_lighting;          // 164 shade surfaces
  bool32 u_clip;              // 168
  int u_loop_probe;           // 172 2: loop_limit_reached's count (shaders/loop_limit_probe.glsl)
  vec4 u_iso[MAX_ISO / 4];    // 176 normalised isovalues, ascending, 4 per vec4 (a float[] would take 16 bytes each)
  vec4 u_slice_plane[LOD_MAX_SLICES];  // 240 slice i: dot(xyz, p) + w = 0, p normalised, xyz a unit normal there
  vec4 u_slice_map[LOD_MAX_SLICES];    // 368 slice i: colour-table coordinate = value · x + y; z its opacity
  int u_slice_count;                   // 496 (read only by SLICES variants)
  int u_hide_volume;                   // 500 0 none, 1 front, 2 back, 3 all (render_settings.h HideVolume)
  float u_cell_tolerance;              // 504 HYBRID: non-linear cells' tolerance, in the field's units
  int u_cell_data;                     // 508 HYBRID: the field is per cell (else per vertex)
  vec4 u_box_lo;                       // 512 data-parallel rendering (src/ugvr/mpi): only t inside the box
  vec4 u_box_hi;                       // 528 [lo, hi] (xyz, normalised) is drawn; read only when u_box_lo.w > 0.5
  // 544 focus+context, NODE_CONTEXT nodes: x saturation kept, y extinction scale (emission-absorption); z the number
  // of u_focus windows (0: none, the node-level rule alone; > 0: the FOCUS_WINDOWS variant, which reads them)
  vec4 u_context;
  // 560 the focus ranges on the rendered field, one window each (lod_engine.cpp set_focus_windows): x MIN, y MAX, z
  // 1 / EDGE in transfer-function coordinates (u_tf_map's), w the range's group (one group's ranges ANDed, groups
  // ORed).
  vec4 u_focus[LOD_MAX_FOCUS_WINDOWS];
  // 624 HYBRID: a cell value's transfer-function coordinate = value · x + y (with u_focus); normalised to the field's
  // range as the bricks' samples are = value · z + w (MIP)
  vec4 u_focus_map;
};

#ifdef __cplusplus
// std140 puts each member at the next multiple of its alignment, C++ right after the one before: the two agree as
// long as each vector member's C++ offset is such a multiple (then std140 has nothing to skip either). The GL test
// LodGpuContract compares every offset with the driver's.
static_assert(sizeof(vec3) == 12 && sizeof(ivec3) == 12 && sizeof(vec4) == 16 && sizeof(vec2) == 8);
static_assert(offsetof(LodFrame, u_eye) % 16 == 0 && offsetof(LodFrame, u_forward) % 16 == 0);
static_assert(offsetof(LodFrame, u_right) % 16 == 0 && offsetof(LodFrame, u_up) % 16 == 0);
static_assert(offsetof(LodFrame, u_root_size) % 16 == 0 && offsetof(LodFrame, u_atlas_inv) % 16 == 0);
static_assert(offsetof(LodFrame, u_slots) % 16 == 0 && offsetof(LodFrame, u_clip_plane) % 16 == 0);
static_assert(offsetof(LodFrame, u_size) % 8 == 0 && offsetof(LodFrame, u_half) % 8 == 0);
static_assert(offsetof(LodFrame, u_tf_map) % 8 == 0 && offsetof(LodFrame, u_iso) % 16 == 0);
static_assert(offsetof(LodFrame, u_iso) + sizeof(LodFrame::u_iso) == offsetof(LodFrame, u_slice_plane));
static_assert(offsetof(LodFrame, u_slice_plane) % 16 == 0 && offsetof(LodFrame, u_slice_map) % 16 == 0);
static_assert(offsetof(LodFrame, u_slice_count) == 496 && offsetof(LodFrame, u_box_lo) == 512);
static_assert(offsetof(LodFrame, u_box_hi) == 528 && offsetof(LodFrame, u_context) == 544);
static_assert(offsetof(LodFrame, u_focus) == 560 && offsetof(LodFrame, u_focus_map) == 624 && sizeof(LodFrame) == 640);
static_assert(LOD_MAX_FOCUS_WINDOWS == 4);  // u_focus_map's offset above
static_assert(MAX_ISO % 4 == 0 && sizeof(LodFrame::u_iso) == MAX_ISO * sizeof(float));

}  // namespace ugvr::lod_gpu
#endif

#endif  // UGVR_LOD_SHARED_H
