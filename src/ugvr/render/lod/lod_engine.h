// The level-of-detail engine: GPU ray casting of a cut of a brick store's octree (Leven et al. 2002, sections
// 5.2-5.4, done as single-pass ray casting instead of texture slicing). docs/lod-engine.md explains the design.
//
// Per frame: choose the cut (lod_cut.h) from the camera, the transfer function and the cut spec; bring the cut's
// bricks into the atlas (brick_atlas.h; bricks already resident stay where they are, so a camera move re-reads only
// the bricks that changed); upload the per-node state (slot / descend / skip); run shaders/lod_raycast.comp over the
// image; read the image back and composite it over the background exactly as the exact engine does, so the two
// engines' images compare pixel for pixel with one camera / transfer function / settings.
//
// Values and geometry are separate: a transfer-function edit re-uploads two 4096-texel tables, the colour and
// extinction and their integrals (pre-integration), and nothing else.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/vec.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/brick_residency.h"
#include "ugvr/render/lod/hybrid_select.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct LodRenderStats {
  double render_seconds = 0;     // wall time of render()
  double cut_seconds = 0;        // choosing the cut
  double load_seconds = 0;       // reading, decoding, padding and uploading bricks not yet resident
  double gpu_seconds = 0;        // the ray-casting dispatch, to completion (glFinish), by the CPU's clock
  double gpu_timer_seconds = 0;  // the same dispatch by a GL timer query (the device's own clock)
  double readback_seconds = 0;
  uint64_t samples = 0;         // texture samples of the volume taken by all rays
  uint64_t bricks_entered = 0;  // node traversals, summed over rays
  uint64_t cut_nodes = 0;
  uint64_t bricks_loaded = 0;     // uploaded to the atlas this frame
  uint64_t bricks_read_sync = 0;  // of those, read from the store on the render thread (not from the RAM tier)
  // Bytes uploaded with them: texels, and in a tricubic atlas their coefficients and cubic margins.
  uint64_t uploaded_bytes = 0;
  // Tricubic: same-level neighbours of the uploaded bricks read from the store for their prefilter (brick_atlas.h).
  uint64_t neighbour_reads = 0;
  // Tricubic: bricks (and ancestors, for the level blend) prefiltered this frame, those whose coefficients came from
  // the coefficient cache instead, and the cache's bytes now (LodOptions::cubic_cache_bytes; docs/tricubic.md).
  uint64_t cubic_prefilters = 0, cubic_cache_hits = 0, cubic_cache_bytes = 0;
  uint64_t culled_frustum = 0, culled_tf = 0;
  bool budget_limited = false;
  int max_level = 0;
  double mean_level = 0;
  uint64_t atlas_bytes = 0;
  uint64_t atlas_slots = 0;
  // Hybrid rendering (LodOptions::hybrid; docs/hybrid.md): the cut's nodes that have cells and a nonzero data error
  // (candidates), those drawn exact this frame and their cells, the cell cache's bytes and budget, nodes read and
  // prepared this frame, nodes given another time step's values this frame (kept prepared: cell_cache.h), cells walked
  // by all rays; budget_full: a candidate did not fit the budget. `hybrid_off`
  // says why no node could be exact ("" when hybrid ran).
  bool hybrid = false;
  std::string hybrid_off;
  uint64_t exact_candidates = 0, exact_nodes = 0, exact_cells = 0;
  uint64_t focus_excluded = 0;  // nodes with cells left resampled for zero interest (--focus)
  uint64_t cell_bytes = 0, cell_budget_bytes = 0, cells_prepared = 0, cells_swapped = 0, cell_steps = 0;
  bool cell_budget_full = false;
  double cells_seconds = 0;  // choosing, reading, preparing and uploading cells
  // Rays that llvmpipe's loop limit cut short (shaders/loop_limit_probe.glsl: 65,535 loop iterations per 8 rays),
  // 0 on a hardware GPU. In a hybrid frame they are drawn again from the voxels (loop_limit_voxel_rays of them);
  // elsewhere their pixels hold what they had gathered.
  uint64_t loop_limit_rays = 0, loop_limit_voxel_rays = 0;
  // Exact boundary (a store with faces; docs/lod-engine.md, "Exact boundary"): the times a ray intersected a node's
  // faces (node_faces, before a second pass through the node), summed over rays; 0 without faces.
  uint64_t face_passes = 0;
};

// Whether settings draw tricubic isosurfaces (the other modes ignore the interpolation).
bool tricubic_iso(const RenderSettings& settings);

// Whether settings draw the boundary overlay: opacity > 0, and not in MIP mode (as the exact engine). The cut must
// then keep nodes that are transparent under the transfer function (CutOptions / ActiveCutOptions::tf_cull false).
bool boundary_overlay_on(const RenderSettings& settings);

// Which of the cut's transfer-function rules apply to a frame of `settings` (CutOptions / ActiveCutOptions): `cull`
// drops nodes transparent under the transfer function, `error` keeps nodes uniform under it coarse. Not with the
// boundary overlay (cull: a transparent node still bounds the data), slices (they show the field where the volume is
// transparent) or isosurfaces (their geometry is the field's whatever the transfer function: a zero opacity drew no
// surface, a constant colour the root brick alone); the cut is then the plain screen-size criterion.
struct TfCutRules {
  bool cull = true, error = true;
};
TfCutRules tf_cut_rules(const RenderSettings& settings);

// Thrown by LodEngine::render_nodes when the device refused an atlas that the budget allowed (llvmpipe caps a texture
// at 1 GiB): atlas_budget_bricks() is now what it does allocate; choose the cut again within it and render again.
class AtlasRefused : public Error {
 public:
  using Error::Error;
};

struct LodOptions {
  uint64_t atlas_budget_bytes = uint64_t(2) << 30;  // GPU memory for bricks
  // RAM for the tricubic prefilter's coefficients per brick (cubic_cache.h: (R+2)³ doubles a brick, 10.6 KiB for
  // bricks of 9³, 343 KiB for 33³), so that a brick uploaded again is not prefiltered again; 0: none kept.
  uint64_t cubic_cache_bytes = uint64_t(256) << 20;
  double step_voxels = 0.5;  // sample step in voxels of each node (RenderSettings.sample_step = 0)
  // Hybrid rendering (docs/hybrid.md): render() draws the cut's nodes that have cells in the store (format version 5)
  // by walking their cells, in priority order (hybrid_select.h) within a GPU budget for cells (0: a quarter of
  // atlas_budget_bytes) and at most max_exact_nodes of them; the rest from their bricks. Emission-absorption without
  // the boundary overlay or slices only: other modes draw voxels alone (stats say so).
  bool hybrid = false;
  uint64_t cell_budget_bytes = 0;
  uint64_t max_exact_nodes = UINT64_MAX;
  // Degree of interest (hybrid_select.h): with focus ranges and/or a region of interest, only nodes of interest > 0 get
  // exact cells, and the others (context) are drawn from their bricks desaturated and faint (Muigg eq. 3.15), in
  // emission-absorption mode: their colour keeps context_saturation of its saturation (mixed towards its luminance)
  // and their extinction is scaled by context_opacity. Both in [0, 1]; 1 and 1 draw the context as the focus.
  // Focus ranges with an edge (FIELD:MIN:MAX~EDGE), all on the rendered field and no region: each sample (and each
  // exact cell piece) is mixed between its full colour and its context colour by its own value's interest (smooth
  // brush edges).
  std::vector<FocusRange> focus;
  std::optional<RegionOfInterest> roi;
  double context_saturation = 0.2, context_opacity = 0.3;
  // Throws ugvr::Error naming the option (--context-saturation, --context-opacity) for a value outside [0, 1].
  void validate() const;
};

class LodEngine {
 public:
  // Opens the store (validated, store/brick_store.h) and prepares GPU state in `gl`, which must stay alive and current
  // on the calling thread. Throws ugvr::Error.
  LodEngine(const std::string& store_path, const GlContext& gl, LodOptions options = {});
  ~LodEngine();
  LodEngine(const LodEngine&) = delete;
  LodEngine& operator=(const LodEngine&) = delete;

  // Binds a field of the store by name (empty = the first). Throws ugvr::Error listing the store's fields.
  void set_field(std::string_view name);
  const std::string& field_name() const;
  double field_min() const;
  double field_max() const;

  // Renders settings.width × settings.height. settings.field is ignored (set_field); settings.sample_step > 0 is one
  // world step at every level, 0 the options' step_voxels per node. boundary_overlay_opacity draws the mesh
  // boundary: on the store's boundary faces with their normals where it has them (format version 4), else where the
  // bricks' stencils put it (voxel resolution; docs/lod-engine.md), with transfer-function culling off
  // (boundary_overlay_on) so that transparent data still bounds it. With faces, every node's samples are clipped at
  // them (docs/lod-engine.md, "Exact boundary").
  Image render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings, const CutSpec& cut,
               LodRenderStats* stats = nullptr);

  // Renders exactly `nodes`, a cut chosen by the caller (the time-critical controller): they must cover the data at
  // most once. The residency (brick_residency.h: this engine's gpu_slots() and the caller's RAM tier) gives each node
  // its atlas slot and the texels of the bricks not in the atlas yet: from its RAM cache, or read from the store here.
  // The atlas keeps bricks across frames and evicts the least recently drawn first. Throws ugvr::Error when the cut
  // does not fit the atlas budget.
  Image render_nodes(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                     std::span<const uint64_t> nodes, BrickResidency& residency, LodRenderStats* stats = nullptr);
  // The same with no RAM tier: the missing bricks are read from the store on this thread.
  Image render_nodes(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                     std::span<const uint64_t> nodes, LodRenderStats* stats = nullptr);
  // The GPU tier's bookkeeping (which node's brick is in which atlas slot), shared by every session drawing with this
  // engine: a session's BrickResidency refers to it. A new atlas (the cut outgrew it) or a new field empties it.
  BrickSlotTable& gpu_slots();
  const BrickSlotTable& gpu_slots() const;
  // Bricks the atlas may hold within the options' budget.
  uint64_t atlas_budget_bricks() const;
  const BrickStoreReader& store() const;
  uint32_t field() const;  // the bound field's index in the store
  // A time store's step (format version 6; 0 for a store of one step): the bricks, node ranges and errors drawn from
  // now on. A switch empties the atlas, as a field switch does. Throws ugvr::Error for a step out of range.
  void set_time_step(uint32_t step);
  uint32_t time_step() const;
  // Sample step in voxels of each node when RenderSettings.sample_step is 0 (progressive refinement refines it).
  void set_step_voxels(double step);
  // Hybrid rendering: at most `n` exact nodes from the next frame on (0: voxels only).
  void set_max_exact_nodes(uint64_t n);
  // Hybrid rendering (LodOptions::hybrid): whether it is on; and, for a cut the caller draws next with render_nodes
  // (the time-critical session), exact cells for at most `max_nodes` of its nodes in priority order (the grant holds
  // for that one call). Fills the hybrid figures of *stats, which the caller then passes to render_nodes.
  bool hybrid() const;
  // Turns hybrid rendering on or off from the next frame on (the viewer's tabs pick "hybrid" or "lod" over one shared
  // engine; the caller sets it before each tab's frame).
  void set_hybrid(bool on);
  // The degree of interest from the next frame on (LodOptions::focus, roi, context_*): the viewer's tabs set their own
  // before each frame. Throws ugvr::Error for a focus field the store lacks or a context value outside [0, 1].
  void set_interest(std::vector<FocusRange> focus, std::optional<RegionOfInterest> roi, double context_saturation,
                    double context_opacity);
  void prepare_exact(std::span<const uint64_t> nodes, const Camera& camera, const TransferFunction& tf,
                     const RenderSettings& settings, uint64_t max_nodes, LodRenderStats* stats);
  // Hybrid rendering: the nodes whose cells are prepared in RAM (read from the store), ascending; empty before the
  // first hybrid frame.
  std::vector<uint64_t> cell_nodes_in_ram() const;

  // Data-parallel rendering (src/ugvr/mpi, docs/mpi.md): only the stretch of each ray inside `box` (world
  // coordinates; faces may be infinite) is drawn, so the images of boxes that tile space compose front to back into
  // the whole image (up to where samples fall); render() draws only the cut's nodes that meet the box. Not a user
  // setting. nullopt (the default): whole rays.
  void set_clip_box(std::optional<Bounds> box);
  // Interactive front ends (FrameRequest::keep_going, renderer.h): from the next frame on, the ray casting is
  // dispatched in bands of rows (render/banded_dispatch.h), asking `keep_going` before each, and a frame it stops
  // throws FrameInterrupted (the atlas keeps what was uploaded; an exact grant ends as after a frame). Empty: one
  // dispatch a frame. The renderers set it around a request's frame and clear it after.
  void set_keep_going(std::function<bool()> keep_going);
  Bounds bounds() const;  // the dataset's bounds
  uint64_t node_count() const;
  uint32_t resolution() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ugvr
