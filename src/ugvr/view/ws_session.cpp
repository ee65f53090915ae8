#include "ugvr/view/ws_session.h"

#include "ugvr/core/error.h"
#include "ugvr/view/tab_memory.h"

namespace ugvr::view {
namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;

// Past the protocol's 64 KiB limit a message still gets an error reply; this one closes the socket (no unbounded
// buffering of what a client sends).
constexpr size_t kHardMessageLimit = 1 << 20;
// Error replies a client has not read yet: past this, further ones are dropped (a client flooding bad messages
// without reading must not grow the server's memory).
constexpr size_t kMaxQueuedReplies = 64;
// Bytes queued for a client that does not read (frames are sent one at a time, texts coalesced): past this the
// client is dropped rather than letting the server's memory grow. Charged to the tab (tab_memory.h).
constexpr size_t kMaxQueuedBytes = kTabQueueBytes;

}  // namespace

WsSession::WsSession(net::ip::tcp::socket socket, TabHost& host, TabState tab)
    : ws_(std::move(socket)), host_(host), tab_(std::move(tab)), id_(tab_.id) {}

void WsSession::run(beast::http::request<beast::http::string_body> request) {
  ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
  ws_.read_message_max(kHardMessageLimit);
  ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
}

void WsSession::send_text(std::string text) {
  send({false, false, std::make_shared<const std::string>(std::move(text))});
}

void WsSession::send_frame(std::string status, std::shared_ptr<const std::string> image) {
  send({false, false, std::make_shared<const std::string>(std::move(status))});
  send({true, true, std::move(image)});
}

void WsSession::send(Outgoing o) {
  if (dropped_) return;
  // A text equal to one still waiting (not the one being written: its buffer is in use) is already on its way: a
  // client repeating hello without reading gets one scene message, not one per hello.
  if (!o.binary && !o.ends_frame)
    for (size_t i = 1; i < out_.size(); ++i)
      if (!out_[i].binary && *out_[i].data == *o.data) return;
  if (out_bytes_ + o.data->size() > kMaxQueuedBytes) {
    // The client does not read: close the connection (the pending read and write then fail and the tab closes).
    dropped_ = true;
    while (out_.size() > 1) out_.pop_back();  // the front one's buffer belongs to the write in progress
    out_bytes_ = out_.empty() ? 0 : out_.front().data->size();
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(net::ip::tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
    return;
  }
  out_bytes_ += o.data->size();
  out_.push_back(std::move(o));
  if (out_.size() == 1) write_next();
}

void WsSession::on_accept(beast::error_code ec) {
  if (ec) {
    host_.tab_closed(id_);  // releases the tab's reservation (ViewServer counts tabs being opened too)
    return;
  }
  host_.attach(std::move(tab_), weak_from_this());
  read_next();
}

void WsSession::read_next() {
  ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
}

void WsSession::on_read(beast::error_code ec, size_t) {
  if (ec) {
    host_.tab_closed(id_);
    return;
  }
  if (!ws_.got_text()) {
    reply_error("message: binary messages are not accepted");
  } else {
    const std::string text = beast::buffers_to_string(buffer_.data());
    try {
      const ClientMessage m = parse_client_message(text);
      for (std::string& reply : host_.apply(id_, m)) send_text(std::move(reply));
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

void WsSession::reply_error(const std::string& message) {
  if (out_.size() < kMaxQueuedReplies) send_text(error_message(message));
}

void WsSession::write_next() {
  const Outgoing& o = out_.front();
  ws_.binary(o.binary);
  ws_.async_write(net::buffer(*o.data), beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
}

void WsSession::on_write(beast::error_code ec, size_t) {
  if (ec) {
    host_.tab_closed(id_);
    return;
  }
  const bool frame_done = out_.front().ends_frame;
  out_bytes_ -= out_.front().data->size();
  out_.pop_front();
  if (frame_done) host_.frame_delivered(id_);
  if (!out_.empty()) write_next();
}

void post_texts(net::io_context& ioc, std::weak_ptr<WsSession> socket, std::vector<std::string> texts) {
  net::post(ioc, [socket = std::move(socket), texts = std::move(texts)] {
    if (const std::shared_ptr<WsSession> ws = socket.lock())
      for (const std::string& t : texts)
        if (!t.empty()) ws->send_text(t);
  });
}

void post_frame(net::io_context& ioc, std::weak_ptr<WsSession> socket, std::string status,
                std::shared_ptr<const std::string> image) {
  net::post(ioc, [socket = std::move(socket), status = std::move(status), image = std::move(image)]() mutable {
    if (const std::shared_ptr<WsSession> ws = socket.lock()) ws->send_frame(std::move(status), std::move(image));
  });
}

}  // namespace ugvr::view
