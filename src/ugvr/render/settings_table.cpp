#include "ugvr/render/settings_table.h"

#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "ugvr/render/render_settings.h"

namespace ugvr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string number_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, end) : "?";
}

// The viewer's size comes from its canvas; the page has no control for it.
constexpr std::string_view kCanvasSize =
    "viewer: the canvas's size, sent in the \"hello\" and \"resize\" messages, not a setting";

const std::array<RenderSettingInfo, 16> kTable = {{
    {"width", "--size", "", "", "Image width in pixels", "", SettingInterval{1, kMaxImageSide}, kCanvasSize},
    {"height", "--size", "", "", "Image height in pixels", "", SettingInterval{1, kMaxImageSide}, kCanvasSize},
    {"background", "--background", "background", "background", "Background colour R,G,B[,A]",
     "each component; the viewer's is opaque, R,G,B (its frames are JPEG while the view moves)", SettingInterval{0, 1},
     ""},
    {"mode", "--mode", "mode", "mode", "How rays composite the field: emission-absorption, MIP or isosurfaces",
     "emission_absorption, mip or isosurface (the flag and the message: ea, mip or iso)", std::nullopt, ""},
    {"field", "--field", "field", "field", "Scalar to render: NAME, NAME:x|y|z|k or NAME:magnitude",
     "a field of the dataset; empty: its first (the viewer: one of the scene's fields)", std::nullopt, ""},
    {"iso_values", "--iso", "iso_value", "iso", "Isosurface values",
     "finite, at least one in isosurface mode; the viewer's message and slider set one value", std::nullopt, ""},
    {"iso_opacity", "--iso-opacity", "iso_opacity", "iso-opacity",
     "Opacity of each isosurface (below 1 shows nested ones)", "", SettingInterval{0, 1}, ""},
    {"clip_plane", "--clip", "clip", "clip", "Clip plane: keeps the half-space the normal points to",
     "a finite point and a finite non-zero normal, or none (off)", std::nullopt, ""},
    {"lighting", "--no-lighting", "lighting", "lighting",
     "Headlight shading of isosurfaces and of the boundary overlay", "on (default) or off", std::nullopt, ""},
    {"volume_lighting", "--volume-lighting", "volume_lighting", "volume-lighting",
     "Shade emission-absorption by the field gradient", "off (default) or on", std::nullopt, ""},
    {"early_termination_opacity", "--early-termination", "early_termination_opacity", "early-termination",
     "Stop a ray once its accumulated opacity reaches this", "", SettingInterval{0, 1, true}, ""},
    {"sample_step", "--sample-step", "sample_step", "sample-step", "Sample step in world units",
     "0: the engine picks it (lod: from its step in voxels of each node); the exact engine integrates each cell "
     "exactly and ignores it",
     SettingInterval{0, kInf}, ""},
    {"boundary_overlay_opacity", "--boundary-opacity", "boundary_opacity", "boundary",
     "Opacity of the dataset's outer boundary drawn over the image (0: off)", "", SettingInterval{0, 1}, ""},
    {"slices", "--slice", "slices", "", "Cutting planes drawn with the volume, colour-mapped (docs/slices.md)",
     "up to 8, each a finite point, a finite non-zero normal, opacity in (0, 1], a built-in colour map or the "
     "volume's, a range lo < hi or the volume's, contour lines (a count or up to 64 values, colour, width in "
     "pixels) (the flag: PX,PY,PZ,NX,NY,NZ[,OPACITY], repeated; --slice-map, --slice-range, --slice-contours)",
     std::nullopt, "page: web/slices.js's own panel (planes added, dragged and turned), not one control"},
    {"hide_volume", "--hide-volume", "hide_volume", "", "Where the volume is hidden around the slices",
     "none (default), front (the side each slice's normal points to), back or all", std::nullopt,
     "page: web/slices.js's own panel, not one control"},
    {"interpolation", "--interpolation", "interpolation", "interpolation",
     "Reconstruction between voxels for isosurfaces (lod engine)",
     "trilinear (default) or tricubic (cubic B-spline, analytic normals; docs/tricubic.md)", std::nullopt, ""},
}};

}  // namespace

bool SettingInterval::contains(double v) const { return std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi; }

std::string SettingInterval::text() const {
  return (lo_open ? "(" : "[") + number_text(lo) + ", " + number_text(hi) + (std::isinf(hi) ? ")" : "]");
}

std::span<const RenderSettingInfo> render_setting_table() { return kTable; }

const RenderSettingInfo& render_setting(std::string_view key) {
  for (const RenderSettingInfo& row : kTable)
    if (row.key == key) return row;
  throw std::out_of_range("no render setting \"" + std::string(key) + "\"");
}

const RenderSettingInfo* render_setting_for_message(std::string_view message_key) {
  for (const RenderSettingInfo& row : kTable)
    if (!row.message_key.empty() && row.message_key == message_key) return &row;
  return nullptr;
}

std::string setting_values_text(const RenderSettingInfo& row) {
  std::string s = row.interval ? row.interval->text() : "";
  if (!row.values.empty()) s += (s.empty() ? "" : "; ") + std::string(row.values);
  return s;
}

}  // namespace ugvr
