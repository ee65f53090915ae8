// What to render, independent of the engine. JSON form (settings_to_json / settings_from_json), every key optional
// with the defaults below, unknown keys rejected:
//   {"width": 512, "height": 512, "background": [r, g, b, a], "mode": "emission_absorption" | "mip" | "isosurface",
//    "field": "NAME[:component]", "iso_values": [..], "clip_plane": {"point": [x,y,z], "normal": [x,y,z]} | null,
//    "iso_opacity": 1, "lighting": true, "volume_lighting": false, "early_termination_opacity": 0.99,
//    "sample_step": 0, "boundary_overlay_opacity": 0,
//    "slices": [{"point": [x,y,z], "normal": [x,y,z], "opacity": 1, "color_map": "", "range": null | [lo, hi],
//                "contours": 0 | N | [v1, v2, ..], "contour_color": [r, g, b], "contour_width": 1.5}],
//    "hide_volume": "none" | "front" | "back" | "all", "interpolation": "trilinear" | "tricubic"}
#pragma once

#include <array>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/vec.h"

namespace ugvr {

enum class RenderMode { EmissionAbsorption, Mip, Isosurface };
std::string_view render_mode_name(RenderMode m);

// Keeps the half-space dot(p - point, normal) >= 0, the side the normal points to, and removes the other. (ParaView's
// Clip filter removes that side by default, "Invert" keeps it; ugvr keeps what the normal points at.)
struct ClipPlane {
  Vec3d point;
  Vec3d normal;
  bool operator==(const ClipPlane&) const = default;
};

// A cutting plane drawn through the volume (LaMar 2000, ch. 6; ParaView's Slice): the field on the plane, colour-mapped
// and composited at the plane's depth together with the volume, only where the plane is inside the data. The plane is
// flat-coloured (not lit), so its pixels read the field's value through the colour map exactly.
struct Slice {
  Vec3d point;
  Vec3d normal;        // non-zero; its direction also says which side hide_volume "front" means
  double opacity = 1;  // in (0, 1]: 1 opaque, below shows the volume behind it
  // "": the volume's transfer-function colours; else a built-in preset name (transfer_function.h: "viridis", ...).
  std::string color_map;
  // The scalar range the colour map spans; none: the volume transfer function's range.
  std::optional<std::array<double, 2>> range;
  // Contour (iso) lines on the plane (ParaView's Contour on a Slice): `contours` values evenly spaced inside the colour
  // map's range (slice_contour_values), or the explicit `contour_values` (then contours is 0). A pixel is on a line
  // where |f - c| / |derivative of f across one pixel, along the plane| < contour_width / 2: lines of constant width
  // in pixels whatever the zoom or the field's slope, anti-aliased over one pixel (docs/slices.md).
  int contours = 0;
  std::vector<double> contour_values{};
  std::array<double, 3> contour_color{0, 0, 0};  // rgb in [0, 1]
  double contour_width = 1.5;                    // pixels, in (0, 64]
  bool operator==(const Slice&) const = default;
};

inline constexpr size_t kMaxSlices = 8;  // the GPU engines keep the planes in a fixed uniform array
// Contour values per slice at most: the GPU engines keep them in one texture row each, and every slice pixel compares
// its value with each (64 lines on one plane is already more than a reader can tell apart).
inline constexpr int kMaxSliceContours = 64;
// The slice's contour values, ascending: its explicit list, or `contours` values lo + k (hi - lo) / (contours + 1),
// k = 1..contours (interior: the range's ends are usually the field's extremes, where a line would be a dot), where
// [lo, hi] is the slice's range or else [tf_lo, tf_hi], the transfer function's.
std::vector<double> slice_contour_values(const Slice& slice, double tf_lo, double tf_hi);
// The pixel coverage in [0, 1] of a slice's contour lines where the field is `value` and changes by `per_pixel` from
// one pixel to the next along the plane (the norm of its screen-space gradient; slice_screen_derivative): 1 within
// width / 2 - 0.5 pixels of the nearest line, falling linearly to 0 at width / 2 + 0.5 (a box filter of one pixel).
// The shaders' slice_contours.glsl computes the same.
double slice_contour_coverage(std::span<const double> values, double width, double value, double per_pixel);
// The change of a field with world gradient `gradient` from one pixel to the next on a plane with normal `normal`,
// seen along the unit ray direction `dir`: the pixel's footprint vectors `px`, `py` (world, across the image's
// columns and rows at the crossing's depth) moved along the ray onto the plane, dotted with the gradient; the norm
// of the two. (No screen derivatives outside fragment shaders: this is the analytic form of dFdx, dFdy.)
double slice_screen_derivative(Vec3d gradient, Vec3d normal, Vec3d dir, Vec3d px, Vec3d py);
// The GPU engines' contour row of a slice (layout in shaders/slice_contours.glsl), rgba floats: (count, width), the
// colour, then each value v as v · scale + offset (the engine's value units). Always at least 2 texels.
std::vector<float> slice_contour_row(const Slice& slice, std::span<const double> values, double scale, double offset);

// Where the volume is drawn when there are slices. A plane's "front" is the side its normal points to. front: the
// volume shows only behind every slice (each plane's negative side; ParaView users get the same with a clip on the
// volume alone), back: only in front of every slice, all: slices alone. With no slices front and back hide nothing.
// A separate setting rather than the clip plane because the clip plane also cuts the slices and the boundary overlay.
enum class HideVolume { None, Front, Back, All };
std::string_view hide_volume_name(HideVolume h);
// "none", "front", "back", "all"; throws ugvr::Error naming `source`.
HideVolume parse_hide_volume(std::string_view text, std::string_view source);

// How the LOD engine reconstructs the field between a brick's samples for isosurfaces (docs/tricubic.md): trilinear
// (C0; normals by central differences) or the cubic B-spline of the samples (C2; the surface is found on it and its
// normals are its analytic gradient). Other modes and the exact engine (which interpolates each cell exactly) ignore
// it.
enum class Interpolation { Trilinear, Tricubic };
std::string_view interpolation_name(Interpolation i);
// "trilinear", "tricubic"; throws ugvr::Error naming `source`.
Interpolation parse_interpolation(std::string_view text, std::string_view source);

struct ImageSize {
  int width = 0, height = 0;
  bool operator==(const ImageSize&) const = default;
};

inline constexpr int kMaxImageSide = 16384;

struct RenderSettings {
  int width = 512, height = 512;
  std::array<double, 4> background{0.32, 0.34, 0.43, 1.0};  // ParaView's default background, opaque
  RenderMode mode = RenderMode::EmissionAbsorption;
  std::string field;  // FieldSet::scalar selector; empty = the dataset's first field
  std::vector<double> iso_values;
  double iso_opacity = 1;  // opacity of each isosurface (opaque, like ParaView's Contour; < 1 shows nested ones)
  std::optional<ClipPlane> clip_plane;
  bool lighting = true;          // headlight shading of isosurfaces and of the boundary overlay
  bool volume_lighting = false;  // shade emission-absorption by the field gradient (ParaView's "Shade", off there too)
  double early_termination_opacity = 0.99;  // stop a ray once its accumulated opacity reaches this
  double sample_step = 0;                   // world units between samples; 0 = the engine picks from cell size
  double boundary_overlay_opacity = 0;      // opacity of the dataset's outer boundary drawn over the image; 0 = off
  std::vector<Slice> slices;                // at most kMaxSlices
  HideVolume hide_volume = HideVolume::None;
  Interpolation interpolation = Interpolation::Trilinear;

  // Throws ugvr::Error "SOURCE: key "K": message": size in [1, 16384], background in [0, 1], isosurface mode
  // needs iso_values, all numbers finite, clip normal non-zero, early termination in (0, 1], step >= 0,
  // overlay opacity in [0, 1], at most kMaxSlices slices each with a finite point, a finite non-zero normal, opacity
  // in (0, 1], a built-in colour map or "" and a finite range lo < hi, contours in [0, kMaxSliceContours] or at most
  // that many finite contour values (not both), contour colour in [0, 1], contour width in (0, 64] (errors name
  // "slices[i].KEY").
  void validate(std::string_view source) const;
  bool operator==(const RenderSettings&) const = default;
};

nlohmann::json settings_to_json(const RenderSettings& s);
RenderSettings settings_from_json(const nlohmann::json& json, std::string_view source);
RenderSettings read_render_settings(const std::string& path);

// "512" -> 512 x 512, "800x600" -> 800 x 600; each side in [1, 16384]. Errors name `source` (e.g. "--size").
ImageSize parse_size(std::string_view text, std::string_view source = "size");

}  // namespace ugvr
