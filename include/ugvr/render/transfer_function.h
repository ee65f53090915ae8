// Transfer functions: scalar -> colour and scalar -> opacity, both piecewise linear, as ParaView's colour map
// (vtkColorTransferFunction) and opacity map (vtkPiecewiseFunction).
// Layout: color_points and opacity_points are sorted by strictly increasing x; between two points the value is
// interpolated linearly, outside the first/last point it is clamped to that point's value. NaN scalars get
// nan_color and opacity 0 (invisible), so holes in the data do not paint the volume.
// Colour interpolation is always in RGB. ParaView interpolates "Diverging" maps (Cool to Warm) in Msh space and
// "Lab"/"HSV" maps in those spaces; the ColorSpace is read and written back unchanged but only changes the colours
// between control points slightly for the shipped presets, which carry enough points.
// opacity_unit_distance is ParaView's "Scalar Opacity Unit Distance": a table opacity a is the opacity of a slab of
// that thickness, so a segment of length d has opacity 1 - (1 - a)^(d / unit) (see corrected_opacity).
//
// ParaView preset JSON (read_paraview_presets / paraview_preset_json): an array of objects, or one object, with
//   "Name": string, "ColorSpace": string (optional, default "RGB"),
//   "RGBPoints": [x, r, g, b, x, r, g, b, ...]  (required, >= 1 point, x strictly increasing, r,g,b in [0,1])
//   "Points": [x, opacity, midpoint, sharpness, ...]  (optional opacity; midpoint and sharpness are ignored, which
//            is exact for ParaView's defaults 0.5 / 0.0, i.e. linear segments)
//   "NanColor": [r, g, b] (optional)
//   "ScalarOpacityUnitDistance": number (optional; a ugvr extension ParaView ignores)
// Without "Points" the opacity is a linear ramp from 0 at the first colour point to 1 at the last (ParaView's
// default for a new opacity map).
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/vec.h"

namespace ugvr {

struct ColorPoint {
  double x;
  Vec3d rgb;  // each in [0, 1]
  bool operator==(const ColorPoint&) const = default;
};

struct OpacityPoint {
  double x;
  double opacity;  // in [0, 1]
  bool operator==(const OpacityPoint&) const = default;
};

// The optical model every engine integrates (emission-absorption with emission proportional to extinction, as a
// ray caster compositing colour c with opacity a does): along a ray, scalar s(x),
//   extinction  tau(s) = -ln(1 - min(opacity(s), kMaxTableOpacity)) / opacity_unit_distance
//   radiance    I = integral c(s) tau(s) T(x) dx,   T(x) = exp(-integral_0^x tau)
// so a constant-s slab of thickness unit_distance has exactly the table's opacity. An opacity of 1 is capped at
// kMaxTableOpacity (extinction 13.8 / unit distance) to keep tau finite.
inline constexpr double kMaxTableOpacity = 1 - 1e-6;

// Opacity of a segment of length `length` whose unit-distance opacity is `alpha` (see the header comment).
double corrected_opacity(double alpha, double length, double unit_distance);

struct TransferFunction {
  std::string name;
  std::string color_space = "RGB";
  std::vector<ColorPoint> color_points;
  std::vector<OpacityPoint> opacity_points;
  Vec3d nan_color{1, 1, 0};  // ParaView's default NaN colour (yellow)
  double opacity_unit_distance = 1;

  Vec3d color(double s) const;
  double opacity(double s) const;
  // Opacity for a ray segment of `length` world units: corrected_opacity(opacity(s), length, unit distance).
  double opacity_for_length(double s, double length) const {
    return corrected_opacity(opacity(s), length, opacity_unit_distance);
  }
  // Extinction coefficient tau(s) of the optical model above (0 for NaN).
  double extinction(double s) const;
  // Scalar range of the colour points (first x, last x).
  double range_min() const { return color_points.front().x; }
  double range_max() const { return color_points.back().x; }
  // Maps every colour and opacity point linearly from [range_min, range_max] to [lo, hi] (ParaView's "Rescale to
  // data range"). A constant field (lo == hi) is widened to [lo - 0.5, lo + 0.5] so the map stays well defined.
  void rescale(double lo, double hi);
  // Throws ugvr::Error "SOURCE: KEY: message" for unsorted points, values out of [0, 1], non-finite numbers.
  void validate(std::string_view source) const;
  bool operator==(const TransferFunction&) const = default;
};

// Every preset of a ParaView preset JSON text; `source` names the file in errors.
std::vector<TransferFunction> parse_paraview_presets(std::string_view json_text, std::string_view source);
// One preset from a file: the one called `name`, or the first when name is empty.
TransferFunction read_paraview_preset(const std::string& path, std::string_view name = "");
// ParaView's form: an array holding one object.
std::string paraview_preset_json(const TransferFunction& tf);
void write_paraview_preset(const std::string& path, const TransferFunction& tf);
// The preset's own "ScalarOpacityUnitDistance" in a preset file (the preset `name`, or the first), if it has one: it
// then wins over a renderer's bounds-based default.
std::optional<double> read_preset_unit_distance(const std::string& path, std::string_view name = "");

// Built-in presets over [0, 1] with a linear opacity ramp: "viridis", "inferno" (matplotlib's tables sampled at 16
// points), "cool-warm" (ParaView's Cool to Warm), "grayscale", "rainbow" (jet-like). Throws listing the names.
TransferFunction builtin_preset(std::string_view name);
std::vector<std::string> builtin_preset_names();

// The opacity unit distance a transfer function gets when nothing sets it: the bounds' diagonal / 10 (1 for empty or
// single-point bounds). With ParaView's mean cell size (or the diagonal / 100 used before), a linear opacity ramp makes
// every value above the middle of the range opaque within a few cells and the data an opaque slab; at a tenth of the
// diagonal a ray crossing the data sees the opaque upper values and through the rest.
double default_unit_distance(const Bounds& bounds);
// "viridis" with its linear opacity ramp rescaled to [lo, hi] (kept on [0, 1] when lo or hi is not finite: an
// all-NaN field), opacity unit distance default_unit_distance(bounds): the viewer's first transfer function, and what
// the default ("auto", src/ugvr/render/default_transfer_function.h) keeps when the field's histogram has no dominant
// mode.
TransferFunction default_transfer_function(double lo, double hi, const Bounds& bounds);

}  // namespace ugvr
