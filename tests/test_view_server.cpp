// `ugvr view`'s server end to end, in process: a small brick store, the server on a free loopback port, and Beast
// clients speaking HTTP and the WebSocket protocol of view_protocol.h. Needs an OpenGL 4.5 context (llvmpipe in CI),
// like test_lod_engine.cpp; UGVR_NO_GL_TESTS=1 skips instead of failing where EGL is known to be missing.
#include <gtest/gtest.h>
#include <sys/socket.h>

// clang-format off
#include <utility>  // Boost 1.74's asio needs it first (view_server.cpp says why)
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
// clang-format on
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/structured_grid.h"
#include "ugvr/octree/builder.h"
#include "ugvr/view/frame_scheduler.h"
#include "ugvr/view/tab_memory.h"
#include "ugvr/view/view_server.h"

namespace ugvr::view {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

// A box of tetrahedra, 1 x 0.75 x 0.5, with a field that varies along x so that views differ.
Dataset make_box() {
  StructuredGrid g;
  const uint32_t nx = 9, ny = 7, nz = 5;
  g.dims = GridDims{{nx, ny, nz}};
  std::vector<float> wave;
  for (uint32_t k = 0; k < nz; ++k)
    for (uint32_t j = 0; j < ny; ++j)
      for (uint32_t i = 0; i < nx; ++i) {
        const Vec3f p{float(i) / 8.0f, float(j) / 8.0f, float(k) / 8.0f};
        g.points.push_back(p);
        wave.push_back(float(std::tanh(6.0 * (p.x - 0.5)) + 0.3 * p.y));
      }
  Block b;
  b.name = "box";
  b.grid = std::move(g);
  b.fields.add(Field("wave", Association::Vertex, DataArray::from(std::move(wave), 1)));
  Dataset ds;
  ds.sources = {"box"};
  ds.blocks.push_back(to_unstructured_block(b, StructuredCellShape::SixTetrahedra));
  return ds;
}

OctreeBuildOptions small_build() {
  OctreeBuildOptions o;
  o.resolution = 8;
  o.max_depth = 3;
  o.error = 0;
  return o;
}

std::string make_store(const std::filesystem::path& dir) {
  const std::string store = (dir / "box.ugvr").string();
  const std::vector<std::string> fields = {"wave"};
  build_octree(prepare_octree_input(make_box(), fields), small_build(), store);
  return store;
}

struct Shared {
  std::filesystem::path dir;
  std::string store;
  std::string cells_store;  // the same box built with its leaves' cells (`ugvr build --cells`): hybrid
};

// Removes the scratch directory at exit.
struct RemoveAtExit {
  std::filesystem::path dir;
  ~RemoveAtExit() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};

const Shared& shared() {
  static Shared s = [] {
    Shared r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-view-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    r.store = make_store(r.dir);
    r.cells_store = (r.dir / "box-cells.ugvr").string();
    OctreeBuildOptions cells = small_build();
    cells.leaf_cells = true;
    build_octree(prepare_octree_input(make_box(), std::vector<std::string>{"wave"}), cells, r.cells_store);
    return r;
  }();
  static const RemoveAtExit cleanup{s.dir};
  return s;
}

// Holds a viewer's background build (ViewServerOptions::before_build) until open(), so that what each phase shows is
// checked, not raced. Opened on every way out (a failed assertion returns early), as the server's destructor waits
// for the build: declare the gate after the server, so that it opens first.
class BuildGate {
 public:
  std::function<void()> hold() const {
    return [f = future_] { f.wait(); };
  }
  // Held until open(), or `limit` at most: for a hold the test expects not to be waited for, so that a server that
  // does wait fails the test instead of hanging it.
  std::function<void()> hold_at_most(std::chrono::seconds limit) const {
    return [f = future_, limit] { f.wait_for(limit); };
  }
  void open() {
    if (!opened_) promise_.set_value();
    opened_ = true;
  }
  ~BuildGate() { open(); }

 private:
  std::promise<void> promise_;
  std::shared_future<void> future_ = promise_.get_future().share();
  bool opened_ = false;
};

// Starts the viewer with `options` into `server`, or ends the test: skipped where there is no GL context
// (UGVR_NO_GL_TESTS), failed otherwise. The gates given after the options are opened first, so that no build stays
// held by a server that never started.
#define START_VIEW_SERVER(server, options, ...)                                               \
  do {                                                                                        \
    try {                                                                                     \
      server = std::make_unique<ViewServer>(options);                                         \
    } catch (const Error& e) {                                                                \
      for (BuildGate * gate_ : std::initializer_list<BuildGate*>{__VA_ARGS__}) gate_->open(); \
      if (std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << e.what();                          \
      FAIL() << "cannot start the server: " << e.what();                                      \
    }                                                                                         \
  } while (0)

// A server on a free loopback port (the extra arguments set options o_ after the defaults: 16 MiB of RAM per session,
// the shared store), or a failure (a skip with UGVR_NO_GL_TESTS) when there is no OpenGL 4.5.
#define START_SERVER(server, ...)     \
  std::unique_ptr<ViewServer> server; \
  do {                                \
    ViewServerOptions o_;             \
    o_.ram_per_session = 16 << 20;    \
    o_.store = shared().store;        \
    __VA_ARGS__;                      \
    START_VIEW_SERVER(server, o_);    \
  } while (0)

void set_receive_timeout(tcp::socket& s, int seconds) {
  timeval tv{seconds, 0};
  ::setsockopt(s.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
}

struct HttpReply {
  int status = 0;
  std::string body;
  std::string csp;  // the Content-Security-Policy header
};

HttpReply http_get(uint16_t port, const std::string& target, std::string host = "") {
  net::io_context ioc;
  tcp::socket socket(ioc);
  socket.connect({net::ip::make_address("127.0.0.1"), port});
  set_receive_timeout(socket, 30);
  http::request<http::empty_body> req(http::verb::get, target, 11);
  req.set(http::field::host, host.empty() ? "127.0.0.1:" + std::to_string(port) : host);
  http::write(socket, req);
  beast::flat_buffer buffer;
  http::response<http::string_body> res;
  http::read(socket, buffer, res);
  return {int(res.result_int()), res.body(), std::string(res["Content-Security-Policy"])};
}

// A WebSocket upgrade request for /ws, written without waiting for the answer (a burst writes many first).
void write_upgrade_request(tcp::socket& s, uint16_t port) {
  http::request<http::empty_body> req(http::verb::get, "/ws", 11);
  req.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  req.set(http::field::upgrade, "websocket");
  req.set(http::field::connection, "upgrade");
  req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
  req.set(http::field::sec_websocket_version, "13");
  http::write(s, req);
}

struct Message {
  bool binary = false;
  std::string data;
};

class Client {
 public:
  // Throws beast::system_error when the handshake is refused.
  explicit Client(uint16_t port, const std::string& target = "/ws", const std::string& origin = "") : ws_(ioc_) {
    ws_.next_layer().connect({net::ip::make_address("127.0.0.1"), port});
    set_receive_timeout(ws_.next_layer(), 60);  // a server that stops answering fails the test, not hangs it
    if (!origin.empty())
      ws_.set_option(websocket::stream_base::decorator(
          [origin](websocket::request_type& req) { req.set(http::field::origin, origin); }));
    ws_.handshake("127.0.0.1:" + std::to_string(port), target);
  }
  void send(const std::string& text) {
    ws_.text(true);
    ws_.write(net::buffer(text));
  }
  Message read() {
    beast::flat_buffer buffer;
    ws_.read(buffer);
    return {ws_.got_binary(), beast::buffers_to_string(buffer.data())};
  }

 private:
  net::io_context ioc_;
  websocket::stream<tcp::socket> ws_;
};

// Everything up to and including the next binary frame.
struct Frame {
  std::optional<json> scene, status;
  std::vector<std::string> errors;
  std::string bytes;
};

Frame read_frame(Client& c) {
  Frame f;
  for (int i = 0; i < 100; ++i) {
    Message m = c.read();
    if (m.binary) {
      f.bytes = std::move(m.data);
      return f;
    }
    const json j = json::parse(m.data);
    if (j["type"] == "scene") f.scene = j;
    if (j["type"] == "status") f.status = j;
    if (j["type"] == "error") f.errors.push_back(j["message"].get<std::string>());
  }
  ADD_FAILURE() << "no frame in 100 messages";
  return f;
}

// The first text message (frames skipped) for which `done` is true, within 400 messages; every text message read is
// shown to `done` first.
std::optional<json> read_text_until(Client& c, const std::function<bool(const json&)>& done) {
  for (int i = 0; i < 400; ++i) {
    const Message m = c.read();
    if (m.binary) continue;
    json j = json::parse(m.data);
    if (done(j)) return j;
  }
  return std::nullopt;
}

// The next error reply (frames of an earlier request may come first).
std::string read_error(Client& c) {
  for (int i = 0; i < 100; ++i) {
    const Message m = c.read();
    if (m.binary) continue;
    const json j = json::parse(m.data);
    if (j["type"] == "error") return j["message"];
  }
  return "(no error reply)";
}

bool is_jpeg(const std::string& b) {
  return b.size() > 4 && uint8_t(b[0]) == 0xFF && uint8_t(b[1]) == 0xD8 && uint8_t(b[b.size() - 2]) == 0xFF &&
         uint8_t(b[b.size() - 1]) == 0xD9;
}
bool is_png(const std::string& b) { return b.size() > 8 && std::memcmp(b.data(), "\x89PNG\r\n\x1a\n", 8) == 0; }

// Width and height from the JPEG's SOF marker, or from the PNG's IHDR.
std::pair<int, int> image_size(const std::string& b) {
  auto be16 = [&](size_t i) { return int(uint8_t(b[i])) << 8 | int(uint8_t(b[i + 1])); };
  if (is_png(b)) return {be16(18), be16(22)};
  for (size_t i = 2; i + 9 < b.size();) {
    if (uint8_t(b[i]) != 0xFF) break;
    const int marker = uint8_t(b[i + 1]);
    if (marker >= 0xC0 && marker <= 0xC2) return {be16(i + 7), be16(i + 5)};
    i += 2 + size_t(be16(i + 2));
  }
  return {0, 0};
}

// The first frame that reflects the client's first `request` accepted messages (frames of earlier requests may still
// be on the wire).
Frame read_frame_for(Client& c, uint64_t request) {
  for (int i = 0; i < 200; ++i) {
    Frame f = read_frame(c);
    if (f.status && (*f.status)["request"].get<uint64_t>() >= request) return f;
  }
  ADD_FAILURE() << "no frame for request " << request << " in 200";
  return {};
}

// Frames until a converged (PNG) one of that request.
Frame read_until_converged(Client& c, uint64_t request) {
  for (int i = 0; i < 200; ++i) {
    Frame f = read_frame_for(c, request);
    if (f.status && (*f.status)["converged"] == true) return f;
  }
  ADD_FAILURE() << "no converged frame in 200";
  return {};
}

json camera_message(const json& scene, double angle) {
  const json& c = scene["camera"];
  const double fx = c["focal_point"][0], fy = c["focal_point"][1], fz = c["focal_point"][2];
  const double d =
      std::hypot(double(c["position"][0]) - fx, double(c["position"][1]) - fy, double(c["position"][2]) - fz);
  return {{"type", "camera"},
          {"position", {fx + d * std::sin(angle), fy, fz + d * std::cos(angle)}},
          {"focal_point", c["focal_point"]},
          {"view_up", {0, 1, 0}},
          {"view_angle", 30}};
}

TEST(ViewServer, ServesThePageAndItsAssets) {
  START_SERVER(server);
  EXPECT_EQ(server->url(), "http://127.0.0.1:" + std::to_string(server->port()) + "/");
  EXPECT_TRUE(server->token().empty());
  const HttpReply page = http_get(server->port(), "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("<canvas"), std::string::npos);
  EXPECT_NE(page.body.find("app.js"), std::string::npos);
  const HttpReply js = http_get(server->port(), "/app.js");
  EXPECT_EQ(js.status, 200);
  EXPECT_NE(js.body.find("WebSocket"), std::string::npos);
  EXPECT_EQ(http_get(server->port(), "/style.css").status, 200);
  EXPECT_EQ(http_get(server->port(), "/nope").status, 404);
  // Loopback names only (DNS rebinding): another host name is refused.
  EXPECT_EQ(http_get(server->port(), "/", "localhost:" + std::to_string(server->port())).status, 200);
  EXPECT_EQ(http_get(server->port(), "/", "[::1]:" + std::to_string(server->port())).status, 200);
  EXPECT_EQ(http_get(server->port(), "/", "evil.example:" + std::to_string(server->port())).status, 403);
  // The socket: from our own page (or a non-browser client), not from another origin.
  EXPECT_NO_THROW(Client(server->port(), "/ws", "http://127.0.0.1:" + std::to_string(server->port())));
  EXPECT_THROW(Client(server->port(), "/ws", "http://evil.example"), beast::system_error);
  EXPECT_THROW(Client(server->port(), "/elsewhere"), beast::system_error);
}

TEST(ViewServer, StreamsJpegWhileMovingThenPngWhenConverged) {
  START_SERVER(server, o_.fps = 30);
  Client c(server->port());
  c.send(R"({"type":"hello","width":64,"height":48})");
  const Frame first = read_frame(c);
  ASSERT_TRUE(first.scene) << "no scene message before the first frame";
  EXPECT_EQ((*first.scene)["field"], "wave");
  ASSERT_TRUE(first.status);
  EXPECT_TRUE(first.errors.empty()) << first.errors.front();
  const json& st = *first.status;
  for (const char* key : {"fps", "cut_nodes", "texel_error", "converged", "seq", "format"})
    EXPECT_TRUE(st.contains(key)) << key;
  EXPECT_EQ(st["format"], is_png(first.bytes) ? "png" : "jpeg");
  EXPECT_TRUE(is_jpeg(first.bytes) || is_png(first.bytes));
  EXPECT_EQ(image_size(first.bytes), std::make_pair(64, 48));

  EXPECT_EQ(st["request"], 1);  // the hello

  // A camera move: the first frame of a new view is an interactive (JPEG) one.
  c.send(camera_message(*first.scene, 0.5).dump());
  const Frame moved = read_frame_for(c, 2);
  ASSERT_TRUE(moved.status);
  EXPECT_EQ((*moved.status)["converged"], false);
  EXPECT_TRUE(is_jpeg(moved.bytes)) << "first bytes " << int(uint8_t(moved.bytes[0]));
  EXPECT_GT(moved.bytes.size(), 100u);
  EXPECT_EQ(image_size(moved.bytes), std::make_pair(64, 48));
  EXPECT_GT((*moved.status)["seq"].get<int>(), st["seq"].get<int>());
  EXPECT_GT((*moved.status)["cut_nodes"].get<int>(), 0);

  // The view rests: refinement ends with a lossless frame, and then nothing more is sent until the view changes.
  const Frame still = read_until_converged(c, 2);
  EXPECT_TRUE(is_png(still.bytes));
  EXPECT_EQ(image_size(still.bytes), std::make_pair(64, 48));
  // The same camera again changes nothing: no frame is drawn (a settled view would be drawn at full quality again),
  // the message is acknowledged.
  c.send(camera_message(*first.scene, 0.5).dump());
  const Message ack = c.read();
  ASSERT_FALSE(ack.binary) << "a frame was drawn for a message that changed nothing";
  EXPECT_EQ(json::parse(ack.data), json::parse(R"({"type":"ack","request":3})"));
  c.send(R"({"type":"resize","width":32,"height":40})");
  const Frame resized = read_frame_for(c, 4);
  EXPECT_EQ(image_size(resized.bytes), std::make_pair(32, 40));
}

TEST(ViewServer, MalformedMessagesGetAnErrorAndServingGoesOn) {
  START_SERVER(server, o_.fps = 30);
  Client c(server->port());
  c.send(R"({"type":"hello","width":8,"height":64})");
  EXPECT_NE(read_error(c).find("width"), std::string::npos);
  c.send("{not json");
  EXPECT_NE(read_error(c).find("message"), std::string::npos);
  c.send(R"({"type":"dance"})");
  EXPECT_NE(read_error(c).find("type"), std::string::npos);
  c.send(R"({"type":"tf","preset":"nope"})");
  EXPECT_NE(read_error(c).find("preset"), std::string::npos);
  c.send(std::string(70 * 1024, ' '));
  EXPECT_NE(read_error(c).find("too large"), std::string::npos);

  c.send(R"({"type":"hello","width":64,"height":64})");
  const Frame f = read_frame(c);
  ASSERT_TRUE(f.status);
  EXPECT_EQ(image_size(f.bytes), std::make_pair(64, 64));
  // A bad message while frames flow: an error reply, then frames again for the next valid request.
  c.send(camera_message(*f.scene, 0.3).dump().replace(0, 1, "{\"zoom\":2,"));
  EXPECT_NE(read_error(c).find("zoom"), std::string::npos);
  c.send(R"({"type":"tf","preset":"grayscale","opacity":0.5})");
  const Frame g = read_frame_for(c, 2);  // hello and tf accepted, the rest rejected
  EXPECT_TRUE(g.status);
  EXPECT_TRUE(is_jpeg(g.bytes) || is_png(g.bytes));
}

TEST(ViewServer, TwoClientsEachGetTheirOwnView) {
  START_SERVER(server, o_.fps = 30);
  Client a(server->port()), b(server->port());
  a.send(R"({"type":"hello","width":64,"height":64})");
  b.send(R"({"type":"hello","width":48,"height":32})");
  const Frame fa = read_frame(a), fb = read_frame(b);
  ASSERT_TRUE(fa.scene && fb.scene);
  EXPECT_EQ(image_size(fa.bytes), std::make_pair(64, 64));
  EXPECT_EQ(image_size(fb.bytes), std::make_pair(48, 32));
  // Different cameras, same size: both converge, to different images.
  a.send(camera_message(*fa.scene, 0.0).dump());
  b.send(R"({"type":"resize","width":64,"height":64})");
  b.send(camera_message(*fb.scene, 1.2).dump());
  const Frame ca = read_until_converged(a, 2), cb = read_until_converged(b, 3);
  EXPECT_EQ(image_size(ca.bytes), std::make_pair(64, 64));
  EXPECT_EQ(image_size(cb.bytes), std::make_pair(64, 64));
  EXPECT_NE(ca.bytes, cb.bytes);
  // A client that goes away does not stop the other.
  {
    Client gone(server->port());
    gone.send(R"({"type":"hello","width":64,"height":64})");
  }
  a.send(camera_message(*fa.scene, 0.7).dump());
  EXPECT_TRUE(read_frame_for(a, 3).status);
}

TEST(ViewServer, LatestRequestWinsAndAFloodDoesNotStarveOthers) {
  START_SERVER(server, o_.fps = 30);
  Client a(server->port()), b(server->port());
  a.send(R"({"type":"hello","width":64,"height":64})");
  b.send(R"({"type":"hello","width":64,"height":64})");
  const Frame fa = read_frame(a);
  ASSERT_TRUE(fa.scene);
  // A burst of camera moves: frames follow the latest, the stale ones are dropped rather than rendered in turn.
  const int moves = 200;
  for (int i = 0; i < moves; ++i) a.send(camera_message(*fa.scene, 0.01 * i).dump());
  // Meanwhile the other tab still gets its frames through to full quality.
  const Frame cb = read_until_converged(b, 1);
  EXPECT_TRUE(is_png(cb.bytes));
  int frames = 0;
  for (; frames < 2 * moves; ++frames) {
    const Frame f = read_frame(a);
    ASSERT_TRUE(f.status);
    if ((*f.status)["request"] == moves + 1) break;
  }
  EXPECT_LT(frames, moves / 2) << "frames rendered for stale requests";
}

TEST(ViewServer, TokenAndOriginAreChecked) {
  START_SERVER(server, o_.token = "s3cret");
  EXPECT_EQ(server->url(), "http://127.0.0.1:" + std::to_string(server->port()) + "/?token=s3cret");
  EXPECT_EQ(http_get(server->port(), "/").status, 403);
  EXPECT_EQ(http_get(server->port(), "/?token=wrong").status, 403);
  EXPECT_EQ(http_get(server->port(), "/?token=s3cret").status, 200);
  EXPECT_THROW(Client(server->port(), "/ws"), beast::system_error);
  EXPECT_THROW(Client(server->port(), "/ws?token=s3cre"), beast::system_error);
  const std::string own = "http://127.0.0.1:" + std::to_string(server->port());
  // A page from another origin may not open the socket, even with the token.
  EXPECT_THROW(Client(server->port(), "/ws?token=s3cret", "http://evil.example"), beast::system_error);
  Client c(server->port(), "/ws?token=s3cret", own);
  c.send(R"({"type":"hello","width":32,"height":32})");
  EXPECT_TRUE(read_frame(c).status);
}

TEST(ViewServer, BadStoreIsAnError) {
  ViewServerOptions o;
  o.store = (shared().dir / "missing.ugvr").string();
  EXPECT_THROW(ViewServer{o}, Error);
  o.store = shared().store;
  o.host = "not-an-address";
  EXPECT_THROW(ViewServer{o}, Error);
}

TEST(CliView, BadFlagsNameTheFlag) {
  const std::string store = shared().store;
  const std::pair<std::string, std::string> cases[] = {
      {"view", "INPUT"},
      {"view " + store + " --demo", "INPUT"},
      {"view " + store + " --error 2", "--error"},
      {"view " + store + " --size 8", "--size"},
      {"view " + store + " --size 5000x64", "--size"},
      {"view " + store + " --fps -1", "--fps"},
      {"view " + store + " --fps fast", "--fps"},
      {"view " + store + " --port 70000", "--port"},
      {"view " + store + " --host nowhere", "--host"},
  };
  for (const auto& [args, flag] : cases) {
    const test::CommandResult r = test::run_ugvr(args);
    // 1: ugvr's own checks; CLI11's range checks exit with its own code (105).
    EXPECT_TRUE(r.status == 1 || r.status == 105) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(flag), std::string::npos) << args << "\n" << r.out;
  }
}

// The binary prints its URL, serves it, and exits cleanly on SIGTERM.
TEST(CliView, PrintsTheUrlAndStopsOnSigterm) {
  const std::string out = (shared().dir / "view-out.txt").string();
  const std::string script = "timeout 120 " + std::string(UGVR_BINARY) + " view " + shared().store + " --size 64 > " +
                             out + " 2>&1 & pid=$!; for i in $(seq 600); do grep -q serving " + out +
                             " && break; sleep 0.1; done; kill -TERM $pid; wait $pid; echo rc=$?";
  FILE* p = popen(script.c_str(), "r");
  ASSERT_TRUE(p);
  std::string rc;
  char buf[256];
  while (fgets(buf, sizeof buf, p)) rc += buf;
  pclose(p);
  std::string printed;
  if (FILE* f = std::fopen(out.c_str(), "r")) {
    while (fgets(buf, sizeof buf, f)) printed += buf;
    std::fclose(f);
  }
  if (printed.find("OpenGL") != std::string::npos && std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << printed;
  EXPECT_NE(printed.find("ugvr view: serving http://127.0.0.1:"), std::string::npos) << printed;
  EXPECT_EQ(rc, "rc=0\n") << printed;
}

// Runs a shell script, returns its standard output.
std::string shell(const std::string& script) {
  FILE* p = popen(script.c_str(), "r");
  if (!p) return "(popen failed)";
  std::string out;
  char buf[256];
  while (fgets(buf, sizeof buf, p)) out += buf;
  pclose(p);
  return out;
}

// `ugvr view MESH.vtu` builds the mesh's store in the cache directory while serving; the next run starts from it.
// A shallow store (--max-depth 3): the default depth took over the 120 s limit under ASan on 2 busy cores once the
// builder checked leaves against the cells' interpolant.
TEST(CliView, BuildsAGridsStoreInTheCacheAndReusesIt) {
  const std::filesystem::path dir = shared().dir / "cli-cache";
  std::filesystem::create_directories(dir);
  const std::string mesh = (dir / "wing.vtu").string();
  ASSERT_EQ(test::run_ugvr("--quiet generate --cells 3000 --kind mixed -o " + mesh).status, 0);
  const std::string cache = (dir / "cache").string();
  const auto run = [&](const std::string& wait_for, const std::string& log) {
    return shell("UGVR_CACHE_DIR=" + cache + " timeout 120 " + std::string(UGVR_BINARY) + " view " + mesh +
                 " --size 64 --max-depth 3 > " + log + " 2>&1 & pid=$!; for i in $(seq 1200); do " + wait_for +
                 " && break; sleep 0.1; done; kill -TERM $pid; wait $pid; echo rc=$?; cat " + log);
  };
  const std::string first = run("ls " + cache + "/wing-*.ugvr >/dev/null 2>&1", (dir / "first.txt").string());
  if (first.find("OpenGL") != std::string::npos && std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << first;
  EXPECT_NE(first.find("rc=0"), std::string::npos) << first;
  EXPECT_NE(first.find("building the brick store " + cache + "/wing-"), std::string::npos) << first;
  EXPECT_NE(first.find("ugvr view: serving http://127.0.0.1:"), std::string::npos) << first;
  size_t stores = 0;
  for (const auto& e : std::filesystem::directory_iterator(cache)) stores += e.path().extension() == ".ugvr";
  EXPECT_EQ(stores, 1u);
  const std::string second = run("grep -q serving " + (dir / "second.txt").string(), (dir / "second.txt").string());
  EXPECT_NE(second.find("rc=0"), std::string::npos) << second;
  EXPECT_NE(second.find("showing the brick store built earlier, " + cache + "/wing-"), std::string::npos) << second;
}

TEST(ViewServer, SendsAContentSecurityPolicyAndLimitsTabs) {
  START_SERVER(server, o_.max_sessions = 2);
  const HttpReply page = http_get(server->port(), "/");
  EXPECT_NE(page.csp.find("default-src 'self'"), std::string::npos) << page.csp;
  EXPECT_NE(page.csp.find("frame-ancestors 'none'"), std::string::npos) << page.csp;
  EXPECT_EQ(page.csp, http_get(server->port(), "/app.js").csp);
  Client a(server->port()), b(server->port());
  // The sessions count once their handshake is done: say hello and wait for a frame on both.
  a.send(R"({"type":"hello","width":32,"height":32})");
  b.send(R"({"type":"hello","width":32,"height":32})");
  read_frame(a);
  read_frame(b);
  EXPECT_THROW(Client(server->port()), beast::system_error) << "a third tab past max_sessions = 2";
}

// Issue 23: 40 connections opened at once, their upgrade requests all sent before any is answered. The tab limit
// counts tabs still in their handshake, so no more than max_sessions are accepted (before: 40 of 40 got through a
// limit of 16 when the requests raced the handshakes).
TEST(ViewServer, AConnectionBurstCannotPassTheTabLimit) {
  START_SERVER(server, o_.max_sessions = 4);
  net::io_context ioc;
  std::vector<std::unique_ptr<tcp::socket>> sockets;
  for (int i = 0; i < 40; ++i) {
    auto s = std::make_unique<tcp::socket>(ioc);
    s->connect({net::ip::make_address("127.0.0.1"), server->port()});
    set_receive_timeout(*s, 30);
    sockets.push_back(std::move(s));
  }
  for (auto& s : sockets) write_upgrade_request(*s, server->port());
  int accepted = 0, refused = 0;
  for (auto& s : sockets) {
    beast::flat_buffer buffer;
    http::response_parser<http::empty_body> parser;
    parser.skip(false);
    http::read_header(*s, buffer, parser);
    const int status = int(parser.get().result_int());
    if (status == 101) ++accepted;
    if (status == 503) ++refused;
  }
  EXPECT_EQ(accepted, 4);
  EXPECT_EQ(refused, 36);
  // The accepted tabs leave; new ones are admitted again.
  sockets.clear();
  bool admitted = false;
  for (int attempt = 0; attempt < 100 && !admitted; ++attempt) {
    try {
      Client c(server->port());
      admitted = true;
    } catch (const beast::system_error&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  EXPECT_TRUE(admitted) << "no tab admitted after the burst's sockets closed";
}

// Issue 23: a client repeating hello without reading got a 2.9 KB scene message queued per hello (400,000 hellos:
// 1.2 GB). Equal texts waiting in a tab's queue are coalesced and a queue past 16 MiB closes the client; the server
// stays responsive to others.
TEST(ViewServer, AHelloFloodWithoutReadingKeepsTheServerSmall) {
  START_SERVER(server);
  Client reader(server->port());
  reader.send(R"({"type":"hello","width":32,"height":32})");
  read_frame(reader);
  const uint64_t before = current_rss_bytes();
  {
    Client flood(server->port());
    const std::string hello = R"({"type":"hello","width":32,"height":32})";
#if !defined(UGVR_UNDER_ASAN)
    constexpr int kHellos = 100000;
#else
    constexpr int kHellos = 20000;  // the memory check below is off here; uncoalesced they would still queue 58 MB
#endif
    for (int i = 0; i < kHellos; ++i) flood.send(hello);
    // Back on the reader: it is still served (the flood's messages have been applied by now, in order on one thread).
    reader.send(R"({"type":"resize","width":40,"height":40})");
    read_frame(reader);
    const uint64_t after = current_rss_bytes();
    // Measured: +0.25 MB; without the coalescing +52 MB at this point (the server still reading the flood). Not
    // under AddressSanitizer, whose quarantine keeps up to 256 MB of freed memory (the coalesced copies) resident.
#if !defined(UGVR_UNDER_ASAN)
    EXPECT_LT(after, before + (uint64_t(16) << 20)) << "RSS " << before << " -> " << after;
#else
    (void)before, (void)after;
#endif
  }
}

// Issue 23: every tab's allocations (outgoing queue, canvas, RAM brick cache) are charged against one server-wide
// budget: a tab past it is refused with the reason, a later tab gets a smaller cache, a canvas too large is refused,
// and a tab that leaves gives its charge back.
TEST(ViewServer, TabsShareOneMemoryBudget) {
  constexpr uint64_t MiB = uint64_t(1) << 20;
  const uint64_t fixed = kTabQueueBytes + canvas_bytes(512, 512);  // at the page's initial size
  START_SERVER(server, o_.ram_per_session = 64 * MiB, o_.tabs_memory = (fixed + 64 * MiB) + (fixed + 40 * MiB));
  auto ram_budget = [](Client& c) {  // at the size the tab was admitted with, so that its charge stays
    c.send(R"({"type":"hello","width":512,"height":512})");
    const Frame f = read_frame(c);
    return f.status ? (*f.status)["ram_budget"].get<uint64_t>() : 0;
  };
  auto upgrade = [&]() -> HttpReply {
    net::io_context ioc;
    tcp::socket s(ioc);
    s.connect({net::ip::make_address("127.0.0.1"), server->port()});
    set_receive_timeout(s, 30);
    write_upgrade_request(s, server->port());
    beast::flat_buffer buffer;
    http::response<http::string_body> res;
    http::read(s, buffer, res);
    return {int(res.result_int()), res.body(), ""};
  };
  auto a = std::make_unique<Client>(server->port());
  EXPECT_EQ(ram_budget(*a), 64 * MiB);
  Client b(server->port());
  EXPECT_EQ(ram_budget(b), 40 * MiB) << "the second tab's cache is what the budget has left";
  const HttpReply refused = upgrade();
  EXPECT_EQ(refused.status, 503);
  EXPECT_NE(refused.body.find("--tabs-memory"), std::string::npos) << refused.body;
  // A canvas past the budget is refused; the tab goes on at its size.
  b.send(R"({"type":"resize","width":4096,"height":4096})");
  EXPECT_NE(read_error(b).find("4096x4096"), std::string::npos);
  // The first tab leaves: a new one is admitted (the charge is given back when the socket closes).
  a.reset();
  bool admitted = false;
  for (int attempt = 0; attempt < 100 && !admitted; ++attempt) {
    try {
      Client c(server->port());
      admitted = true;
      EXPECT_EQ(ram_budget(c), 64 * MiB);
    } catch (const beast::system_error&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  EXPECT_TRUE(admitted) << "no tab admitted after one left";
}

// The Python API's live view (Viewer.camera / Viewer.tf): current_view reports what the tab that moved last shows;
// set_view moves every tab, tells the pages ("view" message) and redraws; a tab opened afterwards starts from it.
TEST(ViewServer, SetViewMovesTheTabsAndCurrentViewFollowsThem) {
  START_SERVER(server);
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  const Frame first = read_frame(c);
  ASSERT_TRUE(first.scene);
  EXPECT_EQ(camera_to_json(server->current_view().camera), (*first.scene)["camera"]) << "no tab moved yet";
  const json moved = camera_message(*first.scene, 0.7);
  c.send(moved.dump());
  read_frame_for(c, 2);
  EXPECT_EQ(camera_to_json(server->current_view().camera)["position"], moved["position"]);

  Camera camera = camera_from_json((*first.scene)["camera"], "scene");
  camera.view_angle = 20;
  TransferFunction tf = builtin_preset("inferno");
  tf.rescale(0, 1);
  tf.opacity_points = {{0, 0}, {0.5, 0.25}, {1, 0.75}};
  server->set_view(camera, tf);
  const std::optional<json> told = read_text_until(c, [](const json& j) { return j["type"] == "view"; });
  ASSERT_TRUE(told);
  EXPECT_EQ((*told)["camera"], camera_to_json(camera));
  EXPECT_EQ((*told)["tf"]["opacity_points"], json({0, 0, 0.5, 0.25, 1, 0.75}));
  const ViewServer::View now = server->current_view();
  EXPECT_EQ(camera_to_json(now.camera), camera_to_json(camera));
  EXPECT_EQ(now.tf.opacity_points.size(), 3u);
  EXPECT_EQ(now.tf.color_points.size(), tf.color_points.size());
  // A tab opened now starts from the view set, and is told after the scene.
  Client d(server->port());
  d.send(R"({"type":"hello","width":32,"height":32})");
  EXPECT_TRUE(read_text_until(d, [](const json& j) { return j["type"] == "view"; }));
  EXPECT_THROW(server->set_view(std::nullopt, TransferFunction{}), Error) << "an empty transfer function";
}

// `ugvr view MESH`: the exact engine shows the grid while its store is built in the background, then every tab moves
// to the store with the view it had.
TEST(ViewServer, ShowsAGridWithTheExactEngineWhileItsStoreIsBuilt) {
  const std::filesystem::path store = shared().dir / "built-in-background.ugvr";
  std::filesystem::remove(store);
  // The build waits until the test has seen an exact frame, so what each phase shows is checked, not raced.
  std::unique_ptr<ViewServer> server;  // before the gate, so that it is destroyed after the gate opens
  BuildGate gate;
  {
    ViewServerOptions o;
    o.store = store.string();
    o.dataset = std::make_shared<Dataset>(make_box());
    o.fields = {"wave"};
    o.build = small_build();
    o.fps = 30;
    o.before_build = gate.hold();
    START_VIEW_SERVER(server, o, &gate);
  }
  Client c(server->port());
  c.send(R"({"type":"hello","width":48,"height":40})");
  const Frame first = read_frame(c);
  ASSERT_TRUE(first.scene && first.status);
  EXPECT_EQ((*first.scene)["engine"], "exact");
  EXPECT_EQ((*first.scene)["field"], "wave");
  EXPECT_EQ((*first.status)["engine"], "exact");
  EXPECT_TRUE(is_png(first.bytes) || is_jpeg(first.bytes));
  EXPECT_EQ(image_size(first.bytes), std::make_pair(48, 40));
  // A camera move: a scaled exact frame (JPEG), then the full-size exact image once the view rests (PNG).
  c.send(camera_message(*first.scene, 0.7).dump());
  const Frame still = read_until_converged(c, 2);
  EXPECT_EQ((*still.status)["engine"], "exact");
  EXPECT_TRUE(is_png(still.bytes));
  EXPECT_FALSE(std::filesystem::exists(store)) << "the build was held";

  gate.open();
  // Progress ("ready"), then the store's scene; the next frames come from the store, for the same request.
  bool ready = false;
  const std::optional<json> scene = read_text_until(c, [&](const json& j) {
    if (j["type"] == "progress" && j["stage"] == "ready") ready = true;
    if (j["type"] == "progress") {
      EXPECT_NE(j["stage"], "failed") << j.dump();
    }
    return j["type"] == "scene";
  });
  ASSERT_TRUE(scene) << "no new scene after the build";
  EXPECT_TRUE(ready);
  EXPECT_EQ((*scene)["engine"], "lod");
  EXPECT_EQ((*scene)["camera"], (*first.scene)["camera"]) << "the reset view stays";
  EXPECT_TRUE(std::filesystem::exists(store));
  const Frame lod = read_until_converged(c, 2);
  EXPECT_EQ((*lod.status)["engine"], "lod");
  EXPECT_EQ((*lod.status)["request"], 2) << "the tab's view is kept";
  EXPECT_EQ(image_size(lod.bytes), std::make_pair(48, 40));
}

// `ugvr view MESH` keeps the grid once its store is shown: each tab picks the exact or the level-of-detail engine
// ("engine" message), gets frames from either, and the other tabs keep theirs. Before the store is ready only the
// exact engine is offered; with free_grid only the store is, once it is shown.
TEST(ViewServer, EachTabSwitchesBetweenTheExactAndTheLodEngine) {
  for (const bool free_grid : {false, true}) {
    SCOPED_TRACE(free_grid ? "free_grid" : "grid kept");
    const std::filesystem::path store = shared().dir / (free_grid ? "switch-freed.ugvr" : "switch-kept.ugvr");
    std::filesystem::remove(store);
    // The build waits until the test has tried the level-of-detail engine too early.
    std::unique_ptr<ViewServer> server;  // before the gate, so that it is destroyed after the gate opens
    BuildGate gate;
    {
      ViewServerOptions o;
      o.store = store.string();
      o.dataset = std::make_shared<Dataset>(make_box());
      o.fields = {"wave"};
      o.build = small_build();
      o.fps = 30;
      o.free_grid = free_grid;
      o.before_build = gate.hold();
      START_VIEW_SERVER(server, o, &gate);
    }
    Client a(server->port()), b(server->port());
    a.send(R"({"type":"hello","width":48,"height":40})");
    b.send(R"({"type":"hello","width":40,"height":32})");
    const Frame first = read_frame(a);
    ASSERT_TRUE(first.scene && first.status);
    EXPECT_EQ((*first.scene)["engines"], json({"exact"}));
    EXPECT_EQ((*first.scene)["engine"], "exact");
    const std::string exact_label = (*first.scene)["renderers"]["exact"];
    EXPECT_EQ(exact_label.rfind("exact engine (", 0), 0u) << exact_label;
    EXPECT_EQ((*first.scene)["renderer"], exact_label);
    EXPECT_EQ((*first.status)["engine"], "exact");
    // The store is not there yet.
    a.send(R"({"type":"engine","engine":"lod"})");
    EXPECT_NE(read_error(a).find("engine: \"lod\" is not available: the brick store is not ready yet"),
              std::string::npos);
    a.send(R"({"type":"engine","engine":"exact"})");  // request 2: the one there is
    EXPECT_EQ((*read_until_converged(a, 2).status)["engine"], "exact");

    gate.open();
    const std::optional<json> scene = read_text_until(a, [](const json& j) { return j["type"] == "scene"; });
    ASSERT_TRUE(scene) << "no new scene after the build";
    EXPECT_EQ((*scene)["engine"], "lod");
    EXPECT_EQ((*scene)["renderer"], server->renderer());
    if (free_grid) {
      EXPECT_EQ((*scene)["engines"], json({"lod"}));
      EXPECT_FALSE((*scene)["renderers"].contains("exact"));
      a.send(R"({"type":"engine","engine":"exact"})");
      EXPECT_NE(read_error(a).find("engine: \"exact\" is not available"), std::string::npos);
      EXPECT_EQ((*read_until_converged(a, 2).status)["engine"], "lod") << "the tab moved to the store";
      continue;
    }
    EXPECT_EQ((*scene)["engines"], json({"exact", "lod"}));
    EXPECT_EQ((*scene)["renderers"]["exact"], exact_label) << "the exact engine is kept as it was";
    EXPECT_EQ((*scene)["renderers"]["lod"], server->renderer());
    // Every tab moved to the store, the one that had picked the exact engine too.
    const Frame lod = read_until_converged(a, 2);
    EXPECT_EQ((*lod.status)["engine"], "lod");
    EXPECT_TRUE(is_png(lod.bytes));

    // Tab a back to the exact engine: frames from it, at the tab's size, to a converged PNG; tab b stays on the store.
    a.send(R"({"type":"engine","engine":"exact"})");  // request 3
    // A new renderer: its first frame is drawn at a reduced image scale (a view it has not shown yet), then the
    // full-size image at rest.
    const Frame scaled = read_frame_for(a, 3);
    EXPECT_EQ((*scaled.status)["engine"], "exact");
    EXPECT_EQ((*scaled.status)["converged"], false);
    EXPECT_LT((*scaled.status)["scale"].get<double>(), 1.0);
    EXPECT_TRUE(is_jpeg(scaled.bytes));
    EXPECT_EQ(image_size(scaled.bytes), std::make_pair(48, 40)) << "magnified to the tab's size";
    const Frame exact = read_until_converged(a, 3);
    EXPECT_EQ((*exact.status)["engine"], "exact");
    EXPECT_TRUE(is_png(exact.bytes));
    EXPECT_EQ(image_size(exact.bytes), std::make_pair(48, 40));
    b.send(camera_message(*scene, 0.4).dump());  // b: request 2
    const Frame other = read_until_converged(b, 2);
    EXPECT_EQ((*other.status)["engine"], "lod") << "one tab's pick is its own";
    EXPECT_EQ(image_size(other.bytes), std::make_pair(40, 32));
    // A move on the exact engine: an interactive frame, then the full-size image at rest.
    a.send(camera_message(*scene, 0.9).dump());  // request 4
    const Frame moving = read_frame_for(a, 4);
    EXPECT_EQ((*moving.status)["engine"], "exact");
    EXPECT_EQ((*moving.status)["converged"], false);
    const Frame rest = read_until_converged(a, 4);
    EXPECT_EQ((*rest.status)["engine"], "exact");
    EXPECT_NE(rest.bytes, exact.bytes) << "another view";
    // And back to the store, with the view the tab has now.
    a.send(R"({"type":"engine","engine":"lod"})");  // request 5
    const Frame back = read_until_converged(a, 5);
    EXPECT_EQ((*back.status)["engine"], "lod");
    EXPECT_GT((*back.status)["cut_nodes"].get<int>(), 0);
    EXPECT_EQ(image_size(back.bytes), std::make_pair(48, 40));
    // An unknown engine is refused, and so is hybrid for a store without cells; the tab goes on with the one it has.
    a.send(R"({"type":"engine","engine":"fancy"})");
    EXPECT_NE(read_error(a).find(R"(engine: expected "exact", "lod" or "hybrid", found "fancy")"), std::string::npos);
    a.send(R"({"type":"engine","engine":"hybrid"})");
    EXPECT_NE(read_error(a).find(R"(engine: "hybrid" is not available)"), std::string::npos);
    a.send(R"({"type":"resize","width":32,"height":32})");  // request 6
    EXPECT_EQ((*read_frame_for(a, 6).status)["engine"], "lod");
  }
}

// A store with cells is drawn by the hybrid engine (docs/hybrid.md): voxels while the view moves, then at rest exact
// nodes batch by batch, each frame sent, the status saying how many, until every candidate is exact; a tab may pick
// the level-of-detail engine instead (voxels only), and `hybrid` off makes that the default.
TEST(ViewServer, AStoreWithCellsRefinesToExactCellsAtRest) {
  for (const bool hybrid : {true, false}) {
    SCOPED_TRACE(hybrid ? "hybrid default" : "hybrid off");
    START_SERVER(server, o_.store = shared().cells_store; o_.fps = 30; o_.hybrid = hybrid;
                 o_.exact_batch = 16);  // several batches, each frame sent
    Client c(server->port());
    c.send(R"({"type":"hello","width":48,"height":40})");
    const Frame first = read_frame(c);
    ASSERT_TRUE(first.scene && first.status);
    EXPECT_EQ((*first.scene)["engines"], json({"hybrid", "lod"}));
    EXPECT_EQ((*first.scene)["engine"], hybrid ? "hybrid" : "lod");
    if (!hybrid) {
      const Frame still = read_until_converged(c, 1);
      EXPECT_EQ((*still.status)["engine"], "lod");
      EXPECT_FALSE(still.status->contains("exact")) << still.status->dump();
      c.send(R"({"type":"engine","engine":"hybrid"})");  // request 2: the tab may still pick it
      const Frame picked = read_until_converged(c, 2);
      EXPECT_EQ((*picked.status)["engine"], "hybrid");
      ASSERT_TRUE(picked.status->contains("exact")) << picked.status->dump();
      EXPECT_GT((*picked.status)["exact"]["nodes"].get<uint64_t>(), 0u);
      continue;
    }
    // A move, then rest: frames until converged, the exact count never falling, none exact while moving.
    c.send(camera_message(*first.scene, 0.3).dump());  // request 2
    std::vector<uint64_t> exact;
    std::optional<json> last;
    for (int i = 0; i < 200; ++i) {
      const Frame f = read_frame_for(c, 2);
      ASSERT_TRUE(f.status);
      const json& st = *f.status;
      EXPECT_EQ(st["engine"], "hybrid");
      if (st.contains("exact")) {
        EXPECT_TRUE(st["exact"]["off"].is_null()) << st.dump();
        exact.push_back(st["exact"]["nodes"]);
      } else {
        EXPECT_EQ(st["converged"], false) << "a converged hybrid frame says how much is exact";
        EXPECT_TRUE(exact.empty()) << "no voxel-only frame once the view rests";
      }
      if (st["converged"] == true) {
        EXPECT_TRUE(is_png(f.bytes));
        last = st;
        break;
      }
    }
    ASSERT_TRUE(last) << "no converged frame";
    ASSERT_FALSE(exact.empty());
    std::printf("exact nodes frame by frame at rest:");
    for (uint64_t n : exact) std::printf(" %llu", (unsigned long long)n);
    std::printf(" (of %llu candidates)\n", (unsigned long long)(*last)["exact"]["candidates"].get<uint64_t>());
    EXPECT_TRUE(std::is_sorted(exact.begin(), exact.end()));
    // Batch by batch: the intermediate images come too (at most 16 more nodes a frame).
    EXPECT_GE(exact.size(), 2u);
    for (size_t i = 1; i < exact.size(); ++i) EXPECT_LE(exact[i], exact[i - 1] + 16);
    const json& e = (*last)["exact"];
    EXPECT_GT(e["nodes"].get<uint64_t>(), 0u) << last->dump();
    EXPECT_TRUE(e["nodes"] == e["candidates"] || e["budget_full"] == true) << last->dump();
    EXPECT_GT(e["cells"].get<uint64_t>(), 0u);
    EXPECT_GT(e["fraction"].get<double>(), 0.0);
    EXPECT_LE(e["fraction"].get<double>(), 1.0);
    // The same view with the level-of-detail engine: voxels only, no exact figures.
    c.send(R"({"type":"engine","engine":"lod"})");  // request 3
    const Frame lod = read_until_converged(c, 3);
    EXPECT_EQ((*lod.status)["engine"], "lod");
    EXPECT_FALSE(lod.status->contains("exact"));
  }
}

// A resting frame (here the hybrid engine's exact batches) is cut short when the tab's view moves on meanwhile: the
// move is drawn next, not after the whole resting frame. The render thread is held at the start of the first resting
// frame of the first move (ViewServerOptions::on_frame_start) until the second move has been applied, so the
// interruption is certain, not raced: without it, that frame would be drawn and sent for request 2.
TEST(ViewServer, AMoveCutsTheRestingFrameUnderWayShort) {
  std::promise<void> resting_started;
  std::atomic<bool> held{false};
  std::atomic<bool> saw_stop{false};
  START_SERVER(
      server, o_.store = shared().cells_store; o_.fps = 30; o_.hybrid = true; o_.exact_batch = 16;
      o_.on_frame_start = [&](const FrameJob& job, const std::function<bool()>& keep_going) {
        if (!keep_going || job.generation < 2 || held.exchange(true)) return;
        resting_started.set_value();
        // Until the next move is applied (bounded: a server that never applies it fails below).
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        while (keep_going() && std::chrono::steady_clock::now() < until)
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        saw_stop = !keep_going();
      });
  Client c(server->port());
  c.send(R"({"type":"hello","width":48,"height":40})");
  const Frame first = read_frame(c);
  ASSERT_TRUE(first.scene && first.status);
  c.send(camera_message(*first.scene, 0.3).dump());  // request 2
  ASSERT_EQ(resting_started.get_future().wait_for(std::chrono::seconds(60)), std::future_status::ready)
      << "no resting frame after the move";
  c.send(camera_message(*first.scene, 0.6).dump());  // request 3, while request 2's resting frame is held
  // Request 2's frames: its moving one only. Then request 3's, which count the interruption.
  std::vector<json> of_2;
  Frame next;
  for (int i = 0; i < 50; ++i) {
    next = read_frame(c);
    ASSERT_TRUE(next.status);
    const uint64_t r = (*next.status)["request"];
    if (r >= 3) break;
    if (r == 2) of_2.push_back(*next.status);
  }
  ASSERT_EQ((*next.status)["request"], 3) << next.status->dump();
  EXPECT_TRUE(saw_stop) << "the held frame's renderer was never told to stop";
  ASSERT_EQ(of_2.size(), 1u) << "request 2's resting frame was drawn and sent: " << of_2.back().dump();
  EXPECT_EQ(of_2[0]["converged"], false);
  EXPECT_EQ((*next.status)["interrupted"].get<uint64_t>(), of_2[0]["interrupted"].get<uint64_t>() + 1)
      << next.status->dump();
  // The tab goes on as usual: request 3 refines to its converged, exact image.
  const Frame still = read_until_converged(c, 3);
  EXPECT_TRUE(is_png(still.bytes));
  ASSERT_TRUE(still.status->contains("exact"));
  EXPECT_GT((*still.status)["exact"]["nodes"].get<uint64_t>(), 0u);
}

// stop() while the render thread moves to a store that has just been built (it opens the store with the lock
// released): the stop must not be lost. It once was: the loop went on to wait for work, and stop() waited for it.
TEST(ViewServer, StopsWhileSwitchingToTheBuiltStore) {
  std::promise<void> opening;
  std::future<void> opened = opening.get_future();
  ViewServerOptions o;
  o.store = (shared().dir / "stop-while-opening.ugvr").string();
  std::filesystem::remove(o.store);
  o.dataset = std::make_shared<Dataset>(make_box());
  o.build = small_build();
  // The render thread is held just before it opens the store, long enough for stop() to come in meanwhile.
  o.opening_store = [&opening] {
    opening.set_value();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  };
  std::unique_ptr<ViewServer> server;
  START_VIEW_SERVER(server, o);
  ASSERT_EQ(opened.wait_for(std::chrono::seconds(60)), std::future_status::ready) << "the store was never opened";
  auto stopped = std::async(std::launch::async, [&] { server->stop(); });
  // A lost stop would hang here: fail instead (the test binary then cannot end cleanly, which CI also sees).
  ASSERT_EQ(stopped.wait_for(std::chrono::seconds(30)), std::future_status::ready) << "stop() hung";
}

TEST(ViewServer, AFailedBuildIsReportedAndTheExactEngineGoesOn) {
  std::unique_ptr<ViewServer> server;
  {
    ViewServerOptions o;
    // A directory that cannot be created: the build fails at once.
    o.store = "/proc/ugvr-cannot-write/here.ugvr";
    o.dataset = std::make_shared<Dataset>(make_box());
    o.build = small_build();
    START_VIEW_SERVER(server, o);
  }
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  const std::optional<json> failed =
      read_text_until(c, [](const json& j) { return j["type"] == "progress" && j["stage"] == "failed"; });
  ASSERT_TRUE(failed);
  EXPECT_NE((*failed)["message"].get<std::string>().find("ugvr-cannot-write"), std::string::npos) << failed->dump();
  c.send(R"({"type":"resize","width":40,"height":24})");
  const Frame f = read_frame_for(c, 2);
  ASSERT_TRUE(f.status);
  EXPECT_EQ((*f.status)["engine"], "exact");
  EXPECT_EQ(image_size(f.bytes), std::make_pair(40, 24));
}

// Serve first, load after (issue 24): the server listens before the grid is read; a tab that connects meanwhile gets
// the load's progress ("read" with the reader's own fraction), then, when the exact engine can draw, the scene and a
// first image while the store is still being built (held here), then the store.
TEST(ViewServer, ServesBeforeReadingThenShowsProgressAndAFirstImageWhileTheStoreIsBuilt) {
  const std::filesystem::path store = shared().dir / "served-first.ugvr";
  std::filesystem::remove(store);
  std::unique_ptr<ViewServer> server;  // before the gates, so that it is destroyed after they open
  BuildGate reading, build;
  {
    ViewServerOptions o;
    o.store = store.string();
    o.load = [f = reading.hold()] {
      // A reader's progress, as vtk_xml_reader reports it, then the read waits for the test.
      Progress p("reading box.vtu", 10);
      p.set(5);
      f();
      return std::make_shared<Dataset>(make_box());
    };
    o.fields = {"wave"};
    o.build = small_build();
    o.before_build = build.hold();
    // Constructed on another thread: if the constructor waited for the read it would never return.
    auto made = std::async(std::launch::async, [o] { return std::make_unique<ViewServer>(o); });
    ASSERT_EQ(made.wait_for(std::chrono::seconds(60)), std::future_status::ready) << "the server waited for the read";
    try {
      server = made.get();
    } catch (const Error& e) {
      reading.open();
      if (std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << e.what();
      FAIL() << "cannot start the server: " << e.what();
    }
  }
  EXPECT_EQ(http_get(server->port(), "/").status, 200) << "the page is served while the grid is read";
  Client c(server->port());
  c.send(R"({"type":"hello","width":48,"height":40})");
  bool scene_early = false;
  const std::optional<json> read = read_text_until(c, [&](const json& j) {
    scene_early |= j["type"] == "scene";
    return j["type"] == "progress" && j["stage"] == "read" && j["fraction"] == 0.5;
  });
  ASSERT_TRUE(read) << "no reading progress";
  EXPECT_EQ((*read)["label"], "reading box.vtu");
  EXPECT_FALSE(scene_early) << "a scene before there is anything to draw";
  EXPECT_NE(server->progress().find("\"read\""), std::string::npos) << server->progress();

  reading.open();
  // The store's build starts once the grid is read (and is held); the walk mesh is built beside it; then the scene
  // and the first image, from the exact engine, while the build still runs.
  std::vector<std::string> stages;
  const std::optional<json> scene = read_text_until(c, [&](const json& j) {
    if (j["type"] == "progress") stages.push_back(j["stage"].get<std::string>() + "/" + j["label"].get<std::string>());
    return j["type"] == "scene";
  });
  ASSERT_TRUE(scene);
  EXPECT_EQ((*scene)["engine"], "exact");
  for (const std::string& st : stages) EXPECT_TRUE(st.rfind("read/", 0) == 0 || st.rfind("build/", 0) == 0) << st;
  const Frame first = read_frame(c);
  ASSERT_TRUE(first.status);
  EXPECT_EQ((*first.status)["engine"], "exact");
  EXPECT_EQ(image_size(first.bytes), std::make_pair(48, 40)) << "the tab's size from its hello, said before the scene";
  EXPECT_FALSE(std::filesystem::exists(store)) << "the build was held: the first image came before the store";
  EXPECT_NE(server->progress().find("\"build\""), std::string::npos) << server->progress();

  build.open();
  const std::optional<json> lod = read_text_until(c, [](const json& j) { return j["type"] == "scene"; });
  ASSERT_TRUE(lod);
  EXPECT_EQ((*lod)["engine"], "lod");
  EXPECT_EQ((*lod)["camera"], (*scene)["camera"]);
}

// A grid that cannot be read: the page is told why ("failed"), and so is the caller (on_failure); nothing draws.
TEST(ViewServer, AGridThatCannotBeReadIsReportedToThePageAndTheCaller) {
  std::promise<std::string> failed;
  std::future<std::string> said = failed.get_future();
  std::unique_ptr<ViewServer> server;
  BuildGate reading;
  {
    ViewServerOptions o;
    o.store = (shared().dir / "never-built.ugvr").string();
    o.load = [f = reading.hold()]() -> std::shared_ptr<const Dataset> {
      f();
      throw Error("broken.vtu: not a VTK XML file");
    };
    o.on_failure = [&failed](const std::string& m) { failed.set_value(m); };
    START_VIEW_SERVER(server, o, &reading);
  }
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  reading.open();
  const std::optional<json> j = read_text_until(c, [](const json& m) {
    EXPECT_NE(m["type"], "scene");
    return m["type"] == "progress" && m["stage"] == "failed";
  });
  ASSERT_TRUE(j);
  EXPECT_NE((*j)["message"].get<std::string>().find("broken.vtu: not a VTK XML file"), std::string::npos) << j->dump();
  ASSERT_EQ(said.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_NE(said.get().find("broken.vtu"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(shared().dir / "never-built.ugvr"));
}

// A collective renderer (a partitioned store's pieces, or the ranks under MPI) is opened on the render loop's first
// turn, after the server listens: a billion-cell store's 16 pieces take seconds to open, and the URL must not wait
// for them. While it opens, a tab is told so; when it cannot be opened, the page and the caller are told why.
TEST(ViewServer, ListensBeforeTheCollectiveRendererIsOpenedAndReportsItsFailure) {
  std::promise<std::string> failed;
  std::future<std::string> said = failed.get_future();
  std::unique_ptr<ViewServer> server;
  BuildGate opening;
  const auto start = std::chrono::steady_clock::now();
  {
    ViewServerOptions o;
    // Held until the test opens it, or 20 s: a server that opened it before listening would wait that long.
    o.collective = [held = opening.hold_at_most(std::chrono::seconds(20))]() -> CollectiveRenderer {
      held();
      throw Error("p.json: piece 3: no such file");
    };
    o.on_failure = [&failed](const std::string& m) { failed.set_value(m); };
    START_VIEW_SERVER(server, o, &opening);
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10)
      << "the server listened only once the collective renderer was opened";
  EXPECT_GT(server->port(), 0);
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  const std::optional<json> waiting = read_text_until(c, [](const json& m) {
    EXPECT_NE(m["type"], "scene");
    return m["type"] == "progress";
  });
  ASSERT_TRUE(waiting);
  EXPECT_NE((*waiting)["message"].get<std::string>().find("opening the data"), std::string::npos) << waiting->dump();
  opening.open();
  const std::optional<json> j = read_text_until(c, [](const json& m) {
    EXPECT_NE(m["type"], "scene");
    return m["type"] == "progress" && m["stage"] == "failed";
  });
  ASSERT_TRUE(j);
  EXPECT_NE((*j)["message"].get<std::string>().find("piece 3: no such file"), std::string::npos) << j->dump();
  ASSERT_EQ(said.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_NE(said.get().find("opening the data failed: p.json: piece 3"), std::string::npos);
}

// Over the memory budget the grid is never read: its store is built out of core from the .vtu, the page says why
// from the first progress on, and the store's scene is the first one.
TEST(ViewServer, AGridOverTheBudgetIsShownFromItsStoreBuiltOutOfCore) {
  const std::filesystem::path dir = shared().dir / "out-of-core";
  std::filesystem::create_directories(dir);
  const std::string mesh = (dir / "wing.vtu").string();
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + mesh).status, 0);
  std::unique_ptr<ViewServer> server;
  BuildGate build;
  {
    ViewServerOptions o;
    o.store = (dir / "wing.ugvr").string();
    o.out_of_core_input = mesh;
    o.out_of_core_budget = uint64_t(256) << 20;
    o.notice = "the grid would take about 9 GiB in memory, over the memory budget";
    o.build = small_build();
    o.before_build = build.hold();
    START_VIEW_SERVER(server, o, &build);
  }
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  const std::optional<json> p = read_text_until(c, [](const json& m) { return m["type"] == "progress"; });
  ASSERT_TRUE(p);
  EXPECT_EQ((*p)["stage"], "build");
  EXPECT_NE((*p)["message"].get<std::string>().find("over the memory budget"), std::string::npos) << p->dump();
  build.open();
  const Frame f = read_frame(c);
  ASSERT_TRUE(f.scene && f.status);
  EXPECT_EQ((*f.scene)["engine"], "lod");
  EXPECT_EQ((*f.scene)["engines"].size(), 1u) << "no exact engine: the grid was not read";
  EXPECT_EQ((*f.status)["engine"], "lod");
}

// `ugvr view` prints its URL before it reads the grid: a file that turns out unreadable is reported after the URL,
// and the viewer then exits non-zero.
TEST(CliView, PrintsTheUrlBeforeReadingAndExitsNonZeroOnAnUnreadableGrid) {
  const std::filesystem::path dir = shared().dir / "cli-bad";
  std::filesystem::create_directories(dir);
  const std::string bad = (dir / "broken.vtu").string();
  {
    std::FILE* f = std::fopen(bad.c_str(), "w");
    ASSERT_TRUE(f);
    std::fputs("<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"4\"", f);
    std::fclose(f);
  }
  const std::string out = shell("UGVR_CACHE_DIR=" + (dir / "cache").string() + " timeout 120 " +
                                std::string(UGVR_BINARY) + " view " + bad + " --size 64 2>&1; echo rc=$?");
  if (out.find("OpenGL") != std::string::npos && std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << out;
  const size_t url = out.find("ugvr view: serving http://127.0.0.1:");
  const size_t error = out.find("broken.vtu", out.find("ugvr: error:"));
  ASSERT_NE(url, std::string::npos) << out;
  ASSERT_NE(error, std::string::npos) << out;
  EXPECT_LT(url, error) << "the URL comes first\n" << out;
  EXPECT_EQ(out.find("rc=0"), std::string::npos) << out;
  EXPECT_NE(out.find("rc=1"), std::string::npos) << out;
}

// The budget decision end to end: a small budget (the flag, or the variable) makes `ugvr view` skip the exact preview
// and build the store out of core, saying why; the store then appears in the cache.
TEST(CliView, AGridOverTheMemoryBudgetIsBuiltOutOfCoreAndTheViewerSaysWhy) {
  const std::filesystem::path dir = shared().dir / "cli-budget";
  std::filesystem::create_directories(dir);
  const std::string mesh = (dir / "tets.vtu").string();
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + mesh).status, 0);
  for (const std::string& how : std::vector<std::string>{"--memory-budget 100kB", "env"}) {
    SCOPED_TRACE(how);
    const std::string cache = (dir / (how == "env" ? "cache-env" : "cache-flag")).string();
    const std::string log = cache + ".txt";
    const std::string env = how == "env" ? "UGVR_VIEW_MEMORY_BUDGET=100kB " : "";
    const std::string flag = how == "env" ? "" : how;
    const std::string r =
        shell(env + "UGVR_CACHE_DIR=" + cache + " timeout 120 " + std::string(UGVR_BINARY) + " view " + mesh +
              " --size 64 --max-depth 3 " + flag + " > " + log + " 2>&1 & pid=$!; for i in $(seq 1200); do ls " +
              cache + "/tets-*.ugvr >/dev/null 2>&1 && break; sleep 0.1; done; kill -TERM $pid; wait $pid; " +
              "echo rc=$?; cat " + log);
    if (r.find("OpenGL") != std::string::npos && std::getenv("UGVR_NO_GL_TESTS")) GTEST_SKIP() << r;
    EXPECT_NE(r.find("rc=0"), std::string::npos) << r;
    EXPECT_NE(r.find("over the memory budget of 97.7 KiB (" +
                     std::string(how == "env" ? "UGVR_VIEW_MEMORY_BUDGET" : "--memory-budget") + ")"),
              std::string::npos)
        << r;
    EXPECT_NE(r.find(" cells, "), std::string::npos) << "estimated from the header's counts\n" << r;
    EXPECT_NE(r.find("out of core"), std::string::npos) << r;
    size_t stores = 0;
    for (const auto& e : std::filesystem::directory_iterator(cache)) stores += e.path().extension() == ".ugvr";
    EXPECT_EQ(stores, 1u) << r;
  }
  // Within the budget (the default here: half of the machine's memory) the grid is read for the exact preview.
  const std::string fits = test::run_ugvr("view " + mesh + " --memory-budget 10x").out;
  EXPECT_NE(fits.find("--memory-budget"), std::string::npos) << fits;
}

// Out of core, the build's coarse preview (octree/coarse_preview.h: levels 0 .. K) is shown as soon as it is written,
// while the bricks are still being built (the build is held right after the preview), the page saying so; then every
// tab moves to the store once it is done.
TEST(ViewServer, AnOutOfCoreBuildShowsItsCoarsePreviewWhileTheStoreIsBuilt) {
  const std::filesystem::path dir = shared().dir / "coarse-preview";
  std::filesystem::create_directories(dir);
  const std::string mesh = (dir / "wing.vtu").string();
  const std::filesystem::path store = dir / "wing.ugvr";
  std::filesystem::remove(store);
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + mesh).status, 0);
  std::unique_ptr<ViewServer> server;
  BuildGate after_preview;
  {
    ViewServerOptions o;
    o.store = store.string();
    o.out_of_core_input = mesh;
    o.out_of_core_budget = uint64_t(256) << 20;
    o.build = small_build();
    o.build.preview_depth = 2;
    o.build.on_preview = [hold = after_preview.hold()](const std::string&) { hold(); };
    START_VIEW_SERVER(server, o, &after_preview);
  }
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  // Everything up to the first image, which comes while the build is held: from the preview.
  bool said_preview = false;
  std::optional<json> scene;
  std::string image;
  for (int i = 0; i < 400 && image.empty(); ++i) {
    Message m = c.read();
    if (m.binary) {
      image = std::move(m.data);
      break;
    }
    const json j = json::parse(m.data);
    if (j["type"] == "scene") scene = j;
    if (j["type"] == "progress" &&
        j["message"].get<std::string>().find("coarse preview (levels 0\xe2\x80\x93"
                                             "2) while the store is built") != std::string::npos)
      said_preview = true;
  }
  ASSERT_FALSE(image.empty());
  EXPECT_TRUE(is_png(image) || is_jpeg(image));
  ASSERT_TRUE(scene);
  EXPECT_EQ((*scene)["engine"], "lod");
  EXPECT_TRUE(said_preview);
  EXPECT_FALSE(std::filesystem::exists(store)) << "the first image came before the store";
  EXPECT_TRUE(std::filesystem::exists(store.string() + ".preview"));
  // The build goes on: the store's scene follows ("ready"), then its frames; the preview's file is gone.
  after_preview.open();
  const std::optional<json> ready =
      read_text_until(c, [](const json& m) { return m["type"] == "progress" && m["stage"] == "ready"; });
  ASSERT_TRUE(ready);
  EXPECT_TRUE(std::filesystem::exists(store));
  EXPECT_FALSE(std::filesystem::exists(store.string() + ".preview"));
  const Frame f = read_frame(c);  // every tab draws again on the store
  EXPECT_TRUE(is_png(f.bytes) || is_jpeg(f.bytes));
}

// A mesh with enough points gets the point sketch first (octree/point_sketch.h: before any cell is read), the page
// saying it is approximate; then the coarse preview replaces it (a new scene), then the store.
TEST(ViewServer, AnOutOfCoreBuildShowsItsPointSketchThenItsPreview) {
  const std::filesystem::path dir = shared().dir / "point-sketch";
  std::filesystem::create_directories(dir);
  const std::string mesh = (dir / "wing.vtu").string();
  const std::filesystem::path store = dir / "wing.ugvr";
  std::filesystem::remove(store);
  ASSERT_EQ(test::run_ugvr("generate --cells 20000 --kind tet -o " + mesh).status, 0);
  std::unique_ptr<ViewServer> server;
  BuildGate after_sketch, after_preview;
  {
    ViewServerOptions o;
    o.store = store.string();
    o.out_of_core_input = mesh;
    o.out_of_core_budget = uint64_t(256) << 20;
    o.build = small_build();
    o.build.resolution = 5;  // level 1's lattice (9³) has a quarter of the mesh's ~3,400 points at most
    o.build.preview_depth = 2;
    o.build.on_sketch = [hold = after_sketch.hold()](const std::string&, int) { hold(); };
    o.build.on_preview = [hold = after_preview.hold()](const std::string&) { hold(); };
    START_VIEW_SERVER(server, o, &after_sketch, &after_preview);
  }
  Client c(server->port());
  c.send(R"({"type":"hello","width":32,"height":32})");
  bool said_sketch = false;
  std::string image;
  for (int i = 0; i < 400 && image.empty(); ++i) {
    Message m = c.read();
    if (m.binary) {
      image = std::move(m.data);
      break;
    }
    const json j = json::parse(m.data);
    if (j["type"] == "progress" &&
        j["message"].get<std::string>().find("sketch from the mesh's points (levels 0\xe2\x80\x93"
                                             "1, approximate; the coarse preview follows)") != std::string::npos)
      said_sketch = true;
  }
  ASSERT_FALSE(image.empty());
  EXPECT_TRUE(said_sketch);
  EXPECT_FALSE(std::filesystem::exists(store.string() + ".preview")) << "the sketch comes before the cells";
  EXPECT_TRUE(std::filesystem::exists(store.string() + ".sketch"));
  // The build goes on to the preview: a new scene, then its frames, the page saying it shows the preview.
  after_sketch.open();
  const std::optional<json> preview = read_text_until(c, [](const json& m) {
    return m["type"] == "progress" && m["message"].get<std::string>().find(
                                          "coarse preview (levels 0\xe2\x80\x93"
                                          "2) while the store is built") != std::string::npos;
  });
  ASSERT_TRUE(preview);
  EXPECT_TRUE(read_text_until(c, [](const json& m) { return m["type"] == "scene"; }));
  const Frame from_preview = read_frame(c);
  EXPECT_TRUE(is_png(from_preview.bytes) || is_jpeg(from_preview.bytes));
  after_preview.open();
  const std::optional<json> ready =
      read_text_until(c, [](const json& m) { return m["type"] == "progress" && m["stage"] == "ready"; });
  ASSERT_TRUE(ready);
  EXPECT_FALSE(std::filesystem::exists(store.string() + ".sketch")) << "removed when the build ended";
}

}  // namespace
}  // namespace ugvr::view
