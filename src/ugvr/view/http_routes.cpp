#include "ugvr/view/http_routes.h"

#include <chrono>

#include "ugvr/view/security_policy.h"
#include "ugvr/view/web_assets.h"

namespace ugvr::view {

Route route(const RouteRequest& request, std::string_view token) {
  const auto refused = [&] { return refusal(token, request.target, request.host, request.origin); };
  const auto plain = [](unsigned status, std::string body) { return Route{false, status, "text/plain", body}; };
  const std::string_view path = target_path(request.target);
  if (request.upgrade) {
    if (path != "/ws") return plain(404, "not found\n");
    if (const std::string why = refused(); !why.empty()) return plain(403, why + "\n");
    return Route{true, 101, {}, {}};
  }
  if (!request.get_or_head) return plain(405, "only GET\n");
  const std::string_view asset_path = path == "/" ? std::string_view("/index.html") : path;
  for (const WebAsset& a : web_assets()) {
    if (a.path != asset_path) continue;
    // The page itself needs the token; its scripts and style are the same for everyone and hold no data.
    if (a.path == "/index.html")
      if (const std::string why = refused(); !why.empty()) return plain(403, why + "\n");
    return Route{false, 200, a.content_type, std::string(a.body)};
  }
  return plain(404, "not found\n");
}

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = boost::asio::ip::tcp;

std::optional<std::string_view> header(const http::request<http::string_body>& req, http::field field) {
  const auto it = req.find(field);
  if (it == req.end()) return std::nullopt;
  return std::string_view(it->value().data(), it->value().size());
}

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, HttpHost& host) : stream_(std::move(socket)), host_(host) {}

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
    const std::string target(req.target().data(), req.target().size());
    const Route r =
        route({websocket::is_upgrade(req), req.method() == http::verb::get || req.method() == http::verb::head, target,
               header(req, http::field::host), header(req, http::field::origin)},
              host_.token());
    if (!r.websocket) return respond(req, http::status(r.status), r.content_type, r.body);
    std::string why;
    std::optional<TabState> tab = host_.open_tab(why);
    if (!tab) return respond(req, http::status::service_unavailable, "text/plain", why + "\n");
    stream_.expires_never();  // the WebSocket has its own timeouts
    std::make_shared<WsSession>(stream_.release_socket(), host_, std::move(*tab))->run(std::move(req));
  }

  void respond(const http::request<http::string_body>& req, http::status status, std::string_view type,
               std::string body) {
    auto res = std::make_shared<http::response<http::string_body>>(status, req.version());
    res->set(http::field::server, "ugvr view");
    res->set(http::field::content_type, beast::string_view(type.data(), type.size()));
    for (const HeaderField& h : security_headers())
      res->set(beast::string_view(h.name.data(), h.name.size()), beast::string_view(h.value.data(), h.value.size()));
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
  HttpHost& host_;
};

}  // namespace

void serve_http(tcp::socket socket, HttpHost& host) { std::make_shared<HttpSession>(std::move(socket), host)->run(); }

}  // namespace ugvr::view
