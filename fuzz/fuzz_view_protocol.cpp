// libFuzzer target for the viewer's WebSocket protocol: the input is one client message (view_protocol.h). Whatever
// a page or another local process sends must parse or be refused with a ugvr::Error naming the field.
#include <string_view>

#include "ugvr/core/error.h"
#include "ugvr/view/view_protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const ugvr::view::ClientMessage m =
        ugvr::view::parse_client_message(std::string_view(reinterpret_cast<const char*>(data), size));
    volatile size_t sink = m.index();
    (void)sink;
  } catch (const ugvr::Error&) {
    // Refused with a message for the page.
  }
  return 0;
}
