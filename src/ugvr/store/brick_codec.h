// Encoding of one brick: the R³ samples of one field of one octree node plus the node's validity mask, as one
// self-describing, independently compressed block. Pure functions of memory (no I/O): the store writer runs encode on
// many threads, the reader and a RAM cache decode blocks they fetched themselves. The choices (16-bit quantization,
// 3-D Lorenzo predictor, byte shuffle, zstd) and the measurements behind them are in docs/brick-store.md.
//
// Block layout: a 48-byte BlockRecord (store/brick_store_format.h: encoding, predictor, codec, flags, sizes, the valid
// samples' range and the Quant16 grid, each member with its offset), then the payload compressed by its codec.
//
// The decompressed payload is
//   [mask]   ceil(R³/8) bytes when flag bit 0 is set: bit (s & 7) of byte s / 8 is 1 where sample s has data
//   [values] one residual per VALID sample, in sample order (s = x + R·(y + R·z), x fastest): u16 for Quant16,
//            u32 for Float32; with flag bit 1 the residuals are split into byte planes (all low bytes first).
// Invalid samples cost nothing: they have no residual. Both sides give them the prediction clamped into the brick's
// range, so prediction runs over them without a discontinuity; decoding therefore returns, at invalid samples, a
// deterministic extrapolation of the valid ones within the decoded range: a usable pad for linear interpolation at
// the data boundary, but only the mask says what is data.
//
// Prediction p of sample (x, y, z) from the samples before it, as reconstructed (invalid ones as filled), with
// neighbours outside the brick taken as 0. Naming the neighbours
//   a = (x-1, y, z)  b = (x, y-1, z)  c = (x, y, z-1)  ab = (x-1, y-1, z)  ac = (x-1, y, z-1)  bc = (x, y-1, z-1)
//   abc = (x-1, y-1, z-1):
//   Lorenzo  p = a + ((b + c + abc) - (ab + ac + bc)), sums left to right (the grouping fixes float rounding)
//   DeltaX   p = a
//   None     p = 0
// Quant16: the values lie on a grid origin + i·step, i an integer. A valid sample v has grid index
// i = round((v - origin) · (1 / step)) (double arithmetic, halves away from zero) and code q = i - base in
// [0, qmax]; code q decodes to v' = float32(origin + double(base + q) · step), double arithmetic (base + q is exact),
// rounded to nearest. v' is a function of the grid index alone, so blocks that share origin and step (every block
// of a store field, see store/brick_store.h) decode equal input samples to bit-identical values, whatever their own
// range. |v' - v| <= step / 2 plus half a float32 ulp of v (and double rounding, ~1e-16 relative). Decoded values lie
// in [v'(0), v'(qmax)], which may reach step / 2 beyond [lo, hi]: there is no cap at hi, as a cap would depend on the
// block and break the identity. A code above qmax occurs only in a corrupt payload: the reader clamps it while
// decoding (so the output stays within that range) and then refuses the block. p is computed on codes in exact
// integers; residual = zigzag16((q - p) mod 2^16) (None: q itself); an invalid sample takes clamp(p, 0, qmax). Float32
// (lossless, bit exact): p is computed in float32; pc = clamp(p, lo, hi) (NaN -> lo); residual = zigzag32((ord(v) -
// ord(pc)) mod 2^32), ord mapping a float's bits to an unsigned integer of the same order so that nearby values give
// small residuals (None: the float's bits); an invalid sample takes pc. zigzag maps 0, -1, 1, -2, ... (the difference
// read as signed) to 0, 1, 2, 3, ...
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace ugvr {

enum class SampleEncoding : uint8_t { Quant16 = 1, Float32 = 2 };
enum class Predictor : uint8_t { None = 0, DeltaX = 1, Lorenzo = 2 };
enum class BrickCodec : uint8_t { Stored = 0, Lz4 = 1, Zstd = 2 };

std::string_view sample_encoding_name(SampleEncoding e);  // "quant16", "float32"
std::string_view predictor_name(Predictor p);             // "none", "delta-x", "lorenzo"
std::string_view brick_codec_name(BrickCodec c);          // "stored", "lz4", "zstd"

// How blocks are written. The default is the measured choice (docs/brick-store.md).
struct BrickEncoding {
  SampleEncoding samples = SampleEncoding::Quant16;
  Predictor predictor = Predictor::Lorenzo;
  bool shuffle = true;
  BrickCodec codec = BrickCodec::Zstd;
  // Zstd: compression level (<= 0: 3). Lz4: <= 0 the fast compressor, >= 1 LZ4HC at that level (same decoder).
  int level = 0;
};

inline constexpr size_t kBlockHeaderSize = 48;
inline constexpr uint32_t kMinBrickResolution = 2, kMaxBrickResolution = 512;  // a Float32 block stays < 4 GiB

// Bytes of a packed mask of r³ samples.
inline uint64_t mask_bytes(uint32_t r) { return (uint64_t(r) * r * r + 7) / 8; }

struct BlockHeader {
  SampleEncoding samples = SampleEncoding::Quant16;
  Predictor predictor = Predictor::None;
  BrickCodec codec = BrickCodec::Stored;
  bool has_mask = false, shuffled = false;
  uint32_t raw_size = 0;
  uint32_t valid = 0;
  float lo = 0, hi = 0;
  uint32_t qmax = 0;  // Quant16 grid (see the layout above); all 0 for Float32
  int64_t base = 0;
  double origin = 0, step = 0;
};

struct EncodedBlock {
  std::vector<std::byte> bytes;  // header + compressed payload
  uint32_t valid = 0;            // valid samples
  float lo = 0, hi = 0;          // range of the valid samples as given
  // Range of every value decode_brick returns (valid and filled samples): Float32 [lo, hi]; Quant16 within step / 2
  // of it, and not always containing it.
  float decoded_lo = 0, decoded_hi = 0;
  double step = 0;           // Quant16 step used (max error step / 2), 0 for Float32 and for exact constant bricks
  bool shared_grid = false;  // Quant16: on the caller's grid (quant_origin, quant_step)
};

// Encodes `samples` (r³ floats, x fastest) under `mask` (r³ bytes, nonzero = data; nullptr = all data).
// Quant16 only: quant_step > 0 puts the block on the grid quant_origin + i·quant_step, the same for every block
// encoded with the same two numbers, so that equal samples decode to equal values in all of them (neighbouring
// bricks share their border samples). A store passes 2 × tolerance × field range and the field's minimum. A brick
// that does not fit that grid in 16 bits (its valid samples span more than 65535 steps: values beyond the range the
// step was made for) or whose grid indices or decoded values would be out of range gets a grid of its own instead:
// origin its minimum, step max(quant_step, range / 65535); identity with its neighbours is then not promised.
// quant_step <= 0 always means a grid of the brick's own: its range over 65535 codes (exact for a constant brick).
// Throws ugvr::Error if no sample is valid (store no brick instead) or a valid sample is not finite (mask it).
EncodedBlock encode_brick(const BrickEncoding& encoding, uint32_t r, const float* samples, const uint8_t* mask,
                          double quant_step, double quant_origin = 0.0);

// Parses and checks a block header against r and the block's size. `file` and `offset` (of the block) name a bad
// block in the error.
BlockHeader parse_block_header(std::span<const std::byte> block, uint32_t r, std::string_view file, uint64_t offset);

// Decodes a block into r³ float samples and, if mask is not null, r³ mask bytes (1 = data, 0 = none). Thread-safe
// (scratch memory and decompression contexts are per thread). Corrupt blocks throw ugvr::Error naming file and
// offset; the block's checksum is the caller's (the store verifies it before decoding).
void decode_brick(std::span<const std::byte> block, uint32_t r, float* samples, uint8_t* mask, std::string_view file,
                  uint64_t offset);

}  // namespace ugvr
