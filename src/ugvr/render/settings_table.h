// The engine-independent render options (RenderSettings, include/ugvr/render/render_settings.h) declared once: for
// each field its key in settings_to_json, its `ugvr render` flag (src/cli/render_flags.cpp), its key in the viewer's
// "settings" message (src/ugvr/view/view_protocol.h), the id of the page's control (web/index.html), a one-line
// description and the valid values. The CLI's help and the viewer protocol's ranges are taken from here, and
// tests/test_settings_table.cpp checks every front end against it: a new RenderSettings field needs a row, and the
// row's flag, message key and control must exist, unless the row says why one is deliberately absent.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace ugvr {

// A closed interval [lo, hi] (lo_open: (lo, hi]); hi may be infinite. Only finite values are inside.
struct SettingInterval {
  double lo = 0, hi = 0;
  bool lo_open = false;
  bool contains(double v) const;
  // "[0, 1]", "(0, 1]", "[0, inf)".
  std::string text() const;
};

struct RenderSettingInfo {
  std::string_view key;          // settings_to_json's key
  std::string_view flag;         // the `ugvr render` flag that sets it; empty: see `absent`
  std::string_view message_key;  // its key in the viewer's "settings" message; empty: see `absent`
  std::string_view element_id;   // the id of the page's control (web/index.html); empty: see `absent`
  std::string_view description;  // one line, a sentence fragment starting with a capital ("Opacity of ...")
  std::string_view values;       // the valid values in words, for what `interval` does not say ("" when it does)
  std::optional<SettingInterval> interval;  // numbers (each component of a list): the valid range
  std::string_view absent;                  // why a front end above is deliberately empty; "" when every one is there
};

// Every field of RenderSettings, in settings_to_json's order.
std::span<const RenderSettingInfo> render_setting_table();

// The row of settings_to_json's `key`; throws std::out_of_range when there is none (a programming error).
const RenderSettingInfo& render_setting(std::string_view key);

// The row whose viewer message key is `message_key`, or null.
const RenderSettingInfo* render_setting_for_message(std::string_view message_key);

// The valid values in words: interval->text(), then `values` ("[0, 1]", "(0, 1]; ...").
std::string setting_values_text(const RenderSettingInfo& row);

}  // namespace ugvr
