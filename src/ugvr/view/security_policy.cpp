#include "ugvr/view/security_policy.h"

#include <cstdio>
#include <random>

namespace ugvr::view {

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

std::string_view target_path(std::string_view target) { return target.substr(0, target.find('?')); }

bool loopback_host(std::string_view host) {
  if (host.starts_with("[::1]")) return host.size() == 5 || host[5] == ':';
  const std::string_view name = host.substr(0, host.find(':'));
  return name == "localhost" || name == "127.0.0.1";
}

bool same_token(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char d = 0;
  for (size_t i = 0; i < a.size(); ++i) d |= static_cast<unsigned char>(a[i] ^ b[i]);
  return d == 0;
}

std::string refusal(std::string_view token, std::string_view target, std::optional<std::string_view> host,
                    std::optional<std::string_view> origin) {
  if (!token.empty() && !same_token(query_param(target, "token"), token))
    return "forbidden: the URL needs the token that `ugvr view` printed";
  // Without a token, only a loopback name may address us: a web page whose own host name is made to resolve to
  // 127.0.0.1 (DNS rebinding) would otherwise count as same-origin below.
  if (token.empty() && (!host || !loopback_host(*host)))
    return "forbidden: address the viewer as 127.0.0.1, localhost or [::1]";
  // A page from another origin may open a WebSocket to localhost (browsers allow it): only our own page may.
  if (origin) {
    if (!host || *origin != "http://" + std::string(*host)) return "forbidden: cross-origin WebSocket";
  }
  return {};
}

std::string tab_limit_refusal(size_t open, size_t max_tabs) {
  if (open < max_tabs) return {};
  return "too many viewer tabs are open (" + std::to_string(max_tabs) + ")";
}

std::span<const HeaderField> security_headers() {
  static constexpr HeaderField kHeaders[] = {
      {"Cache-Control", "no-store"},
      {"X-Content-Type-Options", "nosniff"},
      // The page runs only its own code and talks only to this server; no other site may frame it.
      {"Content-Security-Policy",
       "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; style-src 'self'; script-src 'self'; "
       "frame-ancestors 'none'"},
      {"Referrer-Policy", "no-referrer"},  // the token in the URL goes nowhere else
  };
  return kHeaders;
}

}  // namespace ugvr::view
