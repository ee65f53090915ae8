// Raw and NRRD voxel volume readers: every value type and byte order written synthetically and read back value by
// value, header skips, NRRD raw/gzip/ascii encodings, detached headers, 4-D vector volumes, space directions/origin,
// and malformed input that must fail with ugvr::Error naming the file and the line or offset.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/codec.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

using test::ScratchDir;

using test::error_of;

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// Value i of the test volumes: in every type's range (int8 included), negative ones for signed types.
template <class T>
T test_value(uint64_t i) {
  return std::is_signed_v<T> ? T(int(i % 40) * 3 - 7) : T((i % 80) * 3);
}

// `count` test values of type T in the given byte order.
template <class T>
std::string values_bytes(uint64_t count, bool big) {
  std::string s;
  for (uint64_t i = 0; i < count; ++i) {
    const T v = test_value<T>(i);
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
    s.append(b, sizeof(T));
  }
  return s;
}

template <class T>
void check_values(const Field& f, uint64_t count) {
  ASSERT_EQ(f.data().type(), scalar_type_of<T>());
  ASSERT_EQ(f.data().value_count(), count);
  const std::span<const T> v = f.data().values<T>();
  for (uint64_t i = 0; i < count; ++i) {
    ASSERT_EQ(v[i], test_value<T>(i)) << "value " << i;
  }
}

const ImageGrid& image_of(const Dataset& ds) { return std::get<ImageGrid>(ds.blocks.at(0).grid); }

// ---- Raw ----

template <class T>
void raw_round_trip(const char* type, bool big, uint64_t header) {
  ScratchDir dir;
  const std::string path = dir.file("v.raw");
  write_file(path, std::string(size_t(header), 'h') + values_bytes<T>(4 * 5 * 6, big));
  RawVolumeOptions o;
  o.dims = {4, 5, 6};
  o.type = type;
  o.big_endian = big;
  o.header_bytes = header;
  o.spacing = {0.5, 1, 2};
  o.origin = {1, 2, 3};
  const Dataset ds = read_raw_volume(path, o);
  const ImageGrid& g = image_of(ds);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{4, 5, 6}));
  EXPECT_EQ(g.spacing.z, 2);
  EXPECT_EQ(g.origin.y, 2);
  ASSERT_EQ(ds.blocks[0].fields.size(), 1u);
  EXPECT_EQ(ds.blocks[0].fields[0].name(), "values");
  check_values<T>(ds.blocks[0].fields[0], 120);
}

TEST(RawVolumeReader, AllTypesBothByteOrdersAndHeaderSkip) {
  for (bool big : {false, true}) {
    for (uint64_t header : {uint64_t(0), uint64_t(13)}) {
      SCOPED_TRACE(std::string(big ? "big" : "little") + " header " + std::to_string(header));
      raw_round_trip<int8_t>("int8", big, header);
      raw_round_trip<uint8_t>("uint8", big, header);
      raw_round_trip<int16_t>("int16", big, header);
      raw_round_trip<uint16_t>("uint16", big, header);
      raw_round_trip<int32_t>("int32", big, header);
      raw_round_trip<uint32_t>("uint32", big, header);
      raw_round_trip<float>("float32", big, header);
      raw_round_trip<double>("float64", big, header);
    }
  }
}

TEST(RawVolumeReader, WrongSizesFail) {
  ScratchDir dir;
  const std::string path = dir.file("v.raw");
  write_file(path, std::string(119, '\0'));
  RawVolumeOptions o;
  o.dims = {4, 5, 6};
  o.type = "uint8";
  std::string e = error_of([&] { read_raw_volume(path, o); });
  EXPECT_NE(e.find("v.raw"), std::string::npos) << e;
  EXPECT_NE(e.find("119"), std::string::npos) << e;
  EXPECT_NE(e.find("120"), std::string::npos) << e;
  o.type = "uint16";  // 240 bytes needed
  EXPECT_NE(error_of([&] { read_raw_volume(path, o); }).find("240"), std::string::npos);
  o.dims = {4, 0, 6};
  EXPECT_NE(error_of([&] { read_raw_volume(path, o); }).find("at least 1"), std::string::npos);
  o.dims = {4000000000u, 4000000000u, 4000000000u};
  EXPECT_NE(error_of([&] { read_raw_volume(path, o); }).find("2^64"), std::string::npos);
  o.dims = {4, 5, 6};
  o.type = "float16";
  EXPECT_NE(error_of([&] { read_raw_volume(path, o); }).find("unknown raw value type"), std::string::npos);
  // Too large by one byte is as wrong as too small.
  write_file(path, std::string(121, '\0'));
  o.type = "uint8";
  EXPECT_NE(error_of([&] { read_raw_volume(path, o); }).find("121"), std::string::npos);
}

TEST(RawVolumeReader, DispatchedByExtension) {
  ScratchDir dir;
  const std::string path = dir.file("v.raw");
  write_file(path, values_bytes<uint16_t>(120, false));
  ReadOptions o;
  o.raw.dims = {4, 5, 6};
  o.raw.type = "uint16";
  const std::vector<std::string> paths{path};
  const Dataset ds = read_dataset(paths, o);
  EXPECT_EQ(ds.point_count(), 120u);
  EXPECT_EQ(ds.blocks[0].fields[0].range().max, 79 * 3);
}

// ---- NRRD ----

std::string nrrd_header(const std::string& type, const std::string& sizes, const std::string& encoding,
                        const std::string& extra = "", int dimension = 3) {
  return "NRRD0004\n# a comment\ntype: " + type + "\ndimension: " + std::to_string(dimension) + "\nsizes: " + sizes +
         "\nencoding: " + encoding + "\n" + extra;
}

// zlib's stream rewrapped as gzip (header, raw deflate, CRC-32, size), as `gzip` writes it.
std::string gzip_bytes(const std::string& data) {
  const std::vector<std::byte> z =
      compress(Codec::Zlib, std::span(reinterpret_cast<const std::byte*>(data.data()), data.size()), 6);
  uint32_t crc = 0xffffffffu;
  for (unsigned char c : data) {
    crc ^= c;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc = ~crc;
  std::string out("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff", 10);
  out.append(reinterpret_cast<const char*>(z.data()) + 2, z.size() - 6);
  const uint32_t size = uint32_t(data.size());
  for (uint32_t v : {crc, size})
    for (int k = 0; k < 4; ++k) out.push_back(char((v >> (8 * k)) & 0xff));
  return out;
}

TEST(NrrdReader, RawAttachedBothEndians) {
  ScratchDir dir;
  for (bool big : {false, true}) {
    const std::string path = dir.file("a.nrrd");
    write_file(path, nrrd_header("short", "4 5 6", "raw",
                                 std::string("endian: ") + (big ? "big" : "little") +
                                     "\nspacings: 0.5 1 2\ncontent: density\n\n") +
                         values_bytes<int16_t>(120, big));
    const Dataset ds = read_nrrd(path);
    const ImageGrid& g = image_of(ds);
    EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{4, 5, 6}));
    EXPECT_EQ(g.spacing.x, 0.5);
    EXPECT_EQ(g.spacing.z, 2);
    EXPECT_EQ(ds.blocks[0].fields[0].name(), "density");
    check_values<int16_t>(ds.blocks[0].fields[0], 120);
  }
}

TEST(NrrdReader, GzipAndAsciiEncodings) {
  ScratchDir dir;
  const std::string path = dir.file("g.nrrd");
  write_file(path,
             nrrd_header("float", "4 5 6", "gzip", "endian: little\n\n") + gzip_bytes(values_bytes<float>(120, false)));
  check_values<float>(read_nrrd(path).blocks[0].fields[0], 120);
  // The "gz" alias and a zlib stream (inflate accepts both wrappers).
  const std::string raw = values_bytes<uint32_t>(120, true);
  const std::vector<std::byte> z =
      compress(Codec::Zlib, std::span(reinterpret_cast<const std::byte*>(raw.data()), raw.size()));
  write_file(path, nrrd_header("uint", "4 5 6", "gz", "endian: big\n\n") +
                       std::string(reinterpret_cast<const char*>(z.data()), z.size()));
  check_values<uint32_t>(read_nrrd(path).blocks[0].fields[0], 120);

  std::string text;
  for (int i = 0; i < 120; ++i)
    text += std::to_string(int(test_value<int8_t>(uint64_t(i)))) + (i % 7 == 6 ? "\n" : " ");
  write_file(path, nrrd_header("int8", "4 5 6", "ascii", "\n") + text);
  check_values<int8_t>(read_nrrd(path).blocks[0].fields[0], 120);
  write_file(path, nrrd_header("double", "4 5 6", "text", "\n") + text);
  check_values<double>(read_nrrd(path).blocks[0].fields[0], 120);

  // Truncated gzip / ascii data.
  write_file(path,
             nrrd_header("float", "4 5 6", "gzip", "endian: little\n\n") + gzip_bytes(values_bytes<float>(100, false)));
  std::string e = error_of([&] { read_nrrd(path); });
  EXPECT_NE(e.find("g.nrrd"), std::string::npos) << e;
  EXPECT_NE(e.find("gzip data ends"), std::string::npos) << e;
  write_file(path, nrrd_header("float", "4 5 6", "gzip", "endian: little\n\n") + "this is not gzip at all");
  EXPECT_NE(error_of([&] { read_nrrd(path); }).find("g.nrrd: byte"), std::string::npos);
  write_file(path, nrrd_header("int8", "2 2 2", "ascii", "\n") + "1 2 x 4 5 6 7 8");
  e = error_of([&] { read_nrrd(path); });
  EXPECT_NE(e.find("g.nrrd:8:"), std::string::npos) << e;  // line 8: the data line after a 7-line header
  EXPECT_NE(e.find("'x'"), std::string::npos) << e;
}

TEST(NrrdReader, DetachedHeaderWithSkips) {
  ScratchDir dir;
  write_file(dir.file("d.raw"), "two lines\nof text\nBB" + values_bytes<uint16_t>(120, false));
  write_file(dir.file("d.nhdr"),
             nrrd_header("ushort", "4 5 6", "raw", "endian: little\ndata file: d.raw\nline skip: 2\nbyte skip: 2\n"));
  const Dataset ds = read_nrrd(dir.file("d.nhdr"));
  check_values<uint16_t>(ds.blocks[0].fields[0], 120);
  ASSERT_EQ(ds.sources.size(), 2u);
  // byte skip -1: the data are the file's last bytes.
  write_file(dir.file("e.nhdr"),
             nrrd_header("ushort", "4 5 6", "raw", "endian: little\ndatafile: d.raw\nbyte skip: -1\n"));
  check_values<uint16_t>(read_nrrd(dir.file("e.nhdr")).blocks[0].fields[0], 120);
  // Missing data file, LIST form.
  write_file(dir.file("f.nhdr"), nrrd_header("ushort", "4 5 6", "raw", "endian: little\ndata file: nothere.raw\n"));
  EXPECT_NE(error_of([&] { read_nrrd(dir.file("f.nhdr")); }).find("nothere.raw"), std::string::npos);
  write_file(dir.file("l.nhdr"), nrrd_header("ushort", "4 5 6", "raw", "endian: little\ndata file: LIST\na.raw\n"));
  const std::string e = error_of([&] { read_nrrd(dir.file("l.nhdr")); });
  EXPECT_NE(e.find("l.nhdr:8:"), std::string::npos) << e;
  EXPECT_NE(e.find("LIST"), std::string::npos) << e;
}

TEST(NrrdReader, VectorVolumeAndSpaceFields) {
  ScratchDir dir;
  const std::string path = dir.file("v.nrrd");
  write_file(path, nrrd_header("uchar", "3 4 5 6", "raw",
                               "space: right-anterior-superior\nspace directions: none (0.5,0,0) (0,1.5,0) (0,0,2)\n"
                               "space origin: (10,-20,30.5)\nkinds: vector domain domain domain\n\n",
                               4) +
                       values_bytes<uint8_t>(360, false));
  const Dataset ds = read_nrrd(path);
  const ImageGrid& g = image_of(ds);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{4, 5, 6}));
  EXPECT_EQ(g.spacing.x, 0.5);
  EXPECT_EQ(g.spacing.y, 1.5);
  EXPECT_EQ(g.spacing.z, 2);
  EXPECT_EQ(g.origin.x, 10);
  EXPECT_EQ(g.origin.y, -20);
  EXPECT_EQ(g.origin.z, 30.5);
  const Field& f = ds.blocks[0].fields[0];
  EXPECT_EQ(f.components(), 3);
  EXPECT_EQ(f.tuples(), 120u);
  EXPECT_EQ(f.data().get(1, 0), 9);  // tuple 1 = values 3, 4, 5 -> 9, 12, 15
  EXPECT_EQ(f.data().get(1, 2), 15);

  // Rotated directions are refused with a clear message; so is a vector axis over 4.
  write_file(path, nrrd_header("uchar", "4 5 6", "raw", "space directions: (0.7,0.7,0) (0,1,0) (0,0,1)\n\n") +
                       values_bytes<uint8_t>(120, false));
  std::string e = error_of([&] { read_nrrd(path); });
  EXPECT_NE(e.find("v.nrrd:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("axis-aligned"), std::string::npos) << e;
  write_file(path, nrrd_header("uchar", "5 4 5 6", "raw", "\n", 4) + values_bytes<uint8_t>(600, false));
  EXPECT_NE(error_of([&] { read_nrrd(path); }).find("at most 4"), std::string::npos);
}

TEST(NrrdReader, MalformedHeadersFail) {
  ScratchDir dir;
  const std::string path = dir.file("m.nrrd");
  const std::string data = values_bytes<uint8_t>(120, false);
  struct Case {
    std::string text, needle;
  };
  const std::vector<Case> cases = {
      {"NRRD0009\ntype: uchar\n\n", "m.nrrd:1:"},
      {nrrd_header("uchar", "4 5", "raw", "\n"), "m.nrrd:5:"},                      // sizes count
      {nrrd_header("uchar", "4 -5 6", "raw", "\n"), "sizes"},                       // negative size
      {nrrd_header("uchar", "4 5 6", "bzip2", "\n"), "m.nrrd:6:"},                  // encoding
      {nrrd_header("block", "4 5 6", "raw", "\n"), "m.nrrd:3:"},                    // type
      {nrrd_header("short", "4 5 6", "raw", "\n"), "'endian'"},                     // missing endian
      {nrrd_header("uchar", "4 5 6", "raw", "dimension: 3\n\n"), "appears twice"},  // duplicate
      {nrrd_header("uchar", "4 5 6", "raw", "no colon here\n\n"), "m.nrrd:7:"},     // not a field
      {nrrd_header("uchar", "4 5 6", "raw", "spacings: 1 1 -1\n\n"), "not positive"},
      {nrrd_header("uchar", "4 5 6", "raw", "space origin: (1,2)\n\n"), "m.nrrd:7:"},
      {nrrd_header("uchar", "40000 40000 40000", "raw", "\n"), "m.nrrd: byte"},  // data cannot be there
      {nrrd_header("uchar", "40000 40000 40000", "gzip", "\n"), "cannot decompress"},
      {nrrd_header("uchar", "40000 40000 40000", "ascii", "\n"), "ASCII value count"},
      {"NRRD0004\ntype: uchar\nsizes: 4 5 6\nencoding: raw\n\n", "'dimension'"},
  };
  for (const Case& c : cases) {
    write_file(path, c.text + data.substr(0, 100));
    const std::string e = error_of([&] { read_nrrd(path); });
    EXPECT_NE(e.find("m.nrrd"), std::string::npos) << c.text << " -> " << e;
    EXPECT_NE(e.find(c.needle), std::string::npos) << c.text << " -> " << e;
  }
}

}  // namespace
}  // namespace ugvr
