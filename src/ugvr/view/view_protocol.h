// The browser viewer's WebSocket protocol (`ugvr view`, view_server.h). Every client message is one JSON object in a
// text frame, at most kMaxClientMessageBytes, with a "type" and only the keys listed for it (unknown keys are typos
// and rejected, like everywhere else in ugvr). Numbers must be finite and in range.
//
// Client -> server:
//   {"type":"hello",  "width":W, "height":H}          first message: the canvas size, W and H in [16, 4096]
//   {"type":"resize", "width":W, "height":H}
//   {"type":"camera", "position":[x,y,z], "focal_point":[x,y,z], "view_up":[x,y,z], "view_angle":A,
//                     "parallel_projection":B, "parallel_scale":S}           camera.h's JSON form (validated there)
//   {"type":"tf", "preset":NAME, "opacity":A, "rgb_points":[x,r,g,b,...], "opacity_points":[x,a,...]}
//       every key optional: a built-in preset (rescaled to the field's range), and/or explicit points in data
//       values (ParaView's flat layout, at most kMaxTfPoints points each); "opacity" in [0, 1] scales the opacity
//   {"type":"settings", "mode":"ea"|"mip"|"iso", "iso_value":V, "step_voxels":S, "fps":F, "full_quality":true,
//    "field":NAME, "boundary_opacity":A, "clip":{"point":[x,y,z],"normal":[x,y,z]}|null, "iso_opacity":A,
//    "lighting":B, "volume_lighting":B, "early_termination_opacity":A, "sample_step":D, "background":[r,g,b],
//    "slices":[{"point":[x,y,z],"normal":[x,y,z],"opacity":A,"color_map":NAME,"range":[lo,hi]|null}...],
//    "hide_volume":"none"|"front"|"back"|"all", "interpolation":"trilinear"|"tricubic"}
//       every key optional: step in (0, 8] voxels (the resting step), fps in [0, 240] (0: every frame at full
//       quality), full_quality asks for one converged frame of the current view now; field one of the scene's
//       fields (a non-empty name of at most kMaxFieldName bytes; switching resets explicit transfer-function
//       points, so the preset is rescaled to the new range); boundary_opacity in [0, 1] (the dataset's outer
//       boundary drawn over the image, 0: off); clip keeps the half-space the non-zero normal points to, null: off;
//       iso_opacity in [0, 1] (each isosurface's); lighting true/false (headlight shading of isosurfaces and the
//       boundary); volume_lighting true/false (emission-absorption shaded by the gradient); early_termination_opacity
//       in (0, 1] (a ray stops at this opacity); sample_step in world units, >= 0 (0: the engine's level of detail,
//       step_voxels); background [r, g, b] in [0, 1] (opaque: frames are JPEG while moving); slices: the whole
//       list of cutting planes (replaces the tab's; [] removes them; render_settings.h Slice, at most kMaxSlices,
//       web/slices.js sends it), hide_volume where the volume is hidden around them; interpolation the
//       isosurfaces' reconstruction in the LOD engine (docs/tricubic.md). These are
//       RenderSettings fields: src/ugvr/render/settings_table.h maps each to its message key and gives the ranges
//   {"type":"engine", "engine":"exact"|"lod"|"hybrid"}   which engine draws this tab: the exact engine over the
//       grid, the level-of-detail engine over the brick store, or the hybrid engine (the same store's voxels while
//       moving, its leaves' cells exact at rest; only a store built with --cells, docs/hybrid.md); it must be one of
//       the scene's "engines" (view_request.h rejects the others), and a tab that never sends one is drawn by the
//       scene's "engine"
//   {"type":"interest", "focus":"FIELD:MIN:MAX[+...][,...]"|null,
//   "roi":"box:X0,Y0,Z0,X1,Y1,Z1"|"sphere:CX,CY,CZ,R"|null,
//    "context_saturation":S, "context_opacity":A}   the tab's degree of interest (docs/hybrid.md; `ugvr render`'s
//       --focus, --roi, --context-saturation, --context-opacity, the same texts): every key optional, null removes
//       the focus or the region; a focus field must be one of the scene's; S and A in [0, 1]. The store's engines
//       (lod, hybrid) draw the nodes of zero interest as context, desaturated and faint, and the hybrid engine gives
//       exact cells to the focus only; the exact engine ignores it
//   {"type":"time", "step":N, "playing":B}   shows step N (an integer in [0, count)) of a time series (the scene's
//       "time"); "playing" (optional, default false): the page is playing, so the server reads the next step ahead
//       while this one renders. A scene without a time axis rejects it ("step: ...")
//
// Server -> client:
//   text {"type":"scene", ...}   after hello: field, range, fields (with histograms), bounds, the initial camera,
//         presets and their colours, limits, the engines a tab may pick and each one's renderer label; again when the
//         server switches engine (a background build finished: every tab moves to "lod"); a time series adds
//         "time":{"count", "times":[t...], "step"} (the step new tabs show; the field ranges are over every step),
//         and "play": R when the page should start playing at R steps a second (`ugvr view --play`)
//   text {"type":"status", "seq", "request", "format":"jpeg"|"png", "width", "height", "fps", "frame_seconds",
//         "cut_nodes", "visible_nodes", "texel_error", "max_texel_error", "scale", "converged"}   describes the
//         binary frame that follows it; "request" counts the client messages accepted (not rejected) before the
//         frame's view was taken, so a client knows when frames reflect its latest request (earlier ones may still be
//         on the wire)
//   binary: the frame, JPEG while moving or refining, PNG once converged (lossless)
//   text {"type":"ack", "request":N}   the client's first N accepted messages are reflected by the frame it has (or
//         the one on its way): the last of them changed nothing that is drawn (a repeated camera, the same step
//         again), so no frame is drawn for it. A client takes the larger of a status's and the last ack's "request"
//   text {"type":"error", "message":"FIELD: what is wrong"}   a rejected message; the session goes on
//   text {"type":"progress", ...}  loading the grid and the background build of its store (ProgressInfo); a new
//         "scene" follows "ready". A viewer of a grid serves before it reads it: its first messages after hello are
//         progress ("read", then "build"), and the first "scene" comes when an engine can draw (none before it: frames
//         only follow a scene). At most one every 250 ms, except a stage's end
//   text {"type":"view", "camera":{...}, "tf":{"rgb_points":[...],"opacity_points":[...]}}   the server moved the
//       tab's view (ViewServer::set_view; either part may be absent; also after hello, once one was set): the page
//       takes it as its own and sends nothing back
//   status also carries "time_step" and "time" (a time series: the step the frame shows), "engine", "ram_bytes",
//   "ram_budget", "atlas_bytes", "atlas_budget", "pending_bricks"; a hybrid frame "exact":{"nodes", "candidates",
//   "fraction", "cells", "cell_bytes", "cell_budget", "budget_full", "focus_excluded", "off"}: its exact nodes, of
//   the visible nodes with cells (candidates), the fraction of the cut they are, their cells and memory, whether the
//   cell budget is full (no more can turn exact), nodes left out for zero interest, and why none can be exact
//   ("off", null when hybrid runs)
#pragma once

#include <array>
#include <cstddef>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/lod/hybrid_select.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr::view {

inline constexpr size_t kMaxClientMessageBytes = 64 * 1024;
inline constexpr int kMinViewSide = 16, kMaxViewSide = 4096;
inline constexpr size_t kMaxTfPoints = 1024;
inline constexpr double kMaxFps = 240;
inline constexpr size_t kMaxFieldName = 256;

struct SizeMessage {
  bool hello = false;  // hello (first message) or resize
  int width = 0, height = 0;
};

struct CameraMessage {
  Camera camera;
};

struct TfMessage {
  std::optional<std::string> preset;
  std::optional<double> opacity;
  std::vector<ColorPoint> color_points;  // empty: keep the preset's (or the current) colours
  std::vector<OpacityPoint> opacity_points;
};

struct SettingsMessage {
  std::optional<RenderMode> mode;
  std::optional<double> iso_value;
  std::optional<double> step_voxels;
  std::optional<double> fps;
  bool full_quality = false;
  std::optional<std::string> field;
  std::optional<double> boundary_opacity;
  std::optional<std::optional<ClipPlane>> clip;  // absent: unchanged; holds nullopt: clipping off
  std::optional<double> iso_opacity;
  std::optional<bool> lighting;
  std::optional<bool> volume_lighting;
  std::optional<double> early_termination_opacity;
  std::optional<double> sample_step;
  std::optional<std::array<double, 4>> background;  // alpha always 1
  std::optional<std::vector<Slice>> slices;         // the whole list
  std::optional<HideVolume> hide_volume;
  std::optional<Interpolation> interpolation;
};

// The engines a tab can be drawn by (SceneInfo::engines says which this viewer has).
inline constexpr std::string_view kExactEngine = "exact", kLodEngine = "lod", kHybridEngine = "hybrid";

struct EngineMessage {
  std::string engine;  // kExactEngine, kLodEngine or kHybridEngine
};

struct TimeMessage {
  uint32_t step = 0;     // checked against the scene's step count by apply_message (view_request.h)
  bool playing = false;  // the page plays: the next step is read ahead
};

// The degree of interest (hybrid_select.h): absent keys leave the tab's as they are.
struct InterestMessage {
  std::optional<std::vector<FocusRange>> focus;        // holds an empty list: no focus
  std::optional<std::optional<RegionOfInterest>> roi;  // holds nullopt: no region
  std::optional<double> context_saturation, context_opacity;
};

using ClientMessage =
    std::variant<SizeMessage, CameraMessage, TfMessage, SettingsMessage, EngineMessage, TimeMessage, InterestMessage>;

// One engine a tab may be drawn by, and its renderer's label for the page: "exact engine (CPU)", "exact engine (GPU:
// NAME)", or the GL_RENDERER the level-of-detail engine draws with.
struct EngineChoice {
  std::string name;  // kExactEngine, kLodEngine or kHybridEngine
  std::string renderer;
};

// What the scene message tells a page about the data, and what new tabs start from.
struct FieldInfo {
  std::string name;
  double min = 0, max = 1;          // range over the data (NaN excluded)
  std::vector<uint64_t> histogram;  // counts over [min, max] in equal bins; empty when unknown
};

struct SceneInfo {
  std::vector<FieldInfo> fields;
  std::string field;  // the field new tabs show
  Bounds bounds;
  Camera camera;  // the reset view
  std::string preset = "viridis";
  double fps = 10;
  int width = 512, height = 512;
  std::string renderer;  // the label of `engine`'s renderer (renderers[engine])
  // What new tabs are drawn by: "lod" (the brick store), "hybrid" (a store with cells, unless
  // ViewServerOptions::hybrid is off) or "exact" (while a store is built).
  std::string engine;
  // The engines a tab may pick ("engine" message), in the page's order: exact while the store of a grid is built;
  // exact and lod once it is shown and the grid is kept; lod for a viewer of a store (or with --free-grid); hybrid
  // besides lod where the store keeps cells.
  std::vector<EngineChoice> engines;
  // The transfer function new tabs start from (`ugvr view --tf FILE`: points in data values; an
  // opacity_unit_distance <= 0 means the viewer's default); none: `preset` over the field's range.
  std::optional<TransferFunction> tf;
  // ViewServerOptions::auto_tf (`ugvr view` without --tf): per field name, the "auto" transfer function's opacity
  // points over the field's range and its opacity unit distance (default_transfer_function.h, from the field's
  // histogram), which a tab on that field starts from instead of the preset's ramp (picking a preset keeps them).
  struct AutoOpacity {
    std::vector<OpacityPoint> points;
    double unit_distance = 0;
  };
  std::map<std::string, AutoOpacity> auto_opacity;
  // The background new tabs start from (the demo's is dark); none: RenderSettings' default. A page that picks one
  // sends it in a settings message.
  std::optional<std::array<double, 4>> background;
  // A time series' steps (their times, in order; empty: no time axis, a single step) and the step new tabs show.
  std::vector<double> times;
  uint32_t time_step = 0;
  double play_rate = 0;  // > 0: new tabs start playing the steps at this many a second (`ugvr view --play`)

  // The field called `name` (empty: `field`; a vector's name alone: its "NAME:magnitude"), or null.
  const FieldInfo* find_field(std::string_view name) const;
  // Whether a tab may pick the engine called `name`.
  bool has_engine(std::string_view name) const;
};

// {"type":"scene", "field", "range", "fields":[{"name","range","histogram"}...], "bounds", "camera", "presets",
//  "preset_points":{NAME:[x,r,g,b,...] over [0, 1]}, "preset", "fps", "width", "height", "renderer", "engine",
//  "engines":[NAME...], "renderers":{NAME:LABEL...}, "limits", "tf":{"rgb_points":[x,r,g,b,...],
//  "opacity_points":[x,a,...]} (only with SceneInfo::tf)}; a field in SceneInfo::auto_opacity has "auto_opacity":
//  [x,a,...] too (its opacity points, which the page's editor starts from)
std::string scene_message(const SceneInfo& scene);

// Parses and validates one client message. Throws ugvr::Error "FIELD: what is wrong" (FIELD is "message" for the
// whole text, "type" for the type, else the key).
ClientMessage parse_client_message(std::string_view text);

// {"type":"error","message":...}
std::string error_message(std::string_view message);
// {"type":"view","camera":{...},"tf":{"rgb_points":[x,r,g,b,...],"opacity_points":[x,a,...]}}: the view the server
// moved the tab to (ViewServer::set_view); either part may be absent. The page takes it as its own.
std::string view_message(const std::optional<Camera>& camera, const std::optional<TransferFunction>& tf);

struct FrameStatus {
  uint64_t seq = 0;      // frames sent to this session
  uint64_t request = 0;  // accepted client messages reflected in the frame
  bool png = false;
  int width = 0, height = 0;
  double fps = 0;            // frames per second this session has been getting (moving average)
  double frame_seconds = 0;  // render time of this frame
  uint64_t cut_nodes = 0, visible_nodes = 0;
  double texel_error = 0, max_texel_error = 0;  // screen size of a texel, mean and max, in pixels
  double scale = 1;
  bool converged = false;
  std::string engine = "lod";                  // the engine that drew the frame: "lod", "hybrid" or "exact"
  uint64_t ram_bytes = 0, ram_budget = 0;      // this tab's RAM brick cache: resident decoded bricks, and its budget
  uint64_t atlas_bytes = 0, atlas_budget = 0;  // the GPU atlas (shared by all tabs)
  uint64_t pending_bricks = 0;                 // bricks the refinement waits for (queued or loading from disk)
  uint64_t interrupted = 0;  // this tab's frames cut short so far: resting ones abandoned because the view moved on
  int64_t time_step = -1;    // the series' step shown (-1: no time axis)
  double time = 0;           // its time
  // A hybrid frame (engine "hybrid"; LodRenderStats' figures): how much of the cut is drawn by exact cells.
  bool hybrid = false;
  uint64_t exact_nodes = 0, exact_candidates = 0, exact_cells = 0, focus_excluded = 0;
  double exact_fraction = 0;  // exact_nodes / cut nodes drawn
  uint64_t cell_bytes = 0, cell_budget = 0;
  bool cell_budget_full = false;
  std::string exact_off;  // why no node can be exact ("" when hybrid runs)
};
std::string status_message(const FrameStatus& s);
// {"type":"ack","request":N}: see the protocol above.
std::string ack_message(uint64_t request);

// {"type":"progress", "stage":"read"|"build"|"ready"|"failed", "label", "fraction", "message"}: loading a grid file
// and building its brick store in the background (`ugvr view MESH`): "read" while the file is read (label: the
// reader's step); "build" while the exact engine's walk mesh (label "walk mesh") and then the store are built (label:
// the builder's step); "failed" when loading or building failed (message: why); "ready" just before the new scene
// message of the store. `message` also says why the store is built out of core when the grid is over the memory
// budget (view/memory_budget.h).
struct ProgressInfo {
  std::string stage;
  std::string label;  // the step now under way ("subdivide", "bricks", ...)
  double fraction = 0;
  std::string message;
};
std::string progress_message(const ProgressInfo& p);

}  // namespace ugvr::view
