// Sequential decoding of one VTK XML <DataArray>, whatever its encoding, in chunks: arrays far larger than memory
// are read straight into their destination without a whole-array copy of the file's bytes.
//
// Layouts (VTK's vtkXMLDataParser / vtkXMLWriter):
//   format="ascii"     element text: values separated by whitespace; never compressed.
//   format="binary"    element text: base64 of [header][data].
//   format="appended"  from <AppendedData>'s '_' + the array's offset attribute: [header][data], raw bytes when
//                      encoding="raw", base64 (offset counted in characters) when encoding="base64".
// Header words are UInt32 or UInt64 (VTKFile header_type, default UInt32), in the file's byte_order:
//   uncompressed:  [nbytes] followed by nbytes of values.
//   compressed:    [nblocks][block size][size of the last block, 0 = full][compressed size of each block]
//                  followed by the compressed blocks back to back; every block decompresses to the block size except
//                  the last. Inline base64 encodes header and blocks as two separately padded streams; the base64
//                  decoder accepts that as one byte sequence.
// Values are in byte_order; BigEndian values are swapped to native order as they are read.
//
// Every size read from the file is checked before anything is allocated for it: a header's byte count against the
// bytes the file still has (base64: 3/4 of the characters), compressed block sizes against the bytes available and
// against the largest expansion zlib (1032:1) or LZ4 (255:1) can produce. Failures throw ugvr::Error naming the
// file, a byte offset and the array.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/grid/data_array.h"
#include "ugvr/io/codec.h"

namespace ugvr {

// File-wide settings from <VTKFile> and <AppendedData>.
struct XmlEncoding {
  bool big_endian = false;
  bool header_uint64 = false;
  Codec codec = Codec::None;
  bool appended_base64 = false;
  std::optional<uint64_t> appended_data;  // file offset of the first byte after '_'
};

enum class XmlArrayFormat : uint8_t { Ascii, Binary, Appended };

// One <DataArray> as found in the markup.
struct XmlArray {
  std::string label;            // for messages, e.g. "<PointData> DataArray 'pressure'"
  uint64_t element_offset = 0;  // file offset of the <DataArray> tag
  std::string name;             // Name attribute ("" when absent)
  ScalarType type = ScalarType::Float32;
  int components = 1;
  XmlArrayFormat format = XmlArrayFormat::Ascii;
  // Ascii and Binary: the element's text [begin, end) in the file (empty when the element has none).
  // Appended: begin = appended data start + offset attribute, end = end of file.
  uint64_t begin = 0, end = 0;
};

class XmlByteSource;
class XmlBinaryStream;
class XmlAsciiTokens;

class XmlArrayReader {
 public:
  // Binary and appended arrays have their header read (and checked) here.
  XmlArrayReader(const InputFile& file, const XmlEncoding& encoding, const XmlArray& array);
  ~XmlArrayReader();
  XmlArrayReader(const XmlArrayReader&) = delete;
  XmlArrayReader& operator=(const XmlArrayReader&) = delete;

  const XmlArray& array() const { return array_; }
  // Values the array holds, from its header; nullopt for ascii arrays (known only once read).
  std::optional<uint64_t> value_count() const;
  // The file bytes [first, second) that hold the array as stored (encoded: its text, or its header and raw appended
  // bytes, compressed or not), found from the header without decoding the values; nullopt for appended base64, whose
  // text length the header does not give. Equal stored bytes under equal XmlEncoding decode to equal values.
  std::optional<std::pair<uint64_t, uint64_t>> stored_extent() const;
  // Checks that the array holds `count` values before the caller allocates for them: exactly, from the header, for
  // binary and appended arrays; for ascii arrays that the text is long enough (the exact count is checked by
  // finish()). `what` says where the count comes from, e.g. "NumberOfPoints=12 x 3 components".
  void expect_count(uint64_t count, const std::string& what);

  // The next out.size() values in the array's own type (T must be it), in native byte order.
  template <class T>
  void read_native(std::span<T> out);
  // The next out.size() values converted to T: to float/double by a cast; to int64_t only from integer arrays, with a
  // range check.
  void read(std::span<int64_t> out);
  void read(std::span<float> out);
  void read(std::span<double> out);
  // Passes over the next `count` values: a seek in raw (uncompressed, not base64) binary data, so that a reader of a
  // range of an appended array reads only that range's bytes; decoded through otherwise.
  void skip(uint64_t count);

  // Fails if values are left over: every value stored must have been read.
  void finish();
  [[noreturn]] void fail(const std::string& message) const;

 private:
  void read_native_bytes(std::byte* dst, uint64_t count);
  template <class T>
  void read_converted(std::span<T> out);
  template <class S>
  void parse_ascii(S* dst, uint64_t count);

  const InputFile& file_;
  XmlEncoding encoding_;
  XmlArray array_;
  size_t value_size_;
  uint64_t values_read_ = 0;
  std::unique_ptr<XmlBinaryStream> binary_;
  std::unique_ptr<XmlAsciiTokens> ascii_;
  std::vector<std::byte> scratch_;
};

}  // namespace ugvr
