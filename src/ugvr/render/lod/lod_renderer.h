// The level-of-detail engine (lod_engine.h) behind the renderer interface (render/renderer.h), in two forms:
//  - LodRenderer: every frame draws the cut a CutSpec chooses ("leaves", "error:E", "pixels:P"): `ugvr render STORE`;
//  - InteractiveLodRenderer: a time-critical session (time_critical.h) that holds the request's target frame rate
//    while the view moves and refines to full quality when it rests: `ugvr render --path`, the viewer's tabs.
// Both draw from a LodScene, a store opened on a GL context; several renderers may share one (the viewer's tabs share
// its atlas). The scene's engine binds one field at a time: a renderer binds the field its request names first.
#pragma once
#include <memory>
#include <optional>
#include <string>

#include "ugvr/gpu/gl_context.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"
#include "ugvr/render/renderer.h"

namespace ugvr {

struct LodScene {
  // Opens the store (validated) on `gl`, which must be current on the calling thread. Throws ugvr::Error.
  LodScene(const std::string& store_path, std::shared_ptr<const GlContext> gl, LodOptions options = {});
  std::shared_ptr<const GlContext> gl;
  LodOptions options;
  LodEngine engine;
};

// One cut per frame: the engine's figures.
struct LodFrameStats : EngineFrameStats {
  LodRenderStats render;
  CutSpec cut;
  void to_json(nlohmann::json& j) const override;
};

// A time-critical frame: the controller's and the caches' figures.
struct InteractiveLodFrameStats : EngineFrameStats {
  TimeCriticalFrame frame;
  uint32_t brick_resolution = 0;  // samples per brick axis (uploaded bricks carry one more on each side)
  void to_json(nlohmann::json& j) const override;
};

// What both forms share: the scene, the field this renderer draws, and binding it on the shared engine.
class LodRendererBase : public Renderer {
 public:
  explicit LodRendererBase(std::shared_ptr<LodScene> scene) : scene_(std::move(scene)) {}
  // "hybrid" when the scene draws exact cells (LodOptions::hybrid), else "lod".
  std::string_view engine() const override { return scene_->options.hybrid ? "hybrid" : "lod"; }
  std::string device() const override { return scene_->gl->renderer(); }
  void set_field(std::string_view name) override;
  const std::string& field_name() const override;
  FieldRange field_range() const override;
  Bounds bounds() const override { return scene_->engine.bounds(); }
  // From the store's coarse levels (kCoarseHistogramLevel), as the viewer's editor; empty for a field the store does
  // not hold by that name.
  std::vector<uint64_t> value_histogram(double lo, double hi, int bins) const override;
  // From the node table's ranges down to kVisibleLevel (no brick read); nullopt for a field the store does not hold.
  std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const override;
  std::vector<double> visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                      const Bounds& own) const override;
  void describe(nlohmann::json& j) const override;

 protected:
  // Binds request.settings.field (this renderer's field from now on) on the shared engine; returns the engine.
  LodEngine& bind_request(const FrameRequest& request);
  std::shared_ptr<LodScene> scene_;
  std::string field_;       // a store field name; "" = the first
  uint32_t time_step_ = 0;  // a time store's step (FrameRequest::time_step)
};

class LodRenderer final : public LodRendererBase {
 public:
  LodRenderer(std::shared_ptr<LodScene> scene, CutSpec cut);
  Frame render(const FrameRequest& request) override;
  std::string summary(const FrameStats& last) const override;

 private:
  CutSpec cut_;
};

class InteractiveLodRenderer final : public LodRendererBase {
 public:
  // options.target_fps is replaced by each request's target_fps.
  InteractiveLodRenderer(std::shared_ptr<LodScene> scene, TimeCriticalOptions options);
  ~InteractiveLodRenderer() override;
  Frame render(const FrameRequest& request) override;
  std::string summary(const FrameStats& last) const override;
  // Waits for the bricks FrameRequest::prefetch_time_step asked for (TimeCriticalRenderer::wait_prefetch).
  bool wait_prefetch(double timeout_seconds);

 private:
  TimeCriticalOptions options_;
  // The session: its active cut, RAM cache and cost estimate belong to one field and sample step; a new one starts
  // when either changes (a new time step only swaps its bricks).
  std::unique_ptr<TimeCriticalRenderer> session_;
  std::string session_field_;
  double session_step_ = -1, session_fps_ = -1;
  uint32_t session_time_step_ = 0;
};

}  // namespace ugvr
