// `ugvr render`'s flags: the Options they fill, their registration, and the parsing of the engine-independent ones
// into RenderSettings (render_settings.h). Every value flag is bound as text and parsed here, so a bad value is a
// ugvr::Error naming the flag (exit 1) like every other user error, rather than CLI11's own message and exit code.
#pragma once
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
#include "ugvr/render/render_settings.h"

namespace ugvr::cli {

struct RenderOptions {
  std::vector<std::string> inputs;
  ReadOptions read;
  std::string output, size, engine = "auto", camera, view, view_angle, tf, tf_name, range, unit_distance, field, mode,
                            iso, iso_opacity, clip, boundary_opacity, background, early_termination, sample_step,
                            settings, float_output, stats, save_camera, save_tf, threads, frames, cut = "pixels:1",
                            gpu = "auto", step_voxels, fps, path, out_dir, uploads_per_frame, reads_per_frame,
                            error_weight, device = "auto", exact_precision = "double", time;
  std::vector<std::string> slices;  // --slice, repeatable
  std::string slice_map, slice_range, slice_contours, slice_contour_color, slice_contour_width, hide_volume,
      interpolation, focus, roi, context_saturation, context_opacity;
  uint64_t gpu_memory = uint64_t(2) << 30, ram_memory = uint64_t(1) << 30;
  uint64_t gpu_cell_memory = 0;  // hybrid: GPU memory for exact cells (0: a quarter of gpu_memory)
  bool keep_range = false, no_lighting = false, volume_lighting = false;
};

// Adds every flag of `ugvr render` to cmd, bound to o.
void add_render_flags(CLI::App& cmd, RenderOptions& o);

// The view presets --view takes.
extern const std::vector<std::string> kViews;

[[noreturn]] inline void fail_flag(std::string_view flag, const std::string& message) { fail_in(flag, message); }

// Runs f; an error it raises (a file's own message naming the file) is prefixed with the flag that named the file.
template <class F>
auto with_flag(std::string_view flag, F&& f) {
  try {
    return f();
  } catch (const Error& e) {
    fail_flag(flag, e.what());
  }
}

int parse_positive_int(std::string_view text, std::string_view flag);
// "a,b,c" with a count in [min_count, max_count].
std::vector<double> parse_list(std::string_view text, std::string_view flag, size_t min_count, size_t max_count,
                               std::string_view form);
double parse_fraction(std::string_view text, std::string_view flag);
std::string join(const std::vector<std::string>& names, std::string_view sep = ", ");
void check_extension(const std::string& path, std::string_view flag, const std::vector<std::string>& allowed);
// The flags on top of --settings (or the defaults): only what was given overrides.
RenderSettings settings_from_flags(const RenderOptions& o);
// Whether --tf names a file (else a built-in preset).
bool is_tf_file(const std::string& tf);

}  // namespace ugvr::cli
