#include "ugvr/octree/leaf_points.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr {
namespace {

constexpr size_t kBufferBytes = size_t(1) << 20;  // written and read 1 MiB at a time

[[noreturn]] void fail_io(const std::string& path, const char* what) {
  fail_in(path, std::string(what) + ": " + std::strerror(errno));
}

size_t point_bytes(uint32_t field_count) { return 3 * sizeof(double) + size_t(field_count) * sizeof(float); }

}  // namespace

LeafPointWriter::LeafPointWriter(std::string path, uint32_t field_count)
    : path_(std::move(path)), field_count_(field_count) {
  file_ = std::fopen(path_.c_str(), "wb");
  if (!file_) fail_io(path_, "cannot create the temporary point file");
  buffer_.reserve(kBufferBytes + point_bytes(field_count));
}

LeafPointWriter::~LeafPointWriter() {
  if (file_) std::fclose(file_);
}

void LeafPointWriter::add(Vec3d position, const float* values) {
  const double xyz[3] = {position.x, position.y, position.z};
  const auto* p = reinterpret_cast<const std::byte*>(xyz);
  buffer_.insert(buffer_.end(), p, p + sizeof xyz);
  const auto* v = reinterpret_cast<const std::byte*>(values);
  buffer_.insert(buffer_.end(), v, v + size_t(field_count_) * sizeof(float));
  ++points_;
  if (buffer_.size() >= kBufferBytes) flush();
}

void LeafPointWriter::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    fail_io(path_, "cannot write the temporary point file");
  buffer_.clear();
}

void LeafPointWriter::close() {
  if (!file_) return;
  flush();
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) fail_io(path_, "cannot close the temporary point file");
}

void for_each_leaf_point(const std::string& path, uint32_t field_count,
                         const std::function<void(Vec3d, const float*)>& f) {
  const InputFile file(path);
  const size_t bytes = point_bytes(field_count);
  if (file.size() % bytes != 0)
    fail_in(path, "the temporary point file holds " + std::to_string(file.size()) + " bytes, not whole points of " +
                      std::to_string(bytes));
  const size_t per_read = std::max<size_t>(1, kBufferBytes / bytes);
  std::vector<std::byte> buffer(per_read * bytes);
  std::vector<float> values(field_count);
  for (uint64_t at = 0; at < file.size();) {
    const size_t n = size_t(std::min<uint64_t>(buffer.size(), file.size() - at));
    file.read_at(at, buffer.data(), n);
    for (size_t off = 0; off < n; off += bytes) {
      double xyz[3];
      std::memcpy(xyz, buffer.data() + off, sizeof xyz);
      std::memcpy(values.data(), buffer.data() + off + sizeof xyz, size_t(field_count) * sizeof(float));
      f(Vec3d{xyz[0], xyz[1], xyz[2]}, values.data());
    }
    at += n;
  }
}

}  // namespace ugvr
