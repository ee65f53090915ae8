#include "ugvr/octree/leaf_points.h"

#include <algorithm>
#include <cstring>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr {
namespace {

constexpr size_t kBufferBytes = size_t(1) << 20;  // read 1 MiB at a time

size_t point_bytes(uint32_t field_count) { return 3 * sizeof(double) + size_t(field_count) * sizeof(float); }

}  // namespace

LeafPointWriter::LeafPointWriter(std::string path, uint32_t field_count)
    : file_(std::move(path), "temporary point file"), field_count_(field_count) {}

void LeafPointWriter::add(Vec3d position, const float* values) {
  const double xyz[3] = {position.x, position.y, position.z};
  file_.append(xyz, sizeof xyz);
  file_.append(values, size_t(field_count_) * sizeof(float));
  ++points_;
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
