#include "ugvr/view/view_server.h"

// clang-format off
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility> (fixed in later Boost).
#include <utility>
#include <boost/asio.hpp>
// clang-format on
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <future>
#include <map>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/lod/octree_input.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"
#include "ugvr/view/background_build.h"
#include "ugvr/view/exact_preview.h"
#include "ugvr/view/field_histogram.h"
#include "ugvr/view/jpeg.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_request.h"
#include "ugvr/view/web_assets.h"

namespace ugvr::view {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

// Past the protocol's 64 KiB limit a message still gets an error reply; this one closes the socket (no unbounded
// buffering of what a client sends).
constexpr size_t kHardMessageLimit = 1 << 20;
// Error replies a client has not read yet: past this, further ones are dropped (a client flooding bad messages
// without reading must not grow the server's memory).
constexpr size_t kMaxQueuedReplies = 64;

std::string random_token() {
  std::random_device rd;
  std::string t;
  char buf[9];
  for (int i = 0; i < 4; ++i) {
    std::snprintf(buf, sizeof buf, "%08x", unsigned(rd()));
    t += buf;
  }
  return t;
}

// Value of `key` in the query of `target` ("/ws?token=abc"), empty when absent.
std::string query_param(std::string_view target, std::string_view key) {
  const size_t q = target.find('?');
  if (q == std::string_view::npos) return {};
  std::string_view query = target.substr(q + 1);
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view kv = query.substr(0, amp);
    const size_t eq = kv.find('=');
    if (kv.substr(0, eq) == key && eq != std::string_view::npos) return std::string(kv.substr(eq + 1));
    if (amp == std::string_view::npos) break;
    query = query.substr(amp + 1);
  }
  return {};
}

std::string str(beast::string_view s) { return std::string(s.data(), s.size()); }

std::string_view target_path(std::string_view target) { return target.substr(0, target.find('?')); }

// "127.0.0.1:PORT", "localhost:PORT", "[::1]:PORT" (the port is not checked: it is ours, whatever the client typed).
bool loopback_host(std::string_view host) {
  if (host.starts_with("[::1]")) return host.size() == 5 || host[5] == ':';
  const std::string_view name = host.substr(0, host.find(':'));
  return name == "localhost" || name == "127.0.0.1";
}

// Constant-time comparison: the token is a secret.
bool same_token(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char d = 0;
  for (size_t i = 0; i < a.size(); ++i) d |= static_cast<unsigned char>(a[i] ^ b[i]);
  return d == 0;
}

class WsSession;

// Shared between the I/O thread and the render thread, under Impl::mutex.
struct SessionState {
  uint64_t id = 0;
  bool closed = false, in_flight = false, converged = false;
  uint64_t rendered_generation = 0;
  ViewState view;
  std::weak_ptr<WsSession> socket;
};

}  // namespace

struct ViewServer::Impl {
  ViewServerOptions options;
  std::string token;
  bool loopback = true;
  uint16_t port = 0;

  // Published by the render thread before it accepts work.
  SceneInfo scene;
  std::string scene_text;  // scene_message(scene)

  std::mutex mutex;
  std::condition_variable wake;
  std::vector<std::shared_ptr<SessionState>> sessions;
  size_t next_session = 0;
  uint64_t next_id = 1;
  bool stopping = false;

  net::io_context ioc;
  tcp::acceptor acceptor{ioc};
  std::thread io_thread, render_thread;
  bool stopped = false;

  std::string progress_text;  // the latest progress message of a background build (empty: none)
  Clock::time_point last_progress;

  void render_loop(std::promise<void>& started);
  SceneInfo lod_scene(const LodEngine& engine, const std::string& renderer) const;
  void publish_scene(SceneInfo next, bool announce);
  void broadcast(const std::shared_ptr<SessionState>& s, std::vector<std::string> texts);
  void accept();
  void frame_delivered(const std::shared_ptr<SessionState>& s) {
    std::lock_guard lock(mutex);
    s->in_flight = false;
    wake.notify_all();
  }
  void session_closed(const std::shared_ptr<SessionState>& s) {
    std::lock_guard lock(mutex);
    s->closed = true;
    wake.notify_all();
  }
};

namespace {

struct Outgoing {
  bool binary = false;
  bool ends_frame = false;  // the last message of a frame: delivering it frees the session for the next one
  std::shared_ptr<const std::string> data;
};

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket socket, ViewServer::Impl& server, std::shared_ptr<SessionState> state)
      : ws_(std::move(socket)), server_(server), state_(std::move(state)) {}

  void run(http::request<http::string_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(kHardMessageLimit);
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

  void send_text(std::string text, bool ends_frame = false) {
    send({false, ends_frame, std::make_shared<const std::string>(std::move(text))});
  }
  void send(Outgoing o) {
    out_.push_back(std::move(o));
    if (out_.size() == 1) write_next();
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
    {
      std::lock_guard lock(server_.mutex);
      state_->socket = weak_from_this();
      server_.sessions.push_back(state_);
    }
    read_next();
  }

  void read_next() { ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this())); }

  void on_read(beast::error_code ec, size_t) {
    if (ec) {
      server_.session_closed(state_);
      return;
    }
    if (!ws_.got_text()) {
      reply_error("message: binary messages are not accepted");
    } else {
      const std::string text = beast::buffers_to_string(buffer_.data());
      try {
        const ClientMessage m = parse_client_message(text);
        std::string scene, progress;
        {
          std::lock_guard lock(server_.mutex);
          apply_message(state_->view, m, server_.scene);
          if (std::holds_alternative<SizeMessage>(m) && std::get<SizeMessage>(m).hello)
            scene = server_.scene_text, progress = server_.progress_text;
          server_.wake.notify_all();
        }
        if (!scene.empty()) send_text(scene);
        if (!progress.empty()) send_text(progress);
      } catch (const Error& e) {
        reply_error(e.what());
      } catch (const std::exception& e) {
        // Nothing a client sends may end the server (an exception escaping a handler would end the I/O thread).
        reply_error(std::string("message: ") + e.what());
      }
    }
    buffer_.consume(buffer_.size());
    read_next();
  }

  void reply_error(const std::string& message) {
    if (out_.size() < kMaxQueuedReplies) send_text(error_message(message));
  }

  void write_next() {
    const Outgoing& o = out_.front();
    ws_.binary(o.binary);
    ws_.async_write(net::buffer(*o.data), beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, size_t) {
    if (ec) {
      server_.session_closed(state_);
      return;
    }
    const bool frame_done = out_.front().ends_frame;
    out_.pop_front();
    if (frame_done) server_.frame_delivered(state_);
    if (!out_.empty()) write_next();
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::deque<Outgoing> out_;
  ViewServer::Impl& server_;
  std::shared_ptr<SessionState> state_;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, ViewServer::Impl& server) : stream_(std::move(socket)), server_(server) {}

  void run() { read_next(); }

 private:
  void read_next() {
    parser_.emplace();
    parser_->body_limit(8 * 1024);  // the page only GETs
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    if (ec) {
      beast::error_code ignored;
      stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
      return;
    }
    http::request<http::string_body> req = parser_->release();
    const std::string target = str(req.target());
    const std::string_view path = target_path(target);
    if (websocket::is_upgrade(req)) {
      if (path != "/ws") return respond(req, http::status::not_found, "text/plain", "not found\n");
      if (const std::string why = refused(req, target); !why.empty())
        return respond(req, http::status::forbidden, "text/plain", why + "\n");
      auto state = std::make_shared<SessionState>();
      {
        std::lock_guard lock(server_.mutex);
        if (server_.sessions.size() >= server_.options.max_sessions)
          return respond(req, http::status::service_unavailable, "text/plain",
                         "too many viewer tabs are open (" + std::to_string(server_.options.max_sessions) + ")\n");
        state->id = server_.next_id++;
        state->view = initial_view(server_.scene);
      }
      stream_.expires_never();  // the WebSocket has its own timeouts
      std::make_shared<WsSession>(stream_.release_socket(), server_, std::move(state))->run(std::move(req));
      return;
    }
    if (req.method() != http::verb::get && req.method() != http::verb::head)
      return respond(req, http::status::method_not_allowed, "text/plain", "only GET\n");
    const std::string_view asset_path = path == "/" ? std::string_view("/index.html") : path;
    for (const WebAsset& a : web_assets()) {
      if (a.path != asset_path) continue;
      // The page itself needs the token; its scripts and style are the same for everyone and hold no data.
      if (a.path == "/index.html")
        if (const std::string why = refused(req, target); !why.empty())
          return respond(req, http::status::forbidden, "text/plain", why + "\n");
      return respond(req, http::status::ok, a.content_type, std::string(a.body));
    }
    respond(req, http::status::not_found, "text/plain", "not found\n");
  }

  // Why a request for the page or the socket is refused (empty: allowed).
  std::string refused(const http::request<http::string_body>& req, const std::string& target) const {
    if (!server_.token.empty() && !same_token(query_param(target, "token"), server_.token))
      return "forbidden: the URL needs the token that `ugvr view` printed";
    const auto host = req.find(http::field::host);
    // Without a token, only a loopback name may address us: a web page whose own host name is made to resolve to
    // 127.0.0.1 (DNS rebinding) would otherwise count as same-origin below.
    if (server_.token.empty() && (host == req.end() || !loopback_host(str(host->value()))))
      return "forbidden: address the viewer as 127.0.0.1, localhost or [::1]";
    // A page from another origin may open a WebSocket to localhost (browsers allow it): only our own page may.
    const auto origin = req.find(http::field::origin);
    if (origin != req.end()) {
      if (host == req.end() || str(origin->value()) != "http://" + str(host->value()))
        return "forbidden: cross-origin WebSocket";
    }
    return {};
  }

  void respond(const http::request<http::string_body>& req, http::status status, std::string_view type,
               std::string body) {
    auto res = std::make_shared<http::response<http::string_body>>(status, req.version());
    res->set(http::field::server, "ugvr view");
    res->set(http::field::content_type, beast::string_view(type.data(), type.size()));
    res->set(http::field::cache_control, "no-store");
    res->set("X-Content-Type-Options", "nosniff");
    // The page runs only its own code and talks only to this server; no other site may frame it.
    res->set("Content-Security-Policy",
             "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; style-src 'self'; "
             "script-src 'self'; frame-ancestors 'none'");
    res->set("Referrer-Policy", "no-referrer");  // the token in the URL goes nowhere else
    res->keep_alive(req.keep_alive());
    const bool head = req.method() == http::verb::head;
    res->body() = std::move(body);
    res->prepare_payload();
    if (head) res->body().clear();
    http::async_write(stream_, *res, [self = shared_from_this(), res](beast::error_code ec, size_t) {
      if (ec || !res->keep_alive()) {
        beast::error_code ignored;
        self->stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
        return;
      }
      self->read_next();
    });
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  ViewServer::Impl& server_;
};

}  // namespace

void ViewServer::Impl::accept() {
  acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket socket) {
    if (ec) {
      if (ec == net::error::operation_aborted) return;
    } else {
      std::make_shared<HttpSession>(std::move(socket), *this)->run();
    }
    accept();
  });
}

// Bins of the transfer-function editor's histograms, and the octree levels a store's histogram is taken from (up to
// 585 bricks: the shape of the distribution, read in a fraction of a second).
constexpr int kHistogramBins = 128, kHistogramMaxLevel = 3;

// Fields of a store: names, ranges, histograms of the coarse levels.
std::vector<FieldInfo> store_fields(const LodEngine& engine) {
  std::vector<FieldInfo> out;
  const BrickStoreReader& store = engine.store();
  for (uint32_t i = 0; i < store.field_count(); ++i) {
    const BrickStoreField& f = store.layout().fields[i];
    out.push_back({f.name, f.min, f.max, store_histogram(store, i, kHistogramBins, kHistogramMaxLevel)});
  }
  return out;
}

SceneInfo ViewServer::Impl::lod_scene(const LodEngine& engine, const std::string& renderer) const {
  SceneInfo sc;
  sc.fields = store_fields(engine);
  sc.field = engine.field_name();
  sc.bounds = engine.bounds();
  sc.camera = options.camera.value_or(reset_camera(sc.bounds, 30));
  sc.tf = options.tf;
  sc.preset = options.preset;
  sc.fps = options.fps;
  sc.width = options.width, sc.height = options.height;
  sc.renderer = renderer;
  sc.engine = "lod";
  return sc;
}

void ViewServer::Impl::publish_scene(SceneInfo next, bool announce) {
  // Under the lock: the I/O thread reads the scene when a tab says hello and when it applies a message.
  const SceneInfo previous = scene;
  scene = std::move(next);
  scene.camera = previous.fields.empty() ? scene.camera : previous.camera;  // the reset view stays the same
  scene_text = scene_message(scene);
  if (!announce) return;
  for (const auto& s : sessions) {
    // Ranges may differ (store vs dataset): the tab's transfer function is composed again over the new ones.
    s->view.request.tf = compose_tf(s->view, scene);
    s->rendered_generation = ~uint64_t(0);  // draw again with the new engine
    s->converged = false;
    broadcast(s, {progress_text, scene_text});
  }
  wake.notify_all();
}

void ViewServer::Impl::broadcast(const std::shared_ptr<SessionState>& s, std::vector<std::string> texts) {
  if (!s->view.ready) return;
  net::post(ioc, [socket = s->socket, texts = std::move(texts)] {
    if (const std::shared_ptr<WsSession> ws = socket.lock())
      for (const std::string& t : texts)
        if (!t.empty()) ws->send_text(t);
  });
}

void ViewServer::Impl::render_loop(std::promise<void>& started) {
  // The GL context is current on the thread that created it: everything GL lives and dies on this thread.
  std::unique_ptr<GlContext> gl;
  std::unique_ptr<LodEngine> engine;
  std::unique_ptr<ExactPreview> preview;
  std::unique_ptr<BackgroundBuild> build;
  std::string renderer;
  try {
    gl = std::make_unique<GlContext>(options.gpu);
    renderer = gl->renderer();
    if (options.dataset) {
      SceneInfo sc;
      // The fields as the store will name them ("velocity:magnitude"), with their ranges; also validates them (NaN,
      // missing) before anything is served.
      std::vector<std::string> names;
      {
        const OctreeInput input = prepare_octree_input(*options.dataset, options.fields);
        for (size_t i = 0; i < input.fields.size(); ++i) {
          const BrickStoreField& f = input.fields[i];
          const ScalarRef& ref = input.scalars[i];
          sc.fields.push_back({f.name, f.min, f.max, field_histogram(*ref.field, ref.component, kHistogramBins)});
          names.push_back(f.name);
        }
        sc.bounds = input.bounds;
      }
      preview = std::make_unique<ExactPreview>(options.dataset);
      sc.field = sc.fields.front().name;
      sc.camera = options.camera.value_or(reset_camera(sc.bounds, 30));
      sc.tf = options.tf;
      sc.preset = options.preset;
      sc.fps = options.fps;
      sc.width = options.width, sc.height = options.height;
      sc.renderer = "exact engine (CPU)";
      sc.engine = "exact";
      progress_text = progress_message({"build", "", 0, "building the brick store " + options.store});
      publish_scene(std::move(sc), false);
      build =
          std::make_unique<BackgroundBuild>(options.dataset, names, options.build, options.store, options.before_build);
    } else {
      LodOptions lo;
      lo.atlas_budget_bytes = options.gpu_memory;
      engine = std::make_unique<LodEngine>(options.store, *gl, lo);
      engine->set_field("");
      publish_scene(lod_scene(*engine, renderer), false);
    }
  } catch (...) {
    started.set_exception(std::current_exception());
    return;
  }
  started.set_value();

  struct Slot {
    std::unique_ptr<TimeCriticalRenderer> renderer;
    std::string field;
    double fps = -1, step = -1;
    ExactPreview::Tab exact;
    uint64_t seq = 0;
    double shown_fps = 0;
    Clock::time_point last;
    bool counting = false;  // the previous frame was part of an interaction (not converged): fps is measured
  };
  std::map<uint64_t, Slot> slots;
  // A session wants a frame: it said hello, has none on the wire, and its view changed, or is still refining, or it
  // asked for full quality.
  const auto wants_frame = [](const SessionState& s) {
    if (!s.view.ready || s.in_flight) return false;
    return !(s.view.generation == s.rendered_generation && s.converged && !s.view.full_quality);
  };
  const auto streaming = [](const SessionState& s) {
    return s.view.ready && !(s.view.generation == s.rendered_generation && s.converged && !s.view.full_quality);
  };

  std::unique_lock lock(mutex);
  while (!stopping) {
    // Sessions that closed: their renderers go (outside the lock: a renderer joins its cache's threads).
    std::vector<uint64_t> gone;
    std::erase_if(sessions, [&](const std::shared_ptr<SessionState>& s) {
      if (s->closed) gone.push_back(s->id);
      return s->closed;
    });
    if (!gone.empty()) {
      lock.unlock();
      for (uint64_t id : gone) slots.erase(id);
      lock.lock();
      continue;
    }
    if (build) {
      const BackgroundBuild::State st = build->state();
      if (st.stage == BackgroundBuild::Stage::Running) {
        const std::string text =
            progress_message({"build", st.label, st.fraction, "building the brick store " + options.store});
        if (text != progress_text && Clock::now() - last_progress > std::chrono::milliseconds(250)) {
          progress_text = text;
          last_progress = Clock::now();
          for (const auto& s : sessions) broadcast(s, {progress_text});
        }
      } else if (st.stage == BackgroundBuild::Stage::Failed) {
        progress_text = progress_message({"failed", st.label, st.fraction, "building the store failed: " + st.error});
        for (const auto& s : sessions) broadcast(s, {progress_text});
        build.reset();  // the exact engine goes on showing the grid
      } else {
        // Done: open the store and move every tab to it (outside the lock: opening reads the store's header).
        lock.unlock();
        if (options.opening_store) options.opening_store();
        std::string error;
        try {
          LodOptions lo;
          lo.atlas_budget_bytes = options.gpu_memory;
          engine = std::make_unique<LodEngine>(options.store, *gl, lo);
          engine->set_field("");
        } catch (const std::exception& e) {
          error = e.what();
        }
        lock.lock();
        build.reset();
        if (engine) {
          progress_text = progress_message({"ready", "", 1, "showing the brick store " + options.store});
          publish_scene(lod_scene(*engine, renderer), true);
          progress_text.clear();
          lock.unlock();
          for (auto& [id, slot] : slots) slot = Slot{};
          preview.reset();  // frees the walk mesh; the dataset goes with the options below
          lock.lock();
          options.dataset.reset();
        } else {
          progress_text = progress_message({"failed", "", 1, "cannot open the new store: " + error});
          for (const auto& s : sessions) broadcast(s, {progress_text});
        }
        continue;  // the lock was released above: `stopping` may have been set meanwhile
      }
    }
    std::shared_ptr<SessionState> chosen;
    size_t active = 0;
    for (const auto& s : sessions) active += streaming(*s) ? 1 : 0;
    for (size_t k = 0; k < sessions.size(); ++k) {
      const size_t i = (next_session + k) % sessions.size();
      if (!wants_frame(*sessions[i])) continue;
      chosen = sessions[i];
      next_session = i + 1;  // round-robin: the next turn starts after this session
      break;
    }
    if (!chosen) {
      // Every path here holds the lock since `stopping` was last read, so stop()'s notification cannot be lost.
      if (build)
        wake.wait_for(lock, std::chrono::milliseconds(250));  // the build's progress is polled
      else
        wake.wait(lock);
      continue;
    }
    const ViewRequest request = chosen->view.request;
    const uint64_t generation = chosen->view.generation;
    const bool full_quality = chosen->view.full_quality;
    const bool resting = generation == chosen->rendered_generation;
    const std::string default_field = scene.field;
    chosen->view.full_quality = false;
    chosen->in_flight = true;
    lock.unlock();

    std::string status, error;
    std::shared_ptr<std::string> bytes;
    bool converged = false;
    try {
      Slot& slot = slots[chosen->id];
      FrameStatus st;
      Image image;
      if (engine) {
        const std::string field = request.settings.field.empty() ? default_field : request.settings.field;
        if (engine->field_name() != field) engine->set_field(field);
        if (!slot.renderer || slot.field != field || slot.step != request.step_voxels) {
          TimeCriticalOptions tc;
          tc.target_fps = request.fps;
          tc.resting_step_voxels = request.step_voxels;
          tc.moving_step_voxels = std::max(1.0, request.step_voxels);
          tc.ram_budget_bytes = options.ram_per_session;
          tc.loader_threads = 2;
          slot.renderer.reset();
          slot.renderer = std::make_unique<TimeCriticalRenderer>(*engine, tc);
          slot.field = field, slot.step = request.step_voxels;
        }
        // The tabs streaming now share the frame time: each targets its rate × their number.
        const double fps = request.fps * double(std::max<size_t>(active, 1));
        if (fps != slot.fps) slot.renderer->set_target_fps(fps);
        slot.fps = fps;
        RenderSettings rs = request.settings;
        rs.width = request.width, rs.height = request.height;
        TimeCriticalFrame f;
        image = full_quality ? slot.renderer->full_quality(request.camera, request.tf, rs, &f)
                             : slot.renderer->frame(request.camera, request.tf, rs, &f);
        converged = f.converged || full_quality;
        st.frame_seconds = f.seconds;
        st.cut_nodes = f.cut_nodes, st.visible_nodes = f.visible_nodes;
        st.texel_error = f.mean_error, st.max_texel_error = f.max_error;
        st.scale = f.scale;
        st.engine = "lod";
        st.ram_bytes = f.cache.resident_bytes, st.ram_budget = options.ram_per_session;
        st.atlas_bytes = f.render.atlas_bytes, st.atlas_budget = options.gpu_memory;
        st.pending_bricks = f.cache.queued + f.cache.loading;
      } else {
        const ExactPreview::Frame f = preview->render(slot.exact, request, resting || full_quality);
        image = std::move(f.image);
        converged = f.converged;
        st.frame_seconds = f.seconds;
        st.scale = f.scale;
        st.engine = "exact";
      }
      bytes = std::make_shared<std::string>();
      const std::vector<unsigned char> encoded = converged ? png_bytes(image) : jpeg_bytes(image);
      bytes->assign(encoded.begin(), encoded.end());
      const Clock::time_point now = Clock::now();
      if (slot.counting) {
        const double dt = std::chrono::duration<double>(now - slot.last).count();
        if (dt > 0) slot.shown_fps = slot.shown_fps > 0 ? 0.8 * slot.shown_fps + 0.2 / dt : 1 / dt;
      }
      slot.counting = !converged;
      slot.last = now;
      st.seq = ++slot.seq;
      st.request = generation;
      st.png = converged;
      st.width = image.width, st.height = image.height;
      st.fps = slot.shown_fps;
      st.converged = converged;
      status = status_message(st);
    } catch (const std::exception& e) {
      error = std::string("render: ") + e.what();
    }

    lock.lock();
    chosen->rendered_generation = generation;
    // A failed view is not retried until the client changes it.
    chosen->converged = converged || !error.empty();
    const std::weak_ptr<WsSession> socket = chosen->socket;
    if (!error.empty()) chosen->in_flight = false;
    net::post(ioc, [socket, status = std::move(status), bytes, error] {
      const std::shared_ptr<WsSession> ws = socket.lock();
      if (!ws) return;
      if (!error.empty()) {
        ws->send_text(error_message(error));
        return;
      }
      ws->send_text(status);
      ws->send({true, true, bytes});
    });
  }
  lock.unlock();
  build.reset();  // cancels a build still running
  slots.clear();
  preview.reset();
  engine.reset();
  gl.reset();
}

ViewServer::ViewServer(ViewServerOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.options = std::move(options);
  beast::error_code ec;
  const net::ip::address address = net::ip::make_address(I.options.host, ec);
  if (ec) fail_in("--host", "\"" + I.options.host + "\" is not an IP address");
  I.loopback = address.is_loopback();
  I.token = I.options.token.empty() && !I.loopback ? random_token() : I.options.token;

  std::promise<void> started;
  std::future<void> ready = started.get_future();
  I.render_thread = std::thread([&I, &started] { I.render_loop(started); });
  try {
    ready.get();
  } catch (...) {
    I.render_thread.join();
    throw;
  }

  const tcp::endpoint endpoint(address, I.options.port);
  I.acceptor.open(endpoint.protocol(), ec);
  if (!ec) I.acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) I.acceptor.bind(endpoint, ec);
  if (!ec) I.acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) {
    stop();
    fail_in("--port",
            "cannot listen on " + I.options.host + ":" + std::to_string(I.options.port) + ": " + ec.message());
  }
  I.port = I.acceptor.local_endpoint().port();
  I.accept();
  I.io_thread = std::thread([&I] { I.ioc.run(); });
}

ViewServer::~ViewServer() { stop(); }

void ViewServer::stop() {
  Impl& I = *impl_;
  if (I.stopped) return;
  I.stopped = true;
  {
    std::lock_guard lock(I.mutex);
    I.stopping = true;
    I.wake.notify_all();
  }
  if (I.render_thread.joinable()) I.render_thread.join();
  I.ioc.stop();
  if (I.io_thread.joinable()) I.io_thread.join();
}

uint16_t ViewServer::port() const { return impl_->port; }
const std::string& ViewServer::token() const { return impl_->token; }
std::string ViewServer::renderer() const { return impl_->scene.renderer; }

std::string ViewServer::url() const {
  const bool v6 = impl_->options.host.find(':') != std::string::npos;
  std::string u = "http://" + (v6 ? "[" + impl_->options.host + "]" : impl_->options.host) + ":" +
                  std::to_string(impl_->port) + "/";
  if (!impl_->token.empty()) u += "?token=" + impl_->token;
  return u;
}

}  // namespace ugvr::view
