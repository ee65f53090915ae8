#include "ugvr/render/lod/brick_atlas.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

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

uint16_t cubic_margin_code(uint32_t resolution, const uint16_t* texels) {
  const int s = int(resolution) + 2;
  const auto at = [&](int x, int y, int z) { return int(texels[((size_t(z) * s + y) * s + x) * 2]); };
  int d[3] = {0, 0, 0}, g[3] = {0, 0, 0};
  for (int z = 0; z < s; ++z)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x) {
        const int v = at(x, y, z);
        if (x + 1 < s) g[0] = std::max(g[0], std::abs(at(x + 1, y, z) - v));
        if (y + 1 < s) g[1] = std::max(g[1], std::abs(at(x, y + 1, z) - v));
        if (z + 1 < s) g[2] = std::max(g[2], std::abs(at(x, y, z + 1) - v));
        if (x > 0 && x + 1 < s) d[0] = std::max(d[0], std::abs(at(x - 1, y, z) - 2 * v + at(x + 1, y, z)));
        if (y > 0 && y + 1 < s) d[1] = std::max(d[1], std::abs(at(x, y - 1, z) - 2 * v + at(x, y + 1, z)));
        if (z > 0 && z + 1 < s) d[2] = std::max(d[2], std::abs(at(x, y, z - 1) - 2 * v + at(x, y, z + 1)));
      }
  const double m = double(d[0] + d[1] + d[2]) / 6.0 + double(g[0] + g[1] + g[2]) / 128.0 + 2.0;
  return uint16_t(std::min(std::ceil(m), 65535.0));
}

namespace {

// Slots along z within max_3d texels, with the margin layers after them: a layer has T_x · T_y = slots_x · slots_y ·
// side² texels, so one layer holds the margins of side² layers of slots.
int slots_along_z(int side, int max_3d) {
  int n = max_3d / side;
  const auto layers = [&](int k) { return (k + side * side - 1) / (side * side); };
  while (n > 0 && n * side + layers(n) > max_3d) --n;
  return n;
}

}  // namespace

uint64_t BrickAtlas::max_slots(uint32_t resolution, int max_3d) {
  const int side = int(resolution) + 2;
  const uint64_t per_axis = uint64_t(max_3d / side);
  return per_axis * per_axis * uint64_t(slots_along_z(side, max_3d));
}

BrickAtlas::BrickAtlas(uint32_t resolution, uint64_t slots, int max_3d) : resolution_(resolution) {
  const int side = int(resolution) + 2;
  const int per_axis = max_3d / side, per_axis_z = slots_along_z(side, max_3d);
  if (per_axis_z < 1) fail_in("brick atlas", "bricks of " + std::to_string(resolution) + "³ do not fit a 3D texture");
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
  if (slots_[2] > per_axis_z) {  // a flat count: widen y
    slots_[1] = per_axis;
    slots_[2] = int((slots + uint64_t(slots_[0]) * slots_[1] - 1) / (uint64_t(slots_[0]) * slots_[1]));
  }
  for (int a = 0; a < 3; ++a) texels_[a] = slots_[a] * side;
  // The margin table's layers (brick_atlas.h): one texel per slot.
  const uint64_t per_layer = uint64_t(texels_[0]) * texels_[1];
  texels_[2] += int((capacity() + per_layer - 1) / per_layer);
  const char* no_bracket = std::getenv("UGVR_TRICUBIC_NO_BRACKET");
  no_bracket_ = no_bracket && *no_bracket;
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
  const uint16_t margin[2] = {no_bracket_ ? uint16_t(65535) : cubic_margin_code(resolution_, texels), 0};
  const uint64_t tx = uint64_t(texels_[0]), ty = uint64_t(texels_[1]);
  glTextureSubImage3D(texture_.id(), 0, int(slot % tx), int((slot / tx) % ty), slots_[2] * side + int(slot / (tx * ty)),
                      1, 1, 1, GL_RG, GL_UNSIGNED_SHORT, margin);
}

}  // namespace ugvr
