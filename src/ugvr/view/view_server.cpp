// The glue of `ugvr view`'s server (view_server.h): the I/O thread (http_routes.h, ws_session.h), the render thread
// (engine_host.h), and the state they share under one lock: the tabs (frame_scheduler.h), their sockets, the scene and
// the build's progress.
#include "ugvr/view/view_server.h"

// clang-format off
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility> (fixed in later Boost).
#include <utility>
#include <boost/asio.hpp>
// clang-format on
#include <malloc.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <variant>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/view/engine_host.h"
#include "ugvr/view/frame_scheduler.h"
#include "ugvr/view/http_routes.h"
#include "ugvr/view/memory_budget.h"
#include "ugvr/view/security_policy.h"
#include "ugvr/view/tab_memory.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_request.h"
#include "ugvr/view/ws_session.h"

namespace ugvr::view {
namespace {

namespace net = boost::asio;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

// One turn of the render thread, chosen under the lock.
struct Idle {};      // nothing to do: wait for a message, a delivery or the build
struct ForgetTabs {  // tabs that closed: their renderers go
  std::vector<uint64_t> tabs;
};
struct SwitchToStore {};    // the background build is done
struct SwitchToPreview {};  // the out-of-core build has written its coarse preview and goes on
struct FinishLoad {};       // the grid is loaded and its walk mesh built: the exact engine can draw
using Turn = std::variant<Idle, ForgetTabs, SwitchToStore, SwitchToPreview, FinishLoad, FrameJob>;

}  // namespace

struct ViewServer::Impl final : HttpHost {
  ViewServerOptions options;
  std::string token_;
  bool loopback = true;
  uint16_t port = 0;

  std::mutex mutex;  // guards what follows, up to the I/O objects
  std::condition_variable wake;
  FrameScheduler scheduler;
  std::map<uint64_t, std::weak_ptr<WsSession>> sockets;  // of the scheduler's tabs
  std::set<uint64_t> opening;                            // tabs admitted, their WebSocket handshake not done yet
  std::optional<TabMemory> tab_memory;                   // every tab's allocations, charged from admission to close
  // set_view: what every tab was moved to, and what new tabs start from (after the scene's own), with its message.
  std::optional<Camera> camera_set;
  std::optional<TransferFunction> tf_set;
  std::string view_text;     // view_message(camera_set, tf_set); empty: set_view never called
  uint64_t last_active = 0;  // the tab that sent a camera or transfer-function message last (0: none)

  // Under the lock: `camera_set` / `tf_set` applied to a tab's view.
  void apply_view_set(ViewState& v) const {
    if (camera_set) v.request.camera = *camera_set;
    if (tf_set) {
      v.tf_colors = tf_set->color_points;
      v.tf_opacities = tf_set->opacity_points;
      v.tf_opacity = 1;
      v.unit_distance = tf_set->opacity_unit_distance;
      v.request.tf = compose_tf(v, scene);
    }
  }
  uint64_t next_id = 1;
  bool stopping = false;
  // Published by the render thread: the I/O thread reads the scene when a tab says hello and when it applies a
  // message.
  SceneInfo scene;
  std::string scene_text;     // scene_message(scene)
  std::string progress_text;  // the latest progress message of a background build (empty: none)
  Clock::time_point last_progress;

  net::io_context ioc;
  tcp::acceptor acceptor{ioc};
  std::thread io_thread, render_thread;
  bool stopped = false;
  std::unique_ptr<EngineHost> engine;  // the render thread's
  // The frame being drawn: its tab and request (0: none), set under the lock when it is taken; and whether that tab's
  // view has changed since (a message that changed what is drawn, or the tab closed), which its renderer asks
  // without the lock (FrameRequest::keep_going) to abandon a resting frame nobody will look at.
  uint64_t drawing_tab = 0, drawing_generation = 0;
  std::atomic<bool> drawing_superseded{false};

  void accept();
  void render_loop(std::promise<void>& started);
  Turn next_turn();
  std::function<void()> perform(const Idle&) {
    return [] {};
  }
  std::function<void()> perform(const ForgetTabs& t);
  std::function<void()> perform(const SwitchToStore&);
  std::function<void()> perform(const SwitchToPreview&);
  std::function<void()> perform(const FinishLoad&);
  void broadcast_progress(const ProgressInfo& p, bool at_once);
  std::string gl_renderer;                    // the render thread's GL_RENDERER (published before serving)
  bool scene_shown = false;                   // a scene was published: tabs have something to draw
  std::optional<Camera> camera_before_scene;  // current_view()'s camera until then
  std::function<void()> perform(const FrameJob& job);
  void publish_scene(bool announce);
  void broadcast(const std::vector<std::string>& texts);
  std::weak_ptr<WsSession> socket_of(uint64_t id) const {
    const auto it = sockets.find(id);
    return it == sockets.end() ? std::weak_ptr<WsSession>() : it->second;
  }

  // HttpHost, on the I/O thread.
  const std::string& token() const override { return token_; }
  std::optional<TabState> open_tab(std::string& why) override {
    std::lock_guard lock(mutex);
    // Tabs still in their WebSocket handshake count too, so a burst of connections cannot pass the limit.
    why = tab_limit_refusal(scheduler.size() + opening.size(), options.max_sessions);
    if (!why.empty()) return std::nullopt;
    TabState tab;
    tab.id = next_id++;
    // Charged before the handshake, like the tab limit: the canvas at the page's initial size until hello says more.
    const std::optional<TabCharge> charge = tab_memory->admit(tab.id, options.width, options.height, why);
    if (!charge) return std::nullopt;
    tab.ram_budget = charge->cache;
    opening.insert(tab.id);
    tab.view = initial_view(scene);
    apply_view_set(tab.view);
    return tab;
  }
  void attach(TabState tab, std::weak_ptr<WsSession> socket) override {
    std::lock_guard lock(mutex);
    opening.erase(tab.id);
    sockets[tab.id] = std::move(socket);
    scheduler.add(std::move(tab));
  }
  std::vector<std::string> apply(uint64_t id, const ClientMessage& message) override {
    std::vector<std::string> replies;
    std::lock_guard lock(mutex);
    TabState* tab = scheduler.find(id);
    if (!tab) return replies;             // closed meanwhile
    std::optional<SizeMessage> admitted;  // a hello too large: said at the size the tab was admitted with
    if (const auto* size = std::get_if<SizeMessage>(&message)) {
      std::string why;
      if (!tab_memory->resize(id, size->width, size->height, why)) {
        replies.push_back(error_message(why));
        if (!size->hello) return replies;
        admitted = SizeMessage{true, tab->view.request.width, tab->view.request.height};
      }
    }
    if (admitted)
      apply_message(tab->view, ClientMessage(*admitted), scene);
    else
      apply_message(tab->view, message, scene);
    if (id == drawing_tab && tab->view.changed > drawing_generation) drawing_superseded = true;
    if (std::holds_alternative<CameraMessage>(message) || std::holds_alternative<TfMessage>(message)) last_active = id;
    // A message that changed nothing drawn gets no frame (a settled view would draw a full-quality one again): the
    // client learns it was taken from an ack.
    if (const std::optional<uint64_t> n = scheduler.take_ack(id)) replies.push_back(ack_message(*n));
    // After hello: the scene, a build's progress, and the view set_view moved the tabs to (the page takes it after
    // the scene's own).
    if (std::holds_alternative<SizeMessage>(message) && std::get<SizeMessage>(message).hello)
      for (const std::string* t : {&scene_text, &progress_text, &view_text})
        if (!t->empty()) replies.push_back(*t);
    wake.notify_all();
    return replies;
  }
  void frame_delivered(uint64_t id) override {
    std::lock_guard lock(mutex);
    scheduler.delivered(id);
    wake.notify_all();
  }
  void tab_closed(uint64_t id) override {
    std::lock_guard lock(mutex);
    opening.erase(id);
    scheduler.close(id);
    if (id == drawing_tab) drawing_superseded = true;
    tab_memory->release(id);
    wake.notify_all();
  }
};

void ViewServer::Impl::accept() {
  acceptor.async_accept(net::make_strand(ioc), [this](boost::system::error_code ec, tcp::socket socket) {
    if (ec) {
      if (ec == net::error::operation_aborted) return;
    } else {
      serve_http(std::move(socket), *this);
    }
    accept();
  });
}

void ViewServer::Impl::render_loop(std::promise<void>& started) {
  // The GL context is current on the thread that created it: everything GL lives and dies on this thread.
  try {
    ViewServerOptions engine_options = options;
    options.dataset.reset();  // the engine host holds the grid, until its store is shown
    engine = std::make_unique<EngineHost>(std::move(engine_options));
    std::lock_guard lock(mutex);
    // A collective frame that cannot be cut short: a tab's full-quality frame waits a moment after its last moving
    // frame, so that the next move of a drag is not held up by it (frame_scheduler.h, set_rest_delay). Half a second:
    // the page sends a drag's next view as soon as the moving frame is shown, well within it.
    if (options.collective && !options.collective_interruptible) scheduler.set_rest_delay(0.5);
    gl_renderer = engine->gl_renderer();
    if (const std::optional<ProgressInfo> p = engine->initial_progress()) progress_text = progress_message(*p);
    if (engine->has_scene()) publish_scene(false);
  } catch (...) {
    started.set_exception(std::current_exception());
    return;
  }
  started.set_value();

  std::unique_lock lock(mutex);
  while (!stopping) {
    const Turn turn = next_turn();
    if (std::holds_alternative<Idle>(turn)) {
      // Every path here holds the lock since `stopping` was last read, so stop()'s notification cannot be lost.
      if (engine->building() || engine->loading())
        wake.wait_for(lock, std::chrono::milliseconds(250));  // the load's and the build's progress are polled
      else if (const auto due = scheduler.next_due())
        wake.wait_until(lock, *due);  // a resting frame held back (set_rest_delay)
      else
        wake.wait(lock);
      continue;
    }
    // The work itself (a frame, opening the built store, freeing renderers that join their threads) runs without the
    // lock, so that the I/O thread goes on meanwhile; what it returns is published under the lock. The loop then
    // reads `stopping` again before it may wait: a stop() that came meanwhile is not lost.
    lock.unlock();
    const std::function<void()> publish = std::visit([this](const auto& t) { return perform(t); }, turn);
    lock.lock();
    publish();
  }
  lock.unlock();
  engine.reset();  // cancels a build still running
}

// Under the lock.
Turn ViewServer::Impl::next_turn() {
  if (std::vector<uint64_t> gone = scheduler.remove_closed(); !gone.empty()) {
    for (uint64_t id : gone) sockets.erase(id);
    return ForgetTabs{std::move(gone)};
  }
  if (const std::optional<EngineHost::LoadReport> load = engine->poll_load()) {
    if (load->failed) {
      broadcast_progress(load->progress, true);
      if (options.on_failure) options.on_failure(load->progress.message);
    } else if (load->ready) {
      return FinishLoad{};
    } else if (load->progress.stage == "read" || !engine->building()) {
      // Then the build's progress says the rest (the walk mesh too); a collective renderer's build has only this.
      broadcast_progress(load->progress, false);
    }
  }
  if (const std::optional<EngineHost::BuildReport> build = engine->build_report()) {
    switch (build->stage) {
      case BackgroundBuild::Stage::Running:
        if (engine->preview_ready()) return SwitchToPreview{};
        broadcast_progress(build->progress, false);
        break;
      case BackgroundBuild::Stage::Failed:
        broadcast_progress(build->progress, true);
        engine->drop_build();  // the exact engine goes on showing the grid (if there is one)
        if (!engine->has_scene() && !engine->loading() && options.on_failure)
          options.on_failure(build->progress.message);  // the store path alone: nothing left to show
        break;
      case BackgroundBuild::Stage::Done: return SwitchToStore{};
    }
  }
  if (!engine->has_scene()) return Idle{};  // nothing draws yet: tabs that said hello wait for the scene
  if (std::optional<FrameJob> job = scheduler.next()) {
    drawing_tab = job->tab, drawing_generation = job->generation;
    drawing_superseded = false;
    return std::move(*job);
  }
  return Idle{};
}

// Under the lock: a progress message to every tab, at most one every 250 ms unless `at_once` (a stage's end).
void ViewServer::Impl::broadcast_progress(const ProgressInfo& p, bool at_once) {
  const std::string text = progress_message(p);
  if (text == progress_text) return;
  if (!at_once && Clock::now() - last_progress < std::chrono::milliseconds(250)) return;
  progress_text = text;
  last_progress = Clock::now();
  broadcast({progress_text});
}

// Without the lock: moves the exact engine to a GPU where that pays. Then every tab is shown the grid.
std::function<void()> ViewServer::Impl::perform(const FinishLoad&) {
  engine->finish_load();
  return [this] {
    if (!engine->has_scene()) return;  // the collective renderer failed to open: the next poll_load says why
    // What the page says now: the store's build, if it still runs (without the walk mesh, which is done); else
    // that nothing is under way any more, so that the page hides its progress line ("opening the data" of a
    // collective renderer would stay there).
    const std::optional<EngineHost::BuildReport> b = engine->build_report();
    const bool building = b && b->stage == BackgroundBuild::Stage::Running;
    progress_text = progress_message(building ? b->progress : ProgressInfo{"ready", "", 1, "ready"});
    publish_scene(true);
    if (!building) progress_text.clear();  // said once, to the tabs there now, as switch_to_store's
  };
}

// Without the lock (a renderer joins its cache's threads).
std::function<void()> ViewServer::Impl::perform(const ForgetTabs& t) {
  for (uint64_t id : t.tabs) engine->forget(id);
  // A tab's RAM cache is many brick-sized blocks that glibc keeps in its arenas after they are freed: hand them back
  // to the system, so that the memory of tabs that left is returned, not only reusable.
  malloc_trim(0);
  return [] {};
}

// Without the lock: opening reads the store's header. Then every tab moves to it.
std::function<void()> ViewServer::Impl::perform(const SwitchToStore&) {
  const EngineHost::Switch done = engine->switch_to_store();
  return [this, done] {
    progress_text = progress_message(done.progress);
    if (!done.opened) {
      broadcast({progress_text});
      if (!engine->has_scene() && options.on_failure) options.on_failure(done.progress.message);
      return;
    }
    publish_scene(true);
    progress_text.clear();
  };
}

// Without the lock: opening reads the preview's header. Then every tab moves to it, the build's progress going on.
std::function<void()> ViewServer::Impl::perform(const SwitchToPreview&) {
  const EngineHost::Switch shown = engine->switch_to_preview();
  return [this, shown] {
    broadcast_progress(shown.progress, true);
    if (shown.opened) publish_scene(true);
  };
}

// Without the lock: renders and encodes the frame; it goes to the tab's socket under the lock.
std::function<void()> ViewServer::Impl::perform(const FrameJob& job) {
  std::string status, error;
  std::shared_ptr<const std::string> image;
  bool converged = false;
  // A resting frame (refining, full quality, exact cells: seconds on llvmpipe) is cut short when its tab moves on: the
  // move is drawn next instead of waiting for it. A moving frame is short and is drawn whole: cutting each one for
  // the drag's next step would show nothing while the drag lasts. A collective renderer that cannot be cut short
  // finishes its frames (ViewServerOptions::collective_interruptible).
  const bool interruptible =
      (job.resting || job.full_quality) && (!options.collective || options.collective_interruptible);
  std::function<bool()> keep_going;
  if (interruptible) keep_going = [this] { return !drawing_superseded.load(std::memory_order_relaxed); };
  try {
    if (options.on_frame_start) options.on_frame_start(job, keep_going);
    EngineHost::Frame frame = engine->render(job, keep_going);
    if (frame.interrupted)
      return [this, job] {
        drawing_tab = 0;
        scheduler.interrupted(job);
      };
    converged = frame.status.converged;
    status = status_message(frame.status);
    image = std::move(frame.image);
  } catch (const std::exception& e) {
    error = std::string("render: ") + e.what();
  }
  return [this, job, converged, status = std::move(status), image = std::move(image), error = std::move(error)] {
    drawing_tab = 0;
    scheduler.rendered(job, converged, !error.empty());
    const std::weak_ptr<WsSession> socket = socket_of(job.tab);
    if (!error.empty())
      post_texts(ioc, socket, {error_message(error)});
    else
      post_frame(ioc, socket, status, image);
    // Messages that changed nothing while it was drawn: this frame shows them too.
    if (const std::optional<uint64_t> n = scheduler.take_ack(job.tab)) post_texts(ioc, socket, {ack_message(*n)});
  };
}

// Under the lock: the engine host's scene becomes the one new tabs start from; `announce`: every tab is told and draws
// again with the new engine.
void ViewServer::Impl::publish_scene(bool announce) {
  scene = engine->scene();
  scene.play_rate = options.play_rate;
  scene_text = scene_message(scene);
  const bool first = !scene_shown;
  scene_shown = true;
  if (!announce) return;
  for (TabState& tab : scheduler.tabs()) {
    if (first) {
      // The tab opened before there was a scene: it starts from the scene's view now, at the size it said.
      ViewState v = initial_view(scene);
      v.ready = tab.view.ready;
      v.generation = tab.view.generation;
      v.request.width = tab.view.request.width, v.request.height = tab.view.request.height;
      apply_view_set(v);
      tab.view = std::move(v);
    }
    // Ranges may differ (store vs dataset): the tab's transfer function is composed again over the new ones.
    tab.view.request.tf = compose_tf(tab.view, scene);
    // Every tab moves to the new scene's engine; it may pick the other again afterwards.
    tab.view.request.engine.clear();
  }
  scheduler.redraw_all();
  broadcast({progress_text, scene_text});
  wake.notify_all();
}

// Under the lock: to every tab that has said hello.
void ViewServer::Impl::broadcast(const std::vector<std::string>& texts) {
  std::vector<std::string> said;  // an empty text is nothing to say (no progress)
  for (const std::string& t : texts)
    if (!t.empty()) said.push_back(t);
  if (said.empty()) return;
  for (const TabState& tab : scheduler.tabs())
    if (tab.view.ready) post_texts(ioc, socket_of(tab.id), said);
}

ViewServer::ViewServer(ViewServerOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.options = std::move(options);
  boost::system::error_code ec;
  const net::ip::address address = net::ip::make_address(I.options.host, ec);
  if (ec) fail_in("--host", "\"" + I.options.host + "\" is not an IP address");
  I.loopback = address.is_loopback();
  I.token_ = I.options.token.empty() && !I.loopback ? random_token() : I.options.token;
  I.tab_memory.emplace(I.options.tabs_memory ? I.options.tabs_memory : view_memory_budget(std::nullopt),
                       I.options.ram_per_session);
  if (I.options.camera)
    I.camera_before_scene = I.options.camera;
  else if (I.options.dataset)
    I.camera_before_scene = default_camera(I.options.dataset->bounds(), 30);

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
const std::string& ViewServer::token() const { return impl_->token_; }
std::string ViewServer::renderer() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->scene_shown ? impl_->scene.renderer : impl_->gl_renderer;
}

std::string ViewServer::progress() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->progress_text;
}

ViewServer::View ViewServer::current_view() const {
  Impl& I = *impl_;
  std::lock_guard lock(I.mutex);
  if (const TabState* tab = I.scheduler.find(I.last_active)) return {tab->view.request.camera, tab->view.request.tf};
  ViewState v = initial_view(I.scene);
  // Before the grid is loaded there is no scene yet: its camera will be the given one, or the default over the grid's
  // bounds (known when the grid was given in memory).
  if (!I.scene_shown && I.camera_before_scene) v.request.camera = *I.camera_before_scene;
  I.apply_view_set(v);
  return {v.request.camera, v.request.tf};
}

void ViewServer::set_view(const std::optional<Camera>& camera, const std::optional<TransferFunction>& tf) {
  if (tf) {
    TransferFunction check = *tf;  // a unit distance <= 0 means the viewer's default (compose_tf)
    if (!(check.opacity_unit_distance > 0)) check.opacity_unit_distance = 1;
    check.validate("tf");
  }
  Impl& I = *impl_;
  std::lock_guard lock(I.mutex);
  if (camera) I.camera_set = camera;
  if (tf) I.tf_set = tf;
  I.view_text = view_message(I.camera_set, I.tf_set);
  for (TabState& tab : I.scheduler.tabs()) {
    I.apply_view_set(tab.view);
    tab.view.changed = ++tab.view.generation;
  }
  I.scheduler.redraw_all();
  I.broadcast({view_message(camera, tf)});
  I.wake.notify_all();
}

std::string ViewServer::url() const {
  const bool v6 = impl_->options.host.find(':') != std::string::npos;
  std::string u = "http://" + (v6 ? "[" + impl_->options.host + "]" : impl_->options.host) + ":" +
                  std::to_string(impl_->port) + "/";
  if (!impl_->token_.empty()) u += "?token=" + impl_->token_;
  return u;
}

}  // namespace ugvr::view
