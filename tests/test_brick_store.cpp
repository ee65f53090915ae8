// Brick codec and brick store: round trips of every encoding, the accuracy bound of 16-bit samples, reads from several
// threads, a byte-level check of the documented layout, and the failure behaviour the issue asks for: a corrupt or
// truncated store is reported with the file, offset and what is wrong, and an interrupted build leaves nothing that
// looks valid.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <thread>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/store/brick_codec.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// ---------------------------------------------------------------------------------------------------------------
// Synthetic bricks

size_t cube(uint32_t r) { return size_t(r) * r * r; }

// A smooth field with features at a few scales, in [-2, 2] roughly.
double smooth_field(double x, double y, double z) {
  return std::sin(3.1 * x + 0.4) * std::cos(2.3 * y) + 0.5 * std::sin(7.7 * z + 5.1 * x) + 0.3 * x * y - 0.2 * z +
         0.05 * std::sin(41.0 * (x + y + z));
}

// Samples of `f` at a node's sample positions (the store's convention: border samples on the cell faces).
template <class F>
std::vector<float> sample_node(const Bounds& cell, uint32_t r, F&& f) {
  std::vector<float> out(cube(r));
  size_t s = 0;
  for (uint32_t z = 0; z < r; ++z) {
    for (uint32_t y = 0; y < r; ++y) {
      for (uint32_t x = 0; x < r; ++x, ++s) {
        const Vec3d t{double(x) / (r - 1), double(y) / (r - 1), double(z) / (r - 1)};
        const Vec3d p{cell.lo.x + t.x * (cell.hi.x - cell.lo.x), cell.lo.y + t.y * (cell.hi.y - cell.lo.y),
                      cell.lo.z + t.z * (cell.hi.z - cell.lo.z)};
        out[s] = float(f(p));
      }
    }
  }
  return out;
}

// The data exist outside a sphere (a body in a flow), as on a mesh around an obstacle.
constexpr Vec3d kSphereCentre{0.3, 0.3, 0.3};
constexpr double kSphereRadius = 0.25;
bool has_data(const Vec3d& p) { return length(p - kSphereCentre) >= kSphereRadius; }

std::vector<uint8_t> sample_mask(const Bounds& cell, uint32_t r) {
  const std::vector<float> m = sample_node(cell, r, [](const Vec3d& p) { return has_data(p) ? 1.0 : 0.0; });
  std::vector<uint8_t> out(m.size());
  for (size_t s = 0; s < m.size(); ++s) out[s] = m[s] != 0;
  return out;
}

std::vector<float> random_samples(uint32_t r, uint32_t seed, float lo, float hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float> out(cube(r));
  for (float& v : out) v = u(rng);
  return out;
}

std::vector<uint8_t> random_mask(uint32_t r, uint32_t seed, double p_valid) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution b(p_valid);
  std::vector<uint8_t> out(cube(r));
  for (uint8_t& m : out) m = b(rng);
  out[0] = 1;  // never all empty
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// Codec

struct CodecCase {
  SampleEncoding samples;
  Predictor predictor;
  bool shuffle;
  BrickCodec codec;
};

std::vector<CodecCase> all_codec_cases() {
  std::vector<CodecCase> cases;
  for (SampleEncoding e : {SampleEncoding::Quant16, SampleEncoding::Float32}) {
    for (Predictor p : {Predictor::None, Predictor::DeltaX, Predictor::Lorenzo}) {
      for (bool shuffle : {false, true}) {
        for (BrickCodec c : {BrickCodec::Stored, BrickCodec::Lz4, BrickCodec::Zstd}) {
          cases.push_back({e, p, shuffle, c});
        }
      }
    }
  }
  return cases;
}

// Checks a decoded brick against its source: Float32 bit exact, Quant16 within step/2 plus float rounding, both on
// valid samples only; every sample within the block's decoded range, which is within step/2 of the exact one; the
// mask reproduced.
void expect_decoded(const EncodedBlock& block, SampleEncoding e, uint32_t r, const std::vector<float>& in,
                    const uint8_t* mask, const std::string& what) {
  std::vector<float> out(cube(r), NAN);
  std::vector<uint8_t> out_mask(cube(r), 7);
  decode_brick(block.bytes, r, out.data(), out_mask.data(), "mem", 0);
  size_t bad = 0;
  for (size_t s = 0; s < cube(r) && bad < 5; ++s) {
    const bool valid = !mask || mask[s];
    if (out_mask[s] != (valid ? 1 : 0)) {
      ADD_FAILURE() << what << ": mask at " << s;
      ++bad;
    }
    if (valid) {
      if (e == SampleEncoding::Float32) {
        if (std::bit_cast<uint32_t>(out[s]) != std::bit_cast<uint32_t>(in[s])) {
          ADD_FAILURE() << what << ": sample " << s << " " << out[s] << " != " << in[s];
          ++bad;
        }
      } else {
        const double bound = block.step / 2.0 * (1 + 1e-9) + (std::abs(in[s]) + block.step) * 6e-8 + 1e-30;
        if (!(std::abs(double(out[s]) - in[s]) <= bound)) {
          ADD_FAILURE() << what << ": sample " << s << " " << out[s] << " vs " << in[s] << " (bound " << bound << ")";
          ++bad;
        }
      }
    }
    if (!(out[s] >= block.decoded_lo && out[s] <= block.decoded_hi)) {
      ADD_FAILURE() << what << ": sample " << s << " decodes to " << out[s] << " outside the decoded range";
      ++bad;
    }
  }
  if (e == SampleEncoding::Float32) {
    EXPECT_EQ(block.decoded_lo, block.lo) << what;
    EXPECT_EQ(block.decoded_hi, block.hi) << what;
  } else {
    const double slack = block.step / 2.0 * (1 + 1e-9) + (std::abs(block.lo) + std::abs(block.hi)) * 6e-8 + 1e-30;
    EXPECT_LE(std::abs(double(block.decoded_lo) - block.lo), slack) << what;
    EXPECT_LE(std::abs(double(block.decoded_hi) - block.hi), slack) << what;
  }
}

TEST(BrickCodec, RoundTripEveryEncoding) {
  for (uint32_t r : {5u, 8u, 32u}) {  // 5: a mask that does not fill its last byte
    const Bounds cell{{0.1, 0.2, 0.3}, {0.6, 0.7, 0.8}};
    const std::vector<float> smooth = sample_node(cell, r, [](const Vec3d& p) { return smooth_field(p.x, p.y, p.z); });
    const std::vector<float> noise = random_samples(r, 7 * r, -1e3f, 3e3f);
    const std::vector<uint8_t> sparse = random_mask(r, 11 * r, 0.3);
    const std::vector<uint8_t> sphere = sample_mask(Bounds{{0.0, 0.0, 0.0}, {0.5, 0.5, 0.5}}, r);
    for (const CodecCase& c : all_codec_cases()) {
      const BrickEncoding enc{c.samples, c.predictor, c.shuffle, c.codec, 0};
      for (const auto* data : {&smooth, &noise}) {
        for (const uint8_t* mask : {static_cast<const uint8_t*>(nullptr), sparse.data(), sphere.data()}) {
          const std::string what = std::string(sample_encoding_name(c.samples)) + "/" +
                                   std::string(predictor_name(c.predictor)) + "/" + (c.shuffle ? "shuffle/" : "") +
                                   std::string(brick_codec_name(c.codec)) + " r=" + std::to_string(r) +
                                   (data == &smooth ? " smooth" : " noise") +
                                   (mask == nullptr         ? " full"
                                    : mask == sparse.data() ? " sparse"
                                                            : " sphere");
          const EncodedBlock block = encode_brick(enc, r, data->data(), mask, 0.0);
          expect_decoded(block, c.samples, r, *data, mask, what);
          const BlockHeader h = parse_block_header(block.bytes, r, "mem", 0);
          EXPECT_EQ(h.has_mask, mask != nullptr) << what;
          EXPECT_EQ(h.valid, block.valid) << what;
        }
      }
    }
  }
}

TEST(BrickCodec, ConstantAndExtremeBricks) {
  const uint32_t r = 8;
  for (SampleEncoding e : {SampleEncoding::Quant16, SampleEncoding::Float32}) {
    const BrickEncoding enc{e, Predictor::Lorenzo, true, BrickCodec::Zstd, 0};
    const std::vector<float> constant(cube(r), -3.25f);
    // On a shared grid a constant brick takes the grid's value, as its neighbours do; on its own grid it is exact.
    EncodedBlock b = encode_brick(enc, r, constant.data(), nullptr, 1e-3, 0.1);
    expect_decoded(b, e, r, constant, nullptr, "constant");
    EXPECT_EQ(b.step, e == SampleEncoding::Quant16 ? 1e-3 : 0.0);
    EXPECT_EQ(b.shared_grid, e == SampleEncoding::Quant16);
    b = encode_brick(enc, r, constant.data(), nullptr, 0.0);
    expect_decoded(b, e, r, constant, nullptr, "constant, own grid");
    EXPECT_EQ(b.step, 0.0);
    EXPECT_EQ(b.decoded_lo, -3.25f);
    EXPECT_EQ(b.decoded_hi, -3.25f);
    // Values near the float limits: the predictor overflows to inf and must still agree on both sides.
    std::vector<float> extreme = random_samples(r, 3, -1.0f, 1.0f);
    for (float& v : extreme) v *= 3e38f;
    b = encode_brick(enc, r, extreme.data(), nullptr, 0.0);
    expect_decoded(b, e, r, extreme, nullptr, "extreme");
    const std::vector<uint8_t> mask = random_mask(r, 5, 0.5);
    b = encode_brick(enc, r, extreme.data(), mask.data(), 0.0);
    expect_decoded(b, e, r, extreme, mask.data(), "extreme masked");
    // A shared grid on which the extremes would decode beyond float32: the brick takes a grid of its own.
    extreme[0] = std::numeric_limits<float>::max();
    b = encode_brick(enc, r, extreme.data(), nullptr, 1.1e34, 0.0);  // FLT_MAX / step rounds up
    expect_decoded(b, e, r, extreme, nullptr, "float32 limit");
    EXPECT_FALSE(b.shared_grid);
  }
}

TEST(BrickCodec, InvalidSamplesDoNotCostSpace) {
  // The same valid samples with garbage where the mask says "no data": the block must not depend on the garbage.
  const uint32_t r = 32;
  const std::vector<uint8_t> mask = sample_mask(Bounds{{0.0, 0.0, 0.0}, {0.5, 0.5, 0.5}}, r);
  std::vector<float> a = sample_node(Bounds{{0.0, 0.0, 0.0}, {0.5, 0.5, 0.5}}, r,
                                     [](const Vec3d& p) { return smooth_field(p.x, p.y, p.z); });
  std::vector<float> b = a;
  std::mt19937 rng(1);
  for (size_t s = 0; s < b.size(); ++s) {
    if (!mask[s]) {
      a[s] = 0;
      b[s] = std::bit_cast<float>(uint32_t(rng()) | 0x7f800000u);  // inf and NaN too
    }
  }
  const BrickEncoding enc;
  const EncodedBlock ea = encode_brick(enc, r, a.data(), mask.data(), 0.0);
  const EncodedBlock eb = encode_brick(enc, r, b.data(), mask.data(), 0.0);
  EXPECT_EQ(ea.bytes, eb.bytes);
  EXPECT_LT(ea.valid, cube(r));
}

TEST(BrickCodec, RejectsBadInput) {
  const uint32_t r = 4;
  std::vector<float> v(cube(r), 1.0f);
  std::vector<uint8_t> none(cube(r), 0);
  EXPECT_THROW(encode_brick({}, r, v.data(), none.data(), 0.0), Error);
  v[5] = NAN;
  try {
    encode_brick({}, r, v.data(), nullptr, 0.0);
    FAIL() << "NaN accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample 5"), std::string::npos) << e.what();
  }
  none[5] = 0;
  none[6] = 1;
  EXPECT_NO_THROW(encode_brick({}, r, v.data(), none.data(), 0.0));  // the NaN is masked out
}

TEST(BrickCodec, CorruptBlocksAreReported) {
  const uint32_t r = 8;
  const std::vector<float> v = sample_node(Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}}, r,
                                           [](const Vec3d& p) { return smooth_field(p.x, p.y, p.z); });
  const EncodedBlock b = encode_brick({}, r, v.data(), nullptr, 0.0);
  ASSERT_EQ(parse_block_header(b.bytes, r, "mem", 0).codec, BrickCodec::Zstd);
  std::vector<float> out(cube(r));
  auto expect_error = [&](std::vector<std::byte> bytes, const std::string& needle) {
    try {
      decode_brick(bytes, r, out.data(), nullptr, "x.ugvr", 1000);
      ADD_FAILURE() << "no error for " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("x.ugvr: byte 10"), std::string::npos) << e.what();
    }
  };
  auto bytes = b.bytes;
  bytes[0] = std::byte{9};
  expect_error(bytes, "sample encoding");
  bytes = b.bytes;
  bytes[9] ^= std::byte{0xff};  // valid count
  expect_error(bytes, "valid sample count");
  bytes = b.bytes;
  bytes.resize(bytes.size() - 3);
  expect_error(bytes, "zstd");
  bytes = b.bytes;
  bytes.resize(10);
  expect_error(bytes, "shorter than its 48-byte header");
  // A mask whose population disagrees with the header.
  std::vector<uint8_t> mask(cube(r), 1);
  mask[3] = 0;
  const EncodedBlock m = encode_brick({SampleEncoding::Quant16, Predictor::Lorenzo, true, BrickCodec::Stored, 0}, r,
                                      v.data(), mask.data(), 0.0);
  bytes = m.bytes;
  bytes[kBlockHeaderSize] ^= std::byte{0x08};  // sample 3 marked valid
  expect_error(bytes, "mask marks");
}

// The Quant16 grid fields, each at its documented offset, damaged so that decoding would overflow or produce
// non-numbers: every one is refused before decoding, naming its byte.
TEST(BrickCodec, CorruptGridFieldsAreReported) {
  const uint32_t r = 8;
  const std::vector<float> v = sample_node(Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}}, r,
                                           [](const Vec3d& p) { return smooth_field(p.x, p.y, p.z); });
  const EncodedBlock b = encode_brick({}, r, v.data(), nullptr, 2 * kQuant16Tolerance * 4.0, -2.0);
  ASSERT_TRUE(b.shared_grid);
  const BlockHeader good = parse_block_header(b.bytes, r, "mem", 0);
  EXPECT_EQ(good.origin, -2.0);
  EXPECT_EQ(good.step, 2 * kQuant16Tolerance * 4.0);
  EXPECT_GT(good.qmax, 1000u);
  std::vector<float> out(cube(r));
  auto expect_error = [&](size_t at, auto value, const std::string& needle, uint64_t byte) {
    std::vector<std::byte> bytes = b.bytes;
    std::memcpy(bytes.data() + at, &value, sizeof value);
    try {
      decode_brick(bytes, r, out.data(), nullptr, "x.ugvr", 1000);
      ADD_FAILURE() << "no error for " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("x.ugvr: byte " + std::to_string(1000 + byte)), std::string::npos)
          << e.what();
    }
  };
  expect_error(20, uint32_t(65536), "largest code 65536", 20);
  expect_error(24, std::numeric_limits<int64_t>::max(), "grid index base", 24);  // base + q would overflow
  expect_error(24, std::numeric_limits<int64_t>::min(), "grid index base", 24);
  expect_error(24, int64_t(1) << 52, "grid index base", 24);  // base + q inexact in double
  expect_error(32, double(NAN), "origin", 32);
  expect_error(32, double(INFINITY), "origin", 32);
  expect_error(32, 1e300, "beyond float32", 24);  // finite, but not as a float
  expect_error(40, double(NAN), "quantization step", 40);
  expect_error(40, -1.0, "quantization step", 40);
  expect_error(40, 0.0, "quantization step", 40);  // codes up to qmax > 0 need a step
  expect_error(40, 1e300, "beyond float32", 24);
  // Float32 blocks carry no grid.
  const EncodedBlock f = encode_brick({SampleEncoding::Float32}, r, v.data(), nullptr, 0.0);
  std::vector<std::byte> bytes = f.bytes;
  const double origin = 1.0;
  std::memcpy(bytes.data() + 32, &origin, 8);
  EXPECT_THROW(decode_brick(bytes, r, out.data(), nullptr, "x.ugvr", 1000), Error);
}

// Damage that a checksum would catch, fed straight to the decoder (as a cache holding bad bytes would): every outcome
// is an Error or some decoded values, never a read outside the block (the sanitizer build checks).
TEST(BrickCodec, MutatedBlocksNeverCrash) {
  const uint32_t r = 8;
  const std::vector<float> v = sample_node(Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}}, r,
                                           [](const Vec3d& p) { return smooth_field(p.x, p.y, p.z); });
  const std::vector<uint8_t> mask = random_mask(r, 3, 0.7);
  std::mt19937 rng(5);
  std::vector<float> out(cube(r));
  std::vector<uint8_t> out_mask(cube(r));
  size_t errors = 0, runs = 0;
  for (const CodecCase& c : all_codec_cases()) {
    const BrickEncoding enc{c.samples, c.predictor, c.shuffle, c.codec, 0};
    const EncodedBlock b = encode_brick(enc, r, v.data(), mask.data(), 0.0);
    for (int trial = 0; trial < 20; ++trial, ++runs) {
      std::vector<std::byte> bytes = b.bytes;
      const int flips = 1 + int(rng() % 4);
      for (int f = 0; f < flips; ++f) bytes[rng() % bytes.size()] ^= std::byte(1u << (rng() % 8));
      if (trial % 5 == 0) bytes.resize(rng() % bytes.size());
      try {
        decode_brick(bytes, r, out.data(), out_mask.data(), "mem", 0);
      } catch (const Error&) {
        ++errors;
      }
    }
  }
  EXPECT_GT(errors, runs / 10);
}

// The accuracy the issue asks of leaf samples: within 1e-5 of the field's range, whatever the brick's own range.
TEST(BrickCodec, Quant16AccuracyBound) {
  const uint32_t r = 32;
  const double field_min = -250.0, field_max = 1750.0, range = field_max - field_min;
  const double step = 2 * kQuant16Tolerance * range;
  double worst = 0;
  for (uint32_t seed = 0; seed < 12; ++seed) {
    // Bricks spanning the whole range, a tenth of it, and a sliver, with smooth and random content.
    const float width = float(range / std::pow(10.0, seed % 4));
    const float lo = float(field_min + (range - width) * (seed % 3) / 2.0);
    std::vector<float> v = random_samples(r, seed, lo, lo + width);
    if (seed % 2) {
      v = sample_node(Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}}, r,
                      [&](const Vec3d& p) { return lo + width * (0.5 + 0.5 * std::sin(5 * p.x + 3 * p.y * p.z)); });
    }
    v[0] = lo;  // the extremes are present
    v[1] = lo + width;
    const EncodedBlock b = encode_brick({}, r, v.data(), nullptr, step, field_min);
    EXPECT_TRUE(b.shared_grid);
    EXPECT_EQ(b.step, step);
    std::vector<float> out(cube(r));
    decode_brick(b.bytes, r, out.data(), nullptr, "mem", 0);
    for (size_t s = 0; s < out.size(); ++s) worst = std::max(worst, std::abs(double(out[s]) - double(v[s])));
  }
  EXPECT_LE(worst / range, 1e-5);
  EXPECT_LE(worst / range, kQuant16Tolerance * 1.01);
  EXPECT_GT(worst / range, kQuant16Tolerance * 0.5);  // and the figure is the one the quantization predicts
}

// ---------------------------------------------------------------------------------------------------------------
// Store

// A tree over [0, 1]³ refined towards the sphere's surface, built breadth first (children after their parent), with
// some octants missing so child masks are not all 0xff.
std::vector<OctreeNode> sphere_tree(int max_level) {
  const Bounds root{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
  std::vector<OctreeNode> nodes(1);
  for (size_t id = 0; id < nodes.size(); ++id) {
    const OctreeNode n = nodes[id];
    if (n.level >= max_level) continue;
    const Bounds b = node_bounds(root, n);
    const double d = length(b.center() - kSphereCentre), half_diag = length(b.size()) / 2;
    if (n.level >= 1 && std::abs(d - kSphereRadius) > half_diag) continue;  // not on the surface: leaf
    uint8_t mask = 0;
    for (int o = 0; o < 8; ++o) {
      if (n.level >= 1 && o == int((n.i + n.j + n.k) % 8)) continue;  // a missing octant
      mask |= uint8_t(1u << o);
    }
    nodes[id].first_child = nodes.size();
    nodes[id].child_mask = mask;
    for (int o = 0; o < 8; ++o) {
      if (!(mask >> o & 1)) continue;
      OctreeNode c;
      c.parent = id;
      c.level = uint8_t(n.level + 1);
      c.i = 2 * n.i + (o & 1);
      c.j = 2 * n.j + (o >> 1 & 1);
      c.k = 2 * n.k + (o >> 2 & 1);
      nodes.push_back(c);
    }
  }
  return nodes;
}

struct TestStore {
  BrickStoreLayout layout;
  std::vector<OctreeNode> nodes;
  std::vector<FieldError> errors;
  // Per node, per field: the exact samples; per node the mask (empty vector: no brick).
  std::vector<std::vector<std::vector<float>>> samples;
  std::vector<std::vector<uint8_t>> masks;
};

TestStore make_test_store(uint32_t r, int max_level, BrickEncoding encoding = {}) {
  TestStore t;
  t.layout.resolution = r;
  t.layout.root = Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
  t.layout.data = Bounds{{0.0, 0.0, 0.0}, {1.0, 0.9, 1.0}};
  t.layout.encoding = encoding;
  t.layout.fields = {{"pressure", Association::Vertex, -3.0, 3.0},
                     {"velocity:x", Association::Vertex, -100.0, 100.0},
                     {"noise", Association::Cell, 0.0, 1.0}};
  t.nodes = sphere_tree(max_level);
  const Bounds root = t.layout.root;
  t.samples.resize(t.nodes.size());
  t.masks.resize(t.nodes.size());
  for (size_t id = 0; id < t.nodes.size(); ++id) {
    const Bounds b = node_bounds(root, t.nodes[id]);
    std::vector<uint8_t> mask = sample_mask(b, r);
    if (std::none_of(mask.begin(), mask.end(), [](uint8_t m) { return m != 0; })) continue;  // inside the body
    t.masks[id] = std::move(mask);
    t.samples[id].push_back(sample_node(b, r, [](const Vec3d& p) { return smooth_field(p.x, p.y, p.z); }));
    t.samples[id].push_back(sample_node(b, r, [](const Vec3d& p) { return 90 * std::sin(4 * p.x) * p.y; }));
    t.samples[id].push_back(random_samples(r, uint32_t(id), 0.0f, 1.0f));
  }
  for (size_t id = 0; id < t.nodes.size(); ++id) {
    for (int f = 0; f < 3; ++f) t.errors.push_back({float(id) * 0.01f + f, float(id) * 0.001f + f});
  }
  return t;
}

void write_test_store(const TestStore& t, const std::string& path) {
  BrickStoreWriter w(path, t.layout);
  // Bricks in an order unrelated to node ids, as a parallel builder would append them.
  std::vector<size_t> order(t.nodes.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), std::mt19937(42));
  for (size_t id : order) {
    if (t.masks[id].empty()) continue;
    const float* fields[3] = {t.samples[id][0].data(), t.samples[id][1].data(), t.samples[id][2].data()};
    w.add_brick(id, fields, t.masks[id].data());
  }
  w.commit(t.nodes, t.errors);
}

size_t count_entries(const std::string& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

void check_store(const TestStore& t, const BrickStoreReader& s) {
  const uint32_t r = t.layout.resolution;
  ASSERT_EQ(s.resolution(), r);
  ASSERT_EQ(s.field_count(), 3u);
  ASSERT_EQ(s.node_count(), t.nodes.size());
  for (size_t f = 0; f < 3; ++f) {
    EXPECT_EQ(s.layout().fields[f].name, t.layout.fields[f].name);
    EXPECT_EQ(s.layout().fields[f].association, t.layout.fields[f].association);
    EXPECT_EQ(s.layout().fields[f].min, t.layout.fields[f].min);
    EXPECT_EQ(s.layout().fields[f].max, t.layout.fields[f].max);
  }
  EXPECT_EQ(s.field_index("noise"), 2);
  EXPECT_EQ(s.field_index("nope"), -1);
  EXPECT_EQ(s.layout().root.lo, t.layout.root.lo);
  EXPECT_EQ(s.layout().root.hi, t.layout.root.hi);
  EXPECT_EQ(s.layout().data.hi, t.layout.data.hi);
  EXPECT_EQ(s.layout().encoding.codec, t.layout.encoding.codec);
  EXPECT_EQ(s.layout().tolerance, t.layout.encoding.samples == SampleEncoding::Float32 ? 0.0 : t.layout.tolerance);

  std::vector<float> out(cube(r));
  std::vector<uint8_t> mask(cube(r));
  size_t empty = 0, partial = 0;
  for (size_t id = t.nodes.size(); id-- > 0;) {
    const BrickNode& n = s.node(id);
    const OctreeNode& e = t.nodes[id];
    ASSERT_EQ(n.parent, e.parent);
    ASSERT_EQ(n.first_child, e.first_child);
    ASSERT_EQ(n.child_mask, e.child_mask);
    ASSERT_EQ(n.level, e.level);
    ASSERT_EQ(n.i, e.i);
    ASSERT_EQ(n.j, e.j);
    ASSERT_EQ(n.k, e.k);
    ASSERT_EQ(n.has_brick(), !t.masks[id].empty()) << id;
    if (!n.has_brick()) {
      ++empty;
      EXPECT_EQ(n.valid_fraction, 0.0f);
      EXPECT_THROW(s.read_brick(id, 0, out.data(), nullptr), Error);
    } else {
      const size_t valid = size_t(std::count(t.masks[id].begin(), t.masks[id].end(), 1));
      EXPECT_FLOAT_EQ(n.valid_fraction, float(double(valid) / double(cube(r))));
      partial += valid < cube(r);
    }
    for (uint32_t f = 0; f < 3; ++f) {
      const FieldStats& st = s.stats(id, f);
      EXPECT_EQ(st.error_max, t.errors[id * 3 + f].max);
      EXPECT_EQ(st.error_rms, t.errors[id * 3 + f].rms);
      // Conservative range: contains the node's own valid samples, exact and decoded, and its children's ranges.
      float lo = INFINITY, hi = -INFINITY;
      if (n.has_brick()) {
        s.read_brick(id, f, out.data(), nullptr);
        for (size_t q = 0; q < cube(r); ++q) {
          if (!t.masks[id][q]) continue;
          lo = std::min({lo, t.samples[id][f][q], out[q]});
          hi = std::max({hi, t.samples[id][f][q], out[q]});
        }
      }
      for (int o = 0; o < 8; ++o) {
        if (const uint64_t c = n.child(o); c != kNoNode) {
          lo = std::min(lo, s.stats(c, f).min);
          hi = std::max(hi, s.stats(c, f).max);
        }
      }
      EXPECT_EQ(st.min, lo);
      EXPECT_EQ(st.max, hi);
      if (!n.has_brick()) continue;
      s.read_brick(id, f, out.data(), f == 0 ? mask.data() : nullptr);
      if (f == 0) {
        EXPECT_EQ(mask, t.masks[id]);
      }
      const double range = t.layout.fields[f].max - t.layout.fields[f].min;
      // Float32 is exact; Quant16 within the bound, 1e-5 of the field's range.
      const double bound = t.layout.encoding.samples == SampleEncoding::Float32 ? 0.0 : 1e-5 * range;
      double worst = 0;
      for (size_t q = 0; q < cube(r); ++q) {
        if (t.masks[id][q]) worst = std::max(worst, std::abs(double(out[q]) - t.samples[id][f][q]));
      }
      ASSERT_LE(worst, bound) << "node " << id << " field " << f;
    }
  }
  EXPECT_GT(empty, 0u);    // the tree has empty nodes (inside the body),
  EXPECT_GT(partial, 0u);  // partial ones (on its surface)
}

TEST(BrickStore, RoundTrip) {
  ScratchDir dir;
  for (uint32_t r : {8u, 32u}) {
    TestStore t = make_test_store(r, r == 8 ? 4 : 3);
    // The default, each brick on its own 16-bit grid (tolerance 0), and lossless.
    const std::pair<BrickEncoding, double> variants[] = {
        {BrickEncoding{}, kQuant16Tolerance},
        {BrickEncoding{}, 0.0},
        {BrickEncoding{SampleEncoding::Float32, Predictor::Lorenzo, true, BrickCodec::Lz4, 0}, kQuant16Tolerance}};
    for (const auto& [enc, tolerance] : variants) {
      t.layout.encoding = enc;
      t.layout.tolerance = tolerance;
      const std::string path = dir.file("r" + std::to_string(r) + ".ugvr");
      write_test_store(t, path);
      BrickStoreReader s(path);
      SCOPED_TRACE("r=" + std::to_string(r) + " " + std::string(sample_encoding_name(enc.samples)) + " tolerance " +
                   std::to_string(tolerance));
      check_store(t, s);
      EXPECT_EQ(count_entries(dir.file("")), 1u);  // no temporary left behind
      std::filesystem::remove(path);
    }
  }
}

// The requirement: samples shared by neighbouring bricks of one level are identical, for what the renderer
// reads. Every node of a complete two-level tree samples three fields at its lattice points, each value a function
// of the point's global lattice coordinates (so shared samples are bit-identical inputs), with ranges that differ
// from brick to brick: a linear field (a brick's maximum lies on faces it shares with neighbours whose maximum is
// elsewhere), a wave, and hashed noise. Written with the default encoding (Quant16, default tolerance), every shared
// valid sample decodes to the same bits in every brick holding it, and every sample stays within tolerance × range
// (+ float rounding) of its input.
TEST(BrickStore, SharedSamplesDecodeIdentically) {
  ScratchDir dir;
  const uint32_t r = 8;
  const int levels = 2;
  BrickStoreLayout layout;
  layout.resolution = r;
  layout.root = Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
  layout.data = layout.root;
  // The fields' extremes over the cube (the linear field's corners are exact floats).
  layout.fields = {{"linear", Association::Vertex, -3.0, 2.25},
                   {"wave", Association::Vertex, -1.0, 1.0},
                   {"noise", Association::Vertex, -7.0, 5.0}};
  auto field = [](int f, int level, uint64_t gx, uint64_t gy, uint64_t gz) -> float {
    const double scale = std::ldexp(1.0, -level) / (r - 1);
    const double x = double(gx) * scale, y = double(gy) * scale, z = double(gz) * scale;
    if (f == 0) return float(1.75 * x - 1.5 * y + 2.0 * z - 1.5);
    if (f == 1) return float(std::sin(5.0 * x + 1.0) * std::cos(4.0 * y - 2.0 * z));
    uint64_t h = (uint64_t(level) << 60) ^ (gx * 0x9E3779B97F4A7C15ull) ^ (gy * 0xC2B2AE3D27D4EB4Full) ^
                 (gz * 0x165667B19E3779F9ull);
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return float(-7.0 + 12.0 * double(h >> 11) * 0x1.0p-53);
  };
  // A complete tree: the root, 8 children, 64 grandchildren, breadth first.
  std::vector<OctreeNode> nodes(1);
  for (size_t id = 0; id < nodes.size(); ++id) {
    if (nodes[id].level >= levels) continue;
    nodes[id].first_child = nodes.size();
    nodes[id].child_mask = 0xff;
    for (int o = 0; o < 8; ++o) {
      OctreeNode c;
      c.parent = id;
      c.level = uint8_t(nodes[id].level + 1);
      c.i = 2 * nodes[id].i + (o & 1);
      c.j = 2 * nodes[id].j + (o >> 1 & 1);
      c.k = 2 * nodes[id].k + (o >> 2 & 1);
      nodes.push_back(c);
    }
  }
  const size_t n = cube(r);
  std::vector<std::vector<std::vector<float>>> in(nodes.size(), std::vector<std::vector<float>>(3));
  std::vector<std::vector<uint8_t>> masks(nodes.size());
  auto global = [&](const OctreeNode& node, size_t s) {
    return std::array<uint64_t, 3>{uint64_t(node.i) * (r - 1) + s % r, uint64_t(node.j) * (r - 1) + s / r % r,
                                   uint64_t(node.k) * (r - 1) + s / (size_t(r) * r)};
  };
  for (size_t id = 0; id < nodes.size(); ++id) {
    masks[id].resize(n);
    for (int f = 0; f < 3; ++f) in[id][size_t(f)].resize(n);
    for (size_t s = 0; s < n; ++s) {
      const auto g = global(nodes[id], s);
      for (int f = 0; f < 3; ++f) in[id][size_t(f)][s] = field(f, nodes[id].level, g[0], g[1], g[2]);
      // A hole, so that some bricks are partial (a function of the point too, so shared samples agree on it).
      const double span = double(uint64_t(r - 1) << nodes[id].level);
      masks[id][s] = length(Vec3d{g[0] / span, g[1] / span, g[2] / span} - kSphereCentre) >= kSphereRadius;
    }
  }
  for (double tolerance : {kQuant16Tolerance, 0.0}) {
    layout.tolerance = tolerance;
    const std::string path = dir.file("shared.ugvr");
    {
      BrickStoreWriter w(path, layout);
      for (size_t id = 0; id < nodes.size(); ++id) {
        const float* fields[3] = {in[id][0].data(), in[id][1].data(), in[id][2].data()};
        w.add_brick(id, fields, masks[id].data());
      }
      w.commit(nodes);
    }
    const BrickStoreReader store(path);
    // (field, level, global lattice point) -> decoded bits of the first brick holding it, and whether the sample is
    // that brick's maximum.
    std::map<std::array<uint64_t, 5>, std::pair<uint32_t, bool>> first;
    size_t shared = 0, mismatches = 0, max_and_not = 0;
    double worst = 0;
    std::vector<float> out(n);
    std::vector<uint8_t> mask(n);
    for (size_t id = 0; id < nodes.size(); ++id) {
      if (!store.node(id).has_brick()) continue;
      for (uint32_t f = 0; f < 3; ++f) {
        store.read_brick(id, f, out.data(), mask.data());
        ASSERT_EQ(mask, masks[id]);
        const double range = layout.fields[f].max - layout.fields[f].min;
        float brick_max = -INFINITY;
        for (size_t s = 0; s < n; ++s) {
          if (mask[s]) brick_max = std::max(brick_max, in[id][f][s]);
        }
        const FieldStats& st = store.stats(id, f);
        for (size_t s = 0; s < n; ++s) {
          if (!mask[s]) continue;
          const float v = in[id][f][s];
          EXPECT_GE(out[s], st.min);  // the node's range bounds what is decoded
          EXPECT_LE(out[s], st.max);
          if (tolerance > 0) worst = std::max(worst, (std::abs(double(out[s]) - v) - std::abs(v) * 6e-8) / range);
          const size_t x = s % r, y = s / r % r, z = s / (size_t(r) * r);
          if (x != 0 && y != 0 && z != 0 && x != r - 1 && y != r - 1 && z != r - 1) continue;
          const auto g = global(nodes[id], s);
          const uint32_t bits = std::bit_cast<uint32_t>(out[s]);
          const auto [it, fresh] = first.try_emplace({f, nodes[id].level, g[0], g[1], g[2]}, bits, v == brick_max);
          if (fresh) continue;
          ++shared;
          mismatches += it->second.first != bits;
          max_and_not += f == 0 && it->second.second != (v == brick_max);
        }
      }
    }
    std::printf("tolerance %g: %zu of %zu shared samples differ after decoding\n", tolerance, mismatches, shared);
    EXPECT_GT(shared, 1000u);
    if (tolerance > 0) {
      EXPECT_EQ(mismatches, 0u);
      EXPECT_LE(worst, tolerance * (1 + 1e-9));
      EXPECT_GT(max_and_not, 0u);  // the case where capping at a brick's maximum broke the identity
    } else {
      EXPECT_GT(mismatches, 0u);  // per-brick grids promise no identity: the check above has teeth
    }
  }
}

TEST(BrickStore, NodeGeometry) {
  const Bounds root{{-1.0, 0.0, 10.0}, {3.0, 2.0, 11.0}};
  OctreeNode n;
  n.level = 2;
  n.i = 3;
  n.j = 0;
  n.k = 1;
  const Bounds b = node_bounds(root, n);
  EXPECT_EQ(b.lo, (Vec3d{2.0, 0.0, 10.25}));
  EXPECT_EQ(b.hi, (Vec3d{3.0, 0.5, 10.5}));
  n.first_child = 40;
  n.child_mask = 0b10100100;
  EXPECT_EQ(n.child(2), 40u);
  EXPECT_EQ(n.child(5), 41u);
  EXPECT_EQ(n.child(7), 42u);
  EXPECT_EQ(n.child(0), kNoNode);
}

// The header as docs/brick-store.md describes it, read here byte by byte, independently of the reader.
TEST(BrickStore, DocumentedLayout) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("layout.ugvr");
  write_test_store(t, path);
  std::ifstream in(path, std::ios::binary);
  const std::string f((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto u32 = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, f.data() + at, 4);
    return v;
  };
  auto u64 = [&](size_t at) {
    uint64_t v;
    std::memcpy(&v, f.data() + at, 8);
    return v;
  };
  auto f64 = [&](size_t at) {
    double v;
    std::memcpy(&v, f.data() + at, 8);
    return v;
  };
  EXPECT_EQ(f.substr(0, 8), std::string("\x89UBS\r\n\x1a\n", 8));
  EXPECT_EQ(u32(8), 5u);
  const uint32_t header_size = u32(12);
  EXPECT_EQ(u32(16), 8u);
  EXPECT_EQ(u32(20), 3u);
  EXPECT_EQ(u32(24), 48u + 24 * 3);
  EXPECT_EQ(f[28], 1);  // quant16
  EXPECT_EQ(f[29], 2);  // lorenzo
  EXPECT_EQ(f[30], 2);  // zstd
  EXPECT_EQ(f64(40), kQuant16Tolerance);
  EXPECT_EQ(f64(48 + 24), 1.0);  // root hi.x
  EXPECT_EQ(f64(96 + 32), 0.9);  // data hi.y
  EXPECT_EQ(u64(144), t.nodes.size());
  EXPECT_EQ(u64(160), f.size());
  EXPECT_EQ(u64(152) + u64(144) * u32(24), f.size());
  std::string h = f.substr(0, header_size);
  std::memset(h.data() + 172, 0, 4);
  EXPECT_EQ(u32(172), uint32_t(crc32(0, reinterpret_cast<const Bytef*>(h.data()), uInt(h.size()))));
  EXPECT_EQ(u32(168),
            uint32_t(crc32(0, reinterpret_cast<const Bytef*>(f.data() + u64(152)), uInt(f.size() - u64(152)))));
  // Version 3: the transfer-function error table's record, version 4: the boundary faces' record, version 5: the
  // cells' record (none written here: all zero), then the field records, "pressure" first.
  EXPECT_EQ(f.substr(176, 24 + 40 + 32), std::string(24 + 40 + 32, '\0'));
  const size_t fr = 272;
  EXPECT_EQ(f64(fr), -3.0);
  EXPECT_EQ(f64(fr + 8), 3.0);
  EXPECT_EQ(f[fr + 16], 0);
  EXPECT_EQ(uint16_t(uint8_t(f[fr + 18]) | uint8_t(f[fr + 19]) << 8), 8);
  EXPECT_EQ(f.substr(fr + 20, 8), "pressure");
  EXPECT_EQ(f.substr(fr + 32 + 20, 10), "velocity:x");
  // Node 0's record and its first block, whose crc is in the record.
  const size_t rec = u64(152);
  EXPECT_EQ(u64(rec), kNoNode);
  EXPECT_EQ(u64(rec + 8), 1u);
  const uint64_t brick = u64(rec + 16);
  EXPECT_GE(brick, header_size);  // bricks follow the header, in the order they were appended
  const uint32_t size0 = u32(rec + 48 + 16);
  EXPECT_EQ(u32(rec + 48 + 20), uint32_t(crc32(0, reinterpret_cast<const Bytef*>(f.data() + brick), size0)));
  EXPECT_EQ(f[brick], 1);  // block header: quant16
  // Its grid: the field's minimum and 2 × tolerance × range, both f64, the base code and the largest code.
  EXPECT_EQ(f64(brick + 32), -3.0);
  EXPECT_EQ(f64(brick + 40), 2 * kQuant16Tolerance * 6.0);
  int64_t base;
  std::memcpy(&base, f.data() + brick + 24, 8);
  EXPECT_GE(base, 0);
  EXPECT_LE(base + int64_t(u32(brick + 20)), 65535);  // the field's range is 65535 steps
  float lo, hi;
  std::memcpy(&lo, f.data() + brick + 12, 4);
  std::memcpy(&hi, f.data() + brick + 16, 4);
  EXPECT_NEAR(-3.0 + double(base) * f64(brick + 40), lo, f64(brick + 40) / 2 * 1.001);
  EXPECT_NEAR(-3.0 + double(base + u32(brick + 20)) * f64(brick + 40), hi, f64(brick + 40) / 2 * 1.001);
}

TEST(BrickStore, ConcurrentReads) {
  ScratchDir dir;
  const TestStore t = make_test_store(16, 4);
  const std::string path = dir.file("c.ugvr");
  write_test_store(t, path);
  const BrickStoreReader s(path);
  const size_t n = cube(16);
  // Reference: every brick decoded on this thread.
  std::vector<std::vector<float>> ref(s.node_count() * 3);
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    if (!s.node(id).has_brick()) continue;
    for (uint32_t f = 0; f < 3; ++f) {
      ref[id * 3 + f].resize(n);
      s.read_brick(id, f, ref[id * 3 + f].data(), nullptr);
    }
  }
  std::atomic<size_t> mismatches{0}, reads{0};
  std::vector<std::thread> threads;
  for (int th = 0; th < 4; ++th) {
    threads.emplace_back([&, th] {
      std::vector<float> out(n);
      std::vector<uint8_t> mask(n);
      std::mt19937 rng{uint32_t(th)};
      for (int pass = 0; pass < 3; ++pass) {
        std::vector<uint64_t> order(s.node_count());
        for (uint64_t i = 0; i < order.size(); ++i) order[i] = i;
        std::shuffle(order.begin(), order.end(), rng);
        for (uint64_t id : order) {
          if (!s.node(id).has_brick()) continue;
          const uint32_t f = uint32_t(rng() % 3);
          s.read_brick(id, f, out.data(), mask.data());
          if (out != ref[id * 3 + f]) ++mismatches;
          ++reads;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(reads, 100u);
}

TEST(BrickStore, ConcurrentWriterAndRawBlocks) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 4);
  const std::string path = dir.file("w.ugvr");
  {
    BrickStoreWriter w(path, t.layout);
    std::atomic<size_t> next{0};
    std::vector<std::thread> threads;
    for (int th = 0; th < 3; ++th) {
      threads.emplace_back([&] {
        for (size_t id; (id = next++) < t.nodes.size();) {
          if (t.masks[id].empty()) continue;
          const float* fields[3] = {t.samples[id][0].data(), t.samples[id][1].data(), t.samples[id][2].data()};
          const EncodedBrick b = w.encode(fields, t.masks[id].data());
          w.append(id, b);
        }
      });
    }
    for (auto& th : threads) th.join();
    EXPECT_GT(w.block_bytes(), 0u);
    w.commit(t.nodes, t.errors);
  }
  const BrickStoreReader s(path);
  check_store(t, s);
  // Raw blocks, as a RAM cache would keep them, decode to what read_brick gives.
  const size_t n = cube(8);
  std::vector<float> a(n), b(n);
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    if (!s.node(id).has_brick()) continue;
    const BlockRef ref = s.block(id, 1);
    std::vector<std::byte> raw(ref.size);
    s.read_block(id, 1, raw.data());
    s.decode_block(id, 1, raw, a.data(), nullptr);
    s.read_brick(id, 1, b.data(), nullptr);
    ASSERT_EQ(a, b);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Failures

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}
void patch_u32(std::string& f, size_t at, uint32_t v) { std::memcpy(f.data() + at, &v, 4); }
uint64_t get_u64(const std::string& f, size_t at) {
  uint64_t v;
  std::memcpy(&v, f.data() + at, 8);
  return v;
}
uint32_t get_u32(const std::string& f, size_t at) {
  uint32_t v;
  std::memcpy(&v, f.data() + at, 4);
  return v;
}
// Recomputes both checksums, so a test can plant a structural error the checksums do not catch.
void reseal(std::string& f) {
  const size_t table = get_u64(f, 152), header = get_u32(f, 12);
  patch_u32(f, 168, uint32_t(crc32(0, reinterpret_cast<const Bytef*>(f.data() + table), uInt(f.size() - table))));
  patch_u32(f, 172, 0);
  patch_u32(f, 172, uint32_t(crc32(0, reinterpret_cast<const Bytef*>(f.data()), uInt(header))));
}

// Opens `path` expecting an error that names it and contains every needle.
void expect_open_error(const std::string& path, std::initializer_list<std::string> needles) {
  try {
    BrickStoreReader s(path);
    ADD_FAILURE() << "opened a bad store; expected " << *needles.begin();
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    for (const std::string& n : needles) EXPECT_NE(what.find(n), std::string::npos) << what;
  }
}

class BrickStoreCorruption : public ::testing::Test {
 protected:
  void SetUp() override {
    t_ = make_test_store(8, 3);
    path_ = dir_.file("good.ugvr");
    write_test_store(t_, path_);
    good_ = read_file(path_);
    bad_ = dir_.file("bad.ugvr");
  }
  ScratchDir dir_;
  TestStore t_;
  std::string path_, good_, bad_;
};

TEST_F(BrickStoreCorruption, Truncated) {
  write_file(bad_, good_.substr(0, good_.size() - 100));
  expect_open_error(bad_, {"truncated", "byte"});
  write_file(bad_, good_.substr(0, 100));
  expect_open_error(bad_, {"shorter than its header"});
  write_file(bad_, good_ + "junk");
  expect_open_error(bad_, {"appended"});
  write_file(bad_, "");
  expect_open_error(bad_, {"not a ugvr brick store"});
}

TEST_F(BrickStoreCorruption, WrongMagicOrVersion) {
  std::string f = good_;
  f[1] = 'X';
  write_file(bad_, f);
  expect_open_error(bad_, {"byte 0", "wrong magic"});
  f = good_;
  patch_u32(f, 8, 1);  // a store of the previous format: its blocks quantize each brick on a grid of its own
  write_file(bad_, f);
  expect_open_error(bad_, {"byte 8", "version 1", "reads versions 2 to 6", "rebuild"});
  f = good_;
  patch_u32(f, 8, 7);
  write_file(bad_, f);
  expect_open_error(bad_, {"byte 8", "version 7", "newer"});
}

TEST_F(BrickStoreCorruption, FlippedHeaderOrNodeTableByte) {
  std::string f = good_;
  f[60] ^= 1;  // in the root bounds
  write_file(bad_, f);
  expect_open_error(bad_, {"byte 172", "header checksum mismatch"});
  f = good_;
  const size_t table = get_u64(f, 152);
  f[table + 200] ^= 0x10;
  write_file(bad_, f);
  expect_open_error(bad_, {"byte " + std::to_string(table), "node table checksum mismatch"});
  // A structural error with valid checksums: node 3's level.
  f = good_;
  const size_t rec = get_u32(f, 24);
  f[table + 3 * rec + 36] = 5;
  reseal(f);
  write_file(bad_, f);
  expect_open_error(bad_, {"byte " + std::to_string(table + 3 * rec + 24), "node 3"});
  // A block that would run into the node table.
  f = good_;
  patch_u32(f, table + 2 * rec + 48 + 16, 1u << 30);
  reseal(f);
  write_file(bad_, f);
  expect_open_error(bad_, {"node 2", "outside the block area"});
}

TEST_F(BrickStoreCorruption, FlippedBrickByteIsReportedNotRendered) {
  std::string f = good_;
  // Node 5's second field, in the middle of its compressed payload.
  const BrickStoreReader good(path_);
  ASSERT_TRUE(good.node(5).has_brick());
  const BlockRef b = good.block(5, 1);
  f[b.offset + b.size / 2] ^= 0x40;
  write_file(bad_, f);
  const BrickStoreReader s(bad_);  // the tables are intact: opening succeeds
  std::vector<float> out(cube(8), 12345.0f);
  try {
    s.read_brick(5, 1, out.data(), nullptr);
    FAIL() << "corrupt brick decoded";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(bad_ + ": byte " + std::to_string(b.offset)), std::string::npos) << what;
    EXPECT_NE(what.find("node 5 field 'velocity:x'"), std::string::npos) << what;
    EXPECT_NE(what.find("checksum mismatch"), std::string::npos) << what;
  }
  EXPECT_TRUE(std::all_of(out.begin(), out.end(), [](float v) { return v == 12345.0f; }));  // nothing written
  std::vector<std::byte> raw(b.size);
  EXPECT_THROW(s.read_block(5, 1, raw.data()), Error);
  // Other bricks still read.
  EXPECT_NO_THROW(s.read_brick(5, 0, out.data(), nullptr));
}

// ---------------------------------------------------------------------------------------------------------------
// Interrupted builds

// ---- the transfer-function error table (format version 3) ----------------------------------------------------------

// Entries whose every byte depends on node, field and position, so a misplaced entry shows.
std::vector<store_format::TfErrorEntry> tf_entries(uint64_t nodes, uint32_t fields) {
  std::vector<store_format::TfErrorEntry> out(nodes * fields);
  for (uint64_t i = 0; i < out.size(); ++i) {
    store_format::TfErrorEntry& e = out[i];
    for (int g = 0; g <= store_format::kTfErrorGroups; ++g) e.bound[g] = uint16_t(i * 31 + uint64_t(g) * 977);
    for (int g = 0; g < store_format::kTfErrorGroups; ++g) {
      e.spread[g] = uint16_t(i * 7 + uint64_t(g));
      e.weight[g] = uint8_t(i + uint64_t(g) * 3);
    }
  }
  return out;
}

TEST(BrickStore, TfErrorTableRoundTripAndChecksum) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("tf.ugvr");
  const auto entries = tf_entries(t.nodes.size(), 3);
  {
    BrickStoreWriter w(path, t.layout);
    for (size_t id = 0; id < t.nodes.size(); ++id) {
      if (t.masks[id].empty()) continue;
      const float* fields[3] = {t.samples[id][0].data(), t.samples[id][1].data(), t.samples[id][2].data()};
      w.add_brick(id, fields, t.masks[id].data());
    }
    w.commit(t.nodes, t.errors, entries);
  }
  std::string good = read_file(path);
  uint64_t table_at = 0;
  {
    const BrickStoreReader s(path);
    check_store(t, s);
    ASSERT_TRUE(s.has_tf_errors());
    ASSERT_EQ(s.tf_errors().size(), entries.size());
    EXPECT_EQ(std::memcmp(s.tf_errors().data(), entries.data(), entries.size() * sizeof(entries[0])), 0);
    table_at = s.tf_error_header().table_offset;
    EXPECT_EQ(s.tf_error_header().entry_size, 44u);
    EXPECT_EQ(s.tf_error_header().table_size, entries.size() * 44);
    // Between the blocks and the node table, at the offset the header names (byte 176 of a version 3 header).
    EXPECT_EQ(get_u64(good, 176), table_at);
    EXPECT_EQ(std::memcmp(good.data() + table_at, entries.data(), 44), 0);
  }
  // A flipped byte in the table: the open fails naming the table and its offset.
  const std::string bad = dir.file("bad.ugvr");
  std::string f = good;
  f[table_at + 100] ^= 4;
  write_file(bad, f);
  expect_open_error(bad, {"transfer-function error table checksum mismatch", "byte " + std::to_string(table_at)});
  // A table size that does not match the node count, the header resealed: refused before reading.
  f = good;
  std::memcpy(f.data() + 176 + 8, "\x01\x00\x00\x00\x00\x00\x00\x00", 8);
  reseal(f);
  write_file(bad, f);
  expect_open_error(bad, {"transfer-function error table of 1 bytes", "byte 184"});
  // Without a table (the default commit), the store opens and says so.
  const std::string plain = dir.file("plain.ugvr");
  write_test_store(t, plain);
  const BrickStoreReader p(plain);
  EXPECT_FALSE(p.has_tf_errors());
  EXPECT_TRUE(p.tf_errors().empty());
  // The writer refuses a table of the wrong size.
  BrickStoreWriter w(dir.file("w.ugvr"), t.layout);
  EXPECT_THROW(w.commit(t.nodes, t.errors, std::span(entries).first(5)), Error);
}

// An older store: the same file less `bytes` of header records at `at`, every offset after them moved back.
std::string older_store(std::string f, uint32_t version, uint64_t at, uint64_t bytes, uint64_t nodes) {
  f.erase(at, bytes);
  patch_u32(f, 8, version);
  patch_u32(f, 12, get_u32(f, 12) - uint32_t(bytes));
  const uint64_t table = get_u64(f, 152) - bytes, size = get_u64(f, 160) - bytes;
  std::memcpy(f.data() + 152, &table, 8);
  std::memcpy(f.data() + 160, &size, 8);
  const uint64_t rec = get_u32(f, 24);
  for (uint64_t id = 0; id < nodes; ++id) {
    const uint64_t where = table + id * rec + 16;  // NodeRecord::brick_offset
    uint64_t offset = get_u64(f, where);
    if (offset) offset -= bytes;
    std::memcpy(f.data() + where, &offset, 8);
  }
  reseal(f);
  return f;
}

// A version 2 store (before the table): without the 24-byte TfErrorHeaderRecord, the 40-byte BoundaryHeaderRecord and
// the 32-byte CellsHeaderRecord. It must still open, with none of them.
TEST(BrickStore, Version2StoresStillOpen) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("v4.ugvr");
  write_test_store(t, path);
  const std::string v2 = dir.file("v2.ugvr");
  write_file(v2, older_store(read_file(path), 2, 176, 24 + 40 + 32, t.nodes.size()));
  const BrickStoreReader s(v2);
  EXPECT_EQ(s.header().version, 2u);
  EXPECT_FALSE(s.has_tf_errors());
  EXPECT_FALSE(s.has_boundary());
  check_store(t, s);
}

// A version 3 store (before the boundary faces): without the BoundaryHeaderRecord and the CellsHeaderRecord. It opens,
// with no faces.
TEST(BrickStore, Version3StoresStillOpen) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("v4.ugvr");
  write_test_store(t, path);
  const std::string v3 = dir.file("v3.ugvr");
  write_file(v3, older_store(read_file(path), 3, 200, 40 + 32, t.nodes.size()));
  const BrickStoreReader s(v3);
  EXPECT_EQ(s.header().version, 3u);
  EXPECT_FALSE(s.has_boundary());
  check_store(t, s);
}

// A version 4 store (before the cells): without the CellsHeaderRecord. It opens, with no cells.
TEST(BrickStore, Version4StoresStillOpen) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("v5.ugvr");
  write_test_store(t, path);
  const std::string v4 = dir.file("v4.ugvr");
  write_file(v4, older_store(read_file(path), 4, 240, 32, t.nodes.size()));
  const BrickStoreReader s(v4);
  EXPECT_EQ(s.header().version, 4u);
  EXPECT_FALSE(s.has_cells());
  EXPECT_EQ(s.cell_block(0).offset, 0u);
  check_store(t, s);
}

TEST(BrickStoreAtomicity, WriterDestroyedBeforeCommit) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("out.ugvr");
  {
    BrickStoreWriter w(path, t.layout);
    for (size_t id = 0; id < 5; ++id) {
      if (t.masks[id].empty()) continue;
      const float* fields[3] = {t.samples[id][0].data(), t.samples[id][1].data(), t.samples[id][2].data()};
      w.add_brick(id, fields, t.masks[id].data());
    }
    EXPECT_EQ(count_entries(dir.file("")), 1u);   // the temporary exists while building,
    EXPECT_FALSE(std::filesystem::exists(path));  // the output does not
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_EQ(count_entries(dir.file("")), 0u);
}

TEST(BrickStoreAtomicity, ExceptionMidBuild) {
  ScratchDir dir;
  const TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("out.ugvr");
  write_file(path, "an older file the failed build must not replace");
  auto build = [&] {
    BrickStoreWriter w(path, t.layout);
    for (size_t id = 0; id < t.nodes.size(); ++id) {
      if (id == 7) throw std::runtime_error("voxelizer failed");
      if (t.masks[id].empty()) continue;
      const float* fields[3] = {t.samples[id][0].data(), t.samples[id][1].data(), t.samples[id][2].data()};
      w.add_brick(id, fields, t.masks[id].data());
    }
    w.commit(t.nodes, t.errors);
  };
  EXPECT_THROW(build(), std::runtime_error);
  EXPECT_EQ(read_file(path), "an older file the failed build must not replace");
  EXPECT_EQ(count_entries(dir.file("")), 1u);
}

TEST(BrickStoreAtomicity, InvalidTreeCommitsNothing) {
  ScratchDir dir;
  TestStore t = make_test_store(8, 3);
  const std::string path = dir.file("out.ugvr");
  {
    BrickStoreWriter w(path, t.layout);
    const float* fields[3] = {t.samples[0][0].data(), t.samples[0][1].data(), t.samples[0][2].data()};
    w.add_brick(0, fields, t.masks[0].data());
    EXPECT_THROW(w.add_brick(0, fields, t.masks[0].data()), Error);  // a second brick for node 0
    t.nodes[4].i ^= 1;                                               // no longer where its parent says
    try {
      w.commit(t.nodes, t.errors);
      FAIL() << "invalid tree committed";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("node 4"), std::string::npos) << e.what();
    }
    EXPECT_THROW(w.commit(t.nodes, t.errors), Error);  // unusable after a failure
  }
  EXPECT_EQ(count_entries(dir.file("")), 0u);
  {
    BrickStoreWriter w(path, t.layout);
    const float* fields[3] = {t.samples[0][0].data(), t.samples[0][1].data(), t.samples[0][2].data()};
    w.add_brick(1000, fields, t.masks[0].data());
    std::vector<OctreeNode> root_only(1);
    EXPECT_THROW(w.commit(root_only), Error);  // a brick for a node the tree does not have
  }
  EXPECT_EQ(count_entries(dir.file("")), 0u);
}

TEST(BrickStoreAtomicity, InvalidLayoutRejected) {
  ScratchDir dir;
  BrickStoreLayout l;
  l.root = Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
  l.fields = {{"p", Association::Vertex, 0.0, 1.0}};
  l.tolerance = 1e-6;  // finer than 16 bits can honour
  EXPECT_THROW(BrickStoreWriter(dir.file("a.ugvr"), l), Error);
  l.tolerance = kQuant16Tolerance;
  l.resolution = 1;
  EXPECT_THROW(BrickStoreWriter(dir.file("a.ugvr"), l), Error);
  l.resolution = 8;
  l.fields.clear();
  EXPECT_THROW(BrickStoreWriter(dir.file("a.ugvr"), l), Error);
  EXPECT_EQ(count_entries(dir.file("")), 0u);
}

// A build killed outright (no destructor runs): nothing at the path, and the temporary it leaves cannot be mistaken
// for a store.
TEST(BrickStoreAtomicity, KilledBuildLeavesNothingValid) {
  ScratchDir dir;
  // Large enough bricks that the writer's buffer reaches the disk before the "crash".
  const TestStore t = make_test_store(32, 3);
  const std::string path = dir.file("out.ugvr");
  auto build_then_die = [&] {
    BrickStoreWriter w(path, t.layout);
    for (size_t id = 0; id < t.nodes.size(); ++id) {
      if (t.masks[id].empty()) continue;
      const float* fields[3] = {t.samples[id][0].data(), t.samples[id][1].data(), t.samples[id][2].data()};
      w.add_brick(id, fields, t.masks[id].data());
    }
    std::_Exit(3);  // as if killed before commit(): no destructor runs
  };
  EXPECT_EXIT(build_then_die(), ::testing::ExitedWithCode(3), "");
  EXPECT_FALSE(std::filesystem::exists(path));
  size_t temporaries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.file(""))) {
    ++temporaries;
    EXPECT_GT(std::filesystem::file_size(e.path()), 1u << 20);
    expect_open_error(e.path().string(), {"byte 0", "header is blank"});
  }
  EXPECT_EQ(temporaries, 1u);
}

}  // namespace
}  // namespace ugvr
