// The viewer's security policy and HTTP routing (src/ugvr/view/security_policy.h, http_routes.h) as pure functions:
// token, Host and Origin checks, the tab limit, the headers of every response, and which request gets what. The same
// over real sockets: test_view_server.cpp.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <string_view>

#include "ugvr/view/http_routes.h"
#include "ugvr/view/security_policy.h"

namespace ugvr::view {
namespace {

TEST(ViewSecurity, QueryAndPath) {
  EXPECT_EQ(query_param("/ws?token=abc", "token"), "abc");
  EXPECT_EQ(query_param("/?a=1&token=x2&b", "token"), "x2");
  EXPECT_EQ(query_param("/?tokens=1&token", "token"), "");
  EXPECT_EQ(query_param("/ws", "token"), "");
  EXPECT_EQ(target_path("/ws?token=abc"), "/ws");
  EXPECT_EQ(target_path("/app.js"), "/app.js");
}

TEST(ViewSecurity, LoopbackHostsAndTokens) {
  for (const char* h : {"127.0.0.1:8080", "localhost:1", "localhost", "[::1]:9", "[::1]"})
    EXPECT_TRUE(loopback_host(h)) << h;
  for (const char* h : {"evil.example:8080", "127.0.0.2:1", "[::1]x", "localhost.evil:1", ""})
    EXPECT_FALSE(loopback_host(h)) << h;
  EXPECT_TRUE(same_token("abc", "abc"));
  EXPECT_FALSE(same_token("abc", "abd"));
  EXPECT_FALSE(same_token("abc", "abcd"));
  const std::string t = random_token();
  EXPECT_EQ(t.size(), 32u);
  EXPECT_EQ(t.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_NE(t, random_token());
}

TEST(ViewSecurity, Refusals) {
  const std::optional<std::string_view> none;
  // No token: a loopback Host, and an Origin (when sent) that is this host's own page.
  EXPECT_EQ(refusal("", "/", "127.0.0.1:80", none), "");
  EXPECT_EQ(refusal("", "/ws", "127.0.0.1:80", "http://127.0.0.1:80"), "");
  EXPECT_NE(refusal("", "/", "rebound.example:80", none).find("127.0.0.1"), std::string::npos);  // DNS rebinding
  EXPECT_NE(refusal("", "/", none, none), "");
  EXPECT_EQ(refusal("", "/ws", "127.0.0.1:80", "http://evil.example"), "forbidden: cross-origin WebSocket");
  // A token: required, whatever the Host; the Origin is still checked.
  EXPECT_NE(refusal("secret", "/", "10.0.0.1:80", none).find("token"), std::string::npos);
  EXPECT_NE(refusal("secret", "/?token=wrong", "10.0.0.1:80", none), "");
  EXPECT_EQ(refusal("secret", "/?token=secret", "10.0.0.1:80", none), "");
  EXPECT_EQ(refusal("secret", "/ws?token=secret", "10.0.0.1:80", "http://10.0.0.1:80"), "");
  EXPECT_EQ(refusal("secret", "/ws?token=secret", "10.0.0.1:80", "http://evil.example"),
            "forbidden: cross-origin WebSocket");
  EXPECT_EQ(refusal("secret", "/ws?token=secret", none, "http://10.0.0.1:80"), "forbidden: cross-origin WebSocket");
  // The tab limit.
  EXPECT_EQ(tab_limit_refusal(15, 16), "");
  EXPECT_EQ(tab_limit_refusal(16, 16), "too many viewer tabs are open (16)");
}

TEST(ViewSecurity, EveryResponseCarriesThePolicyHeaders) {
  std::string csp, referrer, nosniff, cache;
  for (const HeaderField& h : security_headers()) {
    if (h.name == "Content-Security-Policy") csp = h.value;
    if (h.name == "Referrer-Policy") referrer = h.value;
    if (h.name == "X-Content-Type-Options") nosniff = h.value;
    if (h.name == "Cache-Control") cache = h.value;
  }
  EXPECT_EQ(csp,
            "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; style-src 'self'; script-src 'self'; "
            "frame-ancestors 'none'");
  EXPECT_EQ(referrer, "no-referrer");
  EXPECT_EQ(nosniff, "nosniff");
  EXPECT_EQ(cache, "no-store");
}

TEST(ViewSecurity, Routes) {
  const auto get = [](std::string_view target, std::string_view token = "") {
    return route({false, true, target, "127.0.0.1:1", std::nullopt}, token);
  };
  const Route page = get("/");
  EXPECT_FALSE(page.websocket);
  EXPECT_EQ(page.status, 200u);
  EXPECT_NE(page.content_type.find("text/html"), std::string_view::npos);
  EXPECT_EQ(get("/index.html").body, page.body);
  EXPECT_EQ(get("/app.js").status, 200u);
  EXPECT_EQ(get("/style.css").status, 200u);
  EXPECT_EQ(get("/nothing").status, 404u);
  EXPECT_EQ(get("/ws").status, 404u);  // not an upgrade
  // With a token the page needs it, its scripts and style do not (they hold no data).
  EXPECT_EQ(get("/", "t0k").status, 403u);
  EXPECT_EQ(get("/?token=t0k", "t0k").status, 200u);
  EXPECT_EQ(get("/app.js", "t0k").status, 200u);
  // Only GET (and HEAD).
  EXPECT_EQ(route({false, false, "/", "127.0.0.1:1", std::nullopt}, "").status, 405u);
  // The upgrade: only /ws, with the same checks as the page.
  EXPECT_TRUE(route({true, true, "/ws", "127.0.0.1:1", "http://127.0.0.1:1"}, "").websocket);
  EXPECT_TRUE(route({true, true, "/ws?token=t0k", "127.0.0.1:1", std::nullopt}, "t0k").websocket);
  const Route other = route({true, true, "/socket", "127.0.0.1:1", std::nullopt}, "");
  EXPECT_FALSE(other.websocket);
  EXPECT_EQ(other.status, 404u);
  const Route cross = route({true, true, "/ws", "127.0.0.1:1", "http://evil.example"}, "");
  EXPECT_FALSE(cross.websocket);
  EXPECT_EQ(cross.status, 403u);
  EXPECT_EQ(cross.body, "forbidden: cross-origin WebSocket\n");
  EXPECT_EQ(route({true, true, "/ws", "127.0.0.1:1", std::nullopt}, "t0k").status, 403u);
}

}  // namespace
}  // namespace ugvr::view
