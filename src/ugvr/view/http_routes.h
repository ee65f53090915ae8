// The viewer's HTTP side (view_server.h): GET / (index.html), /app.js, /style.css from the embedded page
// (web_assets.h), and GET /ws, the upgrade to a tab's WebSocket (ws_session.h), each checked by security_policy.h.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "ugvr/view/ws_session.h"

namespace ugvr::view {

// What the server needs to know of one HTTP request to route it.
struct RouteRequest {
  bool upgrade = false;                          // a WebSocket upgrade
  bool get_or_head = true;                       // the method is GET or HEAD
  std::string_view target;                       // with its query ("/ws?token=...")
  std::optional<std::string_view> host, origin;  // those headers, if present
};

// The answer: an HTTP response, or (websocket) the upgrade to a tab's socket, still subject to the tab limit.
struct Route {
  bool websocket = false;
  unsigned status = 200;
  std::string_view content_type;
  std::string body;
};

// Routes a request (pure: the page and its assets, the /ws upgrade, refusals). `token`: the server's (empty: none).
Route route(const RouteRequest& request, std::string_view token);

// What the HTTP side needs from the server beyond a tab's socket (ViewServer, which takes its lock).
class HttpHost : public TabHost {
 public:
  // The token the page and the socket need (empty: none).
  virtual const std::string& token() const = 0;
  // A new tab (its id, and the scene's initial view), or nullopt with `why` when too many are open.
  virtual std::optional<TabState> open_tab(std::string& why) = 0;

 protected:
  ~HttpHost() = default;
};

// Serves one accepted connection on the I/O thread until it closes, or hands it to a WsSession once it upgrades.
void serve_http(boost::asio::ip::tcp::socket socket, HttpHost& host);

}  // namespace ugvr::view
