#include "ugvr/mpi/piece_renderer.h"

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/render/lod/lod_renderer.h"
#include "ugvr/render/visible_bounds.h"

namespace ugvr {
namespace {

// The first drawn piece's engine figures, then the pieces' own: their cut sizes (the sum as `cut_nodes`).
struct PieceFrameStats : EngineFrameStats {
  std::shared_ptr<const EngineFrameStats> first;
  std::vector<int> pieces;          // drawn, in visibility order
  std::vector<uint64_t> cut_nodes;  // per drawn piece, same order
  void to_json(nlohmann::json& j) const override {
    if (first) first->to_json(j);
    uint64_t sum = 0;
    for (uint64_t n : cut_nodes) sum += n;
    j["cut_nodes"] = sum;
    j["pieces_drawn"] = pieces;
    j["piece_cut_nodes"] = cut_nodes;
  }
};

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
  // The pieces' counts summed (their cells are disjoint; a piece's ghost layers count twice, a small error in a shape).
  std::vector<uint64_t> value_histogram(double lo, double hi, int bins) const override {
    std::vector<uint64_t> sum;
    for (const auto& r : renderers_) {
      const std::vector<uint64_t> h = r->value_histogram(lo, hi, bins);
      if (sum.empty()) sum.assign(h.size(), 0);
      for (size_t i = 0; i < h.size() && i < sum.size(); ++i) sum[i] += h[i];
    }
    return sum;
  }
  // The pieces' weights added up (each piece's nodes are its own), as one store's would be.
  std::vector<double> visible_weights(const TransferFunction& tf, double threshold, const Bounds& over,
                                      const Bounds& own) const override {
    std::optional<VisibleWeights> sum;
    for (const auto& r : renderers_) {
      const std::optional<VisibleWeights> w =
          VisibleWeights::from_flat(over, r->visible_weights(tf, threshold, over, own));
      if (!w) return {};  // a piece cannot say: nor can the whole
      if (sum)
        sum->merge(*w);
      else
        sum = *w;
    }
    return sum ? sum->flat() : std::vector<double>{};
  }
  // The box of the pieces' weights; else their boxes united; nullopt when no piece can say.
  std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const override {
    if (const std::optional<VisibleWeights> w =
            VisibleWeights::from_flat(bounds(), visible_weights(tf, threshold, bounds(), all_space())))
      return w->box();
    std::optional<Bounds> all;
    for (const auto& r : renderers_)
      if (const std::optional<Bounds> b = r->visible_bounds(tf, threshold)) {
        if (!all) all = Bounds{};
        all->add(*b);
      }
    return all;
  }
  void describe(nlohmann::json& j) const override {
    renderers_[0]->describe(j);
    j["pieces"] = total_;
    j["pieces_drawn"] = pieces_;
  }
  std::string summary(const FrameStats& last) const override {
    FrameStats first = last;
    const auto* d = dynamic_cast<const PieceFrameStats*>(last.detail.get());
    first.detail = d ? d->first : nullptr;
    const int front = d && !d->pieces.empty() ? d->pieces[0] : pieces_[0];
    const size_t i = size_t(std::find(pieces_.begin(), pieces_.end(), front) - pieces_.begin());
    return std::to_string(pieces_.size()) + " of " + std::to_string(total_) + " pieces (" +
           std::to_string(last.cut_nodes) + " cut nodes in all); front piece " + std::to_string(front) + ": " +
           renderers_[std::min(i, renderers_.size() - 1)]->summary(first);
  }

  Frame render(const FrameRequest& request) override {
    // A maximum intensity projection composes by the maximum of the pieces' values, not by blending their colours.
    if (request.settings.mode == RenderMode::Mip)
      throw OptionError("mode",
                        "mip is not supported for a partitioned store yet (pieces' maxima would need max "
                        "compositing)");
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
    auto detail = std::make_shared<PieceFrameStats>();
    for (int piece : tree_.visibility_order(request.camera)) {
      const auto it = std::find(pieces_.begin(), pieces_.end(), piece);
      if (it == pieces_.end()) continue;
      const size_t i = size_t(it - pieces_.begin());
      // In one process a frame of many pieces (seconds at full quality) stops between them too, not only inside one.
      if (request.keep_going && !request.keep_going()) throw FrameInterrupted();
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
      if (!detail->first) detail->first = f.stats.detail;
      detail->pieces.push_back(piece);
      detail->cut_nodes.push_back(f.stats.cut_nodes);
    }
    out.stats.detail = detail;
    out.image = apply_background(blended, width, height, request.settings.background);
    out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

 private:
  KdTree tree_;
  std::vector<int> pieces_;
  std::vector<std::unique_ptr<Renderer>> renderers_;
  int total_ = 0;
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
