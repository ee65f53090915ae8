#include "ugvr/io/vtk_xml_skeleton.h"

#include <algorithm>
#include <cstring>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

constexpr size_t kChunk = size_t(1) << 20;
// The first read: the whole markup of an appended file (its header before <AppendedData>) in most files, without
// reading into the data after it, which a time step's fields-only read (io/step_fields.h) mostly skips.
constexpr size_t kFirstChunk = size_t(64) << 10;
constexpr size_t kMaxMarkup = size_t(64) << 20;
constexpr size_t kMaxTag = size_t(1) << 20;
constexpr size_t kMaxDepth = 256;

bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

// Sequential reader over the file with a chunk buffer, growing from kFirstChunk to kChunk; get() returns -1 at the end
// of the file.
class Cursor {
 public:
  explicit Cursor(const InputFile& file)
      : file_(file), buf_(size_t(std::clamp<uint64_t>(file.size(), 1, kFirstChunk))) {}

  uint64_t offset() const { return start_ + pos_; }
  int get() {
    if (pos_ == len_ && !refill()) return -1;
    return static_cast<unsigned char>(buf_[pos_++]);
  }
  int peek() {
    if (pos_ == len_ && !refill()) return -1;
    return static_cast<unsigned char>(buf_[pos_]);
  }
  // Advances to the next '<' (or the end of the file). Returns whether the skipped text has a non-blank character.
  bool skip_text() {
    bool nonblank = false;
    while (pos_ < len_ || refill()) {
      const char* begin = buf_.data() + pos_;
      const char* end = buf_.data() + len_;
      const char* lt = static_cast<const char*>(std::memchr(begin, '<', size_t(end - begin)));
      const char* stop = lt ? lt : end;
      if (!nonblank) nonblank = std::any_of(begin, stop, [](char c) { return !is_space(c); });
      pos_ = size_t(stop - buf_.data());
      if (lt) return nonblank;
    }
    return nonblank;
  }

 private:
  bool refill() {
    start_ += len_;
    pos_ = 0;
    if (len_ == buf_.size() && buf_.size() < kChunk) buf_.resize(std::min(buf_.size() * 2, kChunk));
    len_ = file_.read_some_at(start_, buf_.data(), buf_.size());
    return len_ > 0;
  }

  const InputFile& file_;
  std::vector<char> buf_;
  uint64_t start_ = 0;
  size_t pos_ = 0, len_ = 0;
};

class Scanner {
 public:
  explicit Scanner(const InputFile& file) : file_(file), cur_(file) {}

  XmlSkeleton run() {
    while (true) {
      const uint64_t text_start = cur_.offset();
      const bool nonblank = cur_.skip_text();
      const uint64_t text_end = cur_.offset();
      if (nonblank && !stack_.empty()) {
        emit(text_start, "<?" + std::string(kXmlTextMarker) + " " + std::to_string(text_start) + " " +
                             std::to_string(text_end - text_start) + "?>");
      }
      if (cur_.get() < 0) break;  // end of file
      if (!markup_item(text_end)) break;
    }
    if (!stack_.empty()) {
      fail_at_offset(file_.path(), cur_.offset(),
                     "unexpected end of file: <" + stack_.back().first + "> (opened at byte " +
                         std::to_string(stack_.back().second) + ") is not closed");
    }
    if (!seen_root_) fail_in(file_.path(), "no XML element found: not a VTK XML file");
    return std::move(out_);
  }

 private:
  // Handles what follows a '<' at `at`; returns false when scanning is complete.
  bool markup_item(uint64_t at) {
    const int c = cur_.peek();
    if (c == '?') {
      skip_until(at, "?>", "processing instruction");
      return true;
    }
    if (c == '!') {
      declaration(at);
      return true;
    }
    if (c == '/') return end_tag(at);
    return start_tag(at);
  }

  // After "<!": a comment (skipped), a DOCTYPE-like declaration (skipped), or CDATA (refused: VTK writes none, and
  // array text inside it would need unescaping rules of its own).
  void declaration(uint64_t at) {
    cur_.get();  // '!'
    if (cur_.peek() == '-') {
      cur_.get();
      if (cur_.get() != '-') fail_at_offset(file_.path(), at, "malformed comment: expected <!--");
      skip_until(at, "-->", "comment");
      return;
    }
    if (cur_.peek() == '[') fail_at_offset(file_.path(), at, "CDATA sections are not supported in VTK XML files");
    int depth = 0;  // an internal DTD subset in [ ] may contain '>'
    while (true) {
      const int ch = cur_.get();
      if (ch < 0) fail_at_offset(file_.path(), at, "unterminated <! declaration");
      if (ch == '[') ++depth;
      if (ch == ']') --depth;
      if (ch == '>' && depth <= 0) return;
    }
  }

  // Skips to just after `terminator`.
  void skip_until(uint64_t at, std::string_view terminator, std::string_view what) {
    std::string tail;
    while (!tail.ends_with(terminator)) {
      const int ch = cur_.get();
      if (ch < 0) fail_at_offset(file_.path(), at, "unterminated " + std::string(what));
      tail += char(ch);
      if (tail.size() > 8) tail.erase(0, tail.size() - 4);
    }
  }

  // Reads the rest of a tag after '<' up to and including '>', honouring quoted attribute values.
  std::string read_tag(uint64_t at) {
    std::string tag = "<";
    char quote = 0;
    while (true) {
      const int ch = cur_.get();
      if (ch < 0) fail_at_offset(file_.path(), at, "unterminated tag " + tag.substr(0, 40));
      if (ch == 0) fail_at_offset(file_.path(), cur_.offset() - 1, "NUL byte inside a tag");
      tag += char(ch);
      if (tag.size() > kMaxTag) fail_at_offset(file_.path(), at, "tag longer than 1 MiB");
      if (quote) {
        if (ch == quote) quote = 0;
      } else if (ch == '"' || ch == '\'') {
        quote = char(ch);
      } else if (ch == '>') {
        return tag;
      }
    }
  }

  static std::string tag_name(std::string_view tag, size_t from) {
    size_t end = from;
    while (end < tag.size() && !is_space(tag[end]) && tag[end] != '/' && tag[end] != '>') ++end;
    return std::string(tag.substr(from, end - from));
  }

  bool start_tag(uint64_t at) {
    if (seen_root_ && stack_.empty()) return false;  // trailing content after the root element
    const std::string tag = read_tag(at);
    const std::string name = tag_name(tag, 1);
    if (name.empty()) fail_at_offset(file_.path(), at, "malformed tag " + tag.substr(0, 40));
    const bool self_closing = tag.size() >= 2 && tag[tag.size() - 2] == '/';
    seen_root_ = true;
    emit(at, tag);
    if (self_closing) return !stack_.empty();
    if (stack_.size() >= kMaxDepth) fail_at_offset(file_.path(), at, "elements nested deeper than 256 levels");
    stack_.emplace_back(name, at);
    if (name == "AppendedData") {
      appended(at);
      return false;
    }
    return true;
  }

  bool end_tag(uint64_t at) {
    const std::string tag = read_tag(at);
    const std::string name = tag_name(tag, 2);
    if (stack_.empty() || stack_.back().first != name) {
      fail_at_offset(file_.path(), at,
                     "end tag </" + name + "> does not match " +
                         (stack_.empty() ? std::string("any open element")
                                         : "<" + stack_.back().first + "> opened at byte " +
                                               std::to_string(stack_.back().second)));
    }
    emit(at, "</" + name + ">");
    stack_.pop_back();
    return !stack_.empty();
  }

  // After <AppendedData ...>: blanks, then '_', then the data, which is not XML and is never scanned.
  void appended(uint64_t at) {
    int ch = cur_.get();
    while (ch >= 0 && is_space(char(ch))) ch = cur_.get();
    if (ch != '_') {
      fail_at_offset(file_.path(), ch < 0 ? cur_.offset() : cur_.offset() - 1,
                     "expected '_' to start the data of <AppendedData> (opened at byte " + std::to_string(at) + ")");
    }
    out_.appended_data = cur_.offset();
    while (!stack_.empty()) {
      emit(cur_.offset(), "</" + stack_.back().first + ">");
      stack_.pop_back();
    }
  }

  void emit(uint64_t file_offset, std::string_view text) {
    if (out_.markup.size() + text.size() > kMaxMarkup) {
      fail_at_offset(file_.path(), file_offset, "XML markup larger than 64 MiB; not a plausible VTK XML header");
    }
    out_.origins.emplace_back(out_.markup.size(), file_offset);
    out_.markup += text;
  }

  const InputFile& file_;
  Cursor cur_;
  XmlSkeleton out_;
  std::vector<std::pair<std::string, uint64_t>> stack_;  // open elements: name, file offset
  bool seen_root_ = false;
};

}  // namespace

uint64_t XmlSkeleton::file_offset(uint64_t markup_offset) const {
  auto it = std::upper_bound(origins.begin(), origins.end(), std::pair<uint64_t, uint64_t>(markup_offset, UINT64_MAX));
  if (it == origins.begin()) return 0;
  --it;
  return it->second;
}

XmlSkeleton scan_xml_skeleton(const InputFile& file) { return Scanner(file).run(); }

}  // namespace ugvr
