// The WebSocket session's last line of defence against a client that never reads (ws_session.cpp): past
// kTabQueueBytes of queued messages the connection is closed, the tab is released, and nothing more is queued. The
// viewer never gets there by itself (frames are back-pressured, equal texts coalesced), so the session is driven
// directly here with distinct large texts, against a reading client as the control.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <string>
#include <thread>

#include "ugvr/view/tab_memory.h"
#include "ugvr/view/ws_session.h"

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using ugvr::view::WsSession;

class RecordingHost : public ugvr::view::TabHost {
 public:
  virtual ~RecordingHost() = default;
  void attach(ugvr::view::TabState, std::weak_ptr<WsSession> socket) override {
    session = socket;
    attached.set_value();
  }
  std::vector<std::string> apply(uint64_t, const ugvr::view::ClientMessage&) override { return {}; }
  void frame_delivered(uint64_t) override {}
  void tab_closed(uint64_t) override { closed = true; }

  std::promise<void> attached;
  std::weak_ptr<WsSession> session;
  std::atomic<bool> closed{false};
};

// One server-side session on an ephemeral port, its I/O thread, and a client socket that has done the handshake.
struct Fixture {
  net::io_context ioc;
  tcp::acceptor acceptor{ioc, {net::ip::make_address("127.0.0.1"), 0}};
  RecordingHost host;
  std::thread io;
  net::io_context client_ioc;
  websocket::stream<tcp::socket> client{client_ioc};

  explicit Fixture(int client_receive_buffer) {
    auto guard = std::make_shared<net::executor_work_guard<net::io_context::executor_type>>(ioc.get_executor());
    acceptor.async_accept([this, guard](beast::error_code ec, tcp::socket socket) {
      ASSERT_FALSE(ec) << ec.message();
      auto buffer = std::make_shared<beast::flat_buffer>();
      auto request = std::make_shared<http::request<http::string_body>>();
      auto s = std::make_shared<tcp::socket>(std::move(socket));
      http::async_read(*s, *buffer, *request, [this, s, request, buffer](beast::error_code ec2, size_t) {
        ASSERT_FALSE(ec2) << ec2.message();
        ugvr::view::TabState tab;
        tab.id = 1;
        std::make_shared<WsSession>(std::move(*s), host, std::move(tab))->run(std::move(*request));
      });
    });
    io = std::thread([this] { ioc.run(); });
    client.next_layer().open(tcp::v4());
    // A small receive window: the kernel's buffers cannot hide a client that does not read.
    if (client_receive_buffer > 0)
      client.next_layer().set_option(net::socket_base::receive_buffer_size(client_receive_buffer));
    client.next_layer().connect(acceptor.local_endpoint());
    client.handshake("127.0.0.1", "/ws");
    host.attached.get_future().wait();
  }
  ~Fixture() {
    beast::error_code ignored;
    client.next_layer().close(ignored);
    ioc.stop();
    io.join();
  }

  // Queues text number `i` of `bytes` bytes on the I/O thread, as the render thread does.
  void send_text(int i, size_t bytes) {
    ugvr::view::post_texts(ioc, host.session, {std::to_string(i) + ":" + std::string(bytes, 'x')});
  }
};

constexpr size_t kMiB = size_t(1) << 20;

TEST(WsSessionBackstop, ClientThatNeverReadsIsDroppedPastTheQueueLimit) {
  Fixture f(4096);
  const int count = int(2 * ugvr::view::kTabQueueBytes / kMiB) + 8;  // twice the limit, in 1 MiB texts
  for (int i = 0; i < count && !f.host.closed; ++i) {
    f.send_text(i, kMiB);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!f.host.closed && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(f.host.closed) << "the session kept queueing for a client that does not read";
  // What the client can still read ends early: the texts past the limit were never queued.
  int received = 0;
  beast::flat_buffer buffer;
  beast::error_code ec;
  while (!ec) {
    f.client.read(buffer, ec);
    if (!ec) ++received;
    buffer.consume(buffer.size());
  }
  EXPECT_LT(received, count);
  EXPECT_GE(received, 1);
}

// The limit is on what waits, not on what passes: a client that keeps up gets twice the limit's bytes.

TEST(WsSessionBackstop, ClientThatReadsGetsEveryMessage) {
  Fixture f(0);
  const int count = int(2 * ugvr::view::kTabQueueBytes / kMiB) + 8;
  int received = 0;
  beast::flat_buffer buffer;
  for (; received < count; ++received) {
    f.send_text(received, kMiB);
    f.client.read(buffer);
    const std::string text = beast::buffers_to_string(buffer.data());
    ASSERT_EQ(text.substr(0, text.find(':')), std::to_string(received)) << "messages out of order";
    buffer.consume(buffer.size());
  }
  EXPECT_EQ(received, count);
  EXPECT_FALSE(f.host.closed);
}

}  // namespace
