// One viewer tab's WebSocket (view_protocol.h), on the server's I/O thread: reads client messages, validates them and
// hands them to the server (which applies them to the tab's view, view_request.h), and writes what the server sends
// one message at a time, in order.
#pragma once

// clang-format off
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility> (fixed in later Boost).
#include <utility>
#include <boost/asio.hpp>
// clang-format on
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "ugvr/view/frame_scheduler.h"
#include "ugvr/view/view_protocol.h"

namespace ugvr::view {

class WsSession;

// What a tab's socket needs from the server (ViewServer, which takes its lock in each call). Called on the I/O thread.
class TabHost {
 public:
  // The socket is open: the tab joins the round of the render thread.
  virtual void attach(TabState tab, std::weak_ptr<WsSession> socket) = 0;
  // Applies a valid message to the tab's view. Returns the texts to answer with (after hello: the scene and a build's
  // progress). Throws ugvr::Error "FIELD: ..." when the message does not fit the scene (apply_message).
  virtual std::vector<std::string> apply(uint64_t tab, const ClientMessage& message) = 0;
  // The last message of the tab's frame has been written (back-pressure: it may get the next one).
  virtual void frame_delivered(uint64_t tab) = 0;
  // The socket has failed or closed.
  virtual void tab_closed(uint64_t tab) = 0;

 protected:
  ~TabHost() = default;
};

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  // `tab`: the new tab's id and initial view (not yet attached: that happens once the handshake succeeds).
  WsSession(boost::asio::ip::tcp::socket socket, TabHost& host, TabState tab);

  // Completes the upgrade of `request`, then reads messages until the socket closes.
  void run(boost::beast::http::request<boost::beast::http::string_body> request);

  void send_text(std::string text);
  // One frame: its status text, then the image (binary); once the image is written the tab may get its next frame.
  void send_frame(std::string status, std::shared_ptr<const std::string> image);

 private:
  struct Outgoing {
    bool binary = false;
    bool ends_frame = false;  // the last message of a frame: delivering it frees the session for the next one
    std::shared_ptr<const std::string> data;
  };

  void send(Outgoing o);
  void on_accept(boost::beast::error_code ec);
  void read_next();
  void on_read(boost::beast::error_code ec, size_t);
  void reply_error(const std::string& message);
  void write_next();
  void on_write(boost::beast::error_code ec, size_t);

  boost::beast::websocket::stream<boost::beast::tcp_stream> ws_;
  boost::beast::flat_buffer buffer_;
  std::deque<Outgoing> out_;
  size_t out_bytes_ = 0;  // queued in out_
  bool dropped_ = false;  // closed for not reading: nothing more is queued
  TabHost& host_;
  TabState tab_;  // until attached
  const uint64_t id_;
};

// From another thread (the render thread): queued on the I/O thread `ioc`; nothing happens when the tab has gone.
// Empty texts are skipped.
void post_texts(boost::asio::io_context& ioc, std::weak_ptr<WsSession> socket, std::vector<std::string> texts);
void post_frame(boost::asio::io_context& ioc, std::weak_ptr<WsSession> socket, std::string status,
                std::shared_ptr<const std::string> image);

}  // namespace ugvr::view
