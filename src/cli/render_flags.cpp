#include "cli/render_flags.h"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli/cli_numbers.h"
#include "cli/commands.h"
#include "ugvr/core/file.h"
#include "ugvr/render/settings_table.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr::cli {

const std::vector<std::string> kViews = {"+x", "-x", "+y", "-y", "+z", "-z", "iso"};

int parse_positive_int(std::string_view text, std::string_view flag) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v < 1)
    fail_flag(flag, "expected a positive integer, found \"" + std::string(text) + "\"");
  return v;
}

std::vector<double> parse_list(std::string_view text, std::string_view flag, size_t min_count, size_t max_count,
                               std::string_view form) {
  std::vector<double> v;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string_view item = text.substr(start, comma == std::string_view::npos ? comma : comma - start);
    v.push_back(parse_number(item, flag));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (v.size() < min_count || v.size() > max_count)
    fail_flag(flag, "expected " + std::string(form) + ", found " + std::to_string(v.size()) + " value" +
                        (v.size() == 1 ? "" : "s"));
  return v;
}

double parse_fraction(std::string_view text, std::string_view flag) {
  const double v = parse_number(text, flag);
  if (v < 0 || v > 1) fail_flag(flag, "must be in [0, 1], found " + std::string(text));
  return v;
}

std::string join(const std::vector<std::string>& names, std::string_view sep) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : std::string(sep)) + n;
  return s;
}

namespace {

// A number in the range of settings_table.h's row `key`.
double parse_setting(std::string_view text, std::string_view flag, std::string_view key) {
  const double v = parse_number(text, flag);
  const SettingInterval& range = *render_setting(key).interval;
  if (!range.contains(v)) fail_flag(flag, "must be in " + range.text() + ", found " + std::string(text));
  return v;
}

// The help of a numeric setting's flag, from settings_table.h: "Description, in [lo, hi][; notes] (default D)".
std::string setting_help(std::string_view key) {
  const RenderSettingInfo& row = render_setting(key);
  const nlohmann::json default_value = settings_to_json(RenderSettings{})[std::string(key)];
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, default_value.get<double>());
  return std::string(row.description) + ", in " + setting_values_text(row) + " (default " +
         (ec == std::errc() ? std::string(buf, end) : default_value.dump()) + ")";
}

}  // namespace

RenderMode parse_mode(std::string_view text) {
  if (text == "ea" || text == "emission_absorption") return RenderMode::EmissionAbsorption;
  if (text == "mip") return RenderMode::Mip;
  if (text == "iso" || text == "isosurface") return RenderMode::Isosurface;
  fail_flag("--mode", "unknown mode \"" + std::string(text) + "\" (expected ea, mip or iso)");
}

void check_extension(const std::string& path, std::string_view flag, const std::vector<std::string>& allowed) {
  const std::string ext = extension_lower(path);
  if (std::find(allowed.begin(), allowed.end(), ext) == allowed.end())
    fail_flag(flag, "\"" + path + "\" must end in " + join(allowed, " or "));
}

RenderSettings settings_from_flags(const RenderOptions& o) {
  RenderSettings s =
      o.settings.empty() ? RenderSettings{} : with_flag("--settings", [&] { return read_render_settings(o.settings); });
  if (!o.size.empty()) {
    const ImageSize size = parse_size(o.size, "--size");
    s.width = size.width;
    s.height = size.height;
  }
  if (!o.field.empty()) s.field = o.field;
  if (!o.iso.empty()) {
    s.iso_values = parse_list(o.iso, "--iso", 1, 4096, "one or more comma-separated values");
    // Iso values only mean something in isosurface mode, so giving them picks it unless --mode says otherwise.
    if (o.mode.empty()) s.mode = RenderMode::Isosurface;
  }
  if (!o.mode.empty()) s.mode = parse_mode(o.mode);
  if (s.mode == RenderMode::Isosurface && s.iso_values.empty())
    fail_flag("--mode", "isosurface mode needs --iso V1,V2,...");
  if (!o.iso_opacity.empty()) s.iso_opacity = parse_fraction(o.iso_opacity, "--iso-opacity");
  if (!o.clip.empty()) {
    const std::vector<double> c = parse_list(o.clip, "--clip", 6, 6, "PX,PY,PZ,NX,NY,NZ");
    const ClipPlane plane{{c[0], c[1], c[2]}, {c[3], c[4], c[5]}};
    if (length(plane.normal) == 0) fail_flag("--clip", "the normal NX,NY,NZ must be non-zero");
    s.clip_plane = plane;
  }
  if (!o.boundary_opacity.empty())
    s.boundary_overlay_opacity = parse_fraction(o.boundary_opacity, "--boundary-opacity");
  if (!o.early_termination.empty())
    s.early_termination_opacity =
        parse_setting(o.early_termination, "--early-termination", "early_termination_opacity");
  if (!o.sample_step.empty()) s.sample_step = parse_setting(o.sample_step, "--sample-step", "sample_step");
  if (o.no_lighting) s.lighting = false;
  if (o.volume_lighting) s.volume_lighting = true;
  if (!o.interpolation.empty()) s.interpolation = parse_interpolation(o.interpolation, "--interpolation");
  if (!o.background.empty()) {
    const std::vector<double> b = parse_list(o.background, "--background", 3, 4, "R,G,B or R,G,B,A");
    for (double c : b)
      if (c < 0 || c > 1) fail_flag("--background", "components must be in [0, 1]");
    s.background = {b[0], b[1], b[2], b.size() == 4 ? b[3] : 1.0};
  }
  // --slice adds planes to those of --settings; --slice-map and --slice-range apply to the added ones.
  const size_t first_flag_slice = s.slices.size();
  for (const std::string& text : o.slices) {
    const std::vector<double> v = parse_list(text, "--slice", 6, 7, "PX,PY,PZ,NX,NY,NZ[,OPACITY]");
    Slice sl{{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, v.size() == 7 ? v[6] : 1.0, "", std::nullopt};
    if (length(sl.normal) == 0) fail_flag("--slice", "the normal NX,NY,NZ must be non-zero");
    if (!(sl.opacity > 0 && sl.opacity <= 1)) fail_flag("--slice", "OPACITY must be in (0, 1], found " + text);
    s.slices.push_back(sl);
  }
  if (s.slices.size() > kMaxSlices) fail_flag("--slice", "at most " + std::to_string(kMaxSlices) + " slices");
  if (!o.slice_map.empty()) {
    const std::vector<std::string> maps = builtin_preset_names();
    if (o.slice_map != "volume" && std::find(maps.begin(), maps.end(), o.slice_map) == maps.end())
      fail_flag("--slice-map", "unknown colour map \"" + o.slice_map + "\" (expected volume or " + join(maps) + ")");
    for (size_t i = first_flag_slice; i < s.slices.size(); ++i)
      s.slices[i].color_map = o.slice_map == "volume" ? "" : o.slice_map;
  }
  if (!o.slice_range.empty()) {
    const size_t colon = o.slice_range.find(':');
    if (colon == std::string::npos) fail_flag("--slice-range", "expected A:B, found \"" + o.slice_range + "\"");
    const double a = parse_number(std::string_view(o.slice_range).substr(0, colon), "--slice-range");
    const double b = parse_number(std::string_view(o.slice_range).substr(colon + 1), "--slice-range");
    if (!(a < b)) fail_flag("--slice-range", "expected A < B, found \"" + o.slice_range + "\"");
    for (size_t i = first_flag_slice; i < s.slices.size(); ++i) s.slices[i].range = std::array<double, 2>{a, b};
  }
  if (!o.slice_contours.empty()) {
    // A bare integer is a count of evenly spaced lines; anything else a list of values (one value: write it 3.0).
    const std::string& t = o.slice_contours;
    const bool count = t.find_first_not_of("0123456789") == std::string::npos;
    const std::vector<double> v = parse_list(t, "--slice-contours", 1, size_t(kMaxSliceContours), "N or V1,V2,...");
    if (count && !(v[0] >= 1 && v[0] <= kMaxSliceContours))
      fail_flag("--slice-contours", "N must be in [1, " + std::to_string(kMaxSliceContours) + "], found " + t);
    for (size_t i = first_flag_slice; i < s.slices.size(); ++i) {
      s.slices[i].contours = count ? int(v[0]) : 0;
      s.slices[i].contour_values = count ? std::vector<double>{} : v;
    }
  }
  if (!o.slice_contour_color.empty()) {
    const std::vector<double> c = parse_list(o.slice_contour_color, "--slice-contour-color", 3, 3, "R,G,B");
    for (double x : c)
      if (!(x >= 0 && x <= 1)) fail_flag("--slice-contour-color", "components must be in [0, 1]");
    for (size_t i = first_flag_slice; i < s.slices.size(); ++i) s.slices[i].contour_color = {c[0], c[1], c[2]};
  }
  if (!o.slice_contour_width.empty()) {
    const double w = parse_number(o.slice_contour_width, "--slice-contour-width");
    if (!(w > 0 && w <= 64))
      fail_flag("--slice-contour-width", "must be in (0, 64] pixels, found " + o.slice_contour_width);
    for (size_t i = first_flag_slice; i < s.slices.size(); ++i) s.slices[i].contour_width = w;
  }
  if (!o.hide_volume.empty()) s.hide_volume = parse_hide_volume(o.hide_volume, "--hide-volume");
  with_flag("--settings", [&] { s.validate(o.settings.empty() ? "render settings" : o.settings); });
  return s;
}

bool is_tf_file(const std::string& tf) {
  std::error_code ec;
  return extension_lower(tf) == ".json" || std::filesystem::is_regular_file(tf, ec);
}

void add_render_flags(CLI::App& cmd_ref, RenderOptions& o) {
  CLI::App* cmd = &cmd_ref;
  RenderOptions* opts = &o;
  add_input(*cmd, opts->inputs);
  add_read_options(*cmd, opts->read);
  cmd->add_option("-o,--output", opts->output, "Output image (.png or .pfm; required unless --time writes to --out)")
      ->type_name("FILE");
  cmd->add_option("--time", opts->time,
                  "exact, a time series: render steps all|N|A:B[:S] (inclusive, stride S) as --out DIR/time_NNNNN.png "
                  "(and DIR/steps.json, and DIR/movie.mp4 when ffmpeg is on PATH: skipped quietly otherwise); the "
                  "walk mesh is built once for a static mesh; colour range global over these steps unless --range "
                  "per-step or MIN,MAX")
      ->type_name("SPEC");
  cmd->add_option("--size", opts->size, "Image size: N (square) or WxH (default 512, or from --settings)")
      ->type_name("N|WxH");
  cmd->add_option("--engine", opts->engine,
                  "Rendering engine: exact (CPU, a mesh), lod (GPU, a .ugvr brick store), hybrid (lod drawing the "
                  "cells of a store built with --cells where they matter) or auto (lod for a .ugvr input, else exact)")
      ->default_str("auto")
      ->type_name("NAME");
  cmd->add_option("--device", opts->device,
                  "exact: cpu, gpu (the EGL device --gpu names, llvmpipe included) or auto (a hardware GPU that holds "
                  "the mesh, else the CPU)")
      ->default_str("auto")
      ->type_name("NAME");
  cmd->add_option("--exact-precision", opts->exact_precision,
                  "exact on the GPU: the walk's arithmetic, double (as the CPU reference) or float")
      ->default_str("double")
      ->type_name("double|float");
  cmd->add_option("--cut", opts->cut,
                  "lod: which octree nodes to render: leaves, error:E (node error <= E of the field range) or "
                  "pixels:P (one voxel <= P pixels on screen)")
      ->default_str("pixels:1")
      ->type_name("SPEC");
  add_gpu_memory_flags(*cmd, opts->gpu, opts->gpu_memory, opts->ram_memory, "lod: along --path");
  cmd->add_option("--focus", opts->focus,
                  "lod, hybrid: the focus, nodes whose FIELD values meet [MIN, MAX] (ranges joined by '+': all of "
                  "them; groups separated by ',': any); hybrid draws exact cells only there; the rest is context, "
                  "drawn desaturated and faint; ~EDGE: a smooth edge, the interest falling to 0 over EDGE outside "
                  "[MIN, MAX] (per sample where every range is on the rendered field)")
      ->type_name("FIELD:MIN:MAX[~EDGE][+...][,...]");
  cmd->add_option("--roi", opts->roi,
                  "lod, hybrid: region of interest in world coordinates, a box (two opposite corners) or a sphere; "
                  "with --focus both must hold; outside it, context as for --focus")
      ->type_name("box:X0,Y0,Z0,X1,Y1,Z1|sphere:CX,CY,CZ,R");
  cmd->add_option("--context-saturation", opts->context_saturation,
                  "lod, hybrid: with --focus or --roi, the share of the context's colour saturation kept, [0, 1] "
                  "(default 0.2)")
      ->type_name("F");
  cmd->add_option("--context-opacity", opts->context_opacity,
                  "lod, hybrid: with --focus or --roi, the context's extinction scale, [0, 1] (default 0.3)")
      ->type_name("F");
  add_byte_size_option(*cmd, "--gpu-cell-memory", opts->gpu_cell_memory,
                       "hybrid: GPU memory for exact cells (e.g. 256MiB); default a quarter of --gpu-memory", "0");
  cmd->add_option("--step-voxels", opts->step_voxels, "lod: sample step in voxels of each node (default 0.5)")
      ->type_name("F");
  cmd->add_option("--fps", opts->fps, "lod: target frame rate held along --path (time-critical level of detail)")
      ->type_name("F");
  cmd->add_option("--path", opts->path,
                  "lod: camera path: orbit[:N][,rest:M] (a turn about view up in N frames, default --frames or 300, "
                  "then M still "
                  "frames at the start) or a JSON list of cameras (one frame each, or keyframes resampled to --frames "
                  "frames); --stats then writes one JSON line per frame")
      ->type_name("SPEC|FILE");
  cmd->add_option("--out", opts->out_dir,
                  "lod: write every frame of --path as DIR/frame_NNNNN.png; --time: the directory of the steps' images")
      ->type_name("DIR");
  cmd->add_option("--uploads-per-frame", opts->uploads_per_frame, "lod: bricks uploaded to the GPU per frame (64)")
      ->type_name("N");
  cmd->add_option("--error-weight", opts->error_weight,
                  "lod, along --path: split by texel size x (node error / field range)^W, so nodes that hold their "
                  "data exactly are not split (default 0: texel size alone)")
      ->type_name("W");
  cmd->add_option("--reads-per-frame", opts->reads_per_frame, "lod: brick reads requested per frame (256)")
      ->type_name("N");
  cmd->add_option("--camera", opts->camera, "Camera JSON file (as written by --save-camera)")->type_name("FILE");
  cmd->add_option("--view", opts->view,
                  "View preset framed on the data: +x -x +y -y +z -z iso; default: a three-quarter oblique view, +z "
                  "up, from the -x -y side and about 29 degrees above the xy plane")
      ->type_name("NAME");
  cmd->add_option("--view-angle", opts->view_angle, "Vertical view angle in degrees (default 30)")->type_name("DEG");
  cmd->add_option("--tf", opts->tf,
                  "Transfer function: a ParaView preset .json file, a built-in preset (" +
                      join(builtin_preset_names()) +
                      ": colours with a linear opacity ramp), or auto (default): viridis with the field's most "
                      "common values transparent when one narrow bump of the histogram holds much of the data (the "
                      "free stream), else viridis's ramp (docs/first-look.md)")
      ->type_name("FILE|NAME");
  cmd->add_option("--tf-name", opts->tf_name, "Preset to take from the --tf file (default: its first)")
      ->type_name("NAME");
  cmd->add_flag("--keep-range", opts->keep_range,
                "Keep the transfer function's own scalar range instead of rescaling it to the field's range");
  cmd->add_option("--range", opts->range,
                  "Rescale the transfer function to MIN,MAX (default: the field's range; with --time over all the "
                  "steps rendered), or per-step (--time: each step's own range)")
      ->type_name("MIN,MAX|per-step");
  cmd->add_option("--unit-distance", opts->unit_distance,
                  "Scalar opacity unit distance (default: the --tf file's ScalarOpacityUnitDistance, else the "
                  "bounds diagonal / 10, so that the inside shows, or / 100 where auto makes the most common values "
                  "transparent; ParaView uses the mean cell size)")
      ->type_name("D");
  cmd->add_option(
         "--field", opts->field,
         "Scalar to render: NAME, NAME:x|y|z|k or NAME:magnitude; a vector's NAME is its magnitude, on a mesh as "
         "in a store (default: the first field that varies)")
      ->type_name("NAME");
  cmd->add_option("--mode", opts->mode, "ea (emission-absorption, default), mip or iso (isosurfaces)")
      ->type_name("ea|mip|iso");
  cmd->add_option("--iso", opts->iso, "Isosurface values V1,V2,... (implies --mode iso)")->type_name("V1,V2,...");
  cmd->add_option("--iso-opacity", opts->iso_opacity, setting_help("iso_opacity"))->type_name("A");
  cmd->add_option("--clip", opts->clip, "Clip plane PX,PY,PZ,NX,NY,NZ: keeps the side the normal points to")
      ->type_name("PX,PY,PZ,NX,NY,NZ");
  cmd->add_option("--boundary-opacity", opts->boundary_opacity, setting_help("boundary_overlay_opacity"))
      ->type_name("A");
  cmd->add_flag("--no-lighting", opts->no_lighting, "No headlight shading of isosurfaces and the boundary");
  cmd->add_flag("--volume-lighting", opts->volume_lighting, "Shade emission-absorption by the field gradient");
  cmd->add_option("--background", opts->background, "Background R,G,B[,A] in [0, 1] (default ParaView's)")
      ->type_name("R,G,B[,A]");
  cmd->add_option("--early-termination", opts->early_termination, setting_help("early_termination_opacity"))
      ->type_name("A");
  cmd->add_option("--sample-step", opts->sample_step, setting_help("sample_step"))->type_name("S");
  cmd->add_option("--slice", opts->slices,
                  "Cutting plane PX,PY,PZ,NX,NY,NZ[,OPACITY] drawn with the volume, colour-mapped (repeatable; "
                  "docs/slices.md)")
      ->type_name("PX,PY,PZ,NX,NY,NZ[,A]");
  cmd->add_option("--slice-map", opts->slice_map,
                  "Colour map of the --slice planes: volume (the transfer function's colours, default) or " +
                      join(builtin_preset_names()))
      ->type_name("NAME");
  cmd->add_option("--slice-range", opts->slice_range, "Scalar range of the --slice colour map (default the volume's)")
      ->type_name("A:B");
  cmd->add_option("--slice-contours", opts->slice_contours,
                  "Contour lines on the --slice planes: N evenly spaced over the colour map's range, or the values "
                  "V1,V2,.. (at most " +
                      std::to_string(kMaxSliceContours) + ")")
      ->type_name("N|V1,V2,..");
  cmd->add_option("--slice-contour-color", opts->slice_contour_color,
                  "Colour of the --slice planes' contour lines (default black)")
      ->type_name("R,G,B");
  cmd->add_option("--slice-contour-width", opts->slice_contour_width,
                  "Width in pixels of the --slice planes' contour lines (default 1.5)")
      ->type_name("PX");
  cmd->add_option("--hide-volume", opts->hide_volume,
                  "Hide the volume around the slices: front (the side each normal points to), back, all or none")
      ->type_name("WHERE");
  cmd->add_option("--interpolation", opts->interpolation,
                  "Isosurfaces in the lod engine: trilinear (default) or tricubic (cubic B-spline, smooth normals; "
                  "docs/tricubic.md)")
      ->type_name("trilinear|tricubic");
  cmd->add_option("--settings", opts->settings, "Render settings JSON; the flags above override it")->type_name("FILE");
  cmd->add_option("--float", opts->float_output, "Also write the image as a float .pfm")->type_name("FILE");
  cmd->add_option("--stats", opts->stats, "Write timings, counters and the camera and settings used as JSON")
      ->type_name("FILE");
  cmd->add_option("--save-camera", opts->save_camera, "Write the camera used as JSON")->type_name("FILE");
  cmd->add_option("--save-tf", opts->save_tf, "Write the transfer function used as a ParaView preset")
      ->type_name("FILE");
  cmd->add_option("--threads", opts->threads, "Limit the worker threads (default: all cores)")->type_name("N");
  cmd->add_option("--frames", opts->frames,
                  "Render N times (benchmarks): --stats lists every frame time and the median after the first; with "
                  "--path: the number of frames along it")
      ->type_name("N");
}

}  // namespace ugvr::cli
