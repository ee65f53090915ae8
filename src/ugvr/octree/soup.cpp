#include "ugvr/octree/soup.h"

#include <cerrno>
#include <cstring>

#include "ugvr/core/error.h"

namespace ugvr {
namespace {

constexpr size_t kBufferBytes = size_t(1) << 20;
// The largest record: 8 vertices, 1024 scalars (the store's limit) at each.
constexpr size_t kMaxRecordBytes = 16 + 16 * 8 + 4 * 8 * 1024;

[[noreturn]] void fail_io(const std::string& path, const char* what) {
  fail_in(path, std::string(what) + ": " + std::strerror(errno));
}

}  // namespace

SoupFile::SoupFile(std::string path, const SoupLayout& layout, const char* mode, const char* what)
    : path_(std::move(path)), layout_(layout) {
  file_ = std::fopen(path_.c_str(), mode);
  if (!file_) fail_io(path_, what);
}

SoupFile::~SoupFile() {
  if (file_) std::fclose(file_);
}

SoupWriter::SoupWriter(std::string path, const SoupLayout& layout)
    : SoupFile(std::move(path), layout, "wb", "cannot create the temporary cell file") {
  buffer_.reserve(kBufferBytes + kMaxRecordBytes);  // flushed past kBufferBytes: never reallocated
}

void SoupWriter::write(const void* data, size_t n) {
  const auto* b = static_cast<const std::byte*>(data);
  buffer_.insert(buffer_.end(), b, b + n);
  bytes_ += n;
}

void SoupWriter::flush() {
  if (buffer_.empty()) return;
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size()) {
    fail_io(path_, "cannot write the temporary cell file");
  }
  buffer_.clear();
}

void SoupWriter::add(uint64_t id, CellType type, int n, const uint32_t* vertices, const Vec3f* positions,
                     const float* vertex_values, const float* cell_values) {
  std::byte header[16] = {};
  std::memcpy(header, &id, 8);
  header[8] = std::byte(uint8_t(type));
  header[9] = std::byte(uint8_t(n));
  write(header, 16);
  write(vertices, 4 * size_t(n));
  write(positions, 12 * size_t(n));
  write(vertex_values, 4 * size_t(layout_.vertex_fields) * size_t(n));
  write(cell_values, 4 * size_t(layout_.cell_fields));
  ++records_;
  if (buffer_.size() >= kBufferBytes) flush();
}

void SoupWriter::add(const SoupCell& cell) {
  write(cell.data(), cell.bytes());
  ++records_;
  if (buffer_.size() >= kBufferBytes) flush();
}

void SoupWriter::close() {
  if (!file_) return;
  flush();
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) fail_io(path_, "cannot close the temporary cell file");
}

SoupReader::SoupReader(std::string path, const SoupLayout& layout)
    : SoupFile(std::move(path), layout, "rb", "cannot open the temporary cell file") {
  buffer_.resize(kBufferBytes);
}

bool SoupReader::fill(size_t need) {
  if (end_ - begin_ >= need) return true;
  std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
  end_ -= begin_;
  begin_ = 0;
  while (end_ < need && !eof_) {
    const size_t got = std::fread(buffer_.data() + end_, 1, buffer_.size() - end_, file_);
    if (got == 0) {
      if (std::ferror(file_)) fail_io(path_, "cannot read the temporary cell file");
      eof_ = true;
    }
    end_ += got;
  }
  return end_ >= need;
}

bool SoupReader::next(const std::byte*& record) {
  if (!fill(16)) {
    if (end_ != begin_) fail_in(path_, "temporary cell file ends inside a record");
    return false;
  }
  const int n = int(uint8_t(buffer_[begin_ + 9]));
  const size_t size = layout_.record_bytes(n);
  if (!fill(size)) fail_in(path_, "temporary cell file ends inside a record");
  record = buffer_.data() + begin_;
  begin_ += size;
  return true;
}

}  // namespace ugvr
