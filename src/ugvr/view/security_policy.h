// The viewer's security policy (view_server.h, "Security"), as pure functions over a request's target and headers:
// the token, the Host and Origin checks, the tab limit and the headers every response carries. No sockets here: the
// HTTP side (http_routes.h) asks these and answers.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace ugvr::view {

// A fresh random token: 32 hex digits (128 bits).
std::string random_token();

// Value of `key` in the query of `target` ("/ws?token=abc"), empty when absent.
std::string query_param(std::string_view target, std::string_view key);
// `target` without its query ("/ws?token=abc" -> "/ws").
std::string_view target_path(std::string_view target);
// "127.0.0.1:PORT", "localhost:PORT", "[::1]:PORT" (the port is not checked: it is ours, whatever the client typed).
bool loopback_host(std::string_view host);
// Constant-time comparison: the token is a secret.
bool same_token(std::string_view a, std::string_view b);

// Why a request for the page or the socket is refused (empty: allowed). `token`: the server's (empty: none required);
// `target`: the request target with its query; `host`, `origin`: the request's headers of those names, if present.
std::string refusal(std::string_view token, std::string_view target, std::optional<std::string_view> host,
                    std::optional<std::string_view> origin);

// Why one more WebSocket is refused while `open` are open (empty: allowed; HTTP 503 otherwise).
std::string tab_limit_refusal(size_t open, size_t max_tabs);

struct HeaderField {
  std::string_view name, value;
};
// The headers every HTTP response carries: no caching, no MIME sniffing, the Content-Security-Policy, no referrer.
std::span<const HeaderField> security_headers();

}  // namespace ugvr::view
