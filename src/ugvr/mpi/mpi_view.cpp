#include "ugvr/mpi/mpi_view.h"

#include <mpi.h>

#include <chrono>
#include <cstdint>
#include <exception>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>

#include "ugvr/core/error.h"
#include "ugvr/mpi/mpi_renderer.h"
#include "ugvr/mpi/mpi_session.h"
#include "ugvr/render/scaled_while_moving.h"

namespace ugvr::mpi {
namespace {

using Clock = std::chrono::steady_clock;

// Step 1 and 2 of the protocol (mpi_view.h), rank 0's side: an empty text is the quit.
void broadcast_text(const std::string& text) {
  uint64_t length = text.size();
  MPI_Bcast(&length, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  if (length > 0) MPI_Bcast(const_cast<char*>(text.data()), int(length), MPI_CHAR, 0, MPI_COMM_WORLD);
}

// The followers' side: "" means quit.
std::string receive_text() {
  uint64_t length = 0;
  MPI_Bcast(&length, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  std::string text(length, '\0');
  if (length > 0) MPI_Bcast(text.data(), int(length), MPI_CHAR, 0, MPI_COMM_WORLD);
  return text;
}

// Steps 3 and 4, on every rank: the collective frame, then the slowest rank's time for it.
struct DrawnFrame {
  Frame frame;
  double slowest_seconds = 0;
};
DrawnFrame draw_collectively(Renderer& renderer, const FrameRequest& request) {
  const Clock::time_point start = Clock::now();
  DrawnFrame out;
  out.frame = renderer.render(request);
  const double mine = std::chrono::duration<double>(Clock::now() - start).count();
  MPI_Allreduce(&mine, &out.slowest_seconds, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return out;
}

// A question between frames (the text of step 2 is then this JSON instead of a frame request): the box of what `tf`
// makes more than `threshold` opaque in field `field`, which every rank answers together with the compositing
// renderer's reduction (mpi_renderer.cpp visible_bounds), so that the viewer's framed view is one camera. The
// transfer function travels as the frame's does and rank 0 asks with the decoded one, as it draws the decoded frame.
struct VisibleBoundsQuestion {
  std::string field;
  TransferFunction tf;
  double threshold = 0;
};
constexpr const char* kVisibleBoundsKey = "visible_bounds";

std::string encode_visible_bounds_question(const VisibleBoundsQuestion& q) {
  nlohmann::json j;
  j[kVisibleBoundsKey] = {{"field", q.field}, {"tf", paraview_preset_json(q.tf)}, {"threshold", q.threshold}};
  return j.dump();
}

// nullopt: the text is a frame request.
std::optional<VisibleBoundsQuestion> decode_visible_bounds_question(const std::string& text) {
  constexpr std::string_view source = "the visible-bounds question between MPI ranks";
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains(kVisibleBoundsKey)) return std::nullopt;
  const nlohmann::json& q = j[kVisibleBoundsKey];
  for (const char* key : {"field", "tf", "threshold"})
    if (!q.contains(key)) fail_in(source, std::string("missing \"") + key + "\"");
  const std::vector<TransferFunction> tf = parse_paraview_presets(q["tf"].get<std::string>(), source);
  if (tf.size() != 1) fail_in(source, "expected one transfer function");
  return VisibleBoundsQuestion{q["field"].get<std::string>(), tf[0], q["threshold"].get<double>()};
}

// Every rank binds the field asked about, then takes part in the renderer's reduction.
std::optional<Bounds> answer_collectively(Renderer& renderer, const VisibleBoundsQuestion& q) {
  renderer.set_field(q.field);
  return renderer.visible_bounds(q.tf, q.threshold);
}

class ViewLeader final : public Renderer {
 public:
  explicit ViewLeader(std::unique_ptr<Renderer> collective) : collective_(std::move(collective)) {}
  // The followers wait for the next request: this is their last.
  ~ViewLeader() override {
    if (active()) broadcast_text("");
  }
  ViewLeader(const ViewLeader&) = delete;
  ViewLeader& operator=(const ViewLeader&) = delete;

  std::string_view engine() const override { return collective_->engine(); }
  std::string device() const override { return collective_->device(); }
  // Rank 0 only: each frame's request names the field every rank binds.
  void set_field(std::string_view name) override { collective_->set_field(name); }
  const std::string& field_name() const override { return collective_->field_name(); }
  FieldRange field_range() const override { return collective_->field_range(); }
  Bounds bounds() const override { return collective_->bounds(); }
  // value_histogram is left at the default (none): the collective renderer's is a collective call, which rank 0
  // alone would make here while the other ranks wait for a frame.
  // The followers are asked first (step 1 and 2 with a VisibleBoundsQuestion), then every rank reduces: the box of
  // the whole data's visible part, the same on every rank.
  std::optional<Bounds> visible_bounds(const TransferFunction& tf, double threshold) const override {
    const std::string text = encode_visible_bounds_question({collective_->field_name(), tf, threshold});
    const VisibleBoundsQuestion asked = *decode_visible_bounds_question(text);
    broadcast_text(text);
    try {
      return answer_collectively(*collective_, asked);
    } catch (const std::exception& e) {
      abort_job(std::string("error: ") + e.what(), 1);  // the other ranks are inside the reduction
    }
  }
  void describe(nlohmann::json& j) const override { collective_->describe(j); }
  std::string summary(const FrameStats& last) const override { return collective_->summary(last); }

  Frame render(const FrameRequest& request) override {
    refuse_unsupported(request);
    const Clock::time_point start = Clock::now();
    // Moving: a reduced scale, adapted to the slowest rank's time (render/scaled_while_moving.h).
    const MovingScale::Plan plan = scale_.plan(request);
    FrameRequest drawn = plan.drawn;
    // Every rank binds the field rank 0 has bound (the followers never saw rank 0's set_field).
    if (drawn.settings.field.empty()) drawn.settings.field = collective_->field_name();
    drawn.prefetch_time_step.reset();
    drawn.keep_going = request.keep_going;  // sent as the flag "interruptible"
    // What every rank draws is the decoded text, so that rank 0 draws the same numbers as the others; a request that
    // does not survive the trip fails here, before any rank hears of it.
    const std::string text = encode_frame_request(drawn);
    drawn = decode_frame_request(text);
    drawn.keep_going = request.keep_going;  // rank 0 asks the viewer's question; the others follow its answer

    broadcast_text(text);
    DrawnFrame d;
    try {
      d = draw_collectively(*collective_, drawn);
    } catch (const FrameInterrupted&) {
      throw;  // every rank agreed to drop the frame (mpi_frame_stop.h): none is left inside a collective
    } catch (const std::exception& e) {
      // The other ranks are inside this frame's collectives: only ending the job frees them.
      abort_job(std::string("error: ") + e.what(), 1);
    }
    Frame frame = std::move(d.frame);
    scale_.finish(plan, request, d.slowest_seconds, frame);
    frame.stats.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return frame;
  }

 private:
  // Refused on rank 0 before the broadcast (the page says why, the ranks carry on).
  static void refuse_unsupported(const FrameRequest& request) {
    if (request.settings.mode == RenderMode::Mip)
      fail_in("mode",
              "maximum intensity projection is not supported under MPI yet (ranks' maxima would need max "
              "compositing, docs/mpi.md)");
    if (request.time_step) fail_in("time", "time steps are not shown under MPI yet (docs/mpi.md)");
  }

  std::unique_ptr<Renderer> collective_;
  MovingScale scale_;
};

}  // namespace

std::string encode_frame_request(const FrameRequest& request) {
  nlohmann::json j;
  j["camera"] = camera_to_json(request.camera);
  j["tf"] = paraview_preset_json(request.tf);
  j["settings"] = settings_to_json(request.settings);
  j["step_voxels"] = request.step_voxels;
  j["full_quality"] = request.full_quality;
  j["target_fps"] = request.target_fps;
  if (request.time_step) j["time_step"] = *request.time_step;
  if (request.keep_going) j["interruptible"] = true;
  return j.dump();
}

FrameRequest decode_frame_request(const std::string& bytes) {
  constexpr std::string_view source = "the frame request between MPI ranks";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(bytes);
  } catch (const nlohmann::json::exception& e) {
    fail_in(source, e.what());
  }
  for (const char* key : {"camera", "tf", "settings", "step_voxels", "full_quality", "target_fps"})
    if (!j.contains(key)) fail_in(source, std::string("missing \"") + key + "\"");
  FrameRequest r;
  r.camera = camera_from_json(j["camera"], source);
  const std::vector<TransferFunction> tf = parse_paraview_presets(j["tf"].get<std::string>(), source);
  if (tf.size() != 1) fail_in(source, "expected one transfer function");
  r.tf = tf[0];
  r.settings = settings_from_json(j["settings"], source);
  r.step_voxels = j["step_voxels"].get<double>();
  r.full_quality = j["full_quality"].get<bool>();
  r.target_fps = j["target_fps"].get<double>();
  if (j.contains("time_step")) r.time_step = j["time_step"].get<uint32_t>();
  // Only the flag crosses: the ranks > 0 follow rank 0's answer (mpi_frame_stop.h), never this function's.
  if (j.value("interruptible", false)) r.keep_going = [] { return true; };
  return r;
}

std::unique_ptr<Renderer> open_view_leader(const std::vector<std::string>& inputs, const ReadOptions& read,
                                           const RendererOptions& options, std::vector<std::string>* fields,
                                           OpenedInput* opened) {
  if (!threads_serialized())
    fail_in("MPI", "the MPI library does not allow calls from the viewer's render thread (MPI_THREAD_SERIALIZED)");
  return std::make_unique<ViewLeader>(mpi::open_renderer(inputs, read, options, opened, fields, MeshRead::Whole));
}

void follow_view(const std::vector<std::string>& inputs, const ReadOptions& read, const RendererOptions& options) {
  std::unique_ptr<Renderer> collective = mpi::open_renderer(inputs, read, options, nullptr, nullptr, MeshRead::Whole);
  for (std::string text = receive_text(); !text.empty(); text = receive_text()) {
    if (const std::optional<VisibleBoundsQuestion> q = decode_visible_bounds_question(text))
      answer_collectively(*collective, *q);
    else
      try {
        draw_collectively(*collective, decode_frame_request(text));
      } catch (const FrameInterrupted&) {
        // Rank 0 cut the frame short and every rank dropped it together: the next request follows.
      }
  }
}

}  // namespace ugvr::mpi
