#include "ugvr/store/brick_codec.h"

#include <lz4.h>
#include <lz4hc.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/store/brick_store_format.h"

namespace ugvr {

using store_format::BlockRecord;
static_assert(sizeof(BlockRecord) == kBlockHeaderSize);

std::string_view sample_encoding_name(SampleEncoding e) {
  switch (e) {
    case SampleEncoding::Quant16: return "quant16";
    case SampleEncoding::Float32: return "float32";
  }
  return "?";
}

std::string_view predictor_name(Predictor p) {
  switch (p) {
    case Predictor::None: return "none";
    case Predictor::DeltaX: return "delta-x";
    case Predictor::Lorenzo: return "lorenzo";
  }
  return "?";
}

std::string_view brick_codec_name(BrickCodec c) {
  switch (c) {
    case BrickCodec::Stored: return "stored";
    case BrickCodec::Lz4: return "lz4";
    case BrickCodec::Zstd: return "zstd";
  }
  return "?";
}

namespace {

using store_format::kBlockFlagMask;
using store_format::kBlockFlagShuffled;

// ---------------------------------------------------------------------------------------------------------------
// Per-thread state: encode and decode run on many threads at once, and a zstd context costs ~100 KiB to create,
// more than decoding a 32³ brick takes, so each thread keeps its own.

struct ZstdDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

ZSTD_CCtx* thread_cctx() {
  thread_local std::unique_ptr<ZSTD_CCtx, ZstdDeleter> ctx(ZSTD_createCCtx());
  return ctx.get();
}

ZSTD_DCtx* thread_dctx() {
  thread_local std::unique_ptr<ZSTD_DCtx, ZstdDeleter> ctx(ZSTD_createDCtx());
  return ctx.get();
}

struct Scratch {
  std::vector<std::byte> raw;
  std::vector<int32_t> int_planes;
  std::vector<float> float_planes;
  std::vector<uint16_t> code_planes, row;
  std::vector<int32_t> row_pred;
};

Scratch& thread_scratch() {
  thread_local Scratch s;
  return s;
}

// ---------------------------------------------------------------------------------------------------------------
// Integer maps that turn "close to the prediction" into "small unsigned number".

inline uint16_t zigzag16(uint16_t d) { return uint16_t((uint32_t(d) << 1) ^ ((d & 0x8000u) ? 0xFFFFu : 0u)); }
inline uint16_t unzigzag16(uint16_t z) { return uint16_t((z >> 1) ^ ((z & 1u) ? 0xFFFFu : 0u)); }
inline uint32_t zigzag32(uint32_t d) { return (d << 1) ^ ((d & 0x80000000u) ? 0xFFFFFFFFu : 0u); }
inline uint32_t unzigzag32(uint32_t z) { return (z >> 1) ^ ((z & 1u) ? 0xFFFFFFFFu : 0u); }

// Float bits to an unsigned integer of the same order (negative floats reversed below the positive ones), so the
// difference of two nearby floats is small whatever their sign and exponent.
inline uint32_t float_ord(float f) {
  const uint32_t b = std::bit_cast<uint32_t>(f);
  return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}
inline float ord_float(uint32_t o) { return std::bit_cast<float>((o & 0x80000000u) ? (o & 0x7FFFFFFFu) : ~o); }

// Quant16 grid indices stay within +-2^52 so that base + q is exact in double (and in the decoder's sum).
constexpr double kMaxGridIndex = 4503599627370496.0;  // 2^52

// The value of grid index i, as the format defines it (store/brick_codec.h): encoder (for the decoded range) and
// decoder must compute it the same way, bit for bit.
inline double grid_value(double origin, double index, double step) { return origin + index * step; }

inline bool in_float_range(double v) { return std::abs(v) <= double(std::numeric_limits<float>::max()); }

// A Quant16 block's grid: code q stands for index base + q.
struct Grid {
  double origin = 0, step = 0;
  int64_t base = 0;
  int32_t qmax = 0;
  bool shared = false;
};

inline float clamp_float(float p, float lo, float hi) {
  if (!(p >= lo)) return lo;  // also NaN (inf - inf in the predictor)
  return p > hi ? hi : p;
}

// ---------------------------------------------------------------------------------------------------------------
// The one traversal that both encoder and decoder run, so their predictions are identical by construction. Two
// z-planes of (r+1)² values with a zero border row and column stand for "neighbours outside the brick are 0";
// visit(s, prediction) returns the value sample s takes (the exact one, or the fill of an invalid sample).

template <class T, Predictor P, class Visit>
void traverse(uint32_t r, std::vector<T>& planes, Visit&& visit) {
  const size_t w = size_t(r) + 1, plane = w * w;
  planes.assign(2 * plane, T(0));
  T* prev = planes.data();
  T* cur = prev + plane;
  size_t s = 0;
  for (uint32_t z = 0; z < r; ++z) {
    for (uint32_t y = 0; y < r; ++y) {
      T* row = cur + (y + 1) * w + 1;
      const T* up = cur + y * w + 1;
      const T* back = prev + (y + 1) * w + 1;
      const T* back_up = prev + y * w + 1;
      // The x-1 neighbour is carried in a register: read back from memory, it would put a store-to-load forward
      // on the one serial dependency of decoding, which is what bounds its speed.
      T left = T(0);
      for (uint32_t x = 0; x < r; ++x, ++s) {
        T p;
        if constexpr (P == Predictor::None) {
          p = T(0);
        } else if constexpr (P == Predictor::DeltaX) {
          p = left;
        } else {
          const ptrdiff_t xm = ptrdiff_t(x) - 1;
          // This exact grouping, evaluated left to right, is part of the format (floats round by it).
          p = left + ((up[x] + back[x] + back_up[xm]) - (up[xm] + back[xm] + back_up[x]));
        }
        left = visit(s, p);
        row[x] = left;
      }
    }
    std::swap(prev, cur);
  }
}

// Where byte b of residual k of `count` lies: interleaved (little-endian) or in byte planes (all low bytes first).
template <int Bytes, bool Shuffled>
struct ResidualLayout {
  size_t count;
  size_t at(size_t k, int b) const { return Shuffled ? size_t(b) * count + k : k * Bytes + size_t(b); }
  void put(std::byte* base, size_t k, uint32_t v) const {
    for (int b = 0; b < Bytes; ++b) base[at(k, b)] = std::byte(v >> (8 * b));
  }
  uint32_t get(const std::byte* base, size_t k) const {
    uint32_t v = 0;
    for (int b = 0; b < Bytes; ++b) v |= uint32_t(base[at(k, b)]) << (8 * b);
    return v;
  }
};

inline bool mask_bit(const std::byte* bits, size_t s) { return (uint8_t(bits[s >> 3]) >> (s & 7)) & 1u; }

// Calls f.template operator()<P, Shuffled, HasMask>() for the runtime choices, so each combination gets a loop
// without branches on them.
template <class F>
void dispatch(Predictor p, bool shuffled, bool has_mask, F&& f) {
  auto with_mask = [&]<Predictor P, bool S>() {
    if (has_mask) {
      f.template operator()<P, S, true>();
    } else {
      f.template operator()<P, S, false>();
    }
  };
  auto with_shuffle = [&]<Predictor P>() {
    if (shuffled) {
      with_mask.template operator()<P, true>();
    } else {
      with_mask.template operator()<P, false>();
    }
  };
  switch (p) {
    case Predictor::None: with_shuffle.template operator()<Predictor::None>(); break;
    case Predictor::DeltaX: with_shuffle.template operator()<Predictor::DeltaX>(); break;
    case Predictor::Lorenzo: with_shuffle.template operator()<Predictor::Lorenzo>(); break;
  }
}

// Quant16 decoding, a row (fixed y, z) at a time. A row whose samples are all valid (every row of a brick without
// mask) takes three loops of which the compiler vectorizes the first and the last: (1) d = residual + the prediction
// from the rows already decoded (all of Lorenzo but the x-1 neighbour), (2) the x-1 dependency, now a running sum
// mod 2^16, (3) codes to floats. No prediction is clamped in such a row, so mod 2^16 arithmetic gives exactly the
// codes of traverse() (valid samples only need p mod 2^16), with one add per sample left serial: 2-3x faster. Rows
// with invalid samples run the scalar recurrence, which needs the exact prediction to clamp the fill.
// Returns the largest code met: above qmax only in a payload that the encoder did not write.
template <Predictor P, bool Shuffled>
uint16_t decode_quant16(uint32_t r, const std::byte* bits, const std::byte* values, size_t valid, const Grid& grid,
                        float* samples, Scratch& scratch) {
  const int32_t qmax = grid.qmax;
  const uint16_t qcap = uint16_t(qmax);
  const double origin = grid.origin, base = double(grid.base), step = grid.step;
  const size_t w = size_t(r) + 1, plane = w * w;
  scratch.code_planes.assign(2 * plane, 0);
  scratch.row.resize(r);
  scratch.row_pred.resize(r);
  uint16_t* d = scratch.row.data();
  int32_t* t = scratch.row_pred.data();
  uint16_t* prev = scratch.code_planes.data();
  uint16_t* cur = prev + plane;
  const auto* bytes = reinterpret_cast<const uint8_t*>(values);
  auto residual = [&](size_t k) {
    return Shuffled ? uint16_t(bytes[k] | bytes[valid + k] << 8) : uint16_t(bytes[2 * k] | bytes[2 * k + 1] << 8);
  };
  size_t s = 0, k = 0;
  uint16_t top = 0;
  for (uint32_t z = 0; z < r; ++z) {
    for (uint32_t y = 0; y < r; ++y, s += r) {
      uint16_t* row = cur + (y + 1) * w + 1;
      const uint16_t* up = cur + y * w + 1;
      const uint16_t* back = prev + (y + 1) * w + 1;
      const uint16_t* back_up = prev + y * w + 1;
      bool full = true;
      for (uint32_t x = 0; bits && full && x < r; ++x) full = mask_bit(bits, s + x);
      if (full) {
        for (uint32_t x = 0; x < r; ++x) {
          const uint16_t res = residual(k + x);
          if constexpr (P == Predictor::None) {
            row[x] = res;
          } else if constexpr (P == Predictor::DeltaX) {
            d[x] = unzigzag16(res);
          } else {
            const ptrdiff_t xm = ptrdiff_t(x) - 1;
            d[x] = uint16_t(((up[x] + back[x] + back_up[xm]) - (up[xm] + back[xm] + back_up[x])) + unzigzag16(res));
          }
        }
        if constexpr (P != Predictor::None) {
          uint16_t left = 0;
          for (uint32_t x = 0; x < r; ++x) {
            left = uint16_t(left + d[x]);
            row[x] = left;
          }
        }
        k += r;
      } else {
        // The prediction but for the x-1 term first (vectorized), then the serial recurrence with the clamps.
        for (uint32_t x = 0; x < r; ++x) {
          const ptrdiff_t xm = ptrdiff_t(x) - 1;
          t[x] = P == Predictor::Lorenzo ? (up[x] + back[x] + back_up[xm]) - (up[xm] + back[xm] + back_up[x]) : 0;
        }
        int32_t left = 0;
        for (uint32_t x = 0; x < r; ++x) {
          const int32_t p = P == Predictor::None ? 0 : left + t[x];
          if (mask_bit(bits, s + x)) {
            const uint16_t res = residual(k++);
            left = P == Predictor::None ? res : uint16_t(uint32_t(p) + unzigzag16(res));
          } else {
            left = std::clamp(p, 0, qmax);
          }
          row[x] = uint16_t(left);
        }
      }
      // The value depends on the grid index alone (no cap at the brick's hi), so that blocks on one grid agree. Codes
      // above qmax come only from a corrupt payload: clamped, they still decode to finite floats, and the caller
      // refuses the block (a checksum recomputed over a tampered payload must not pass as data).
      for (uint32_t x = 0; x < r; ++x) {
        top = std::max(top, row[x]);
        samples[s + x] = float(grid_value(origin, base + double(std::min(row[x], qcap)), step));
      }
    }
    std::swap(prev, cur);
  }
  return top;
}

// ---------------------------------------------------------------------------------------------------------------
// Compression of the payload.

size_t compress_payload(BrickCodec codec, int level, const std::vector<std::byte>& raw, std::vector<std::byte>& out,
                        size_t at) {
  switch (codec) {
    case BrickCodec::Stored: break;
    case BrickCodec::Lz4: {
      const int cap = LZ4_compressBound(int(raw.size()));
      out.resize(at + size_t(cap));
      const auto* src = reinterpret_cast<const char*>(raw.data());
      auto* dst = reinterpret_cast<char*>(out.data() + at);
      const int n = level <= 0 ? LZ4_compress_default(src, dst, int(raw.size()), cap)
                               : LZ4_compress_HC(src, dst, int(raw.size()), cap, level);
      if (n <= 0) throw Error("brick encode: lz4 compression failed");
      return size_t(n);
    }
    case BrickCodec::Zstd: {
      const size_t cap = ZSTD_compressBound(raw.size());
      out.resize(at + cap);
      const size_t n =
          ZSTD_compressCCtx(thread_cctx(), out.data() + at, cap, raw.data(), raw.size(), level <= 0 ? 3 : level);
      if (ZSTD_isError(n)) throw Error(std::string("brick encode: zstd compression failed: ") + ZSTD_getErrorName(n));
      return n;
    }
  }
  return raw.size();
}

void decompress_payload(BrickCodec codec, std::span<const std::byte> src, std::byte* dst, size_t size,
                        std::string_view file, uint64_t offset) {
  switch (codec) {
    case BrickCodec::Stored:
      if (size) std::memcpy(dst, src.data(), size);
      return;
    case BrickCodec::Lz4: {
      const int n = LZ4_decompress_safe(reinterpret_cast<const char*>(src.data()), reinterpret_cast<char*>(dst),
                                        int(src.size()), int(size));
      if (n < 0 || size_t(n) != size) {
        fail_at_offset(file, offset, "corrupt lz4 payload: expected " + std::to_string(size) + " bytes");
      }
      return;
    }
    case BrickCodec::Zstd: {
      const size_t n = ZSTD_decompressDCtx(thread_dctx(), dst, size, src.data(), src.size());
      if (ZSTD_isError(n) || n != size) {
        fail_at_offset(file, offset,
                       "corrupt zstd payload (" + std::string(ZSTD_isError(n) ? ZSTD_getErrorName(n) : "wrong size") +
                           "): expected " + std::to_string(size) + " bytes");
      }
      return;
    }
  }
}

// A sample's grid index: the encoder's one map from values to codes, for the block's range and for every sample.
inline int64_t grid_index(float v, double origin, double inv_step) {
  return std::llround((double(v) - origin) * inv_step);
}

// The grid of a Quant16 block whose valid samples span [lo, hi] (see encode_brick in store/brick_codec.h). Indices are
// monotone in the value, so every valid sample's code lies in [0, qmax].
Grid choose_grid(float lo, float hi, double quant_step, double quant_origin) {
  if (quant_step > 0 && std::isfinite(quant_step) && std::isfinite(quant_origin)) {
    const double inv = 1.0 / quant_step;
    const double first = (double(lo) - quant_origin) * inv, last = (double(hi) - quant_origin) * inv;
    if (std::abs(first) <= kMaxGridIndex / 2 && std::abs(last) <= kMaxGridIndex / 2) {
      const int64_t base = grid_index(lo, quant_origin, inv), top = grid_index(hi, quant_origin, inv);
      if (top - base <= 65535 && in_float_range(grid_value(quant_origin, double(base), quant_step)) &&
          in_float_range(grid_value(quant_origin, double(top), quant_step))) {
        return Grid{quant_origin, quant_step, base, int32_t(top - base), true};
      }
    }
  }
  // The brick's own grid from its minimum: code 0 decodes to lo exactly, and a constant brick is exact.
  Grid g{double(lo), 0.0, 0, 0, false};
  const double range = double(hi) - double(lo);
  if (!(range > 0)) return g;
  const double fit = range / 65535.0;
  g.step = quant_step >= fit && std::isfinite(quant_step) ? quant_step : fit;
  // Rounding may leave the step a hair too small for 16 bits, or the top code a hair beyond float32 (hi near its
  // limit): nudge it, a few ulps at most.
  for (int tries = 0; tries < 1000; ++tries) {
    const int64_t top = grid_index(hi, g.origin, 1.0 / g.step);
    if (top > 65535) {
      g.step = std::nextafter(g.step, INFINITY);
    } else if (!in_float_range(grid_value(g.origin, double(top), g.step))) {
      g.step = g.step > fit ? fit : std::nextafter(g.step, 0.0);
    } else {
      g.qmax = int32_t(top);
      return g;
    }
  }
  throw Error("brick encode: no 16-bit quantization grid found for the range [" + std::to_string(lo) + ", " +
              std::to_string(hi) + "]");
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------

EncodedBlock encode_brick(const BrickEncoding& enc, uint32_t r, const float* samples, const uint8_t* mask,
                          double quant_step, double quant_origin) {
  if (r < kMinBrickResolution || r > kMaxBrickResolution) {
    throw Error("brick encode: resolution " + std::to_string(r) + " outside [2, 512]");
  }
  const size_t n = size_t(r) * r * r;
  const bool quant = enc.samples == SampleEncoding::Quant16;

  // Range and count of the valid samples; every valid sample must be a number the renderer can use.
  EncodedBlock out;
  float lo = INFINITY, hi = -INFINITY;
  size_t valid = 0;
  for (size_t s = 0; s < n; ++s) {
    if (mask && !mask[s]) continue;
    const float v = samples[s];
    if (!std::isfinite(v)) {
      throw Error("brick encode: sample " + std::to_string(s) + " is " + std::to_string(v) +
                  "; mark samples without a finite value as invalid in the mask");
    }
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    ++valid;
  }
  if (valid == 0) throw Error("brick encode: no valid sample (an empty node is stored without a brick)");
  const bool has_mask = valid != n;

  Grid grid;
  if (quant) grid = choose_grid(lo, hi, quant_step, quant_origin);
  const int32_t qmax = grid.qmax;

  Scratch& scratch = thread_scratch();
  const size_t value_bytes = quant ? 2 : 4;
  const size_t mbytes = has_mask ? size_t(mask_bytes(r)) : 0;
  std::vector<std::byte>& raw = scratch.raw;
  raw.assign(mbytes + valid * value_bytes, std::byte{0});
  for (size_t s = 0; has_mask && s < n; ++s) {
    if (mask[s]) raw[s >> 3] |= std::byte(1u << (s & 7));
  }
  std::byte* values = raw.data() + mbytes;

  const double origin = grid.origin, inv_step = grid.step > 0 ? 1.0 / grid.step : 0.0;
  const int64_t base = grid.base;
  dispatch(enc.predictor, enc.shuffle, has_mask, [&]<Predictor P, bool Shuffled, bool HasMask>() {
    size_t k = 0;
    if (quant) {
      const ResidualLayout<2, Shuffled> io{valid};
      traverse<int32_t, P>(r, scratch.int_planes, [&](size_t s, int32_t p) -> int32_t {
        if (HasMask && !mask[s]) return std::clamp(p, 0, qmax);
        // choose_grid's arithmetic: the codes of lo and hi are 0 and qmax, and the clamp a mere safeguard.
        const int32_t q = int32_t(std::clamp<int64_t>(grid_index(samples[s], origin, inv_step) - base, 0, qmax));
        io.put(values, k++, P == Predictor::None ? uint32_t(q) : zigzag16(uint16_t(q - p)));
        return q;
      });
    } else {
      const ResidualLayout<4, Shuffled> io{valid};
      traverse<float, P>(r, scratch.float_planes, [&](size_t s, float p) -> float {
        const float pc = clamp_float(p, lo, hi);
        if (HasMask && !mask[s]) return pc;
        const float v = samples[s];
        io.put(values, k++, P == Predictor::None ? std::bit_cast<uint32_t>(v) : zigzag32(float_ord(v) - float_ord(pc)));
        return v;
      });
    }
  });

  out.bytes.resize(kBlockHeaderSize);
  BrickCodec codec = enc.codec;
  size_t payload = compress_payload(codec, enc.level, raw, out.bytes, kBlockHeaderSize);
  if (payload >= raw.size()) {  // incompressible (noise): store, which also decodes fastest
    codec = BrickCodec::Stored;
    payload = raw.size();
  }
  out.bytes.resize(kBlockHeaderSize + payload);
  if (codec == BrickCodec::Stored && !raw.empty())
    std::memcpy(out.bytes.data() + kBlockHeaderSize, raw.data(), payload);

  BlockRecord h;
  h.samples = uint8_t(enc.samples);
  h.predictor = uint8_t(enc.predictor);
  h.codec = uint8_t(codec);
  h.flags = uint8_t((has_mask ? kBlockFlagMask : 0) | (enc.shuffle ? kBlockFlagShuffled : 0));
  h.raw_size = uint32_t(raw.size());
  h.valid = uint32_t(valid);
  h.lo = lo;
  h.hi = hi;
  h.qmax = uint32_t(grid.qmax);
  h.base = grid.base;
  h.origin = grid.origin;
  h.step = grid.step;
  store_format::write_record(out.bytes.data(), h);
  out.valid = uint32_t(valid);
  out.lo = lo;
  out.hi = hi;
  out.decoded_lo = lo;
  out.decoded_hi = hi;
  if (quant) {
    out.decoded_lo = float(grid_value(grid.origin, double(grid.base), grid.step));
    out.decoded_hi = float(grid_value(grid.origin, double(grid.base) + double(grid.qmax), grid.step));
  }
  out.step = grid.step;
  out.shared_grid = grid.shared;
  return out;
}

BlockHeader parse_block_header(std::span<const std::byte> block, uint32_t r, std::string_view file, uint64_t offset) {
  if (block.size() < kBlockHeaderSize) {
    fail_at_offset(file, offset,
                   "brick block of " + std::to_string(block.size()) + " bytes is shorter than its " +
                       std::to_string(kBlockHeaderSize) + "-byte header");
  }
  const BlockRecord rec = store_format::read_record<BlockRecord>(block.data());
  // Where a member of the record lies in the file, for messages.
  auto at = [offset](size_t member_offset) { return offset + member_offset; };
  if (rec.samples != 1 && rec.samples != 2) {
    fail_at_offset(file, at(offsetof(BlockRecord, samples)),
                   "unknown sample encoding " + std::to_string(rec.samples) + " (1 quant16, 2 float32)");
  }
  if (rec.predictor > 2) {
    fail_at_offset(file, at(offsetof(BlockRecord, predictor)),
                   "unknown predictor " + std::to_string(rec.predictor) + " (0 none, 1 delta-x, 2 lorenzo)");
  }
  if (rec.codec > 2) {
    fail_at_offset(file, at(offsetof(BlockRecord, codec)),
                   "unknown codec " + std::to_string(rec.codec) + " (0 stored, 1 lz4, 2 zstd)");
  }
  if (rec.flags & ~(kBlockFlagMask | kBlockFlagShuffled)) {
    fail_at_offset(file, at(offsetof(BlockRecord, flags)), "unknown block flags " + std::to_string(rec.flags));
  }
  BlockHeader h;
  h.samples = SampleEncoding(rec.samples);
  h.predictor = Predictor(rec.predictor);
  h.codec = BrickCodec(rec.codec);
  h.has_mask = rec.flags & kBlockFlagMask;
  h.shuffled = rec.flags & kBlockFlagShuffled;
  h.raw_size = rec.raw_size;
  h.valid = rec.valid;
  h.lo = rec.lo;
  h.hi = rec.hi;
  h.qmax = rec.qmax;
  h.base = rec.base;
  h.origin = rec.origin;
  h.step = rec.step;

  const uint64_t n = uint64_t(r) * r * r;
  if (h.valid == 0 || h.valid > n || (!h.has_mask && h.valid != n)) {
    fail_at_offset(file, at(offsetof(BlockRecord, valid)),
                   "valid sample count " + std::to_string(h.valid) + " impossible for a " + std::to_string(r) +
                       "³ brick" + (h.has_mask ? "" : " without a mask"));
  }
  const uint64_t expect =
      (h.has_mask ? mask_bytes(r) : 0) + uint64_t(h.valid) * (h.samples == SampleEncoding::Quant16 ? 2 : 4);
  if (h.raw_size != expect) {
    fail_at_offset(file, at(offsetof(BlockRecord, raw_size)),
                   "payload size " + std::to_string(h.raw_size) + " does not match " + std::to_string(h.valid) +
                       " valid samples (expected " + std::to_string(expect) + ")");
  }
  if (h.codec == BrickCodec::Stored && block.size() - kBlockHeaderSize != h.raw_size) {
    fail_at_offset(file, offset + kBlockHeaderSize,
                   "stored payload of " + std::to_string(block.size() - kBlockHeaderSize) + " bytes, expected " +
                       std::to_string(h.raw_size));
  }
  if (!std::isfinite(h.lo) || !std::isfinite(h.hi) || !(h.lo <= h.hi)) {
    fail_at_offset(file, at(offsetof(BlockRecord, lo)),
                   "invalid brick range [" + std::to_string(h.lo) + ", " + std::to_string(h.hi) + "]");
  }
  if (h.samples == SampleEncoding::Quant16) {
    if (h.qmax > 65535)
      fail_at_offset(file, at(offsetof(BlockRecord, qmax)), "largest code " + std::to_string(h.qmax) + " above 65535");
    // Written so that no extreme base overflows: base + q must stay exact in double.
    if (h.base < -int64_t(kMaxGridIndex) || h.base > int64_t(kMaxGridIndex) - int64_t(h.qmax)) {
      fail_at_offset(
          file, at(offsetof(BlockRecord, base)),
          "grid index base " + std::to_string(h.base) + " + codes up to " + std::to_string(h.qmax) + " outside +-2^52");
    }
    if (!std::isfinite(h.origin)) {
      fail_at_offset(file, at(offsetof(BlockRecord, origin)),
                     "quantization grid origin " + std::to_string(h.origin) + " is not finite");
    }
    if (!std::isfinite(h.step) || h.step < 0 || (h.qmax > 0 && !(h.step > 0))) {
      fail_at_offset(
          file, at(offsetof(BlockRecord, step)),
          "invalid quantization step " + std::to_string(h.step) + " for codes up to " + std::to_string(h.qmax));
    }
    const double first = grid_value(h.origin, double(h.base), h.step),
                 last = grid_value(h.origin, double(h.base) + double(h.qmax), h.step);
    if (!in_float_range(first) || !in_float_range(last)) {
      fail_at_offset(
          file, at(offsetof(BlockRecord, base)),
          "quantization grid decodes to [" + std::to_string(first) + ", " + std::to_string(last) + "], beyond float32");
    }
    // The encoder gives lo code 0 and hi code qmax (choose_grid, with grid_index's arithmetic), so a grid that does
    // not map [lo, hi] onto [0, qmax] cannot come from it: with qmax too small every sample would be clamped to a
    // few codes and decode to values the brick never had. A grid of step 0 is a constant brick's (lo = hi = origin).
    if (h.step > 0) {
      const double inv = 1.0 / h.step;
      // Far-off indices (beyond 2^53, where llround is undefined) are reported as such rather than computed.
      auto code_of = [&](float v) {
        const double i = (double(v) - h.origin) * inv;
        return std::abs(i) <= 2 * kMaxGridIndex ? grid_index(v, h.origin, inv) - h.base
                                                : std::numeric_limits<int64_t>::min();
      };
      const int64_t lo_code = code_of(h.lo), hi_code = code_of(h.hi);
      if (lo_code != 0 || hi_code != int64_t(h.qmax)) {
        fail_at_offset(file, at(offsetof(BlockRecord, qmax)),
                       "quantization grid maps the brick's range [" + std::to_string(h.lo) + ", " +
                           std::to_string(h.hi) + "] to codes [" + std::to_string(lo_code) + ", " +
                           std::to_string(hi_code) + "], not [0, " + std::to_string(h.qmax) +
                           "] (largest code qmax inconsistent with the range)");
      }
    } else if (h.qmax != 0 || h.lo != h.hi || float(h.origin) != h.lo) {
      fail_at_offset(file, at(offsetof(BlockRecord, step)),
                     "quantization step 0 for the range [" + std::to_string(h.lo) + ", " + std::to_string(h.hi) +
                         "] with origin " + std::to_string(h.origin) + ": only a constant brick has no step");
    }
  } else if (h.qmax != 0 || h.base != 0 || h.origin != 0 || h.step != 0) {
    fail_at_offset(file, at(offsetof(BlockRecord, qmax)), "float32 block with quantization grid fields");
  }
  return h;
}

void decode_brick(std::span<const std::byte> block, uint32_t r, float* samples, uint8_t* mask, std::string_view file,
                  uint64_t offset) {
  if (r < kMinBrickResolution || r > kMaxBrickResolution) {
    fail_in(file, "brick resolution " + std::to_string(r) + " outside [2, 512]");
  }
  const BlockHeader h = parse_block_header(block, r, file, offset);
  const size_t n = size_t(r) * r * r;
  const std::span<const std::byte> payload = block.subspan(kBlockHeaderSize);

  Scratch& scratch = thread_scratch();
  const std::byte* raw = payload.data();
  if (h.codec != BrickCodec::Stored) {
    scratch.raw.resize(h.raw_size);
    decompress_payload(h.codec, payload, scratch.raw.data(), h.raw_size, file, offset + kBlockHeaderSize);
    raw = scratch.raw.data();
  }

  const std::byte* bits = raw;
  const size_t mbytes = h.has_mask ? size_t(mask_bytes(r)) : 0;
  if (h.has_mask) {
    uint64_t count = 0;
    size_t i = 0;
    for (; i + 8 <= n / 8; i += 8) {  // 64 bits at a time: without -mpopcnt each popcount is a library call
      uint64_t word;
      std::memcpy(&word, bits + i, 8);
      count += uint64_t(std::popcount(word));
    }
    for (; i < n / 8; ++i) count += uint64_t(std::popcount(uint8_t(bits[i])));
    if (n % 8) {
      const uint8_t last = uint8_t(bits[n / 8]);
      if (last >> (n % 8)) fail_at_offset(file, offset, "mask has bits set past the last sample");
      count += uint64_t(std::popcount(last));
    }
    if (count != h.valid) {
      fail_at_offset(
          file, offset + offsetof(BlockRecord, valid),
          "mask marks " + std::to_string(count) + " valid samples, the header says " + std::to_string(h.valid));
    }
  }
  const std::byte* values = raw + mbytes;

  const bool quant = h.samples == SampleEncoding::Quant16;
  if (quant) {
    const Grid grid{h.origin, h.step, h.base, int32_t(h.qmax), false};
    uint16_t top = 0;
    dispatch(h.predictor, h.shuffled, false, [&]<Predictor P, bool Shuffled, bool>() {
      top = decode_quant16<P, Shuffled>(r, h.has_mask ? bits : nullptr, values, h.valid, grid, samples, scratch);
    });
    if (top > h.qmax) {
      fail_at_offset(file, offset + kBlockHeaderSize,
                     "payload holds code " + std::to_string(top) + ", above the block's largest code qmax " +
                         std::to_string(h.qmax));
    }
  } else {
    dispatch(h.predictor, h.shuffled, h.has_mask, [&]<Predictor P, bool Shuffled, bool HasMask>() {
      size_t k = 0;
      const ResidualLayout<4, Shuffled> io{h.valid};
      traverse<float, P>(r, scratch.float_planes, [&](size_t s, float p) -> float {
        float v = clamp_float(p, h.lo, h.hi);
        if (!HasMask || mask_bit(bits, s)) {
          const uint32_t res = io.get(values, k++);
          v = P == Predictor::None ? std::bit_cast<float>(res) : ord_float(float_ord(v) + unzigzag32(res));
        }
        samples[s] = v;
        return v;
      });
    });
  }

  if (mask) {
    if (!h.has_mask) {
      std::memset(mask, 1, n);
    } else {
      for (size_t i = 0; i < n / 8; ++i) {
        const auto b = uint8_t(bits[i]);
        for (int j = 0; j < 8; ++j) mask[8 * i + size_t(j)] = uint8_t(b >> j & 1u);
      }
      for (size_t s = n / 8 * 8; s < n; ++s) mask[s] = uint8_t(mask_bit(bits, s));
    }
  }
}

}  // namespace ugvr
