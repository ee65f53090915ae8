#include "ugvr/mpi/piece_renderer.h"

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/render/lod/lod_renderer.h"

namespace ugvr {
namespace {

class PieceRenderer final : public Renderer {
 public:
  PieceRenderer(const PieceIndex& index, std::vector<int> pieces, std::vector<std::unique_ptr<Renderer>> renderers)
      : tree_(index.tree), pieces_(std::move(pieces)), renderers_(std::move(renderers)), total_(index.count()) {}

  std::string_view engine() const override { return "lod"; }
  std::string device() const override { return renderers_[0]->device(); }
  void set_field(std::string_view name) override {
    for (auto& r : renderers_) r->set_field(name);
  }
  const std::string& field_name() const override { return renderers_[0]->field_name(); }
  // Every piece records the whole dataset's ranges and bounds.
  FieldRange field_range() const override { return renderers_[0]->field_range(); }
  Bounds bounds() const override { return renderers_[0]->bounds(); }
  void describe(nlohmann::json& j) const override {
    renderers_[0]->describe(j);
    j["pieces"] = total_;
    j["pieces_drawn"] = pieces_;
  }
  std::string summary(const FrameStats& last) const override {
    FrameStats first = last;
    first.detail = first_detail_;
    return std::to_string(pieces_.size()) + " of " + std::to_string(total_) + " pieces (" +
           std::to_string(last.cut_nodes) + " nodes in all); piece " + std::to_string(pieces_[0]) + ": " +
           renderers_[0]->summary(first);
  }

  Frame render(const FrameRequest& request) override {
    const auto t0 = std::chrono::steady_clock::now();
    FrameRequest mine = request;
    mine.settings.background = {0, 0, 0, 0};
    mine.settings.early_termination_opacity = 1;  // what lies in front of a piece is another piece's
    const int width = request.settings.width, height = request.settings.height;
    // Front to back: the whole tree's visibility order, restricted to these pieces (a kd subtree's pieces come in
    // its own order there).
    std::vector<float> blended;
    Frame out;
    out.stats.engine = "lod";
    for (int piece : tree_.visibility_order(request.camera)) {
      const auto it = std::find(pieces_.begin(), pieces_.end(), piece);
      if (it == pieces_.end()) continue;
      const size_t i = size_t(it - pieces_.begin());
      Frame f = renderers_[i]->render(mine);
      if (f.image.width != width || f.image.height != height)
        fail_in("pieces", "piece " + std::to_string(piece) + " drew the wrong image size");
      if (blended.empty())
        blended = premultiplied(f.image);
      else
        blend_under(blended, premultiplied(f.image));
      out.stats.samples += f.stats.samples;
      out.stats.cut_nodes += f.stats.cut_nodes;
      out.stats.visible_nodes += f.stats.visible_nodes;
      out.stats.gpu_bytes += f.stats.gpu_bytes;
      out.stats.gpu_budget += f.stats.gpu_budget;
      if (i == 0) out.stats.detail = f.stats.detail;
    }
    first_detail_ = out.stats.detail;
    out.image = apply_background(blended, width, height, request.settings.background);
    out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

 private:
  KdTree tree_;
  std::vector<int> pieces_;
  std::vector<std::unique_ptr<Renderer>> renderers_;
  int total_ = 0;
  std::shared_ptr<const EngineFrameStats> first_detail_;
};

}  // namespace

std::unique_ptr<Renderer> open_piece_renderer(const PieceIndex& index, std::vector<int> pieces,
                                              const RendererOptions& options) {
  if (options.engine != "auto" && options.engine != "lod")
    throw OptionError("engine", index.path + ": a partitioned store renders with the lod engine");
  if (options.interactive)
    throw OptionError("fps", index.path + ": interactive rendering of a partitioned store is not supported yet");
  if (pieces.empty())
    for (int k = 0; k < index.count(); ++k) pieces.push_back(k);
  std::shared_ptr<const GlContext> gl = options.gl_context;
  if (!gl) {
    try {
      gl = std::make_shared<GlContext>(options.gpu);
    } catch (const Error& e) {
      throw OptionError("gpu", e.what());
    }
  }
  std::vector<std::unique_ptr<Renderer>> renderers;
  for (int k : pieces) {
    if (k < 0 || k >= index.count()) fail_in(index.path, "no piece " + std::to_string(k));
    const std::string path = index.store_path(k);
    std::shared_ptr<LodScene> scene;
    try {
      scene = std::make_shared<LodScene>(path, gl, options.lod);
    } catch (const Error& e) {
      const std::string what = e.what();
      // Name the piece's file whatever the store reader said.
      if (what.find(path) == std::string::npos) fail_in(path, "piece " + std::to_string(k) + ": " + what);
      throw;
    }
    scene->engine.set_clip_box(index.pieces[size_t(k)].box);
    RendererOptions one = options;
    one.gl_context = gl;
    renderers.push_back(make_renderer(std::move(scene), one));
  }
  return std::make_unique<PieceRenderer>(index, std::move(pieces), std::move(renderers));
}

}  // namespace ugvr
