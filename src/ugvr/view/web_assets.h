// The viewer's web page (web/index.html, app.js, style.css), embedded in the binary at build time by
// cmake/embed_web.cmake so that `ugvr view` needs no files beside it and the page loads nothing from elsewhere.
#pragma once

#include <span>
#include <string_view>

namespace ugvr::view {

struct WebAsset {
  std::string_view path;          // URL path, e.g. "/app.js"
  std::string_view content_type;  // e.g. "text/javascript; charset=utf-8"
  std::string_view body;
};

std::span<const WebAsset> web_assets();

}  // namespace ugvr::view
