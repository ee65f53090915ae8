// Brick store values the format cannot hold, planted with every checksum recomputed the way the format computes them
// (crc32 of zlib over the documented byte ranges, store/brick_store_format.h): the reader must refuse them by
// validation, naming the file, the node or field and the byte, instead of rendering them (issue 23: a field range of
// [+inf, -inf] and a block with qmax 0 rendered once their checksums were fixed up).
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/store/brick_codec.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/store/brick_store_format.h"

namespace ugvr {
namespace {

using test::ScratchDir;
using namespace store_format;

constexpr uint32_t kR = 4;

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}
template <class T>
void put(std::string& f, size_t at, T v) {
  std::memcpy(f.data() + at, &v, sizeof v);
}
template <class T>
T get(const std::string& f, size_t at) {
  T v;
  std::memcpy(&v, f.data() + at, sizeof v);
  return v;
}
void fs_remove(const std::string& path) { std::remove(path.c_str()); }
uint32_t crc_of(const std::string& f, size_t at, size_t n) {
  return uint32_t(crc32(0, reinterpret_cast<const Bytef*>(f.data() + at), uInt(n)));
}

// A root and its eight children, each with a brick of two varying fields (so every block has qmax > 0).
void write_small_store(const std::string& path) {
  BrickStoreLayout layout;
  layout.resolution = kR;
  layout.root = Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
  layout.data = layout.root;
  layout.fields = {{"temperature", Association::Vertex, 0.0, 100.0}, {"pressure", Association::Cell, -5.0, 5.0}};
  std::vector<OctreeNode> nodes(9);
  nodes[0].first_child = 1;
  nodes[0].child_mask = 0xff;
  for (int o = 0; o < 8; ++o) {
    OctreeNode& c = nodes[size_t(1 + o)];
    c.parent = 0;
    c.level = 1;
    c.i = uint32_t(o & 1);
    c.j = uint32_t(o >> 1 & 1);
    c.k = uint32_t(o >> 2 & 1);
  }
  BrickStoreWriter w(path, layout);
  const size_t n = size_t(kR) * kR * kR;
  for (uint64_t id = 0; id < nodes.size(); ++id) {
    std::vector<float> a(n), b(n);
    for (size_t s = 0; s < n; ++s) {
      a[s] = float(id * 10 + s % 7);
      b[s] = float(-4.0 + 0.1 * double((s + id) % 50));
    }
    const float* fields[2] = {a.data(), b.data()};
    w.add_brick(id, fields, nullptr);
  }
  std::vector<FieldError> errors(nodes.size() * 2, FieldError{0.5f, 0.25f});
  w.commit(nodes, errors);
}

class StoreValidation : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.file("good.ugvr");
    write_small_store(path_);
    good_ = read_file(path_);
    bad_ = dir_.file("bad.ugvr");
    table_ = get<uint64_t>(good_, offsetof(HeaderRecord, node_table_offset));
    rec_ = get<uint32_t>(good_, offsetof(HeaderRecord, node_record_size));
  }

  // Where node `id`'s entry for field `f` starts.
  size_t node_field(uint64_t id, uint32_t f) const {
    return table_ + id * rec_ + sizeof(NodeRecord) + f * sizeof(NodeFieldRecord);
  }
  // Recomputes the header's and the node table's checksums, as the writer does.
  void reseal(std::string& f) const {
    put(f, offsetof(HeaderRecord, node_table_crc), crc_of(f, table_, f.size() - table_));
    const uint32_t header_size = get<uint32_t>(f, offsetof(HeaderRecord, header_size));
    put(f, offsetof(HeaderRecord, header_crc), uint32_t(0));
    put(f, offsetof(HeaderRecord, header_crc), crc_of(f, 0, header_size));
  }
  // Writes `f` as the bad store and expects opening it to fail with the path, "byte <at>" and every needle.
  void expect_refused(const std::string& f, uint64_t at, std::initializer_list<std::string> needles) {
    write_file(bad_, f);
    try {
      BrickStoreReader s(bad_);
      ADD_FAILURE() << "opened a store with an impossible value; expected " << *needles.begin();
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(bad_ + ": byte " + std::to_string(at)), std::string::npos) << what;
      for (const std::string& n : needles) EXPECT_NE(what.find(n), std::string::npos) << what;
    }
  }

  ScratchDir dir_;
  std::string path_, good_, bad_;
  uint64_t table_ = 0;
  uint32_t rec_ = 0;
};

TEST_F(StoreValidation, TheUntouchedStoreOpensAndDecodes) {
  std::string f = good_;
  reseal(f);  // resealing alone changes nothing
  EXPECT_EQ(f, good_);
  const BrickStoreReader s(path_);
  std::vector<float> out(size_t(kR) * kR * kR);
  for (uint64_t id = 0; id < s.node_count(); ++id) {
    for (uint32_t fi = 0; fi < 2; ++fi) EXPECT_NO_THROW(s.read_brick(id, fi, out.data(), nullptr));
  }
}

TEST_F(StoreValidation, InfiniteOrInvertedFieldRange) {
  std::string f = good_;
  const size_t field0 = header_records_size(get<uint32_t>(f, offsetof(HeaderRecord, version)));  // the file's own
  put(f, field0 + offsetof(FieldRecord, min), double(INFINITY));
  put(f, field0 + offsetof(FieldRecord, max), double(-INFINITY));
  reseal(f);
  expect_refused(f, field0, {"field record 0", "not a finite range with min <= max"});
  // Finite but inverted, in the second field.
  f = good_;
  const size_t field1 = field0 + field_record_size(std::strlen("temperature"));
  put(f, field1 + offsetof(FieldRecord, min), 6.0);
  reseal(f);
  expect_refused(f, field1, {"field record 1", "[6.000000, 5.000000]"});
  // NaN.
  f = good_;
  put(f, field1 + offsetof(FieldRecord, max), double(NAN));
  reseal(f);
  expect_refused(f, field1, {"field record 1"});
}

TEST_F(StoreValidation, HeaderGeometryAndTolerance) {
  std::string f = good_;
  put(f, offsetof(HeaderRecord, root_hi) + 8, double(INFINITY));  // y
  reseal(f);
  expect_refused(f, offsetof(HeaderRecord, root_hi) + 8, {"octree root cell", "axis 1", "not finite"});
  f = good_;
  put(f, offsetof(HeaderRecord, data_lo) + 16, 2.0);  // z: lo above hi
  reseal(f);
  expect_refused(f, offsetof(HeaderRecord, data_lo) + 16, {"dataset bounds", "axis 2", "min <= max"});
  f = good_;
  put(f, offsetof(HeaderRecord, tolerance), double(NAN));
  reseal(f);
  expect_refused(f, offsetof(HeaderRecord, tolerance), {"tolerance"});
  f = good_;
  put(f, offsetof(HeaderRecord, tolerance), 1e-9);  // finer than 16 bits can hold
  reseal(f);
  expect_refused(f, offsetof(HeaderRecord, tolerance), {"tolerance", "1/131070"});
}

TEST_F(StoreValidation, ImpossibleNodeRangesAndErrors) {
  // The root, which has a brick, claiming no data for field 1.
  std::string f = good_;
  put(f, node_field(0, 1) + offsetof(NodeFieldRecord, min), float(INFINITY));
  put(f, node_field(0, 1) + offsetof(NodeFieldRecord, max), -float(INFINITY));
  reseal(f);
  expect_refused(f, node_field(0, 1), {"node 0 field 'pressure'", "says no data, but the node has a brick"});
  // A child whose range pokes out of its parent's: culling the parent would wrongly cull it.
  f = good_;
  put(f, node_field(3, 0) + offsetof(NodeFieldRecord, max), 1e6f);
  reseal(f);
  expect_refused(f, node_field(3, 0), {"node 3 field 'temperature'", "not inside its parent node 0"});
  // min > max.
  f = good_;
  put(f, node_field(2, 0) + offsetof(NodeFieldRecord, min), 1e5f);
  reseal(f);
  expect_refused(f, node_field(2, 0), {"node 2 field 'temperature'", "min <= max"});
  // A NaN or negative error.
  f = good_;
  put(f, node_field(5, 1) + offsetof(NodeFieldRecord, error_max), float(NAN));
  reseal(f);
  expect_refused(f, node_field(5, 1) + offsetof(NodeFieldRecord, error_max), {"node 5 field 'pressure'", "errors"});
  f = good_;
  put(f, node_field(5, 1) + offsetof(NodeFieldRecord, error_rms), -1.0f);
  reseal(f);
  expect_refused(f, node_field(5, 1) + offsetof(NodeFieldRecord, error_max), {"node 5", ">= 0"});
}

// A block whose header is patched: its crc in the node table recomputed, then the tables resealed. Opening succeeds
// (the tables are sound); decoding must refuse the block.
class StoreBlockValidation : public StoreValidation {
 protected:
  void expect_block_refused(const std::string& f, uint64_t node, uint32_t field, uint64_t at,
                            std::initializer_list<std::string> needles) {
    write_file(bad_, f);
    const BrickStoreReader s(bad_);
    std::vector<float> out(size_t(kR) * kR * kR, 12345.0f);
    try {
      s.read_brick(node, field, out.data(), nullptr);
      ADD_FAILURE() << "decoded an impossible block; expected " << *needles.begin();
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(bad_ + ": byte " + std::to_string(at)), std::string::npos) << what;
      for (const std::string& n : needles) EXPECT_NE(what.find(n), std::string::npos) << what;
    }
    // Nothing was written out, and the untouched bricks still decode.
    EXPECT_EQ(out[0], 12345.0f);
    EXPECT_NO_THROW(s.read_brick(node, 1 - field, out.data(), nullptr));
  }
  // Patches a member of node's block for field and recomputes the block's crc and the table's.
  template <class T>
  std::string patched_block(uint64_t node, uint32_t field, size_t member, T value, BlockRef* ref) const {
    const BrickStoreReader s(path_);
    *ref = s.block(node, field);
    std::string f = good_;
    put(f, ref->offset + member, value);
    put(f, node_field(node, field) + offsetof(NodeFieldRecord, block_crc), crc_of(f, ref->offset, ref->size));
    reseal(f);
    return f;
  }
};

TEST_F(StoreBlockValidation, QmaxZeroForAVaryingBrick) {
  BlockRef b;
  const std::string f = patched_block(4, 0, offsetof(BlockRecord, qmax), uint32_t(0), &b);
  ASSERT_NE(get<uint32_t>(good_, b.offset + offsetof(BlockRecord, qmax)), 0u);
  expect_block_refused(f, 4, 0, b.offset + offsetof(BlockRecord, qmax),
                       {"node 4", "'temperature'", "qmax inconsistent with the range"});
}

TEST_F(StoreBlockValidation, QmaxTooLargeOrStepZero) {
  BlockRef b;
  std::string f = patched_block(6, 1, offsetof(BlockRecord, qmax), uint32_t(65535), &b);
  expect_block_refused(f, 6, 1, b.offset + offsetof(BlockRecord, qmax), {"node 6", "qmax inconsistent"});
  f = patched_block(6, 1, offsetof(BlockRecord, step), 0.0, &b);
  expect_block_refused(f, 6, 1, b.offset + offsetof(BlockRecord, step), {"node 6", "step 0"});
}

TEST_F(StoreBlockValidation, BlockRangeOutsideItsNode) {
  // Leaf 7's range for field 0 narrowed below its brick's hi (still inside its parent's, min <= max): the node table
  // is plausible, but the block claims values its node excludes.
  std::string f = good_;
  const float lo = get<float>(f, node_field(7, 0) + offsetof(NodeFieldRecord, min));
  put(f, node_field(7, 0) + offsetof(NodeFieldRecord, max), lo);
  reseal(f);
  const BlockRef b = BrickStoreReader(path_).block(7, 0);
  expect_block_refused(f, 7, 0, b.offset + offsetof(BlockRecord, lo), {"node 7", "outside the node's value range"});
}

// A payload code above qmax (the encoder never writes one: the codes of lo and hi are 0 and qmax) is refused, not
// clamped into a plausible value: with the checksum recomputed it is the only sign of a tampered payload.
TEST(BlockPayloadValidation, CodeAboveQmaxIsRefused) {
  const uint32_t r = 4;
  std::vector<float> v(size_t(r) * r * r);
  for (size_t s = 0; s < v.size(); ++s) v[s] = float(s % 10);
  // No predictor, no shuffle, stored: the payload is the codes themselves, u16 each, after the 48-byte record.
  const BrickEncoding plain{SampleEncoding::Quant16, Predictor::None, false, BrickCodec::Stored, 0};
  const EncodedBlock b = encode_brick(plain, r, v.data(), nullptr, 0.01, 0.0);
  const BlockHeader h = parse_block_header(b.bytes, r, "x.ugvr", 0);
  ASSERT_EQ(h.codec, BrickCodec::Stored);
  ASSERT_GT(h.qmax, 0u);
  std::vector<float> out(v.size());
  EXPECT_NO_THROW(decode_brick(b.bytes, r, out.data(), nullptr, "x.ugvr", 0));
  for (const uint32_t code : {h.qmax + 1, 65535u}) {
    std::vector<std::byte> bad = b.bytes;
    const uint16_t c = uint16_t(code);
    std::memcpy(bad.data() + sizeof(BlockRecord) + 2 * 7, &c, 2);
    try {
      decode_brick(bad, r, out.data(), nullptr, "x.ugvr", 1000);
      ADD_FAILURE() << "decoded code " << code << " above qmax " << h.qmax;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("x.ugvr: byte " + std::to_string(1000 + sizeof(BlockRecord))), std::string::npos) << what;
      EXPECT_NE(what.find("code " + std::to_string(code) + ", above the block's largest code qmax"), std::string::npos)
          << what;
    }
  }
}

// The attack as it was found, through the ugvr binary: a built store whose root block says qmax 0 (or whose field
// range is [+inf, -inf]), checksums recomputed, rendered at a cut that draws the root: refused, exit 1, not rendered.
TEST_F(StoreValidation, TheBinaryRefusesWhatOnceRendered) {
  const std::string mesh = dir_.file("m.vtu"), store = dir_.file("s.ugvr"), png = dir_.file("out.png");
  ASSERT_EQ(test::run_ugvr("generate -o " + mesh + " --cells 20000 --kind tet").status, 0);
  ASSERT_EQ(test::run_ugvr("build " + mesh + " -o " + store + " --fields pressure").status, 0);
  const std::string render = " -o " + png + " --size 64 --engine lod --cut error:10";
  const auto good = test::run_ugvr("render " + store + render);
  ASSERT_EQ(good.status, 0) << good.out;
  std::string f = read_file(store);
  table_ = get<uint64_t>(f, offsetof(HeaderRecord, node_table_offset));
  rec_ = get<uint32_t>(f, offsetof(HeaderRecord, node_record_size));
  const uint64_t block = get<uint64_t>(f, table_ + offsetof(NodeRecord, brick_offset));
  const uint32_t size = get<uint32_t>(f, node_field(0, 0) + offsetof(NodeFieldRecord, block_size));
  ASSERT_GT(get<uint32_t>(f, block + offsetof(BlockRecord, qmax)), 0u);
  put(f, block + offsetof(BlockRecord, qmax), uint32_t(0));
  put(f, node_field(0, 0) + offsetof(NodeFieldRecord, block_crc), crc_of(f, block, size));
  reseal(f);
  write_file(bad_, f);
  fs_remove(png);
  const auto r = test::run_ugvr("render " + bad_ + render);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find(bad_ + ": byte " + std::to_string(block + offsetof(BlockRecord, qmax))), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("qmax inconsistent with the range"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("node 0, field 'pressure'"), std::string::npos) << r.out;
  EXPECT_FALSE(std::ifstream(png).good());
  // The field range [+inf, -inf]: refused on opening, by `info` as by `render`.
  f = read_file(store);
  const size_t field0 = header_records_size(get<uint32_t>(f, offsetof(HeaderRecord, version)));  // the file's own
  put(f, field0 + offsetof(FieldRecord, min), double(INFINITY));
  put(f, field0 + offsetof(FieldRecord, max), double(-INFINITY));
  reseal(f);
  write_file(bad_, f);
  for (const std::string& command : {"info " + bad_, "render " + bad_ + render}) {
    const auto c = test::run_ugvr(command);
    EXPECT_EQ(c.status, 1) << command << ": " << c.out;
    EXPECT_NE(c.out.find(bad_ + ": byte " + std::to_string(field0)), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("not a finite range"), std::string::npos) << c.out;
  }
}

}  // namespace
}  // namespace ugvr
