#include "ugvr/render/lod/brick_atlas.h"

#include <algorithm>
#include <cmath>

#include "ugvr/core/error.h"
#include "ugvr/store/brick_pad.h"

namespace ugvr {

void make_atlas_slot(uint32_t resolution, float* samples, const uint8_t* mask, double lo, double hi,
                     std::vector<uint16_t>& texels) {
  const int r = int(resolution), s = r + 2;
  pad_brick(resolution, 1, samples, mask);
  texels.resize(size_t(s) * s * s * 2);
  const double scale = hi > lo ? 65535.0 / (hi - lo) : 0.0;
  for (int z = 0; z < s; ++z) {
    const int sz = std::clamp(z - 1, 0, r - 1);
    for (int y = 0; y < s; ++y) {
      const int sy = std::clamp(y - 1, 0, r - 1);
      uint16_t* out = texels.data() + (size_t(z) * s + y) * s * 2;
      const size_t row = (size_t(sz) * r + sy) * r;
      for (int x = 0; x < s; ++x) {
        const size_t i = row + size_t(std::clamp(x - 1, 0, r - 1));
        const double v = samples[i];
        const double code = std::isfinite(v) ? std::clamp(std::round((v - lo) * scale), 0.0, 65535.0) : 0.0;
        out[2 * x] = uint16_t(code);
        out[2 * x + 1] = mask[i] ? 65535 : 0;
      }
    }
  }
}

uint64_t BrickAtlas::max_slots(uint32_t resolution, int max_3d) {
  const uint64_t per_axis = uint64_t(max_3d) / (resolution + 2);
  return per_axis * per_axis * per_axis;
}

BrickAtlas::BrickAtlas(uint32_t resolution, uint64_t slots, int max_3d) : resolution_(resolution) {
  const int side = int(resolution) + 2;
  const int per_axis = max_3d / side;
  if (per_axis < 1) fail_in("brick atlas", "bricks of " + std::to_string(resolution) + "³ do not fit a 3D texture");
  slots = std::max<uint64_t>(slots, 1);
  if (slots > max_slots(resolution, max_3d))
    fail_in("brick atlas", std::to_string(slots) + " bricks exceed the largest 3D texture (" +
                               std::to_string(max_slots(resolution, max_3d)) + " slots)");
  // As close to a cube as the count allows: x first, then y, then z.
  int n = int(std::ceil(std::cbrt(double(slots))));
  n = std::min(n, per_axis);
  slots_[0] = n;
  slots_[1] = int(std::min<uint64_t>(per_axis, (slots + n - 1) / n));
  slots_[1] = std::min(slots_[1], n);
  slots_[2] = int((slots + uint64_t(slots_[0]) * slots_[1] - 1) / (uint64_t(slots_[0]) * slots_[1]));
  if (slots_[2] > per_axis) {  // a flat count: widen y
    slots_[1] = per_axis;
    slots_[2] = int((slots + uint64_t(slots_[0]) * slots_[1] - 1) / (uint64_t(slots_[0]) * slots_[1]));
  }
  for (int a = 0; a < 3; ++a) texels_[a] = slots_[a] * side;
  texture_ = GlTexture(GL_TEXTURE_3D);
  glTextureStorage3D(texture_.id(), 1, GL_RG16, texels_[0], texels_[1], texels_[2]);
  check_gl("allocating the brick atlas");
  glTextureParameteri(texture_.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(texture_.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
    glTextureParameteri(texture_.id(), w, GL_CLAMP_TO_EDGE);
}

uint64_t BrickAtlas::bytes() const { return uint64_t(texels_[0]) * texels_[1] * texels_[2] * 4; }

void BrickAtlas::upload(uint64_t slot, const uint16_t* texels) {
  const int side = int(resolution_) + 2;
  const int x = int(slot % uint64_t(slots_[0])), y = int((slot / uint64_t(slots_[0])) % uint64_t(slots_[1]));
  const int z = int(slot / (uint64_t(slots_[0]) * slots_[1]));
  glTextureSubImage3D(texture_.id(), 0, x * side, y * side, z * side, side, side, side, GL_RG, GL_UNSIGNED_SHORT,
                      texels);
}

}  // namespace ugvr
