#include "ugvr/render/lod/lod_engine.h"

#include <epoxy/gl.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "lod_shared.h"  // shaders/lod_shared.h: what the engine and shaders/lod_raycast.comp agree on
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_program.h"
#include "ugvr/render/banded_dispatch.h"
#include "ugvr/render/gpu_readback.h"
#include "ugvr/render/lod/brick_atlas.h"
#include "ugvr/render/lod/brick_cache.h"
#include "ugvr/render/lod/brick_residency.h"
#include "ugvr/render/lod/cell_cache.h"
#include "ugvr/render/lod/cubic_cache.h"
#include "ugvr/render/lod/hybrid_select.h"
#include "ugvr/render/lod/same_level_bricks.h"
#include "ugvr/render/lod/tf_error.h"
#include "ugvr/render/optical_table.h"
#include "ugvr/render/renderer.h"
#include "ugvr/store/boundary_planes.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

namespace {

constexpr size_t kLoadBatch = 64;  // bricks decoded in parallel between uploads (bounds staging memory)
// Tricubic uploads also decode the batch's same-level neighbours for the prefilter (brick_atlas.h,
// CubicNeighbourhood): the batch shrinks so that they stay within this many bytes of texels.
constexpr uint64_t kNeighbourStagingBytes = uint64_t(64) << 20;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

lod_gpu::vec3 to_float(Vec3d v) { return {float(v.x), float(v.y), float(v.z)}; }

// The camera as the shader takes it: the eye in coordinates normalised to the root cell, the frame and the image
// plane's half extents in world terms.
void set_camera(lod_gpu::LodFrame& f, const Camera& camera, int width, int height, const Bounds& root) {
  const Vec3d root_size = root.size();
  const CameraRays rays(camera, width, height);
  f.u_size = {width, height};
  const Vec3d eye = camera.position - root.lo;
  f.u_eye = to_float({eye.x / root_size.x, eye.y / root_size.y, eye.z / root_size.z});
  f.u_forward = to_float(rays.forward());
  f.u_right = to_float(rays.right());
  f.u_up = to_float(rays.up());
  f.u_half = {float(rays.half_width()), float(rays.half_height())};
  f.u_parallel = camera.parallel_projection ? 1 : 0;
}

// The clip plane in normalised coordinates, with a unit normal there: keep dot(xyz, p) + w >= 0.
lod_gpu::vec4 normalised_plane(const ClipPlane& plane, const Bounds& root) {
  const Vec3d root_size = root.size();
  const Vec3d n = plane.normal;
  const Vec3d np{n.x * root_size.x, n.y * root_size.y, n.z * root_size.z};
  const double w0 = dot(root.lo - plane.point, n);
  const double scale = 1 / length(np);
  return {float(np.x * scale), float(np.y * scale), float(np.z * scale), float(w0 * scale)};
}

// The shader reads lod_shared.h when the engine starts, this binary was compiled with it: after an edit without a
// rebuild the two would read the per-frame block differently, silently. The driver's block size and work group
// reveal most such edits.
void check_contract(const ComputeProgram& program) {
  const GLint block = program.uniform_block_size("LodFrame");
  GLint local[3] = {0, 0, 0};
  glGetProgramiv(program.id(), GL_COMPUTE_WORK_GROUP_SIZE, local);
  if (block != GLint(sizeof(lod_gpu::LodFrame)) || local[0] != lod_gpu::WORKGROUP_SIZE ||
      local[1] != lod_gpu::WORKGROUP_SIZE)
    fail_in(shader_directory() + "/lod_shared.h",
            "the shader sees a uniform block of " + std::to_string(block) + " bytes and work groups of " +
                std::to_string(local[0]) + "x" + std::to_string(local[1]) + ", this program was built for " +
                std::to_string(sizeof(lod_gpu::LodFrame)) + " bytes and " + std::to_string(lod_gpu::WORKGROUP_SIZE) +
                "x" + std::to_string(lod_gpu::WORKGROUP_SIZE) + " (rebuild after editing the file)");
}

}  // namespace

bool tricubic_iso(const RenderSettings& settings) {
  return settings.mode == RenderMode::Isosurface && settings.interpolation == Interpolation::Tricubic;
}

bool boundary_overlay_on(const RenderSettings& settings) {
  return settings.boundary_overlay_opacity > 0 && settings.mode != RenderMode::Mip;
}

TfCutRules tf_cut_rules(const RenderSettings& settings) {
  const bool field_shown = !settings.slices.empty() || settings.mode == RenderMode::Isosurface;
  return {!field_shown && !boundary_overlay_on(settings), !field_shown};
}

struct LodEngine::Impl {
  BrickStoreReader store;
  const GlContext& gl;
  LodOptions options;
  uint32_t field = 0;
  // By (mode, volume lighting, boundary overlay, slices, tricubic, hybrid, focus windows): compile-time variants.
  std::map<std::tuple<int, bool, bool, bool, bool, bool, int>, ComputeProgram> programs;
  ComputeProgram& program_for(int mode, bool volume_lighting, bool overlay, bool slices = false, bool tricubic = false,
                              bool hybrid = false, int focus_windows = 0);
  GlBuffer tree, state, counters, readback;
  // The boundary faces (store format version 4), static; `faces` false: the store has none, and the shader is compiled
  // without them (FACES 0: the stencil alone, at no cost).
  bool faces = false;
  GlBuffer face_nodes, face_refs, face_tris;
  GlBuffer frame_block;  // the uniform block LodFrame
  GlTexture tf_texture, preint_texture, out_texture;
  GlTexture slice_texture;  // the slices' colour tables (lod_shared.h SLICE_TEXTURE_BINDING), created on first use
  std::unique_ptr<GlTimerQuery> timer;  // created on first use (the context is current then)
  int out_w = 0, out_h = 0;
  BrickAtlas atlas;
  bool have_atlas = false;
  BrickSlotTable slot_table;         // which slot of the atlas holds which node's brick (brick_residency.h)
  TfNodeErrors tf_errors{store, 0};  // for the last transfer function rendered: recomputed when it changes
  // The most slots the device has agreed to allocate, once it refused more than --gpu-memory allows (llvmpipe caps a
  // texture at 1 GiB, below the default budget); UINT64_MAX until then.
  uint64_t device_slots = UINT64_MAX;
  std::optional<Bounds> clip_box;  // set_clip_box
  // Hybrid rendering: the cell cache (created on the first hybrid frame) and the exact nodes render() granted for the
  // render_nodes call it makes (node, cache entry); empty otherwise.
  std::unique_ptr<CellCache> cells;
  std::vector<std::pair<uint64_t, uint32_t>> exact_now;
  std::function<bool()> keep_going;  // set_keep_going: the frames' dispatch is banded and interruptible when set
  GlBuffer optical;                  // the exact engine's optical table, for the cells (optical.glsl)
  std::optional<TransferFunction> optical_tf;  // what it holds
  void choose_exact(std::span<const uint64_t> cut, const Camera& camera, const RenderSettings& settings,
                    LodRenderStats& st, uint64_t max_nodes = UINT64_MAX);

  Impl(const std::string& path, const GlContext& g, LodOptions o) : store(path), gl(g), options(o) {}
  // options.focus and roi resolved against the store (field indices), when they are set: the constructor,
  // set_interest.
  NodeInterest interest;
  // Tricubic isosurfaces were asked for (sticky, as the atlas's coefficients are): the budget counts the coefficient
  // texture and the margins from then on.
  bool cubic = false;
  // Bytes of the atlas per slot: texels at 4 bytes, and with `cubic` 2 bytes of coefficient and a float of margin.
  uint64_t slot_bytes() const;
  uint64_t budget_slots() const;
  void ensure_atlas(uint64_t needed);
  uint64_t load(std::span<const uint64_t> nodes, BrickResidency& residency);
  // Tricubic uploads: the nodes with bricks by (level, i, j, k), their neighbourhoods and where the fill lies; built on
  // first use.
  std::unique_ptr<SameLevelBricks> same_level;
  SameLevelBricks& same_level_bricks();
  uint64_t load_cubic(std::span<const uint64_t> nodes, const BrickSlotTable::Plan& plan, BrickResidency& residency,
                      double lo, double hi);
  // Level borders (brick_atlas.h, CubicLevelBlend): per direction (CubicNeighbourhood's index) the level of the cut
  // node there when it is coarser than the brick's, else kNotCoarser. A resident brick whose coarser neighbours
  // changed since its upload (uploaded_levels) is uploaded again into its slot.
  static constexpr uint8_t kNotCoarser = 0xff;
  using CoarserLevels = std::array<uint8_t, 27>;
  CoarserLevels coarser_levels(uint64_t node, const std::unordered_map<uint64_t, uint64_t>& cut_by_key) const;
  std::unordered_map<uint64_t, CoarserLevels> uploaded_levels;
  // The spline of `ancestor`'s level refined onto `node`'s lattice (refine_coefficients), from the ancestor's
  // coefficients.
  std::vector<double> refined_onto(uint64_t node, uint64_t ancestor, const std::vector<double>& coefficients) const;
  uint64_t neighbour_reads = 0;  // of the last load
  // Tricubic: the prefilter's coefficients per node (cubic_cache.h), within options.cubic_cache_bytes; prefilters
  // computed by the last load, and the cache's hits before it.
  CubicCoefficientCache cubic_cache{options.cubic_cache_bytes};
  uint64_t cubic_prefilters = 0, cubic_hits_before = 0;
  void upload_transfer_function(const TransferFunction& tf);
  lod_gpu::LodFrame frame_parameters(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                                     bool overlay) const;
  void upload_slice_colors(const TransferFunction& tf, const RenderSettings& settings);
};

ComputeProgram& LodEngine::Impl::program_for(int mode, bool volume_lighting, bool overlay, bool slices, bool tricubic,
                                             bool hybrid, int focus_windows) {
  auto it = programs.find({mode, volume_lighting, overlay, slices, tricubic, hybrid, focus_windows});
  if (it == programs.end()) {
    ComputeProgram p("lod_raycast.comp", {{"MODE", std::to_string(mode)},
                                          {"VOLUME_LIGHTING", volume_lighting ? "1" : "0"},
                                          {"OVERLAY", overlay ? "1" : "0"},
                                          {"FACES", faces ? "1" : "0"},
                                          {"SLICES", slices ? "1" : "0"},
                                          {"TRICUBIC", tricubic ? "1" : "0"},
                                          {"HYBRID", hybrid ? "1" : "0"},
                                          // A variant, not a branch on u_context.z: inside the sample loop's
                                          // per-lane branches llvmpipe ran even the untaken test, at 1.3x the frame.
                                          {"FOCUS_WINDOWS", std::to_string(focus_windows)}});
    check_contract(p);
    it = programs
             .emplace(std::make_tuple(mode, volume_lighting, overlay, slices, tricubic, hybrid, focus_windows),
                      std::move(p))
             .first;
  }
  return it->second;
}

uint64_t LodEngine::Impl::slot_bytes() const {
  const uint64_t side = store.resolution() + 2;
  return side * side * side * (cubic ? 6 : 4) + (cubic ? sizeof(float) : 0);
}

uint64_t LodEngine::Impl::budget_slots() const {
  // Slots stay below NODE_CONTEXT, the state's context bit (lod_shared.h).
  return std::min({BrickAtlas::max_slots(store.resolution(), gl.max_3d_texture_size()),
                   std::max<uint64_t>(1, options.atlas_budget_bytes / slot_bytes()), device_slots,
                   uint64_t(lod_gpu::NODE_CONTEXT)});
}

void LodEngine::Impl::ensure_atlas(uint64_t needed) {
  if (have_atlas && atlas.capacity() >= needed) return;
  // Grow with headroom so that a slowly growing cut does not reallocate every frame; a new atlas starts empty.
  const uint64_t want = std::max(needed, std::min(budget_slots(), std::max(needed + needed / 4, uint64_t(64))));
  atlas = BrickAtlas();
  have_atlas = false;
  // UGVR_ATLAS_MAX_BYTES (fault injection for tests and for trying a smaller device): atlases above it are refused as
  // an out-of-memory device would refuse them.
  const char* limit_env = std::getenv("UGVR_ATLAS_MAX_BYTES");
  const uint64_t injected_limit = limit_env && *limit_env ? std::strtoull(limit_env, nullptr, 10) : UINT64_MAX;
  const auto allocate = [&](uint64_t slots) {
    BrickAtlas a(store.resolution(), slots, gl.max_3d_texture_size());
    if (a.bytes() > injected_limit)
      fail_in("brick atlas",
              "allocating the brick atlas: refused above UGVR_ATLAS_MAX_BYTES = " + std::to_string(injected_limit));
    return a;
  };
  try {
    atlas = allocate(want);
  } catch (const Error& refused) {
    // The device would not allocate it although the budget allows it: find the largest atlas it does allocate
    // (bisection between 1 slot and `want`), make that the budget, and let the caller choose a cut that fits it.
    uint64_t ok = 0, bad = want;
    while (bad > ok + std::max<uint64_t>(1, bad / 64)) {
      const uint64_t mid = ok + (bad - ok) / 2;
      try {
        atlas = allocate(mid);
        ok = std::min(atlas.capacity(), bad - 1);  // slots round up to a box of slots: never past the refused count
        atlas = BrickAtlas();
      } catch (const Error&) {
        bad = mid;
      }
    }
    if (ok == 0) throw;
    device_slots = ok;
    const uint64_t bytes = ok * slot_bytes();
    // In the unit --gpu-memory takes (MiB, or KiB below 16 MiB), rounded down.
    const std::string flag =
        bytes >= (uint64_t(16) << 20) ? std::to_string(bytes >> 20) + "MiB" : std::to_string(bytes >> 10) + "KiB";
    std::fprintf(stderr,
                 "ugvr: the GPU refused a brick atlas of %llu bricks (%s); the budget is now %llu bricks (%s): "
                 "--gpu-memory %s avoids this probe\n",
                 (unsigned long long)want, refused.what(), (unsigned long long)ok, flag.c_str(), flag.c_str());
    throw AtlasRefused("the GPU allocates at most " + std::to_string(ok) + " bricks (" + flag + "); the cut of " +
                       std::to_string(needed) + " bricks must be chosen again");
  }
  have_atlas = true;
  slot_table.reset(atlas.capacity());
}

// Gives every cut node a slot, keeping resident ones where they are, and uploads the missing bricks the residency
// fetches (free slots first, then those of the bricks drawn least recently: BrickSlotTable), a batch at a time.
uint64_t LodEngine::Impl::load(std::span<const uint64_t> nodes, BrickResidency& residency) {
  const BrickSlotTable::Plan plan = residency.plan(nodes);
  const double lo = store.layout().fields[field].min, hi = store.layout().fields[field].max;
  neighbour_reads = 0;
  cubic_prefilters = 0;
  cubic_hits_before = cubic_cache.hits();
  if (atlas.has_coefficients()) return load_cubic(nodes, plan, residency, lo, hi);
  std::vector<std::vector<uint16_t>> read(kLoadBatch);
  std::vector<BrickResidency::Texels> ram(kLoadBatch);
  for (size_t b = 0; b < plan.missing.size(); b += kLoadBatch) {
    const size_t count = std::min(kLoadBatch, plan.missing.size() - b);
    residency.fetch(plan, b, count, field, lo, hi, ram, read);
    for (size_t i = 0; i < count; ++i) {
      atlas.upload(plan.slots[b + i], ram[i] ? ram[i]->data() : read[i].data());
      residency.place(plan.missing[b + i], plan.slots[b + i]);
    }
  }
  if (!plan.missing.empty()) check_gl("uploading bricks");
  return plan.missing.size();
}

namespace {
// A node by (level, i, j, k): 4 bits of level and 20 of each index (the store's depth limit).
uint64_t level_key(uint64_t level, int64_t i, int64_t j, int64_t k) {
  return level << 60 | uint64_t(i) << 40 | uint64_t(j) << 20 | uint64_t(k);
}
}  // namespace

LodEngine::Impl::CoarserLevels LodEngine::Impl::coarser_levels(
    uint64_t node, const std::unordered_map<uint64_t, uint64_t>& cut_by_key) const {
  CoarserLevels levels;
  levels.fill(kNotCoarser);
  const BrickNode& b = store.node(node);
  const int64_t side = int64_t(1) << b.level;
  for (int d = 0; d < 27; ++d) {
    if (d == 13) continue;
    const int64_t i = int64_t(b.i) + d % 3 - 1, j = int64_t(b.j) + d / 3 % 3 - 1, k = int64_t(b.k) + d / 9 - 1;
    if (i < 0 || j < 0 || k < 0 || i >= side || j >= side || k >= side) continue;
    for (int level = int(b.level) - 1; level >= 0; --level) {
      const int up = int(b.level) - level;
      if (cut_by_key.count(level_key(uint64_t(level), i >> up, j >> up, k >> up))) {
        levels[size_t(d)] = uint8_t(level);
        break;
      }
    }
  }
  return levels;
}

std::vector<double> LodEngine::Impl::refined_onto(uint64_t node, uint64_t ancestor,
                                                  const std::vector<double>& coefficients) const {
  const BrickNode &b = store.node(node), &a = store.node(ancestor);
  std::vector<double> c = coefficients;
  for (uint32_t level = a.level + 1; level <= b.level; ++level) {
    const uint32_t up = b.level - level;  // the descendant at `level` on the way to node
    const int octant = int((b.i >> up) & 1) | int((b.j >> up) & 1) << 1 | int((b.k >> up) & 1) << 2;
    refine_coefficients(store.resolution(), c, octant, c);
  }
  return c;
}

SameLevelBricks& LodEngine::Impl::same_level_bricks() {
  if (!same_level) same_level = std::make_unique<SameLevelBricks>(store);
  return *same_level;
}

// load() for tricubic frames: each brick is prefiltered over its same-level neighbourhood (brick_atlas.h,
// cubic_coefficients), so that neighbours hold nearly the same spline across their shared faces (docs/tricubic.md,
// "Seams"). The neighbours' texels come from the batch itself, the session's RAM tier where it has them, or the
// store (read here, in parallel; counted in neighbour_reads); they live for one batch, whose size keeps them within
// kNeighbourStagingBytes. A neighbour that is not in the store at that level (a coarser leaf there, the domain's
// border) leaves that side to the brick's own end condition.
// Level borders: a brick next to coarser cut nodes blends into their level's spline (CubicLevelBlend), computed from
// its ancestor at that level (prefiltered over the ancestor's own neighbourhood, read as above) refined onto the
// brick's lattice. That depends on the cut around the brick, so a resident brick is uploaded again when its coarser
// neighbours change (counted in the frame's bricks_loaded).
uint64_t LodEngine::Impl::load_cubic(std::span<const uint64_t> nodes, const BrickSlotTable::Plan& cut_plan,
                                     BrickResidency& residency, double lo, double hi) {
  const uint32_t r = store.resolution();
  const uint64_t side = r + 2, texel_bytes = side * side * side * 4;
  // A brick's neighbourhood, and its ancestors' at a level border: two neighbourhoods a brick at most.
  const size_t batch = size_t(std::clamp<uint64_t>(kNeighbourStagingBytes / (2 * 27 * texel_bytes), 1, kLoadBatch));
  BrickCache* ram = residency.ram();
  const bool ram_usable = ram && ram->field() == field && ram->step() == store.step();
  const bool blend = atlas.level_blend();
  std::unordered_map<uint64_t, uint64_t> cut_by_key;
  if (blend)
    for (uint64_t n : nodes) {
      const BrickNode& b = store.node(n);
      cut_by_key.emplace(level_key(b.level, b.i, b.j, b.k), n);
    }
  // The cut's levels around each brick; resident bricks whose coarser neighbours changed go again into their slots.
  BrickSlotTable::Plan plan = cut_plan;
  std::unordered_map<uint64_t, CoarserLevels> levels_of;
  for (uint64_t n : nodes) {
    CoarserLevels levels;
    levels.fill(kNotCoarser);
    if (blend) levels = coarser_levels(n, cut_by_key);
    levels_of[n] = levels;
  }
  const std::unordered_set<uint64_t> planned(plan.missing.begin(), plan.missing.end());
  for (uint64_t n : nodes) {
    if (planned.count(n) || !residency.gpu().contains(n)) continue;
    const auto was = uploaded_levels.find(n);
    if (was != uploaded_levels.end() && was->second == levels_of[n]) continue;
    plan.missing.push_back(n);
    plan.slots.push_back(residency.gpu().slot(n));
  }
  std::vector<std::vector<uint16_t>> read(batch);
  SameLevelBricks& by_level = same_level_bricks();
  cubic_cache.use({field, store.step(), lo, hi, atlas.extension(), atlas.fill()});
  constexpr uint64_t kNoData = SameLevelBricks::kNoData;
  const std::vector<uint16_t> no_data(side * side * side * 2, 0);  // value 0, stencil 0: no sample has data
  std::vector<BrickResidency::Texels> from_ram(batch);
  for (size_t b = 0; b < plan.missing.size(); b += batch) {
    const size_t count = std::min(batch, plan.missing.size() - b);
    residency.fetch(plan, b, count, field, lo, hi, from_ram, read);
    std::unordered_map<uint64_t, const uint16_t*> texels;
    for (size_t i = 0; i < count; ++i) texels[plan.missing[b + i]] = from_ram[i] ? from_ram[i]->data() : read[i].data();
    std::vector<uint64_t> to_read;
    std::vector<BrickResidency::Texels> held;
    // node's texels: the batch's, the RAM tier's, or to be read.
    const auto want = [&](uint64_t n) {
      if (n == kNoNode || n == kNoData || texels.count(n)) return;
      if (ram_usable && ram->resident(n)) {
        if (BrickResidency::Texels t = ram->get(n)) {
          texels[n] = t->data();
          held.push_back(std::move(t));
          return;
        }
      }
      texels[n] = nullptr;
      to_read.push_back(n);
    };
    // Each brick's prefilter, and its ancestors' at the coarser levels next to it (the level blend): from the
    // coefficient cache, or computed below over the node's same-level neighbourhood, whose texels are then gathered.
    // A same-level position inside the root cell without a brick (an empty octant, or a coarser leaf there) is
    // kNoData: a brick whose samples all lack data, which the prefilter fills like any partial neighbour
    // (brick_atlas.h, cubic_coefficients), so that the bricks around it extend their splines into it alike; outside the
    // root cell kNoNode: the side is dropped (the domain's border, the not-a-knot end).
    std::unordered_map<uint64_t, CubicCoefficientCache::Shared> prefiltered;
    std::vector<uint64_t> to_prefilter;
    const auto need = [&](uint64_t n) {
      if (prefiltered.count(n)) return;
      CubicCoefficientCache::Shared kept = cubic_cache.find(n);
      if (!kept) {
        to_prefilter.push_back(n);
        want(n);
        for (uint64_t m : by_level.around(n)) want(m);
      }
      prefiltered[n] = std::move(kept);
    };
    for (size_t i = 0; i < count; ++i) {
      const uint64_t n = plan.missing[b + i];
      need(n);
      const BrickNode& node = store.node(n);
      for (uint8_t level : levels_of[n]) {
        if (level == kNotCoarser) continue;
        const int up = int(node.level) - level;
        const uint64_t a = by_level.at(level, node.i >> up, node.j >> up, node.k >> up);
        if (a != kNoNode) need(a);
      }
    }
    // Where the fill lies within two bricks (the prefilter's reach, brick_atlas.h cubic_reach); asked here, on one
    // thread: SameLevelBricks keeps each node's answer.
    std::vector<char> near_fill(to_prefilter.size());
    for (size_t i = 0; i < to_prefilter.size(); ++i) near_fill[i] = by_level.fill_within_two(to_prefilter[i]);
    std::vector<std::vector<uint16_t>> extra(to_read.size());
    tbb::parallel_for(size_t(0), to_read.size(), [&](size_t i) {
      thread_local std::vector<float> samples;
      thread_local std::vector<uint8_t> mask;
      samples.resize(size_t(r) * r * r);
      mask.resize(size_t(r) * r * r);
      store.read_brick(to_read[i], field, samples.data(), mask.data());
      make_atlas_slot(r, samples.data(), mask.data(), lo, hi, extra[i]);
    });
    for (size_t i = 0; i < to_read.size(); ++i) texels[to_read[i]] = extra[i].data();
    neighbour_reads += to_read.size();
    // The prefilters in parallel (the upload's CPU cost; SameLevelBricks::around is const), then into the cache.
    std::vector<CubicCoefficientCache::Entry> computed(to_prefilter.size());
    tbb::parallel_for(size_t(0), to_prefilter.size(), [&](size_t i) {
      const std::array<uint64_t, 27> ids = by_level.around(to_prefilter[i]);
      CubicNeighbourhood hood{};
      for (size_t d = 0; d < 27; ++d)
        if (ids[d] == kNoData)
          hood[d] = no_data.data();
        else if (ids[d] != kNoNode)
          hood[d] = texels.at(ids[d]);
      computed[i].prefiltered = cubic_coefficients(r, texels.at(to_prefilter[i]), computed[i].coefficients, &hood,
                                                   atlas.extension(), atlas.fill(), near_fill[i] != 0);
    });
    for (size_t i = 0; i < to_prefilter.size(); ++i)
      prefiltered[to_prefilter[i]] = cubic_cache.put(to_prefilter[i], std::move(computed[i]));
    cubic_prefilters += to_prefilter.size();
    // The batch's splines (level blend, codes and margins) in parallel, then into their slots.
    std::vector<BrickAtlas::CubicSlot> splines(count);
    tbb::parallel_for(size_t(0), count, [&](size_t i) {
      const uint64_t n = plan.missing[b + i];
      CubicLevelBlend levels;
      const BrickNode& node = store.node(n);
      for (int level = int(node.level) - 1; level >= 0; --level) {  // the finest coarser level first
        CubicLevelTarget target;
        for (size_t d = 0; d < 27; ++d) target.towards[d] = levels_of.at(n)[d] == level;
        if (std::none_of(target.towards.begin(), target.towards.end(), [](bool t) { return t; })) continue;
        const int up = int(node.level) - level;
        const uint64_t a = by_level.at(uint64_t(level), node.i >> up, node.j >> up, node.k >> up);
        const auto ancestor = prefiltered.find(a);
        if (ancestor == prefiltered.end() || !ancestor->second->prefiltered) continue;
        target.coefficients = refined_onto(n, a, ancestor->second->coefficients);
        levels.push_back(std::move(target));
      }
      const CubicCoefficientCache::Entry& own = *prefiltered.at(n);
      splines[i] = atlas.cubic_slot_of(texels.at(n), own.prefiltered ? &own.coefficients : nullptr, &levels);
    });
    for (size_t i = 0; i < count; ++i) {
      const uint64_t n = plan.missing[b + i];
      atlas.upload(plan.slots[b + i], texels.at(n), &splines[i]);
      residency.place(n, plan.slots[b + i]);
      uploaded_levels[n] = levels_of[n];
    }
  }
  if (!plan.missing.empty()) check_gl("uploading bricks");
  return plan.missing.size();
}

// The transfer function over its own range, TF_TEXELS texels; values reach it through the frame's u_tf_map. Also its
// integrals for pre-integration (lod_shared.h, shaders/lod_raycast.comp integral_at): texel i holds
// (∫ c·τ du, ∫ τ du) from u = 0 to u_i = i / (n - 1), u the position in the range (0 to 1), by Simpson's rule on each
// texel's interval (colour and opacity are piecewise linear, τ = -ln(1 - opacity) / d is not: Simpson's error is
// far below float's there), summed in double. 2n - 1 evaluations of the transfer function, about 0.15 ms, on every
// frame as the colour table always was (a transfer-function edit changes nothing else).
void LodEngine::Impl::upload_transfer_function(const TransferFunction& tf) {
  const int n = lod_gpu::TF_TEXELS;
  const double t_lo = tf.range_min(), t_hi = tf.range_max();
  std::vector<float> table(size_t(n) * 4), integrals(size_t(n) * 4);
  // (c·τ, τ) at u.
  auto at = [&](double u) {
    const double s = t_lo + (t_hi - t_lo) * u, tau = tf.extinction(s);
    const Vec3d c = tf.color(s);
    return std::array<double, 4>{c.x * tau, c.y * tau, c.z * tau, tau};
  };
  std::array<double, 4> sum{0, 0, 0, 0}, prev{};
  const double h = 1.0 / double(n - 1);
  for (int i = 0; i < n; ++i) {
    const double u = double(i) * h;
    const std::array<double, 4> cur = at(u);
    const Vec3d c = tf.color(t_lo + (t_hi - t_lo) * u);  // as it is where τ = 0 (MIP and isosurfaces show it)
    table[size_t(i) * 4 + 0] = float(c.x), table[size_t(i) * 4 + 1] = float(c.y);
    table[size_t(i) * 4 + 2] = float(c.z), table[size_t(i) * 4 + 3] = float(cur[3]);
    if (i > 0) {
      const std::array<double, 4> mid = at(u - 0.5 * h);
      for (size_t k = 0; k < 4; ++k) sum[k] += h / 6 * (prev[k] + 4 * mid[k] + cur[k]);
    }
    prev = cur;
    for (size_t k = 0; k < 4; ++k) integrals[size_t(i) * 4 + k] = float(sum[k]);
  }
  glTextureSubImage1D(tf_texture.id(), 0, 0, n, GL_RGBA, GL_FLOAT, table.data());
  glTextureSubImage1D(preint_texture.id(), 0, 0, n, GL_RGBA, GL_FLOAT, integrals.data());
}

namespace {

// 1 / EDGE for the shader's window, which multiplies by it (no division per sample); a range without an edge (or one
// too narrow for float) gets the largest float: any distance > 0 then reaches the window's end at once.
float inverse_edge(double edge) {
  const double inv = edge > 0 ? 1 / edge : HUGE_VAL;
  return float(std::min(inv, double(std::numeric_limits<float>::max())));
}

// Smooth brush edges (docs/hybrid.md): the focus ranges as windows on each sample's value (LodFrame u_focus, count in
// u_context.z), in transfer-function coordinates. Only when every range is on the rendered field, there is no region
// of interest (whose border is a box, not a value), some range has an edge (without one the node-level rule stays,
// bit for bit), they fit the block and the transfer function has a width; otherwise none, and the nodes' interest
// alone decides (NODE_CONTEXT).
void set_focus_windows(lod_gpu::LodFrame& f, const NodeInterest& interest, uint32_t field, double t_lo,
                       double tf_width) {
  const std::vector<ResolvedFocus>& focus = interest.focus;
  const bool on_field =
      std::all_of(focus.begin(), focus.end(), [&](const ResolvedFocus& r) { return r.field == field; });
  const bool edged = std::any_of(focus.begin(), focus.end(), [](const ResolvedFocus& r) { return r.edge > 0; });
  if (focus.empty() || interest.roi || !on_field || !edged || focus.size() > size_t(LOD_MAX_FOCUS_WINDOWS) ||
      !(tf_width > 0))
    return;
  for (size_t i = 0; i < focus.size(); ++i)
    f.u_focus[i] = {float((focus[i].min - t_lo) / tf_width), float((focus[i].max - t_lo) / tf_width),
                    inverse_edge(focus[i].edge / tf_width), float(focus[i].group)};
  f.u_context.z = float(focus.size());
  f.u_focus_map = {float(1 / tf_width), float(-t_lo / tf_width), 0.0f, 0.0f};
}

}  // namespace

// The shader's per-frame parameters: computed in double, passed as float. Coordinates are normalised to the root cell
// (lod_shared.h).
lod_gpu::LodFrame LodEngine::Impl::frame_parameters(const Camera& camera, const TransferFunction& tf,
                                                    const RenderSettings& settings, bool overlay) const {
  lod_gpu::LodFrame f{};
  const Bounds& root = store.layout().root;
  const Vec3d root_size = root.size();
  set_camera(f, camera, settings.width, settings.height, root);
  f.u_root_size = to_float(root_size);
  f.u_resolution = int(store.resolution());
  const int* slots = atlas.slots_per_axis();
  const int* texels = atlas.texels_per_axis();
  f.u_slots = {slots[0], slots[1], slots[2]};
  f.u_atlas_inv = {1.0f / float(texels[0]), 1.0f / float(texels[1]), 1.0f / float(texels[2])};
  const double min_side = std::min({root_size.x, root_size.y, root_size.z});
  const bool fixed_step = settings.sample_step > 0;
  const double step0 =
      fixed_step ? settings.sample_step : options.step_voxels * min_side / double(store.resolution() - 1);
  f.u_step0 = float(step0);
  f.u_fixed_step = fixed_step ? 1 : 0;
  // Values are normalised to the field's range in the atlas; the table spans the transfer function's.
  const double f_lo = store.layout().fields[field].min, f_hi = store.layout().fields[field].max;
  const double t_lo = tf.range_min(), tf_width = tf.range_max() - t_lo;
  f.u_tf_map = {tf_width > 0 ? float((f_hi - f_lo) / tf_width) : 0.0f,
                tf_width > 0 ? float((f_lo - t_lo) / tf_width) : 0.0f};
  f.u_unit_distance = float(tf.opacity_unit_distance);
  std::vector<float> iso;
  for (double v : settings.iso_values) iso.push_back(f_hi > f_lo ? float((v - f_lo) / (f_hi - f_lo)) : 0.0f);
  std::sort(iso.begin(), iso.end());
  f.u_iso_count = int(iso.size());
  // Four to a vec4 (render_nodes checked the count).
  if (!iso.empty()) std::memcpy(f.u_iso, iso.data(), iso.size() * sizeof(float));
  f.u_iso_opacity = float(settings.iso_opacity);
  f.u_lighting = settings.lighting ? 1 : 0;
  f.u_min_transmittance = float(1 - settings.early_termination_opacity);
  f.u_loop_probe = 2;
  f.u_clip = settings.clip_plane ? 1 : 0;
  if (settings.clip_plane) f.u_clip_plane = normalised_plane(*settings.clip_plane, root);
  f.u_overlay_opacity = overlay ? float(settings.boundary_overlay_opacity) : 0.0f;
  // Hybrid: the non-linear cells' tolerance as the exact engine takes it by default (1e-3 of the transfer function's
  // range, ExactEngine::tolerance_abs), in the field's units as the cells' values are.
  f.u_cell_tolerance = float(1e-3 * (tf_width > 0 ? tf_width : std::max(f_hi - f_lo, 1e-30)));
  f.u_cell_data = store.layout().fields[field].association == Association::Cell ? 1 : 0;
  f.u_nudge = float(2e-6 * std::max({root_size.x, root_size.y, root_size.z}));
  // Slices: the planes as the clip plane is passed; each colour table spans the slice's range (or the transfer
  // function's), reached from the normalised value as u_tf_map reaches the transfer function's table.
  static_assert(LOD_MAX_SLICES == kMaxSlices);
  f.u_slice_count = int(settings.slices.size());
  f.u_hide_volume = int(settings.hide_volume);
  for (size_t i = 0; i < settings.slices.size(); ++i) {
    const Slice& sl = settings.slices[i];
    f.u_slice_plane[i] = normalised_plane(ClipPlane{sl.point, sl.normal}, root);
    const double r_lo = sl.range ? (*sl.range)[0] : tf.range_min();
    const double r_w = (sl.range ? (*sl.range)[1] : tf.range_max()) - r_lo;
    f.u_slice_map[i] = {r_w > 0 ? float((f_hi - f_lo) / r_w) : 0.0f, r_w > 0 ? float((f_lo - r_lo) / r_w) : 0.0f,
                        float(sl.opacity), 0.0f};
  }
  if (clip_box) {
    // Normalised, and kept within [-1, 2] (the root cell is [0, 1]): no infinities reach the shader.
    auto norm = [&](double v, double lo, double size) { return float(std::clamp((v - lo) / size, -1.0, 2.0)); };
    const Bounds& b = *clip_box;
    f.u_box_lo = {norm(b.lo.x, root.lo.x, root_size.x), norm(b.lo.y, root.lo.y, root_size.y),
                  norm(b.lo.z, root.lo.z, root_size.z), 1.0f};
    f.u_box_hi = {norm(b.hi.x, root.lo.x, root_size.x), norm(b.hi.y, root.lo.y, root_size.y),
                  norm(b.hi.z, root.lo.z, root_size.z), 0.0f};
  }
  f.u_context = {float(options.context_saturation), float(options.context_opacity), 0.0f, 0.0f};
  set_focus_windows(f, interest, field, t_lo, tf_width);
  // Hybrid MIP: a cell's value normalised to the field's range, as the atlas holds the bricks' samples.
  f.u_focus_map.z = f_hi > f_lo ? float(1 / (f_hi - f_lo)) : 0.0f;
  f.u_focus_map.w = f_hi > f_lo ? float(-f_lo / (f_hi - f_lo)) : 0.0f;
  return f;
}

// One row of SLICE_TEXELS colours per slice over its range: the volume's transfer function or a built-in preset.
void LodEngine::Impl::upload_slice_colors(const TransferFunction& tf, const RenderSettings& settings) {
  if (!slice_texture.id()) {
    slice_texture = GlTexture(GL_TEXTURE_2D);
    // Rows 0..7 the colour tables, 8..15 the contour lines (shaders/slice_contours.glsl).
    glTextureStorage2D(slice_texture.id(), 1, GL_RGBA32F, lod_gpu::SLICE_TEXELS, 2 * LOD_MAX_SLICES);
    glTextureParameteri(slice_texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(slice_texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(slice_texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(slice_texture.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  const int n = lod_gpu::SLICE_TEXELS;
  std::vector<float> row(size_t(n) * 4);
  for (size_t i = 0; i < settings.slices.size(); ++i) {
    const Slice& sl = settings.slices[i];
    TransferFunction colors = sl.color_map.empty() ? tf : builtin_preset(sl.color_map);
    const double r_lo = sl.range ? (*sl.range)[0] : tf.range_min();
    const double r_hi = sl.range ? (*sl.range)[1] : tf.range_max();
    if (!sl.color_map.empty() || sl.range) colors.rescale(r_lo, r_hi);
    for (int k = 0; k < n; ++k) {
      const Vec3d c = colors.color(r_lo + (r_hi - r_lo) * double(k) / double(n - 1));
      row[size_t(k) * 4 + 0] = float(c.x), row[size_t(k) * 4 + 1] = float(c.y);
      row[size_t(k) * 4 + 2] = float(c.z), row[size_t(k) * 4 + 3] = 1.0f;
    }
    glTextureSubImage2D(slice_texture.id(), 0, 0, GLint(i), n, 1, GL_RGBA, GL_FLOAT, row.data());
    // The contour values in the shader's units, normalised to the field's range as the bricks' values are.
    const double f_lo = store.layout().fields[field].min, f_w = store.layout().fields[field].max - f_lo;
    const std::vector<float> lines = slice_contour_row(sl, slice_contour_values(sl, tf.range_min(), tf.range_max()),
                                                       f_w > 0 ? 1 / f_w : 0, f_w > 0 ? -f_lo / f_w : 0);
    glTextureSubImage2D(slice_texture.id(), 0, 0, GLint(LOD_MAX_SLICES + i), GLsizei(lines.size() / 4), 1, GL_RGBA,
                        GL_FLOAT, lines.data());
  }
}

// Hybrid rendering: which of the cut's nodes are drawn by their cells this frame (hybrid_select.h, cell_cache.h).
void LodEngine::Impl::choose_exact(std::span<const uint64_t> cut, const Camera& camera, const RenderSettings& settings,
                                   LodRenderStats& st, uint64_t max_nodes) {
  exact_now.clear();
  if (!options.hybrid) return;
  st.hybrid = true;
  if (!store.has_cells()) {
    st.hybrid_off = "the store keeps no cells (ugvr build --cells)";
  } else if (settings.mode == RenderMode::Isosurface && settings.interpolation == Interpolation::Tricubic) {
    st.hybrid_off = "exact cells draw isosurfaces with trilinear interpolation only";
  } else if (settings.mode == RenderMode::Isosurface && store.layout().fields[field].association == Association::Cell) {
    st.hybrid_off = "exact cells draw the isosurfaces of vertex fields only";
  } else if (boundary_overlay_on(settings) || !settings.slices.empty() || settings.hide_volume != HideVolume::None) {
    st.hybrid_off = "exact cells are drawn without the boundary overlay and slices only";
  } else if (settings.mode == RenderMode::EmissionAbsorption && settings.volume_lighting) {
    // The exact pieces would be unlit among lit voxels (the HYBRID variant's pieces take no shade).
    st.hybrid_off = "exact cells are drawn without volume lighting only";
  }
  if (!st.hybrid_off.empty()) return;
  const auto t0 = std::chrono::steady_clock::now();
  const uint64_t budget = options.cell_budget_bytes ? options.cell_budget_bytes : options.atlas_budget_bytes / 4;
  if (!cells || cells->budget_bytes() != budget) cells = std::make_unique<CellCache>(store, budget);
  // The transfer-function-aware error is emission-absorption's: a node transparent there still holds a MIP maximum
  // or an isosurface, so in those modes the screen-space error alone orders the nodes with cells.
  const TfNodeErrors unweighted(store, field);
  const std::vector<ExactCandidate> cand = exact_candidates(
      store, cut, camera, settings.width, settings.height,
      settings.mode == RenderMode::EmissionAbsorption ? tf_errors : unweighted, interest, &st.focus_excluded);
  std::vector<uint64_t> order;
  order.reserve(cand.size());
  for (const ExactCandidate& c : cand) order.push_back(c.node);
  const CellCache::Grant g = cells->grant(order, field, std::min(options.max_exact_nodes, max_nodes));
  for (size_t i = 0; i < g.nodes.size(); ++i) exact_now.emplace_back(g.nodes[i], g.entries[i]);
  st.exact_candidates = cand.size();
  st.exact_nodes = g.nodes.size();
  st.exact_cells = g.cells;
  st.cell_bytes = g.bytes;
  st.cell_budget_bytes = budget;
  st.cells_prepared = g.prepared;
  st.cells_swapped = g.swapped;
  st.cell_budget_full = g.budget_full;
  st.cells_seconds = seconds_since(t0);
}

namespace {

// The boundary faces for the shader: per entry (node, then virtual node) its first reference and count as stored (a
// node over the cap: count FACE_OVERFLOW, the shader looks in its descendants), except an entry whose faces all lie
// on one plane that they cover (boundary_face_planes): count FACE_PLANE and, instead of a reference, where the plane
// lies in the triangle buffer, past the triangles (n.xyz, w: n·p = w, n outward). The references and the triangles.
void upload_boundary_faces(const BrickStoreReader& store, bool with_planes, GlBuffer& face_nodes, GlBuffer& face_refs,
                           GlBuffer& face_tris) {
  static_assert(lod_gpu::FACE_OVERFLOW == store_format::kBoundaryOverflow);
  static_assert(lod_gpu::FACE_PLANE != store_format::kBoundaryOverflow);
  const StoreBoundary& b = store.boundary();
  std::vector<std::optional<BoundaryPlane>> planes(b.nodes.size());
  if (with_planes) {
    const std::vector<OctreeNode> tree(store.nodes().begin(), store.nodes().end());
    planes = boundary_face_planes(b, tree);
  }
  std::vector<float> tris(b.triangles.size() * 9);
  if (!b.triangles.empty()) std::memcpy(tris.data(), b.triangles.data(), tris.size() * sizeof(float));
  std::vector<uint32_t> entries(b.nodes.size() * 2);
  for (size_t n = 0; n < b.nodes.size(); ++n) {
    entries[2 * n] = b.nodes[n].first;
    entries[2 * n + 1] = b.nodes[n].count;
    if (const std::optional<BoundaryPlane>& p = planes[n]) {
      if (tris.size() + 4 >= lod_gpu::FACE_PLANE) continue;  // past what an entry can address: the triangles
      entries[2 * n] = uint32_t(tris.size());
      entries[2 * n + 1] = lod_gpu::FACE_PLANE;
      tris.insert(tris.end(), {float(p->normal.x), float(p->normal.y), float(p->normal.z), float(p->offset)});
    }
  }
  const uint32_t none = 0;
  face_nodes.upload(entries.data(), entries.size() * sizeof(uint32_t));
  if (b.refs.empty()) {
    face_refs.upload(&none, sizeof none);
  } else {
    face_refs.upload(b.refs.data(), b.refs.size() * sizeof(uint32_t));
  }
  if (tris.empty()) {
    face_tris.upload(&none, sizeof none);
  } else {
    face_tris.upload(tris.data(), tris.size() * sizeof(float));
  }
}

}  // namespace

LodEngine::LodEngine(const std::string& store_path, const GlContext& gl, LodOptions options)
    : impl_(std::make_unique<Impl>(store_path, gl, options)) {
  Impl& I = *impl_;
  if (I.store.resolution() < 2) fail_in(store_path, "brick resolution below 2");
  if (I.store.node_count() >= lod_gpu::NODE_DESCEND)
    fail_in(store_path, "too many nodes for the GPU node table (2^32 - 2)");
  I.options.validate();
  I.interest = {resolve_focus(I.store, I.options.focus), I.options.roi};  // an unknown --focus field fails here
  gl.make_current();
  I.faces = I.store.has_boundary();
  if (I.faces) {
    // UGVR_NO_FACE_PLANES set: the triangles everywhere, the same image (for comparisons: tests, bench).
    const bool planes = !std::getenv("UGVR_NO_FACE_PLANES");
    upload_boundary_faces(I.store, planes, I.face_nodes, I.face_refs, I.face_tris);
  }
  I.program_for(LOD_MODE_EA, false, false);  // compile errors surface here, not at the first frame
  // The octree, static: first child and child mask | level << 8 per node.
  std::vector<uint32_t> tree(I.store.node_count() * 2);
  for (uint64_t n = 0; n < I.store.node_count(); ++n) {
    const BrickNode& node = I.store.node(n);
    tree[2 * n] = node.first_child == kNoNode ? 0u : uint32_t(node.first_child);
    tree[2 * n + 1] = uint32_t(node.child_mask) | uint32_t(node.level) << lod_gpu::TREE_LEVEL_SHIFT;
  }
  I.tree.upload(tree.data(), tree.size() * sizeof(uint32_t));
  I.tf_texture = GlTexture(GL_TEXTURE_1D);
  glTextureStorage1D(I.tf_texture.id(), 1, GL_RGBA32F, lod_gpu::TF_TEXELS);
  glTextureParameteri(I.tf_texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(I.tf_texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(I.tf_texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  I.preint_texture = GlTexture(GL_TEXTURE_1D);
  glTextureStorage1D(I.preint_texture.id(), 1, GL_RGBA32F, lod_gpu::TF_TEXELS);
  glTextureParameteri(I.preint_texture.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(I.preint_texture.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(I.preint_texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  check_gl("creating the lod engine");
}

LodEngine::~LodEngine() = default;

void LodEngine::set_field(std::string_view name) {
  Impl& I = *impl_;
  int f = name.empty() ? 0 : I.store.field_index(name);
  if (f < 0) {
    std::string names;
    for (const BrickStoreField& fd : I.store.layout().fields) names += (names.empty() ? "" : ", ") + fd.name;
    fail_in(I.store.path(), "no field \"" + std::string(name) + "\" in the store (fields: " + names + ")");
  }
  if (uint32_t(f) != I.field) {
    I.field = uint32_t(f);
    I.slot_table.clear();
  }
}

void LodEngine::set_time_step(uint32_t step) {
  Impl& I = *impl_;
  if (step == I.store.step()) return;
  I.store.set_step(step);
  I.slot_table.clear();
}
uint32_t LodEngine::time_step() const { return impl_->store.step(); }

const std::string& LodEngine::field_name() const { return impl_->store.layout().fields[impl_->field].name; }
double LodEngine::field_min() const { return impl_->store.layout().fields[impl_->field].min; }
double LodEngine::field_max() const { return impl_->store.layout().fields[impl_->field].max; }
void LodEngine::set_clip_box(std::optional<Bounds> box) { impl_->clip_box = box; }
void LodEngine::set_keep_going(std::function<bool()> keep_going) { impl_->keep_going = std::move(keep_going); }
Bounds LodEngine::bounds() const { return impl_->store.layout().data; }
uint64_t LodEngine::node_count() const { return impl_->store.node_count(); }
uint32_t LodEngine::resolution() const { return impl_->store.resolution(); }

Image LodEngine::render(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                        const CutSpec& cut_spec, LodRenderStats* stats) {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  LodRenderStats st;
  // The cut, within what the atlas may hold.
  CutOptions co;
  co.field = I.field;
  if (tricubic_iso(settings)) I.cubic = true;  // the cut then fits the atlas with its coefficients
  co.max_nodes = I.budget_slots();
  const TfCutRules rules = tf_cut_rules(settings);
  co.tf_cull = rules.cull, co.tf_error = rules.error;
  I.tf_errors.set_field(I.field);
  I.tf_errors.update(tf);
  co.tf_errors = &I.tf_errors;
  // With a clip box only the nodes that meet it are drawn (the rays sample nothing outside it): a rank of a
  // data-parallel job uploads its part of the cut, not all of it.
  auto in_box = [&](Cut& c) {
    if (!I.clip_box) return;
    const Bounds& box = *I.clip_box;
    std::erase_if(c.nodes, [&](uint64_t n) {
      const Bounds b = I.store.bounds(n);
      return b.hi.x < box.lo.x || b.lo.x > box.hi.x || b.hi.y < box.lo.y || b.lo.y > box.hi.y || b.hi.z < box.lo.z ||
             b.lo.z > box.hi.z;
    });
  };
  Cut cut = select_cut(I.store, cut_spec, camera, settings.width, settings.height, tf, co);
  in_box(cut);
  st.cut_seconds = seconds_since(t0);
  BrickResidency from_store(I.store, I.slot_table);  // no RAM tier: the bricks are read here
  Image image;
  struct ClearExact {
    Impl& impl;
    ~ClearExact() { impl.exact_now.clear(); }
  } clear_exact{I};
  try {
    I.choose_exact(cut.nodes, camera, settings, st);
    image = render_nodes(camera, tf, settings, cut.nodes, from_store, &st);
  } catch (const AtlasRefused&) {
    // The device allocates less than the budget: the cut again, within what it does allocate (once).
    co.max_nodes = I.budget_slots();
    cut = select_cut(I.store, cut_spec, camera, settings.width, settings.height, tf, co);
    in_box(cut);
    I.choose_exact(cut.nodes, camera, settings, st);
    image = render_nodes(camera, tf, settings, cut.nodes, from_store, &st);
  }
  st.cut_nodes = cut.nodes.size();
  st.culled_frustum = cut.culled_frustum;
  st.culled_tf = cut.culled_tf;
  st.budget_limited = cut.budget_limited;
  st.max_level = cut.max_level;
  st.mean_level = cut.mean_level;
  st.render_seconds = seconds_since(t0);
  if (stats) *stats = st;
  return image;
}

BrickSlotTable& LodEngine::gpu_slots() { return impl_->slot_table; }
const BrickSlotTable& LodEngine::gpu_slots() const { return impl_->slot_table; }
uint64_t LodEngine::atlas_budget_bricks() const { return impl_->budget_slots(); }
const BrickStoreReader& LodEngine::store() const { return impl_->store; }
uint32_t LodEngine::field() const { return impl_->field; }
void LodEngine::set_step_voxels(double step) {
  if (!(step > 0) || !std::isfinite(step)) fail_in("lod engine", "step must be > 0 voxels");
  impl_->options.step_voxels = step;
}
void LodEngine::set_max_exact_nodes(uint64_t n) { impl_->options.max_exact_nodes = n; }
bool LodEngine::hybrid() const { return impl_->options.hybrid; }
void LodEngine::set_hybrid(bool on) { impl_->options.hybrid = on; }
void LodEngine::set_interest(std::vector<FocusRange> focus, std::optional<RegionOfInterest> roi,
                             double context_saturation, double context_opacity) {
  LodOptions o = impl_->options;
  o.focus = std::move(focus);
  o.roi = roi;
  o.context_saturation = context_saturation, o.context_opacity = context_opacity;
  o.validate();
  NodeInterest interest{resolve_focus(impl_->store, o.focus), o.roi};  // an unknown field fails here
  impl_->options = std::move(o);
  impl_->interest = std::move(interest);
}

void LodOptions::validate() const {
  if (!(context_saturation >= 0 && context_saturation <= 1))
    fail_in("--context-saturation", "must be in [0, 1] (the share of the context's saturation kept)");
  if (!(context_opacity >= 0 && context_opacity <= 1))
    fail_in("--context-opacity", "must be in [0, 1] (the context's extinction scale)");
}
void LodEngine::prepare_exact(std::span<const uint64_t> nodes, const Camera& camera, const TransferFunction& tf,
                              const RenderSettings& settings, uint64_t max_nodes, LodRenderStats* stats) {
  Impl& I = *impl_;
  I.gl.make_current();
  I.tf_errors.set_field(I.field);
  I.tf_errors.update(tf);
  LodRenderStats st;
  if (stats) st = *stats;
  I.choose_exact(nodes, camera, settings, st, max_nodes);
  if (stats) *stats = st;
}
std::vector<uint64_t> LodEngine::cell_nodes_in_ram() const {
  return impl_->cells ? impl_->cells->nodes_in_ram() : std::vector<uint64_t>{};
}

Image LodEngine::render_nodes(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                              std::span<const uint64_t> nodes, LodRenderStats* stats) {
  BrickResidency from_store(impl_->store, impl_->slot_table);
  return render_nodes(camera, tf, settings, nodes, from_store, stats);
}

Image LodEngine::render_nodes(const Camera& camera, const TransferFunction& tf, const RenderSettings& settings,
                              std::span<const uint64_t> nodes, BrickResidency& residency, LodRenderStats* stats) {
  Impl& I = *impl_;
  if (&residency.gpu() != &I.slot_table) fail_in("lod engine", "the residency is another engine's (gpu_slots())");
  settings.validate("render settings");
  tf.validate("transfer function");
  if (settings.iso_values.size() > size_t(lod_gpu::MAX_ISO))
    fail_in("lod engine", "at most " + std::to_string(lod_gpu::MAX_ISO) + " isosurface values");
  const bool was_cubic = I.cubic;
  if (tricubic_iso(settings)) I.cubic = true;
  if (nodes.size() > I.budget_slots()) {
    const std::string why = "a cut of " + std::to_string(nodes.size()) + " bricks exceeds the atlas budget of " +
                            std::to_string(I.budget_slots()) + " bricks of " + std::to_string(I.slot_bytes()) +
                            " bytes" + (I.cubic ? " (samples, tricubic coefficients and cubic margin)" : "") +
                            ": raise --gpu-memory or draw a coarser cut";
    // The first tricubic frame shrank the budget under a cut chosen without the coefficients: the caller chooses
    // again within atlas_budget_bricks(), as when the device refuses an atlas.
    if (I.cubic && !was_cubic) throw AtlasRefused(why);
    fail_in("lod engine", why);
  }
  const auto t0 = std::chrono::steady_clock::now();
  LodRenderStats st;
  if (stats) st = *stats;  // render() passes its cut figures through
  I.gl.make_current();
  for (uint64_t n : nodes)
    if (n >= I.store.node_count() || !I.store.node(n).has_brick())
      fail_in("lod engine", "node " + std::to_string(n) + " is not a node with a brick");
  st.cut_nodes = nodes.size();

  const auto t1 = std::chrono::steady_clock::now();
  // An atlas sized before tricubic frames may hold more slots than the budget allows with their coefficients.
  if (I.cubic && I.have_atlas && !I.atlas.has_coefficients() && I.atlas.capacity() > I.budget_slots())
    I.have_atlas = false;
  I.ensure_atlas(nodes.size());
  if (I.cubic && !I.atlas.has_coefficients()) {
    I.atlas.add_coefficients();              // the prefiltered spline (brick_atlas.h), from the first tricubic frame
    I.slot_table.reset(I.atlas.capacity());  // on: the bricks resident before have none, upload them again
  }
  st.bricks_loaded = I.load(nodes, residency);
  st.bricks_read_sync = residency.sync_reads();
  st.neighbour_reads = I.neighbour_reads;
  st.cubic_prefilters = I.cubic_prefilters;
  st.cubic_cache_hits = I.cubic_cache.hits() - I.cubic_hits_before;
  st.cubic_cache_bytes = I.cubic_cache.bytes();
  st.uploaded_bytes = st.bricks_loaded * I.slot_bytes();
  std::vector<uint32_t> state(I.store.node_count(), lod_gpu::NODE_SKIP);
  for (uint64_t n : nodes) {
    state[n] = uint32_t(I.slot_table.slot(n));
    for (uint64_t p = I.store.node(n).parent; p != kNoNode && state[p] != lod_gpu::NODE_DESCEND;
         p = I.store.node(p).parent)
      state[p] = lod_gpu::NODE_DESCEND;
  }
  // Exact nodes (render() granted them for this cut): drawn by their cells. Their bricks stay loaded all the same, so
  // that a node whose grant ends draws at once.
  const bool hybrid = !I.exact_now.empty();
  // The voxel nodes' states without the exact grants: what the rays llvmpipe's loop limit cuts short in the hybrid
  // pass are drawn from (shaders/loop_limit_probe.glsl).
  std::vector<uint32_t> voxel_state;
  if (hybrid && I.gl.software()) voxel_state = state;
  for (const auto& [n, entry] : I.exact_now) {
    if (state[n] >= lod_gpu::NODE_DESCEND || entry >= lod_gpu::NODE_EXACT)
      fail_in("lod engine", "exact node " + std::to_string(n) + " is not a node of the cut");
    state[n] = lod_gpu::NODE_EXACT | entry;
  }
  // Focus+context: the resampled nodes of zero interest are drawn as context (lod_shared.h NODE_CONTEXT).
  if (I.interest.any())
    for (uint64_t n : nodes)
      if ((state[n] < lod_gpu::NODE_CONTEXT || (!voxel_state.empty() && voxel_state[n] < lod_gpu::NODE_CONTEXT)) &&
          node_interest(I.store, n, I.interest) == 0) {
        if (state[n] < lod_gpu::NODE_CONTEXT) state[n] |= lod_gpu::NODE_CONTEXT;
        if (!voxel_state.empty() && voxel_state[n] < lod_gpu::NODE_CONTEXT) voxel_state[n] |= lod_gpu::NODE_CONTEXT;
      }
  I.state.upload(state.data(), state.size() * sizeof(uint32_t));
  st.load_seconds = seconds_since(t1);
  st.atlas_bytes = I.atlas.bytes();
  st.atlas_slots = I.atlas.capacity();

  I.upload_transfer_function(tf);
  const int w = settings.width, h = settings.height;
  if (w != I.out_w || h != I.out_h) {
    I.out_texture = GlTexture(GL_TEXTURE_2D);
    glTextureStorage2D(I.out_texture.id(), 1, GL_RGBA32F, w, h);
    check_gl("allocating the image");
    I.out_w = w, I.out_h = h;
  }

  const int mode = settings.mode == RenderMode::Mip          ? LOD_MODE_MIP
                   : settings.mode == RenderMode::Isosurface ? LOD_MODE_ISO
                                                             : LOD_MODE_EA;
  const bool overlay = boundary_overlay_on(settings);
  const bool slices = !settings.slices.empty() || settings.hide_volume != HideVolume::None;
  // Tricubic interpolation is an isosurface variant only (docs/tricubic.md); the other modes ignore the setting.
  const bool tricubic = mode == LOD_MODE_ISO && settings.interpolation == Interpolation::Tricubic;
  const lod_gpu::LodFrame frame = I.frame_parameters(camera, tf, settings, overlay);
  const int focus_windows = mode == LOD_MODE_EA ? int(frame.u_context.z) : 0;  // set_focus_windows's count
  const ComputeProgram& program = I.program_for(mode, mode == LOD_MODE_EA && settings.volume_lighting, overlay, slices,
                                                tricubic, hybrid, focus_windows);
  if (hybrid) {
    I.cells->bind();
    if (mode == LOD_MODE_EA && (!I.optical_tf || !(*I.optical_tf == tf))) {
      const std::vector<float> packed = OpticalTable(tf).pack_for_gpu();
      I.optical.upload(packed.data(), packed.size() * sizeof(float));
      I.optical_tf = tf;
    }
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::CELL_OPTICAL_BUFFER_BINDING, I.optical.id());
  }
  if (slices) {
    I.upload_slice_colors(tf, settings);
    glBindTextureUnit(lod_gpu::SLICE_TEXTURE_BINDING, I.slice_texture.id());
  }
  glUseProgram(program.id());
  I.frame_block.upload(&frame, sizeof frame);
  glBindBufferBase(GL_UNIFORM_BUFFER, lod_gpu::FRAME_BLOCK_BINDING, I.frame_block.id());
  glBindImageTexture(lod_gpu::OUT_IMAGE_BINDING, I.out_texture.id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
  glBindTextureUnit(lod_gpu::ATLAS_TEXTURE_BINDING, I.atlas.texture());
  if (I.atlas.has_coefficients()) {
    glBindTextureUnit(lod_gpu::COEF_TEXTURE_BINDING, I.atlas.coefficients());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::MARGIN_BUFFER_BINDING, I.atlas.margins());
  }
  glBindTextureUnit(lod_gpu::TF_TEXTURE_BINDING, I.tf_texture.id());
  glBindTextureUnit(lod_gpu::PREINT_TEXTURE_BINDING, I.preint_texture.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::TREE_BUFFER_BINDING, I.tree.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::STATE_BUFFER_BINDING, I.state.id());
  if (I.faces) {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::FACE_NODE_BUFFER_BINDING, I.face_nodes.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::FACE_REF_BUFFER_BINDING, I.face_refs.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::FACE_TRI_BUFFER_BINDING, I.face_tris.id());
  }
  const uint32_t zero[lod_gpu::COUNTER_COUNT] = {};
  I.counters.upload(zero, sizeof zero);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, lod_gpu::COUNTERS_BUFFER_BINDING, I.counters.id());
  glFinish();
  const auto t2 = std::chrono::steady_clock::now();
  if (!I.timer) I.timer = std::make_unique<GlTimerQuery>();
  I.timer->begin();
  try {
    dispatch_image(w, h, lod_gpu::WORKGROUP_SIZE, lod_gpu::BAND_ORIGIN_LOCATION, I.keep_going);
  } catch (const FrameInterrupted&) {
    I.timer->end();
    I.exact_now.clear();  // a grant holds for one frame, drawn or not
    throw;
  }
  I.timer->end();
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  glFinish();
  st.gpu_seconds = seconds_since(t2);
  st.gpu_timer_seconds = I.timer->seconds();
  check_gl("ray casting");
  uint32_t counted[lod_gpu::COUNTER_COUNT] = {};
  glGetNamedBufferSubData(I.counters.id(), 0, sizeof counted, counted);
  st.samples = counted[lod_gpu::COUNTER_SAMPLES];
  st.bricks_entered = counted[lod_gpu::COUNTER_BRICKS];
  st.cell_steps = counted[lod_gpu::COUNTER_CELL_STEPS];
  st.loop_limit_rays = counted[lod_gpu::COUNTER_LOOP_LIMIT];
  st.face_passes = counted[lod_gpu::COUNTER_FACE_PASSES];
  I.exact_now.clear();  // a grant holds for one frame

  const auto t3 = std::chrono::steady_clock::now();
  std::vector<uint32_t> cut;
  Image image =
      read_back_composited(I.readback, I.out_texture, w, h, settings.background, "lod engine", hybrid ? &cut : nullptr);
  if (!cut.empty()) {
    // The hybrid rays llvmpipe's loop limit cut short (no hardware GPU has one): the voxel pass of the same cut.
    if (voxel_state.empty()) fail_in("lod engine", "rays were cut short on a device not known to cut them");
    I.state.upload(voxel_state.data(), voxel_state.size() * sizeof(uint32_t));
    const ComputeProgram& voxels = I.program_for(mode, mode == LOD_MODE_EA && settings.volume_lighting, overlay, slices,
                                                 tricubic, false, focus_windows);
    glUseProgram(voxels.id());
    I.counters.upload(zero, sizeof zero);
    dispatch_image(w, h, lod_gpu::WORKGROUP_SIZE, lod_gpu::BAND_ORIGIN_LOCATION, {});
    glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
    glFinish();
    check_gl("ray casting the cut rays' voxels");
    const Image voxel = read_back_composited(I.readback, I.out_texture, w, h, settings.background, "lod engine");
    for (uint32_t i : cut) std::copy_n(voxel.rgba.data() + 4 * size_t(i), 4, image.rgba.data() + 4 * size_t(i));
    st.loop_limit_voxel_rays = cut.size();
  }
  st.readback_seconds = seconds_since(t3);
  st.render_seconds = seconds_since(t0) + st.cut_seconds;
  if (stats) *stats = st;
  return image;
}

}  // namespace ugvr
