// Base64 (RFC 4648, standard alphabet) as VTK XML uses it for format="binary" arrays and encoding="base64" appended
// data. The decoder is incremental, so arrays far larger than memory can be decoded chunk by chunk, and it accepts
// what VTK's writers produce:
//  - whitespace anywhere (line-wrapped text), skipped;
//  - several padded streams back to back ("AAAA==BBBB..."): VTK encodes a compressed array's block header and its
//    blocks as two separate streams, each padded on its own, so '=' ends a quantum, not the data;
//  - an unpadded final quantum (some writers drop the padding).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace ugvr {

class Base64Decoder {
 public:
  struct Result {
    size_t consumed = 0;  // input characters used
    size_t produced = 0;  // bytes written
    // Set when decoding stopped at a character that is neither base64 nor whitespace; consumed is its index.
    bool stopped_at_invalid = false;
  };

  // Decodes from `in` into `out` until either runs out (out needs room for 3 bytes to take another quantum) or an
  // invalid character is met. The partial quantum at the end of `in` is carried over to the next call.
  Result decode(std::string_view in, std::span<std::byte> out);
  // Ends the stream: writes the bytes of an unpadded final quantum (at most 2) into `out` and returns how many.
  // Returns -1 when the stream ends in the middle of a quantum that cannot be completed (a single character).
  int finish(std::span<std::byte> out);
  // True while a quantum is partly read (the stream cannot end here without finish()).
  bool mid_quantum() const { return chars_ != 0; }

 private:
  uint32_t bits_ = 0;  // the 6-bit groups of the quantum read so far
  int chars_ = 0;      // characters of the quantum read so far (0..3)
  int padding_ = 0;    // '=' seen in the current quantum
};

// Standard padded base64 of `data` (used by writers and tests).
std::string base64_encode(std::span<const std::byte> data);

}  // namespace ugvr
