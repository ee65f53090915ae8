// The brick store's byte layout: the structs of store/brick_store_format.h against the tables of docs/brick-store.md,
// and a written store read back by hand at the offsets the doc gives, member by member. The static_asserts pin each
// struct to itself; these tests pin the structs to the documentation and to the bytes, so that reordering a member
// (and its assert) fails a test, and so does a doc table that no longer says what the code writes.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "test_data.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/store/brick_store_format.h"

namespace ugvr {
namespace {

using namespace store_format;

// ---------------------------------------------------------------------------------------------------------------
// The doc's tables

struct DocRow {
  uint64_t offset = 0, size = 0;
};

// Per struct named in a "### ...`Name`..." heading of docs/brick-store.md, its rows whose member column is a
// `backticked` name: member -> offset and size. Rows for what follows a record (a name, a payload) have no backticks.
std::map<std::string, std::map<std::string, DocRow>> doc_tables() {
  std::ifstream in(std::string(UGVR_SOURCE_DIR) + "/docs/brick-store.md");
  EXPECT_TRUE(in) << "docs/brick-store.md not found";
  std::map<std::string, std::map<std::string, DocRow>> tables;
  std::string line, current;
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) == 0) {
      current.clear();
      const size_t a = line.find('`'), b = a == std::string::npos ? a : line.find('`', a + 1);
      if (line.rfind("### ", 0) == 0 && b != std::string::npos) current = line.substr(a + 1, b - a - 1);
      continue;
    }
    if (current.empty() || line.rfind("| ", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    for (std::string cell; std::getline(ss, cell, '|');) {
      const size_t first = cell.find_first_not_of(' '), last = cell.find_last_not_of(' ');
      cells.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
    }
    if (cells.size() < 3 || cells[2].size() < 3 || cells[2].front() != '`' || cells[2].back() != '`') continue;
    const std::string member = cells[2].substr(1, cells[2].size() - 2);
    EXPECT_EQ(tables[current].count(member), 0u) << current << "::" << member << " twice in the doc";
    tables[current][member] = {std::stoull(cells[0]), std::stoull(cells[1])};
  }
  return tables;
}

// A struct's members as the compiler lays them out, in declaration order.
struct Member {
  std::string name;
  uint64_t offset, size;
};
#define UGVR_MEMBER(Record, m) \
  Member { #m, offsetof(Record, m), sizeof(Record::m) }

std::map<std::string, std::vector<Member>> struct_members() {
  return {
      {"HeaderRecord",
       {UGVR_MEMBER(HeaderRecord, magic),
        UGVR_MEMBER(HeaderRecord, version),
        UGVR_MEMBER(HeaderRecord, header_size),
        UGVR_MEMBER(HeaderRecord, resolution),
        UGVR_MEMBER(HeaderRecord, field_count),
        UGVR_MEMBER(HeaderRecord, node_record_size),
        UGVR_MEMBER(HeaderRecord, samples),
        UGVR_MEMBER(HeaderRecord, predictor),
        UGVR_MEMBER(HeaderRecord, codec),
        UGVR_MEMBER(HeaderRecord, shuffle),
        UGVR_MEMBER(HeaderRecord, codec_level),
        UGVR_MEMBER(HeaderRecord, provenance_size),
        UGVR_MEMBER(HeaderRecord, tolerance),
        UGVR_MEMBER(HeaderRecord, root_lo),
        UGVR_MEMBER(HeaderRecord, root_hi),
        UGVR_MEMBER(HeaderRecord, data_lo),
        UGVR_MEMBER(HeaderRecord, data_hi),
        UGVR_MEMBER(HeaderRecord, node_count),
        UGVR_MEMBER(HeaderRecord, node_table_offset),
        UGVR_MEMBER(HeaderRecord, file_size),
        UGVR_MEMBER(HeaderRecord, node_table_crc),
        UGVR_MEMBER(HeaderRecord, header_crc)}},
      {"TfErrorHeaderRecord",
       {UGVR_MEMBER(TfErrorHeaderRecord, table_offset), UGVR_MEMBER(TfErrorHeaderRecord, table_size),
        UGVR_MEMBER(TfErrorHeaderRecord, entry_size), UGVR_MEMBER(TfErrorHeaderRecord, table_crc)}},
      {"BoundaryHeaderRecord",
       {UGVR_MEMBER(BoundaryHeaderRecord, section_offset), UGVR_MEMBER(BoundaryHeaderRecord, section_size),
        UGVR_MEMBER(BoundaryHeaderRecord, triangle_count), UGVR_MEMBER(BoundaryHeaderRecord, reference_count),
        UGVR_MEMBER(BoundaryHeaderRecord, max_per_node), UGVR_MEMBER(BoundaryHeaderRecord, section_crc),
        UGVR_MEMBER(BoundaryHeaderRecord, virtual_nodes), UGVR_MEMBER(BoundaryHeaderRecord, reserved)}},
      {"CellsHeaderRecord",
       {UGVR_MEMBER(CellsHeaderRecord, index_offset), UGVR_MEMBER(CellsHeaderRecord, index_size),
        UGVR_MEMBER(CellsHeaderRecord, total_cells), UGVR_MEMBER(CellsHeaderRecord, index_crc),
        UGVR_MEMBER(CellsHeaderRecord, block_count)}},
      {"CellBlockRecord",
       {UGVR_MEMBER(CellBlockRecord, offset), UGVR_MEMBER(CellBlockRecord, size), UGVR_MEMBER(CellBlockRecord, crc)}},
      {"StepsHeaderRecord",
       {UGVR_MEMBER(StepsHeaderRecord, section_offset), UGVR_MEMBER(StepsHeaderRecord, section_size),
        UGVR_MEMBER(StepsHeaderRecord, step_count), UGVR_MEMBER(StepsHeaderRecord, section_crc),
        UGVR_MEMBER(StepsHeaderRecord, flags), UGVR_MEMBER(StepsHeaderRecord, reserved)}},
      {"CellBlockHeader",
       {UGVR_MEMBER(CellBlockHeader, cell_count), UGVR_MEMBER(CellBlockHeader, point_count),
        UGVR_MEMBER(CellBlockHeader, vertex_references), UGVR_MEMBER(CellBlockHeader, face_slots),
        UGVR_MEMBER(CellBlockHeader, field_count), UGVR_MEMBER(CellBlockHeader, reserved)}},
      {"TfErrorEntry",
       {UGVR_MEMBER(TfErrorEntry, bound), UGVR_MEMBER(TfErrorEntry, spread), UGVR_MEMBER(TfErrorEntry, weight),
        UGVR_MEMBER(TfErrorEntry, reserved)}},
      {"FieldRecord",
       {UGVR_MEMBER(FieldRecord, min), UGVR_MEMBER(FieldRecord, max), UGVR_MEMBER(FieldRecord, association),
        UGVR_MEMBER(FieldRecord, reserved), UGVR_MEMBER(FieldRecord, name_length)}},
      {"NodeRecord",
       {UGVR_MEMBER(NodeRecord, parent), UGVR_MEMBER(NodeRecord, first_child), UGVR_MEMBER(NodeRecord, brick_offset),
        UGVR_MEMBER(NodeRecord, i), UGVR_MEMBER(NodeRecord, j), UGVR_MEMBER(NodeRecord, k),
        UGVR_MEMBER(NodeRecord, level), UGVR_MEMBER(NodeRecord, child_mask), UGVR_MEMBER(NodeRecord, reserved0),
        UGVR_MEMBER(NodeRecord, valid_fraction), UGVR_MEMBER(NodeRecord, reserved1)}},
      {"NodeFieldRecord",
       {UGVR_MEMBER(NodeFieldRecord, min), UGVR_MEMBER(NodeFieldRecord, max), UGVR_MEMBER(NodeFieldRecord, error_max),
        UGVR_MEMBER(NodeFieldRecord, error_rms), UGVR_MEMBER(NodeFieldRecord, block_size),
        UGVR_MEMBER(NodeFieldRecord, block_crc)}},
      {"BlockRecord",
       {UGVR_MEMBER(BlockRecord, samples), UGVR_MEMBER(BlockRecord, predictor), UGVR_MEMBER(BlockRecord, codec),
        UGVR_MEMBER(BlockRecord, flags), UGVR_MEMBER(BlockRecord, raw_size), UGVR_MEMBER(BlockRecord, valid),
        UGVR_MEMBER(BlockRecord, lo), UGVR_MEMBER(BlockRecord, hi), UGVR_MEMBER(BlockRecord, qmax),
        UGVR_MEMBER(BlockRecord, base), UGVR_MEMBER(BlockRecord, origin), UGVR_MEMBER(BlockRecord, step)}},
  };
}
#undef UGVR_MEMBER

TEST(BrickStoreFormat, DocTablesMatchTheStructs) {
  const auto doc = doc_tables();
  const auto code = struct_members();
  for (const auto& [record, members] : code) {
    SCOPED_TRACE(record);
    ASSERT_EQ(doc.count(record), 1u) << "no table for " << record << " in docs/brick-store.md";
    const auto& rows = doc.at(record);
    EXPECT_EQ(rows.size(), members.size()) << "the doc and the struct list different members";
    uint64_t end = 0;
    for (const Member& m : members) {
      ASSERT_EQ(rows.count(m.name), 1u) << m.name << " is not in the doc's table";
      EXPECT_EQ(rows.at(m.name).offset, m.offset) << m.name;
      EXPECT_EQ(rows.at(m.name).size, m.size) << m.name;
      EXPECT_EQ(m.offset, end) << m.name << ": a gap before it (padding)";
      end = m.offset + m.size;
    }
  }
  EXPECT_EQ(doc.size(), code.size()) << "a doc table for a struct this test does not know";
}

// ---------------------------------------------------------------------------------------------------------------
// A written store, read by hand

// Reads members of one record of a file at the offsets the doc gives, and remembers which were read, so that a test
// can check it read them all.
class DocRecord {
 public:
  DocRecord(const std::string& bytes, const std::map<std::string, DocRow>& rows, uint64_t base)
      : bytes_(bytes), rows_(rows), base_(base) {}
  ~DocRecord() {
    for (const auto& [name, row] : rows_) EXPECT_EQ(read_.count(name), 1u) << name << " was not checked";
  }

  // Element `index` of member `name` (a scalar: index 0), as a T of the doc's size.
  template <class T>
  T get(const std::string& name, size_t index = 0) {
    read_.insert(name);
    const auto it = rows_.find(name);
    if (it == rows_.end()) {
      ADD_FAILURE() << name << " not in the doc";
      return T{};
    }
    EXPECT_EQ(it->second.size % sizeof(T), 0u) << name;
    const uint64_t at = base_ + it->second.offset + index * sizeof(T);
    EXPECT_LE(at + sizeof(T), bytes_.size()) << name;
    T v{};
    if (at + sizeof(T) <= bytes_.size()) std::memcpy(&v, bytes_.data() + at, sizeof v);
    return v;
  }

 private:
  const std::string& bytes_;
  const std::map<std::string, DocRow>& rows_;
  uint64_t base_;
  std::set<std::string> read_;
};

// Member `m` of record `rec` (read through the struct) and of `doc` (read by hand at the doc's offset): equal to
// each other and to `expected`.
#define EXPECT_MEMBER(doc, rec, m, expected)                                    \
  do {                                                                          \
    using T = std::remove_cv_t<decltype(rec.m)>;                                \
    const T by_struct = rec.m;                                                  \
    const T by_hand = doc.get<T>(#m);                                           \
    EXPECT_EQ(by_hand, T(expected)) << #m << " at the doc's offset";            \
    EXPECT_EQ(by_struct, by_hand) << #m << ": the struct and the doc disagree"; \
  } while (0)

// A store written to be read by hand: three fields with names of 1, 21 and 10 bytes (so the field records need
// padding), a 5³ brick, and four nodes with distinct coordinates (node 3 at (3, 0, 1)): a root with a full brick, its
// child 1 with a full brick and child 2 without one, and node 1's child 3 with a partial brick. Node 3's brick is
// appended first, so it lies right after the header, then node 0's, then node 1's. Written with two encodings chosen
// so that, in one or the other, no two members of a record hold the same value: a reordering of members shows as a
// wrong value at some documented offset.
struct Variant {
  const char* name;
  BrickEncoding encoding;
  double tolerance;
};
const Variant kVariants[] = {
    {"quant16_lorenzo_stored", {SampleEncoding::Quant16, Predictor::Lorenzo, true, BrickCodec::Stored, 7}, 1e-4},
    {"float32_deltax_zstd", {SampleEncoding::Float32, Predictor::DeltaX, false, BrickCodec::Zstd, -1}, 0.0},
};

void PrintTo(const Variant& v, std::ostream* os) { *os << v.name; }

struct SmallStore {
  static constexpr uint32_t kR = 5, kSamples = kR * kR * kR, kValid3 = 40;
  static constexpr uint64_t kNodes = 4;
  BrickStoreLayout layout;
  std::vector<OctreeNode> nodes;
  std::vector<FieldError> errors;
  std::vector<float> samples[kNodes][3];  // [node][field]: R³; empty for node 2
  std::vector<uint8_t> mask3;             // node 3's

  explicit SmallStore(const Variant& v) {
    layout.resolution = kR;
    layout.fields = {{"p", Association::Vertex, -3.0, 3.0},
                     {"temperature:magnitude", Association::Cell, 0.0, 10.0},
                     {"velocity:x", Association::Vertex, -100.0, 100.0}};
    layout.root = Bounds{{-1.0, -2.0, -3.0}, {3.0, 2.0, 1.0}};
    layout.data = Bounds{{-0.5, -1.5, -2.5}, {2.5, 1.5, 0.5}};
    layout.encoding = v.encoding;
    layout.tolerance = v.tolerance;
    nodes.resize(kNodes);
    nodes[0].first_child = 1;
    nodes[0].child_mask = 0b01000010;           // octants 1 (+x) and 6 (+y +z)
    nodes[1] = {0, 3, 1, 0, 0, 1, 0b00100000};  // octant 5 (+x +z) below it
    nodes[2] = {0, kNoNode, 0, 1, 1, 1, 0};
    nodes[3] = {1, kNoNode, 3, 0, 1, 2, 0};
    for (uint64_t id = 0; id < kNodes; ++id) {
      for (int f = 0; f < 3; ++f) {
        errors.push_back({1.5f + float(id) + 0.25f * float(f), 0.5f + float(id) + 0.125f * float(f)});
        if (id == 2) continue;
        samples[id][f].resize(kSamples);
        for (uint32_t s = 0; s < kSamples; ++s) samples[id][f][s] = sample(id, f, s);
      }
    }
    mask3.assign(kSamples, 0);
    for (uint32_t s = 0; s < kValid3; ++s) mask3[s] = 1;
  }

  // Distinct values per node and field, inside the field's range.
  static float sample(uint64_t id, int f, uint32_t s) {
    const float x = float(s);
    switch (f) {
      case 0: return id == 0 ? -2.0f + 0.025f * x : id == 1 ? 0.5f + 0.01f * x : -1.0f + 0.02f * x;
      case 1: return id == 0 ? 5.0f + float(s % 7) : id == 1 ? 1.0f + 0.05f * x : 2.0f + 0.1f * x;
      default: return id == 0 ? -50.0f + 0.5f * x : id == 1 ? 10.0f * std::sin(x) : -90.0f + x;
    }
  }

  void write(const std::string& path) const {
    BrickStoreWriter w(path, layout);
    for (uint64_t id : {3, 0, 1}) {
      const float* fields[3] = {samples[id][0].data(), samples[id][1].data(), samples[id][2].data()};
      w.add_brick(id, fields, id == 3 ? mask3.data() : nullptr);
    }
    w.commit(nodes, errors);
  }

  bool quant16() const { return layout.encoding.samples == SampleEncoding::Quant16; }
  uint32_t valid(uint64_t id) const { return id == 3 ? kValid3 : kSamples; }
  // The exact range of field f's valid samples in node id's brick.
  std::pair<float, float> range(uint64_t id, int f) const {
    float lo = INFINITY, hi = -INFINITY;
    for (uint32_t s = 0; s < valid(id); ++s) {
      lo = std::min(lo, samples[id][f][s]);
      hi = std::max(hi, samples[id][f][s]);
    }
    return {lo, hi};
  }
  // ... and over its subtree.
  std::pair<float, float> subtree_range(uint64_t id, int f) const {
    auto r = range(id, f);
    for (uint64_t c : {uint64_t(1), uint64_t(3)}) {
      if (c <= id || (id == 1 && c != 3)) continue;
      r.first = std::min(r.first, range(c, f).first);
      r.second = std::max(r.second, range(c, f).second);
    }
    return r;
  }
  // The quant16 grid step of field f (what the writer passes the encoder); 0 for float32.
  double step(int f) const { return 2 * layout.tolerance * (layout.fields[f].max - layout.fields[f].min); }
};

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

uint32_t crc_of(const std::string& bytes, size_t at, size_t n) {
  return uint32_t(crc32(0, reinterpret_cast<const Bytef*>(bytes.data() + at), uInt(n)));
}

class BrickStoreFormatFile : public ::testing::TestWithParam<Variant> {
 protected:
  BrickStoreFormatFile() : store_(GetParam()) {}
  void SetUp() override {
    path_ = dir_.file("small.ugvr");
    store_.write(path_);
    bytes_ = read_file(path_);
    doc_ = doc_tables();
  }
  template <class Record>
  Record record(uint64_t at) const {
    EXPECT_LE(at + sizeof(Record), bytes_.size());
    return read_record<Record>(bytes_.data() + at);
  }
  uint64_t table() const { return bytes_.size() - SmallStore::kNodes * kRecordSize; }

  // Field records of 24, 48 and 32 bytes (names of 1, 21 and 10 bytes); node records of 48 + 3 × 24 bytes.
  // Version 5: the TfErrorHeaderRecord (24 bytes), the BoundaryHeaderRecord (40) and the CellsHeaderRecord (32)
  // between the header record and the field records.
  static constexpr uint64_t kFieldAt[3] = {272, 272 + 24, 272 + 24 + 48};
  static constexpr uint64_t kHeaderSize = 272 + 24 + 48 + 32;
  static constexpr uint64_t kRecordSize = 48 + 3 * 24;

  test::ScratchDir dir_;
  SmallStore store_;
  std::string path_, bytes_;
  std::map<std::string, std::map<std::string, DocRow>> doc_;
};

INSTANTIATE_TEST_SUITE_P(Encodings, BrickStoreFormatFile, ::testing::ValuesIn(kVariants),
                         [](const ::testing::TestParamInfo<Variant>& p) { return std::string(p.param.name); });

TEST_P(BrickStoreFormatFile, HeaderMembersAtTheirDocumentedOffsets) {
  const HeaderRecord h = record<HeaderRecord>(0);
  const BrickEncoding& e = store_.layout.encoding;
  DocRecord d(bytes_, doc_["HeaderRecord"], 0);
  for (size_t i = 0; i < 8; ++i) EXPECT_EQ(d.get<uint8_t>("magic", i), kMagic[i]);
  EXPECT_EQ(std::memcmp(h.magic, kMagic, 8), 0);
  EXPECT_MEMBER(d, h, version, 5u);  // a store of one time step is written as version 5 (6 adds the steps)
  EXPECT_MEMBER(d, h, header_size, kHeaderSize);
  EXPECT_MEMBER(d, h, resolution, SmallStore::kR);
  EXPECT_MEMBER(d, h, field_count, 3);
  EXPECT_MEMBER(d, h, node_record_size, kRecordSize);
  EXPECT_MEMBER(d, h, samples, uint8_t(e.samples));
  EXPECT_MEMBER(d, h, predictor, uint8_t(e.predictor));
  EXPECT_MEMBER(d, h, codec, uint8_t(e.codec));
  EXPECT_MEMBER(d, h, shuffle, e.shuffle ? 1 : 0);
  EXPECT_MEMBER(d, h, codec_level, e.level);
  EXPECT_MEMBER(d, h, provenance_size, 0);
  EXPECT_MEMBER(d, h, tolerance, store_.quant16() ? store_.layout.tolerance : 0.0);
  const Bounds& root = store_.layout.root;
  const Bounds& data = store_.layout.data;
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(d.get<double>("root_lo", size_t(a)), root.lo[a]);
    EXPECT_EQ(d.get<double>("root_hi", size_t(a)), root.hi[a]);
    EXPECT_EQ(d.get<double>("data_lo", size_t(a)), data.lo[a]);
    EXPECT_EQ(d.get<double>("data_hi", size_t(a)), data.hi[a]);
    EXPECT_EQ(h.root_lo[a], root.lo[a]);
    EXPECT_EQ(h.root_hi[a], root.hi[a]);
    EXPECT_EQ(h.data_lo[a], data.lo[a]);
    EXPECT_EQ(h.data_hi[a], data.hi[a]);
  }
  EXPECT_MEMBER(d, h, node_count, SmallStore::kNodes);
  EXPECT_MEMBER(d, h, node_table_offset, table());
  EXPECT_MEMBER(d, h, file_size, bytes_.size());
  EXPECT_MEMBER(d, h, node_table_crc, crc_of(bytes_, table(), bytes_.size() - table()));
  std::string header = bytes_.substr(0, kHeaderSize);
  std::memset(header.data() + 172, 0, 4);
  EXPECT_MEMBER(d, h, header_crc, crc_of(header, 0, header.size()));
  // Written without a transfer-function error table: its record says so with zeros.
  const TfErrorHeaderRecord t = record<TfErrorHeaderRecord>(176);
  DocRecord dt(bytes_, doc_["TfErrorHeaderRecord"], 176);
  EXPECT_MEMBER(dt, t, table_offset, 0);
  EXPECT_MEMBER(dt, t, table_size, 0);
  EXPECT_MEMBER(dt, t, entry_size, 0);
  EXPECT_MEMBER(dt, t, table_crc, 0);
  // Nor boundary faces.
  const BoundaryHeaderRecord bh = record<BoundaryHeaderRecord>(200);
  DocRecord db(bytes_, doc_["BoundaryHeaderRecord"], 200);
  EXPECT_MEMBER(db, bh, section_offset, 0);
  EXPECT_MEMBER(db, bh, section_size, 0);
  EXPECT_MEMBER(db, bh, triangle_count, 0);
  EXPECT_MEMBER(db, bh, reference_count, 0);
  EXPECT_MEMBER(db, bh, max_per_node, 0);
  EXPECT_MEMBER(db, bh, section_crc, 0);
  EXPECT_MEMBER(db, bh, virtual_nodes, 0);
  EXPECT_MEMBER(db, bh, reserved, 0);
  // Nor cells.
  const CellsHeaderRecord ch = record<CellsHeaderRecord>(240);
  DocRecord dc(bytes_, doc_["CellsHeaderRecord"], 240);
  EXPECT_MEMBER(dc, ch, index_offset, 0);
  EXPECT_MEMBER(dc, ch, index_size, 0);
  EXPECT_MEMBER(dc, ch, total_cells, 0);
  EXPECT_MEMBER(dc, ch, index_crc, 0);
  EXPECT_MEMBER(dc, ch, block_count, 0);
}

TEST_P(BrickStoreFormatFile, FieldRecordsAtTheirDocumentedOffsets) {
  for (int f = 0; f < 3; ++f) {
    SCOPED_TRACE("field " + std::to_string(f));
    const BrickStoreField& field = store_.layout.fields[size_t(f)];
    const uint64_t at = kFieldAt[f];
    const FieldRecord r = record<FieldRecord>(at);
    DocRecord d(bytes_, doc_["FieldRecord"], at);
    EXPECT_MEMBER(d, r, min, field.min);
    EXPECT_MEMBER(d, r, max, field.max);
    EXPECT_MEMBER(d, r, association, uint8_t(field.association));
    EXPECT_MEMBER(d, r, reserved, 0);
    EXPECT_MEMBER(d, r, name_length, field.name.size());
    // The name right after the record, then zeros up to the next record.
    EXPECT_EQ(bytes_.substr(at + 20, field.name.size()), field.name);
    const uint64_t end = f == 2 ? kHeaderSize : kFieldAt[f + 1];
    for (uint64_t b = at + 20 + field.name.size(); b < end; ++b) EXPECT_EQ(bytes_[b], 0) << "padding byte " << b;
  }
}

TEST_P(BrickStoreFormatFile, NodeRecordsAtTheirDocumentedOffsets) {
  // The blocks of each brick from the node field entries (sizes checked against the crcs below): bricks of nodes 3,
  // 0 and 1, in that order, from the header's end to the node table.
  auto brick_size = [&](uint64_t id) {
    uint64_t size = 0;
    for (uint64_t f = 0; f < 3; ++f)
      size += record<NodeFieldRecord>(table() + id * kRecordSize + 48 + 24 * f).block_size;
    return size;
  };
  const uint64_t at3 = kHeaderSize, at0 = at3 + brick_size(3), at1 = at0 + brick_size(0);
  EXPECT_EQ(at1 + brick_size(1), table()) << "the node table follows the last brick";
  const uint64_t brick_offsets[SmallStore::kNodes] = {at0, at1, 0, at3};
  for (uint64_t id = 0; id < SmallStore::kNodes; ++id) {
    SCOPED_TRACE("node " + std::to_string(id));
    const uint64_t at = table() + id * kRecordSize;
    const OctreeNode& n = store_.nodes[id];
    const NodeRecord r = record<NodeRecord>(at);
    DocRecord d(bytes_, doc_["NodeRecord"], at);
    EXPECT_MEMBER(d, r, parent, n.parent);
    EXPECT_MEMBER(d, r, first_child, n.first_child);
    EXPECT_MEMBER(d, r, brick_offset, brick_offsets[id]);
    EXPECT_MEMBER(d, r, i, n.i);
    EXPECT_MEMBER(d, r, j, n.j);
    EXPECT_MEMBER(d, r, k, n.k);
    EXPECT_MEMBER(d, r, level, n.level);
    EXPECT_MEMBER(d, r, child_mask, n.child_mask);
    EXPECT_MEMBER(d, r, reserved0, 0);
    EXPECT_MEMBER(d, r, valid_fraction, id == 2 ? 0.0f : float(store_.valid(id)) / float(SmallStore::kSamples));
    EXPECT_MEMBER(d, r, reserved1, 0);
    uint64_t block = brick_offsets[id];
    for (int f = 0; f < 3; ++f) {
      SCOPED_TRACE("field " + std::to_string(f));
      const uint64_t fat = at + 48 + 24 * uint64_t(f);
      const NodeFieldRecord fr = record<NodeFieldRecord>(fat);
      DocRecord fd(bytes_, doc_["NodeFieldRecord"], fat);
      const FieldError& e = store_.errors[id * 3 + size_t(f)];
      EXPECT_MEMBER(fd, fr, error_max, e.max);
      EXPECT_MEMBER(fd, fr, error_rms, e.rms);
      if (id == 2) {  // no brick: an empty range, no block
        EXPECT_MEMBER(fd, fr, min, INFINITY);
        EXPECT_MEMBER(fd, fr, max, -INFINITY);
        EXPECT_MEMBER(fd, fr, block_size, 0);
        EXPECT_MEMBER(fd, fr, block_crc, 0);
        continue;
      }
      // The subtree's range over the samples as given and as decoded: exact for float32, within a step for quant16.
      const auto [lo, hi] = store_.subtree_range(id, f);
      const float min = fd.get<float>("min"), max = fd.get<float>("max");
      EXPECT_EQ(fr.min, min);
      EXPECT_EQ(fr.max, max);
      EXPECT_LE(min, lo);
      EXPECT_GE(min, lo - store_.step(f));
      EXPECT_GE(max, hi);
      EXPECT_LE(max, hi + store_.step(f));
      const uint32_t size = fd.get<uint32_t>("block_size");
      EXPECT_EQ(fr.block_size, size);
      EXPECT_GE(size, sizeof(BlockRecord));
      EXPECT_MEMBER(fd, fr, block_crc, crc_of(bytes_, block, size));
      block += size;
    }
  }
}

TEST_P(BrickStoreFormatFile, BlockRecordsAtTheirDocumentedOffsets) {
  const BrickStoreReader s(path_);
  const BrickEncoding& e = store_.layout.encoding;
  for (uint64_t id : {0, 1, 3}) {
    for (int f = 0; f < 3; ++f) {
      SCOPED_TRACE("node " + std::to_string(id) + " field " + std::to_string(f));
      const uint64_t at = s.block(id, uint32_t(f)).offset;
      const BlockRecord r = record<BlockRecord>(at);
      DocRecord d(bytes_, doc_["BlockRecord"], at);
      const bool masked = id == 3;
      const auto [lo, hi] = store_.range(id, f);
      EXPECT_MEMBER(d, r, samples, uint8_t(e.samples));
      EXPECT_MEMBER(d, r, predictor, uint8_t(e.predictor));
      // The store's codec, or stored where it would not shrink the payload.
      const uint8_t codec = d.get<uint8_t>("codec");
      EXPECT_TRUE(codec == uint8_t(e.codec) || codec == 0) << int(codec);
      EXPECT_EQ(r.codec, codec);
      EXPECT_MEMBER(d, r, flags, (masked ? kBlockFlagMask : 0) | (e.shuffle ? kBlockFlagShuffled : 0));
      EXPECT_MEMBER(d, r, raw_size,
                    (masked ? mask_bytes(SmallStore::kR) : 0) + store_.valid(id) * (store_.quant16() ? 2 : 4));
      EXPECT_MEMBER(d, r, valid, store_.valid(id));
      EXPECT_MEMBER(d, r, lo, lo);
      EXPECT_MEMBER(d, r, hi, hi);
      if (store_.quant16()) {
        // The field's grid; the encoder's grid indices are round((v - origin) · (1 / step)) (store/brick_codec.h).
        const double origin = store_.layout.fields[size_t(f)].min, step = store_.step(f);
        const int64_t first = std::llround((double(lo) - origin) * (1.0 / step));
        const int64_t last = std::llround((double(hi) - origin) * (1.0 / step));
        EXPECT_MEMBER(d, r, qmax, last - first);
        EXPECT_MEMBER(d, r, base, first);
        EXPECT_MEMBER(d, r, origin, origin);
        EXPECT_MEMBER(d, r, step, step);
      } else {  // float32 blocks have no grid
        EXPECT_MEMBER(d, r, qmax, 0);
        EXPECT_MEMBER(d, r, base, 0);
        EXPECT_MEMBER(d, r, origin, 0);
        EXPECT_MEMBER(d, r, step, 0);
      }
    }
  }
}

}  // namespace
}  // namespace ugvr
