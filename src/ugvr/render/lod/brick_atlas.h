// The GPU side of the brick cache: one 3D texture holding the bricks of the current cut, each in its own slot.
//
// Texel layout. Format RG16 (unsigned normalised): R is the sample value mapped linearly from the field's global range
// [min, max] to [0, 1]; G is the validity stencil, 1 where the sample has data and 0 where it has none. A slot is
// (R+2)³ texels: the brick's R³ samples at offset (1, 1, 1) and a one-texel apron around them, a copy of the nearest
// brick sample (clamp). Because neighbouring bricks share their border samples (store/brick_store.h), trilinear lookups
// at sample coordinates in [0, R-1] never read the apron; the apron is there for the gradient's central differences at
// the brick border, which then fall back to one-sided differences instead of reading the next slot. Slots are laid
// out x fastest over a grid of slots_x × slots_y × slots_z; slot s sits at texel origin
//   (s % slots_x, (s / slots_x) % slots_y, s / (slots_x · slots_y)) · (R + 2).
//
// The coefficient texture (tricubic isosurfaces only: add_coefficients, which the engine calls on its first tricubic
// frame): R16, the same size and slot layout as the atlas; slot texels hold the coefficients of the interpolating
// cubic B-spline of the brick's samples (LaMar 2000 ch. 3, the prefilter; cubic_coefficients), mapped from [-1/2,
// 3/2] of the normalised range to [0, 1] so that the coefficients' overshoot past the data (4% at a sine's peak)
// is kept, at half the values' precision. Samples without data (next to the mesh boundary) take a smooth extension of
// the data before the prefilter (cubic_coefficients' `fill`), so that the spline interpolates the data there too and
// same-level neighbours agree on their shared face; the shader still decides inside/outside by the stencil (G).
// With it, the cubic margins (docs/tricubic.md, "Finding the surface"): a float per slot in a storage buffer, slot s's
// at index s, a bound M on |spline − trilinear| anywhere in the slot's cells in the normalised [0, 1] units of the
// values (cubic_margin_code / 65535). The tricubic isosurface brackets crossings on the trilinear value and evaluates
// the spline only where the trilinear value is within M of an iso value; elsewhere both have the same sign. Neither
// exists before the first tricubic frame, so the other modes' atlas and uploads are as they were.
//
// Before upload, a brick's samples without data are padded (store/brick_pad.h: one layer grown outward by averaging
// data neighbours), so hardware trilinear filtering next to the mesh boundary mixes data with pad, never with filler;
// the interpolated stencil then decides per sample (>= 1/2: data), which keeps the boundary free of the striping of
// Leven et al.'s figure 5. 16 bits keep the value within 1/131070 of the range, the store's own default tolerance.
#pragma once

#include <epoxy/gl.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "ugvr/gpu/gl_program.h"

namespace ugvr {

// Builds a slot's texels ((R+2)³ × 2 uint16, x fastest) from a decoded brick: pads `samples` in place (they are the
// caller's scratch), normalises by [lo, hi], copies the border into the apron.
void make_atlas_slot(uint32_t resolution, float* samples, const uint8_t* mask, double lo, double hi,
                     std::vector<uint16_t>& texels);

// The cubic margin of one slot's texels (make_atlas_slot's layout), in value codes (0..65535), rounded up: with D_a
// the largest |second difference| of the slot's values along axis a and G_a the largest |first difference|,
//   (D_x + D_y + D_z) / 6 + (G_x + G_y + G_z) / 128 + 2.
// The first term bounds the exact spline minus the exact trilinear interpolant anywhere in the slot's cells: in 1D on
// cell [i, i+1] at fraction t the difference is w0(t) D_i + w3(t) D_{i+1} with w0 + w3 <= 1/6 (both reproduce linear
// functions); in 3D it telescopes into one such term per axis applied to a positively weighted mean of the samples,
// whose second differences are bounded by D_a. The second term covers the hardware's linear filtering (8-bit
// fractional weights: at most 1/512 of a first difference per axis per fetch, in the spline's 8 convex-weighted
// fetches and in trilinear's one, with a factor 2 of headroom), the last one the codes' rounding.
// With `coefficients` (cubic_coefficients' of the same texels), the bound for their spline: the samples' apron taken
// as their linear extrapolation or as the apron's coefficients, whichever bound is smaller (trilinear lookups inside
// the brick do not read it), plus the largest |coefficient − sample| over the slot (the spline of c minus that of f is
// a convex combination of c − f), the coefficients' first differences in the filtering term, and their rounding.
uint16_t cubic_margin_code(uint32_t resolution, const uint16_t* texels,
                           const std::vector<double>* coefficients = nullptr);

// A brick's same-level neighbourhood for the prefilter: the texels (make_atlas_slot's layout) of the 27 bricks at
// offsets (dx, dy, dz) in {-1, 0, 1}³, index (dx + 1) + 3 (dy + 1) + 9 (dz + 1) (the brick itself at 13, unused);
// null where there is none (the engine passes an all-zero slot, samples without data, for a position inside the root
// cell that has no brick at that level, so that the fill reaches into it). Neighbouring bricks share their border
// samples: neighbour (-1, 0, 0)'s sample R - 1 - m along x is the brick's sample -m.
using CubicNeighbourhood = std::array<const uint16_t*, 27>;
// Samples the prefilter takes from each neighbour (k): 0.27^4 = 0.5 % of a border coefficient's error left
// (LodTricubic.ExtendedPrefilterMatchesTheWholeLattice measures it); farther near samples without data (cubic_reach).
constexpr int kCubicExtension = 4;

// The coefficients of the interpolating cubic B-spline of one slot's samples (make_atlas_slot's layout; the values
// code / 65535), into `coefficients`, (R+2)³ x fastest: along each axis the R samples give R + 2 coefficients
// (the brick's and its apron's) such that the spline passes through every sample, with the not-a-knot condition at
// both ends (no jump of the third derivative at the second and the next-to-last sample; natural, zero second
// difference, below 5 samples), applied axis by axis.
//
// Samples without data (`fill`, the default): before the prefilter, every sample of the block (below) without data
// takes the mean of its 26 neighbours one layer nearer the data, layer by layer outward (Chebyshev distance from the
// data, as store/brick_pad.h's one layer), whatever value its texel held. The fill is a function of the samples around
// it, so two same-level bricks fill the samples both of their blocks hold alike, and partial neighbours take part in
// the neighbourhood like any other: the seam next to the mesh boundary goes (docs/tricubic.md, "Samples without
// data"). A sample on a brick border has data where any brick that holds it has (an all-zero slot for a missing
// brick does not hide the border samples of the brick across from it). The filled values only shape the spline next to
// the data: the shader draws no surface where the stencil says there is none. A block with data everywhere is
// prefiltered as it is, so its coefficients are the same, bit for bit, with or without `fill`. False, and nothing
// written, where the block has no data at all, or (without `fill`, as before it: the approximating spline, the samples
// kept) where the brick has samples without data.
//
// With `neighbours`, the prefilter is solved over the brick extended by `extension` samples (default
// kCubicExtension; with `fill`, cubic_reach's of it, `fill_nearby` the caller's) into each same-level neighbour that
// has one (docs/tricubic.md, "Seams"): the recursive filter's influence decays as (2 - sqrt 3)^k, so the coefficients
// at the brick and its apron are within about 0.27^k of the whole lattice's, and two neighbours hold nearly the same
// spline across their shared face (value and derivatives). The not-a-knot ends move to the extension's far ends. A side
// whose neighbour is missing (the domain's border, a coarser leaf or an empty octant there; without `fill`, also a
// neighbour with samples without data) keeps the brick's own end, as without neighbours; the extended block is a box,
// so a side is dropped too when a diagonal neighbour it needs is missing. Without neighbours (or with none present),
// exactly the per-brick solve above.
bool cubic_coefficients(uint32_t resolution, const uint16_t* texels, std::vector<double>& coefficients,
                        const CubicNeighbourhood* neighbours = nullptr, int extension = kCubicExtension,
                        bool fill = true, bool fill_nearby = false);
// The prefilter's reach (samples taken from each neighbour) for a brick with the fill of samples without data nearby
// (docs/tricubic.md, "Samples without data"). The fill is only C0 at the mesh's boundary, and a block's not-a-knot end
// near that kink leaves a residual 0.27^k of a much larger third difference than smooth data have; the seam on a face
// is the larger of its two bricks' truncations. So: `extension` + 3/4 of it (7 for 4) where a brick of the
// neighbourhood (the brick included) has samples without data or is missing inside the root cell (`next_to_fill`);
// + 1/4 (5) where only a brick within two of it has (`fill_nearby`: its neighbours' neighbourhoods, the 5³ same-level
// positions around it, which the caller knows); `extension` elsewhere (the coefficients as they were, bit for bit).
// Blunt fin, same-level pairs next to the boundary (LodTricubic.BluntFinSameLevelBricksAgreeNextToTheBoundary),
// gradient seam against the floor of pairs with data all round (1.20e-4): 6 / 4 (as before) 3.97e-4; 8 / 4 the same
// (the reach-4 side's own truncation next to a reach-8 brick); 6 / 6 3.73e-4; 7 / 5 1.12e-4; 8 / 6 3.9e-5.
int cubic_reach(int extension, bool next_to_fill, bool fill_nearby);

// Level borders (docs/tricubic.md, "Level borders"). A node's uniform cubic B-spline is also a B-spline on its
// children's lattice, of half the spacing (dyadic knot insertion, exact): along an axis the child's coefficient at
// global child index f (f = offset + j, offset 0 or R - 1 by the octant) is (p[m-1] + 6 p[m] + p[m+1]) / 8 for even
// f = 2m and (p[m] + p[m+1]) / 2 for odd f = 2m + 1, p the parent's coefficients by parent sample index. A child
// slot's R + 2 coefficients per axis need parent indices -1 .. R: the parent's slot holds exactly those.
// `parent` and `child` are slots' coefficients ((R+2)³, x fastest, cubic_coefficients' layout); `octant` is the
// child's (bit a set: the upper half along axis a).
void refine_coefficients(uint32_t resolution, const std::vector<double>& parent, int octant,
                         std::vector<double>& child);

// A fine brick whose cut neighbours are coarser blends its coefficients, in a zone next to them, into the coarser
// level's spline refined onto its lattice (refine_coefficients): weight 1 at the coefficients a point on the shared
// face reads (sample distance <= 1 from it: the apron, the border and the next), so there the fine spline is the
// coarse one, value and first and second derivatives; easing to 0 over kCubicBlendZone(R) samples, LaMar's blend
// ratio (ch. 6) on the coefficients instead of the values. Any coefficients give a C² spline, so the blend is smooth.
// The weight is a function of the distance to the coarser nodes alone (Chebyshev, in samples, max over the
// directions), so two same-level bricks along the same coarse node give their shared coefficients the same weight.
struct CubicLevelTarget {
  std::vector<double> coefficients;  // (R+2)³: the coarser level's spline on this brick's lattice
  std::array<bool, 27> towards{};    // CubicNeighbourhood's directions whose cut node is of that coarser level
};
// One target per coarser level that the cut puts next to the brick, the finest first (applied in that order).
using CubicLevelBlend = std::vector<CubicLevelTarget>;
// Samples over which the weight eases from 1 to 0: half the brick less one, so that the weight is 0 at the far
// border's coefficients (a finer neighbour there blends into this level's unblended spline).
constexpr int kCubicBlendZone(uint32_t resolution) { return std::max(1, (int(resolution) - 1) / 2); }
// The weight at slot texel (tx, ty, tz) (0 .. R+1) towards the directions `towards`.
double level_blend_weight(uint32_t resolution, const std::array<bool, 27>& towards, int tx, int ty, int tz);
// Blends `coefficients` (a slot's, cubic_coefficients') into each target in turn.
void blend_towards_coarser(uint32_t resolution, const CubicLevelBlend& blend, std::vector<double>& coefficients);

class BrickAtlas {
 public:
  BrickAtlas() = default;
  // Allocates room for at least `slots` bricks of resolution R within max_3d texels per axis; throws ugvr::Error
  // when even one axis of slots does not fit, or when the allocation fails (out of GPU memory).
  BrickAtlas(uint32_t resolution, uint64_t slots, int max_3d);

  uint64_t capacity() const { return uint64_t(slots_[0]) * slots_[1] * slots_[2]; }
  uint64_t bytes() const;
  GLuint texture() const { return texture_.id(); }
  // The coefficient texture (above): allocated by add_coefficients, filled by the uploads after it (the slots
  // uploaded before have none: the caller uploads them again).
  bool has_coefficients() const { return coefficients_.id() != 0; }
  GLuint coefficients() const { return coefficients_.id(); }
  GLuint margins() const { return margins_.id(); }
  void add_coefficients();
  const int* slots_per_axis() const { return slots_; }
  const int* texels_per_axis() const { return texels_; }
  // Uploads make_atlas_slot's texels into slot `slot`, and once coefficients are added their spline's coefficients
  // and the slot's cubic margin (the whole range instead when UGVR_TRICUBIC_NO_BRACKET is set: the spline at every
  // sample of the in-loop variant, with slices; a reference for tests: the walk would end at every sample). With
  // `neighbours` the prefilter reaches into them (cubic_coefficients; UGVR_TRICUBIC_EXTENSION samples if set).
  // `neighbours` (tricubic only): the brick's same-level neighbourhood for the prefilter (cubic_coefficients).
  // `levels` (tricubic only): the brick's coarser cut neighbours' splines (blend_towards_coarser), unless
  // UGVR_TRICUBIC_LEVEL_BLEND=0 (each level's own spline, as before; for before/after measurements in one run).
  void upload(uint64_t slot, const uint16_t* texels, const CubicNeighbourhood* neighbours = nullptr,
              const CubicLevelBlend* levels = nullptr);
  // The same in two steps, so that a batch's bricks are prefiltered in parallel (the prefilter is the upload's CPU
  // cost): cubic_slot computes a slot's coefficient codes and cubic margin (thread-safe: it reads the atlas's
  // settings only), upload puts them and the texels into the slot (GL: the context's thread); a null `cubic`
  // uploads the texels alone, as the other modes do. `fill_nearby`: cubic_coefficients' (cubic_reach).
  struct CubicSlot {
    std::vector<uint16_t> codes;  // (R+2)³, x fastest: the coefficients mapped from [-1/2, 3/2] (above)
    float margin = 1.0f;          // the slot's cubic margin, normalised units
  };
  CubicSlot cubic_slot(const uint16_t* texels, const CubicNeighbourhood* neighbours, const CubicLevelBlend* levels,
                       bool fill_nearby = false) const;
  // The same from the prefilter's result (cubic_coefficients'; null where it kept the samples), e.g. one kept in the
  // engine's coefficient cache: the level blend on a copy, the codes and the margin.
  CubicSlot cubic_slot_of(const uint16_t* texels, const std::vector<double>* coefficients,
                          const CubicLevelBlend* levels) const;
  void upload(uint64_t slot, const uint16_t* texels, const CubicSlot* cubic);
  bool level_blend() const { return level_blend_; }
  bool fill() const { return fill_; }           // samples without data filled before the prefilter (cubic_coefficients)
  int extension() const { return extension_; }  // samples the prefilter takes from each neighbour

  // Most slots an atlas can have for R within max_3d texels per axis.
  static uint64_t max_slots(uint32_t resolution, int max_3d);

 private:
  uint32_t resolution_ = 0;
  bool no_bracket_ = false;
  // Samples taken from each neighbour by the prefilter: kCubicExtension, or UGVR_TRICUBIC_EXTENSION (0: each brick's
  // own samples alone, as before the neighbourhood; for benchmarks and before/after measurements in one run).
  int extension_ = kCubicExtension;
  bool level_blend_ = true;
  // cubic_coefficients' `fill`, unless UGVR_TRICUBIC_FILL=0 (bricks with samples without data keep their samples, and
  // their neighbours drop that side, as before; for before/after measurements in one run).
  bool fill_ = true;
  int slots_[3] = {0, 0, 0};
  int texels_[3] = {0, 0, 0};
  GlTexture texture_;
  GlTexture coefficients_;
  GlBuffer margins_;
};

}  // namespace ugvr
