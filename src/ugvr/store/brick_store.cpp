#include "ugvr/store/brick_store.h"

#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/store/brick_store_format.h"

namespace ugvr {

namespace {

using store_format::BoundaryHeaderRecord;
using store_format::CellBlockHeader;
using store_format::CellBlockRecord;
using store_format::CellsHeaderRecord;
using store_format::field_record_size;
using store_format::FieldRecord;
using store_format::header_records_size;
using store_format::HeaderRecord;
using store_format::node_record_size;
using store_format::NodeFieldRecord;
using store_format::NodeRecord;
using store_format::read_record;
using store_format::StepFieldRange;
using store_format::StepNodeRecord;
using store_format::StepsHeaderRecord;
using store_format::TfErrorEntry;
using store_format::TfErrorHeaderRecord;
using store_format::write_record;

constexpr uint32_t kMaxNameLength = 1024;
constexpr uint32_t kMaxHeaderSize = 2u << 20;          // far above 1024 fields of 1024-byte names
constexpr uint64_t kMaxNodeId = uint64_t(1) << 40;     // ids index arrays the writer grows
constexpr size_t kTableChunkBytes = size_t(16) << 20;  // node table I/O in pieces: bounded temporary memory

// Where field f's entry of a node record starts, from the record's first byte.
constexpr uint64_t node_field_offset(uint64_t f) { return sizeof(NodeRecord) + sizeof(NodeFieldRecord) * f; }

uint32_t crc32_of(const void* data, size_t n, uint32_t crc = 0) {
  return uint32_t(crc32_z(crc, static_cast<const Bytef*>(data), n));
}

std::string hex32(uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

void put_corners(const Bounds& box, double (&lo)[3], double (&hi)[3]) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = box.lo[a];
    hi[a] = box.hi[a];
  }
}
Bounds corners_bounds(const double (&lo)[3], const double (&hi)[3]) {
  Bounds box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = lo[a];
    box.hi[a] = hi[a];
  }
  return box;
}

int octant_of(const OctreeNode& n) { return int((n.i & 1) | (n.j & 1) << 1 | (n.k & 1) << 2); }

// What is wrong with a tree, if anything: the node, the byte of its record that holds the culprit, and a sentence.
struct TreeIssue {
  uint64_t node;
  uint64_t record_offset;
  std::string what;
};

// The structural rules of the node table (see store/brick_store.h): node 0 is the root, each child's coordinates, level
// and position among its siblings agree with its parent's child mask, and children come after their parent (so the
// table has no cycles and bottom-up passes run in reverse id order).
template <class Node>
std::optional<TreeIssue> check_tree(std::span<const Node> nodes) {
  const uint64_t count = nodes.size();
  for (uint64_t id = 0; id < count; ++id) {
    const OctreeNode& n = nodes[id];
    if (n.level > kMaxOctreeLevel)
      return TreeIssue{id, offsetof(NodeRecord, level), "level " + std::to_string(n.level) + " above 31"};
    const uint64_t extent = uint64_t(1) << n.level;
    if (n.i >= extent || n.j >= extent || n.k >= extent) {
      return TreeIssue{id, offsetof(NodeRecord, i),
                       "coordinates (" + std::to_string(n.i) + ", " + std::to_string(n.j) + ", " + std::to_string(n.k) +
                           ") outside level " + std::to_string(n.level)};
    }
    if (id == 0) {
      if (n.parent != kNoNode) return TreeIssue{id, offsetof(NodeRecord, parent), "the root (node 0) has a parent"};
      if (n.level != 0) return TreeIssue{id, offsetof(NodeRecord, level), "the root (node 0) is not at level 0"};
    } else {
      if (n.parent >= id) {
        return TreeIssue{id, offsetof(NodeRecord, parent),
                         n.parent == kNoNode ? std::string("a second root (no parent)")
                                             : "parent " + std::to_string(n.parent) + " does not precede it"};
      }
      const OctreeNode& p = nodes[n.parent];
      const int o = octant_of(n);
      if (n.level != p.level + 1 || n.i >> 1 != p.i || n.j >> 1 != p.j || n.k >> 1 != p.k) {
        return TreeIssue{id, offsetof(NodeRecord, i),
                         "level and coordinates are not those of a child of node " + std::to_string(n.parent)};
      }
      const uint64_t rank = uint64_t(std::popcount(unsigned(p.child_mask) & ((1u << o) - 1)));
      if (!(p.child_mask >> o & 1) || p.first_child + rank != id) {
        return TreeIssue{
            id, offsetof(NodeRecord, parent),
            "parent " + std::to_string(n.parent) + " does not list it as its child in octant " + std::to_string(o)};
      }
    }
    if ((n.child_mask == 0) != (n.first_child == kNoNode)) {
      return TreeIssue{id, offsetof(NodeRecord, first_child), "child mask and first child disagree"};
    }
    if (n.child_mask) {
      const uint64_t children = uint64_t(std::popcount(unsigned(n.child_mask)));
      if (n.first_child <= id || n.first_child > count || children > count - n.first_child) {
        return TreeIssue{id, offsetof(NodeRecord, first_child),
                         "children [" + std::to_string(n.first_child) + ", +" + std::to_string(children) +
                             ") do not follow it inside the " + std::to_string(count) + " nodes"};
      }
      for (uint64_t c = n.first_child; c < n.first_child + children; ++c) {
        if (nodes[c].parent != id) {
          return TreeIssue{id, offsetof(NodeRecord, first_child),
                           "its child " + std::to_string(c) + " names another parent"};
        }
      }
    }
  }
  return std::nullopt;
}

// The version a writer writes: 6 for a store of several time steps, else 5 (what a one-step store needs: its bytes
// stay those of the builds before version 6).
uint32_t written_version(const BrickStoreLayout& layout) { return layout.times.empty() ? 5 : kBrickStoreVersion; }

// A transfer-function error entry's codes over [from_lo, from_hi] moved onto [to_lo, to_hi] (which contains it),
// rounded outward as the builder rounds them: the time store's steps are measured over their own ranges, and every
// table of a store is coded over the field record's range (the union of the steps').
TfErrorEntry recode_tf_entry(const TfErrorEntry& e, double from_lo, double from_hi, double to_lo, double to_hi) {
  TfErrorEntry r = e;
  const double from_w = from_hi - from_lo, to_w = to_hi - to_lo;
  if (!(to_w > 0)) {
    std::fill(std::begin(r.bound), std::end(r.bound), uint16_t(0));
    std::fill(std::begin(r.spread), std::end(r.spread), uint16_t(0));
    return r;
  }
  auto clamp_code = [](double c) { return uint16_t(std::clamp(c, 0.0, 65535.0)); };
  for (int g = 0; g <= store_format::kTfErrorGroups; ++g) {
    const double code = (from_lo + e.bound[g] * from_w / 65535.0 - to_lo) / to_w * 65535.0;
    r.bound[g] = clamp_code(g == 0 ? std::floor(code) : std::ceil(code));
  }
  for (int g = 0; g < store_format::kTfErrorGroups; ++g)
    r.spread[g] = clamp_code(std::ceil(e.spread[g] * from_w / to_w));
  return r;
}

// Bytes of a steps section (store_format::StepsHeaderRecord).
uint64_t steps_section_size(uint64_t steps, uint64_t nodes, uint64_t fields, bool tf_errors, bool cells) {
  const uint64_t later = steps - 1;
  return 8 * steps + sizeof(StepFieldRange) * fields * steps +
         later * nodes * (sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * fields) +
         (tf_errors ? later * nodes * fields * sizeof(TfErrorEntry) : 0) +
         (cells ? later * nodes * sizeof(CellBlockRecord) : 0);
}

// Appends a block (a brick, a cell block, a step's values of cells) at the end of the file and returns where it
// starts. A failed write sets `done`: the file may hold part of the block, so only the destructor's cleanup is left.
uint64_t append_block(AtomicOutputFile& out, const std::vector<std::byte>& bytes, bool& done) {
  const uint64_t offset = out.position();
  try {
    out.write(bytes.data(), bytes.size());
  } catch (...) {
    done = true;
    throw;
  }
  return offset;
}

}  // namespace

uint64_t OctreeNode::child(int octant) const {
  if (octant < 0 || octant > 7 || !(child_mask >> octant & 1)) return kNoNode;
  return first_child + uint64_t(std::popcount(unsigned(child_mask) & ((1u << octant) - 1)));
}

Bounds node_bounds(const Bounds& root, const OctreeNode& node) {
  const Vec3d cell = root.size() * std::ldexp(1.0, -int(node.level));
  Bounds b;
  b.lo = root.lo + Vec3d{cell.x * node.i, cell.y * node.j, cell.z * node.k};
  // From the next corner rather than lo + cell, so neighbours share their faces exactly.
  b.hi = root.lo + Vec3d{cell.x * (node.i + 1.0), cell.y * (node.j + 1.0), cell.z * (node.k + 1.0)};
  return b;
}

// ---------------------------------------------------------------------------------------------------------------
// Writer

BrickStoreWriter::BrickStoreWriter(std::string path, BrickStoreLayout layout)
    : path_(std::move(path)), layout_(std::move(layout)) {
  const BrickStoreLayout& l = layout_;
  if (l.resolution < kMinBrickResolution || l.resolution > kMaxBrickResolution) {
    fail_in(path_, "brick resolution " + std::to_string(l.resolution) + " outside [2, 512]");
  }
  if (l.fields.empty() || l.fields.size() > kMaxStoreFields) {
    fail_in(path_, std::to_string(l.fields.size()) + " fields; a brick store holds 1 to 1024");
  }
  uint64_t header = header_records_size(written_version(l));
  for (size_t t = 0; t < l.times.size(); ++t) {
    if (!std::isfinite(l.times[t]) || (t > 0 && l.times[t] < l.times[t - 1]))
      fail_in(path_, "time step " + std::to_string(t) + ": time " + std::to_string(l.times[t]) +
                         " is not finite or decreases");
  }
  if (l.times.size() > 0xFFFFFFFFu) fail_in(path_, "too many time steps");
  for (const BrickStoreField& f : l.fields) {
    if (f.name.empty() || f.name.size() > kMaxNameLength) {
      fail_in(path_, "field name of " + std::to_string(f.name.size()) + " bytes; 1 to 1024 allowed");
    }
    if (!std::isfinite(f.min) || !std::isfinite(f.max) || f.min > f.max) {
      fail_in(path_,
              "field '" + f.name + "': invalid range [" + std::to_string(f.min) + ", " + std::to_string(f.max) + "]");
    }
    header += field_record_size(f.name.size());
  }
  header_size_ = uint32_t(header);
  if (l.root.empty() || !(l.root.size().x > 0 && l.root.size().y > 0 && l.root.size().z > 0) ||
      !std::isfinite(l.root.lo.x + l.root.lo.y + l.root.lo.z + l.root.hi.x + l.root.hi.y + l.root.hi.z)) {
    fail_in(path_, "the octree root cell must be a finite box of positive size on every axis");
  }
  if (l.encoding.samples == SampleEncoding::Float32) {
    layout_.tolerance = 0;
  } else if (!(l.tolerance == 0 || (l.tolerance >= kQuant16Tolerance && std::isfinite(l.tolerance)))) {
    fail_in(path_, "tolerance " + std::to_string(l.tolerance) +
                       ": 16-bit samples honour at least 1/131070 of the field range; use 0 (per-brick range) or "
                       "float32 samples for more");
  }
  for (const BrickStoreField& f : l.fields) {
    steps_.push_back(2 * layout_.tolerance * (f.max - f.min));
    origins_.push_back(f.min);
  }

  out_ = std::make_unique<AtomicOutputFile>(path_);
  // A blank header until commit(): a temporary left by a killed build has no magic.
  const std::vector<std::byte> blank(header_size_);
  out_->write(blank.data(), blank.size());
}

BrickStoreWriter::~BrickStoreWriter() = default;

uint64_t BrickStoreWriter::block_bytes() const {
  std::lock_guard lock(mutex_);
  return block_bytes_;
}

EncodedBrick BrickStoreWriter::encode(std::span<const float* const> fields, const uint8_t* mask) const {
  const size_t nf = layout_.fields.size();
  if (fields.size() != nf) {
    fail_in(path_, "encode: " + std::to_string(fields.size()) + " fields given, the store has " + std::to_string(nf));
  }
  const uint32_t r = layout_.resolution;
  const size_t n = size_t(r) * r * r;
  const size_t valid = mask ? size_t(std::count_if(mask, mask + n, [](uint8_t m) { return m != 0; })) : n;
  EncodedBrick out;
  out.valid = uint32_t(valid);
  if (valid == 0) return out;
  for (size_t f = 0; f < nf; ++f) {
    EncodedBlock block;
    try {
      block = encode_brick(layout_.encoding, r, fields[f], valid == n ? nullptr : mask, steps_[f], origins_[f]);
    } catch (const Error& e) {
      fail_in(path_, "field '" + layout_.fields[f].name + "': " + e.what());
    }
    out.sizes.push_back(uint32_t(block.bytes.size()));
    out.crcs.push_back(crc32_of(block.bytes.data(), block.bytes.size()));
    // Both ranges: culling by the node range must hold for what the renderer decodes, and for the exact samples.
    out.lo.push_back(std::min(block.lo, block.decoded_lo));
    out.hi.push_back(std::max(block.hi, block.decoded_hi));
    out.bytes.insert(out.bytes.end(), block.bytes.begin(), block.bytes.end());
  }
  return out;
}

void BrickStoreWriter::append(uint64_t node, const EncodedBrick& brick) {
  std::lock_guard lock(mutex_);
  const size_t nf = layout_.fields.size();
  if (done_) fail_in(path_, "brick appended after commit() or after a failed write");
  if (node >= kMaxNodeId) fail_in(path_, "node id " + std::to_string(node) + " is absurdly large");
  if (brick.empty()) return;
  if (brick.sizes.size() != nf || brick.crcs.size() != nf || brick.lo.size() != nf || brick.hi.size() != nf) {
    fail_in(path_, "append: brick of node " + std::to_string(node) + " was not encoded for this store");
  }
  if (node >= placed_.size()) {
    const size_t grown = std::max<size_t>(size_t(node) + 1, placed_.size() * 3 / 2);
    placed_.resize(grown);
    sizes_.resize(grown * nf);
    crcs_.resize(grown * nf);
    lo_.resize(grown * nf);
    hi_.resize(grown * nf);
  }
  if (placed_[node].offset) fail_in(path_, "node " + std::to_string(node) + " already has a brick");
  const uint64_t offset = append_block(*out_, brick.bytes, done_);
  placed_[node] = {offset, brick.valid};
  for (size_t f = 0; f < nf; ++f) {
    sizes_[node * nf + f] = brick.sizes[f];
    crcs_[node * nf + f] = brick.crcs[f];
    lo_[node * nf + f] = brick.lo[f];
    hi_[node * nf + f] = brick.hi[f];
  }
  block_bytes_ += brick.bytes.size();
}

void BrickStoreWriter::add_brick(uint64_t node, std::span<const float* const> fields, const uint8_t* mask) {
  append(node, encode(fields, mask));
}

namespace {

// The sizes of a cell block's arrays, from its header (the layout in store/brick_store_format.h).
struct CellBlockSizes {
  uint64_t ids, types, connectivity, across, points, values, total;
};
CellBlockSizes cell_block_sizes(const CellBlockHeader& h, uint64_t value_count) {
  CellBlockSizes z;
  z.ids = 8 * uint64_t(h.cell_count);
  z.types = (uint64_t(h.cell_count) + 3) / 4 * 4;
  z.connectivity = 4 * uint64_t(h.vertex_references);
  z.across = 4 * uint64_t(h.face_slots);
  z.points = 12 * uint64_t(h.point_count);
  z.values = 4 * value_count;
  z.total = sizeof(CellBlockHeader) + z.ids + z.types + z.connectivity + z.across + z.points + z.values;
  return z;
}

// Values a cell block holds for the store's fields: per field V (vertex) or C (cell).
uint64_t cell_value_count(const BrickStoreLayout& layout, uint64_t cells, uint64_t points) {
  uint64_t n = 0;
  for (const BrickStoreField& f : layout.fields) n += f.association == Association::Cell ? cells : points;
  return n;
}

// The largest cell block, decoded: far above a leaf's cells (a 32³ brick's leaf holds thousands), so that a corrupt
// frame cannot make the reader allocate without bound.
constexpr uint64_t kMaxCellBlockBytes = uint64_t(1) << 30;

}  // namespace

EncodedCells BrickStoreWriter::encode_cells(const NodeCells& c) const {
  const uint64_t C = c.ids.size(), V = c.points.size();
  auto bad = [&](const std::string& what) { fail_in(path_, "encode_cells: " + what); };
  if (C == 0 || V == 0) bad("a cell block needs cells and points");
  if (c.types.size() != C) bad("one type per cell expected");
  uint64_t refs = 0, faces = 0;
  for (CellType t : c.types) {
    refs += cell_vertex_count(t);
    faces += cell_face_count(t);
  }
  if (c.connectivity.size() != refs || c.across.size() != faces) bad("connectivity or faces do not match the types");
  if (c.values.size() != cell_value_count(layout_, C, V)) bad("values do not match the store's fields");
  if (C > 0xFFFFFFF0u || V > 0xFFFFFFF0u || refs > 0xFFFFFFFFu || faces > 0xFFFFFFFFu) bad("too many cells");
  CellBlockHeader h;
  h.cell_count = uint32_t(C);
  h.point_count = uint32_t(V);
  h.vertex_references = uint32_t(refs);
  h.face_slots = uint32_t(faces);
  h.field_count = uint32_t(layout_.fields.size());
  const CellBlockSizes z = cell_block_sizes(h, c.values.size());
  if (z.total > kMaxCellBlockBytes) bad("a cell block of " + std::to_string(z.total) + " bytes is too large");
  std::vector<std::byte> raw(z.total, std::byte{0});
  std::byte* p = raw.data();
  write_record(p, h);
  p += sizeof h;
  std::memcpy(p, c.ids.data(), z.ids);
  p += z.ids;
  for (uint64_t i = 0; i < C; ++i) p[i] = std::byte(uint8_t(c.types[i]));
  p += z.types;
  std::memcpy(p, c.connectivity.data(), z.connectivity);
  p += z.connectivity;
  std::memcpy(p, c.across.data(), z.across);
  p += z.across;
  std::memcpy(p, c.points.data(), z.points);
  p += z.points;
  std::memcpy(p, c.values.data(), z.values);
  EncodedCells out;
  out.bytes.resize(ZSTD_compressBound(raw.size()));
  const size_t n = ZSTD_compress(out.bytes.data(), out.bytes.size(), raw.data(), raw.size(), 3);
  if (ZSTD_isError(n)) bad(std::string("zstd: ") + ZSTD_getErrorName(n));
  out.bytes.resize(n);
  out.crc = crc32_of(out.bytes.data(), out.bytes.size());
  out.cells = uint32_t(C);
  out.values = c.values.size();
  return out;
}

EncodedCells BrickStoreWriter::encode_cell_values(std::span<const float> values) const {
  if (values.empty() || values.size_bytes() > kMaxCellBlockBytes)
    fail_in(path_, "encode_cell_values: " + std::to_string(values.size()) + " values");
  EncodedCells out;
  out.bytes.resize(ZSTD_compressBound(values.size_bytes()));
  const size_t n = ZSTD_compress(out.bytes.data(), out.bytes.size(), values.data(), values.size_bytes(), 3);
  if (ZSTD_isError(n)) fail_in(path_, std::string("encode_cell_values: zstd: ") + ZSTD_getErrorName(n));
  out.bytes.resize(n);
  out.crc = crc32_of(out.bytes.data(), out.bytes.size());
  out.values = values.size();
  return out;
}

void BrickStoreWriter::append_cell_values(uint64_t node, const EncodedCells& values) {
  std::lock_guard lock(mutex_);
  if (done_) fail_in(path_, "cell values appended after commit() or after a failed write");
  if (!step_open_ || step_ < 1)
    fail_in(path_,
            "append_cell_values: the values of a time step after the first, between its begin_step and end_step");
  if (node >= cell_blocks_.size() || cell_blocks_[node].offset == 0)
    fail_in(path_, "append_cell_values: node " + std::to_string(node) + " has no cell block");
  if (values.values != cell_value_counts_[node] || values.bytes.empty() || values.bytes.size() > 0xFFFFFFFFu)
    fail_in(path_, "append_cell_values: node " + std::to_string(node) + ": " + std::to_string(values.values) +
                       " values, its cell block holds " + std::to_string(cell_value_counts_[node]));
  std::vector<CellBlockRecord>& index = done_steps_.back().cell_values;
  if (node >= index.size()) index.resize(std::max<size_t>(size_t(node) + 1, index.size() * 3 / 2));
  if (index[node].offset)
    fail_in(path_, "time step " + std::to_string(step_) + ": node " + std::to_string(node) + " already has values");
  const uint64_t offset = append_block(*out_, values.bytes, done_);
  index[node] = {offset, uint32_t(values.bytes.size()), values.crc};
  block_bytes_ += values.bytes.size();
}

void BrickStoreWriter::append_cells(uint64_t node, const EncodedCells& cells) {
  std::lock_guard lock(mutex_);
  if (done_) fail_in(path_, "cells appended after commit() or after a failed write");
  if (node >= kMaxNodeId) fail_in(path_, "node id " + std::to_string(node) + " is absurdly large");
  if (cells.bytes.empty() || cells.bytes.size() > 0xFFFFFFFFu) fail_in(path_, "append_cells: no or too many bytes");
  if (node >= cell_blocks_.size()) {
    cell_blocks_.resize(std::max<size_t>(size_t(node) + 1, cell_blocks_.size() * 3 / 2));
    cell_value_counts_.resize(cell_blocks_.size());
  }
  if (cell_blocks_[node].offset) fail_in(path_, "node " + std::to_string(node) + " already has cells");
  const uint64_t offset = append_block(*out_, cells.bytes, done_);
  cell_blocks_[node] = {offset, uint32_t(cells.bytes.size()), cells.crc};
  cell_value_counts_[node] = cells.values;
  total_cells_ += cells.cells;
  block_bytes_ += cells.bytes.size();
}

void BrickStoreWriter::begin_step(uint32_t step, std::span<const StepFieldRange> ranges) {
  std::lock_guard lock(mutex_);
  const size_t nf = layout_.fields.size();
  if (done_) fail_in(path_, "begin_step() after commit() or after a failed write");
  if (layout_.times.empty()) fail_in(path_, "begin_step(): the store was not laid out with time steps");
  if (step_open_ || int64_t(step) != step_ + 1 || step >= layout_.times.size())
    fail_in(path_, "begin_step(" + std::to_string(step) + "): steps are written in order, each ended before the next");
  if (ranges.size() != nf)
    fail_in(path_, "begin_step(): " + std::to_string(ranges.size()) + " ranges for " + std::to_string(nf) + " fields");
  for (size_t f = 0; f < nf; ++f) {
    const StepFieldRange& r = ranges[f];
    const BrickStoreField& field = layout_.fields[f];
    if (!std::isfinite(r.min) || !std::isfinite(r.max) || r.min > r.max)
      fail_in(path_, "time step " + std::to_string(step) + " field '" + field.name + "': invalid range [" +
                         std::to_string(r.min) + ", " + std::to_string(r.max) + "]");
    steps_[f] = 2 * layout_.tolerance * (r.max - r.min);
    origins_[f] = r.min;
  }
  if (!placed_.empty()) fail_in(path_, "begin_step(): bricks were appended outside a step");
  step_ = step;
  step_open_ = true;
  StepTables t;
  t.ranges.assign(ranges.begin(), ranges.end());
  done_steps_.push_back(std::move(t));
}

void BrickStoreWriter::end_step(std::span<const FieldError> errors, std::span<const TfErrorEntry> tf_errors) {
  std::lock_guard lock(mutex_);
  if (done_ || !step_open_) fail_in(path_, "end_step() without begin_step()");
  StepTables& t = done_steps_.back();
  t.placed = std::move(placed_);
  t.sizes = std::move(sizes_);
  t.crcs = std::move(crcs_);
  t.lo = std::move(lo_);
  t.hi = std::move(hi_);
  t.errors.assign(errors.begin(), errors.end());
  t.tf_errors.assign(tf_errors.begin(), tf_errors.end());
  placed_ = {}, sizes_ = {}, crcs_ = {}, lo_ = {}, hi_ = {};
  step_open_ = false;
}

void BrickStoreWriter::commit(std::span<const OctreeNode> nodes, std::span<const FieldError> errors,
                              std::span<const TfErrorEntry> tf_errors, const StoreBoundary* boundary) {
  std::lock_guard lock(mutex_);
  if (done_) fail_in(path_, "commit() after commit() or after a failed write");
  done_ = true;  // whatever happens below, this writer writes no more
  const uint64_t count = nodes.size();
  const size_t nf = layout_.fields.size();
  const uint64_t step_count = layout_.times.size();
  if (step_count > 0) {
    // A time store: step 0's tables are the node table's; the other steps are checked against them below.
    if (step_open_ || done_steps_.size() != step_count)
      fail_in(path_, "commit: " + std::to_string(done_steps_.size()) + " of " + std::to_string(step_count) +
                         " time steps written" + (step_open_ ? " (the last not ended)" : ""));
    if (!errors.empty() || !tf_errors.empty()) fail_in(path_, "commit: a time store takes its errors per step");
    StepTables& t0 = done_steps_[0];
    placed_ = std::move(t0.placed), sizes_ = std::move(t0.sizes), crcs_ = std::move(t0.crcs);
    lo_ = std::move(t0.lo), hi_ = std::move(t0.hi);
    errors = t0.errors;
    tf_errors = t0.tf_errors;
    for (uint64_t s = 1; s < step_count; ++s) {
      if (done_steps_[s].errors.size() != errors.size() || done_steps_[s].tf_errors.size() != tf_errors.size())
        fail_in(path_, "commit: time step " + std::to_string(s) + " has error tables of other sizes than step 0's");
    }
    // The field records hold the union of the steps' ranges.
    for (size_t f = 0; f < nf; ++f) {
      layout_.fields[f].min = done_steps_[0].ranges[f].min;
      layout_.fields[f].max = done_steps_[0].ranges[f].max;
      for (const StepTables& t : done_steps_) {
        layout_.fields[f].min = std::min(layout_.fields[f].min, t.ranges[f].min);
        layout_.fields[f].max = std::max(layout_.fields[f].max, t.ranges[f].max);
      }
    }
    for (StepTables& t : done_steps_) {
      for (size_t e = 0; e < t.tf_errors.size(); ++e) {
        const size_t f = e % nf;
        t.tf_errors[e] = recode_tf_entry(t.tf_errors[e], t.ranges[f].min, t.ranges[f].max, layout_.fields[f].min,
                                         layout_.fields[f].max);
      }
    }
  }
  if (count == 0) fail_in(path_, "commit: the tree has no node");
  if (!errors.empty() && errors.size() != count * nf) {
    fail_in(path_, "commit: " + std::to_string(errors.size()) + " error entries for " + std::to_string(count) +
                       " nodes × " + std::to_string(nf) + " fields");
  }
  if (!tf_errors.empty() && tf_errors.size() != count * nf) {
    fail_in(path_, "commit: " + std::to_string(tf_errors.size()) + " transfer-function error entries for " +
                       std::to_string(count) + " nodes × " + std::to_string(nf) + " fields");
  }
  if (boundary && !boundary->empty()) {
    if (boundary->nodes.size() < count || (boundary->nodes.size() - count) % 8)
      fail_in(path_, "commit: boundary faces for " + std::to_string(boundary->nodes.size()) + " nodes, the tree has " +
                         std::to_string(count) + " (and virtual nodes come in eights)");
    for (const auto& e : boundary->nodes) {
      if (e.count != store_format::kBoundaryOverflow && uint64_t(e.first) + e.count > boundary->refs.size())
        fail_in(path_, "commit: a node's boundary faces run past the references");
    }
    for (uint32_t r : boundary->refs)
      if (r >= boundary->triangles.size()) fail_in(path_, "commit: a boundary reference past the triangles");
  }
  if (auto issue = check_tree(nodes))
    fail_in(path_, "commit: node " + std::to_string(issue->node) + ": " + issue->what);
  for (uint64_t id = count; id < placed_.size(); ++id) {
    if (placed_[id].offset) {
      fail_in(path_, "commit: a brick was appended for node " + std::to_string(id) + " but the tree has " +
                         std::to_string(count) + " nodes");
    }
  }
  for (uint64_t id = count; id < cell_blocks_.size(); ++id) {
    if (cell_blocks_[id].offset)
      fail_in(path_, "commit: cells were appended for node " + std::to_string(id) + " but the tree has " +
                         std::to_string(count) + " nodes");
  }
  placed_.resize(count);
  sizes_.resize(count * nf);
  crcs_.resize(count * nf);
  lo_.resize(count * nf);
  hi_.resize(count * nf);

  // Value ranges bottom-up (children have larger ids), so that a node's range contains its subtree's.
  auto subtree_ranges = [&](const std::vector<Placed>& placed, const std::vector<float>& lo,
                            const std::vector<float>& hi, std::vector<float>& mins, std::vector<float>& maxs) {
    mins.assign(count * nf, INFINITY);
    maxs.assign(count * nf, -INFINITY);
    for (uint64_t id = count; id-- > 0;) {
      const OctreeNode& n = nodes[id];
      for (size_t f = 0; f < nf; ++f) {
        float& mn = mins[id * nf + f];
        float& mx = maxs[id * nf + f];
        if (placed[id].offset) {
          mn = lo[id * nf + f];
          mx = hi[id * nf + f];
        }
        if (n.child_mask) {
          const uint64_t end = n.first_child + uint64_t(std::popcount(unsigned(n.child_mask)));
          for (uint64_t c = n.first_child; c < end; ++c) {
            mn = std::min(mn, mins[c * nf + f]);
            mx = std::max(mx, maxs[c * nf + f]);
          }
        }
      }
    }
  };
  std::vector<float> mins, maxs;
  subtree_ranges(placed_, lo_, hi_, mins, maxs);
  const uint32_t rec = node_record_size(nf);
  const double samples = double(layout_.resolution) * layout_.resolution * layout_.resolution;
  // The transfer-function error table, before the provenance record (which must end where the node table starts).
  TfErrorHeaderRecord tf_header;
  if (!tf_errors.empty()) {
    tf_header.table_offset = out_->position();
    tf_header.table_size = uint64_t(tf_errors.size_bytes());
    tf_header.entry_size = sizeof(TfErrorEntry);
    tf_header.table_crc = crc32_of(tf_errors.data(), tf_errors.size_bytes());
    out_->write(reinterpret_cast<const std::byte*>(tf_errors.data()), tf_errors.size_bytes());
  }
  // The boundary faces likewise (format version 4): node entries, references, triangles, one checksum.
  BoundaryHeaderRecord boundary_header;
  if (boundary && !boundary->empty()) {
    const StoreBoundary& b = *boundary;
    boundary_header.section_offset = out_->position();
    boundary_header.section_size = b.bytes();
    boundary_header.triangle_count = uint32_t(b.triangles.size());
    boundary_header.reference_count = uint32_t(b.refs.size());
    boundary_header.max_per_node = b.max_per_node;
    boundary_header.virtual_nodes = uint32_t(b.nodes.size() - count);
    const auto* p0 = reinterpret_cast<const std::byte*>(b.nodes.data());
    const auto* p1 = reinterpret_cast<const std::byte*>(b.refs.data());
    const auto* p2 = reinterpret_cast<const std::byte*>(b.triangles.data());
    const size_t n0 = b.nodes.size() * sizeof(b.nodes[0]), n1 = b.refs.size() * 4,
                 n2 = b.triangles.size() * sizeof(b.triangles[0]);
    boundary_header.section_crc = crc32_of(p2, n2, crc32_of(p1, n1, crc32_of(p0, n0)));
    out_->write(p0, n0);
    out_->write(p1, n1);
    out_->write(p2, n2);
  }
  // The cells' index (format version 5): one record per node.
  CellsHeaderRecord cells_header;
  if (!cell_blocks_.empty()) {
    cell_blocks_.resize(count);
    cells_header.index_offset = out_->position();
    cells_header.index_size = count * sizeof(CellBlockRecord);
    cells_header.total_cells = total_cells_;
    cells_header.block_count = uint32_t(std::count_if(cell_blocks_.begin(), cell_blocks_.end(),
                                                      [](const CellBlockRecord& r) { return r.offset != 0; }));
    const auto* p = reinterpret_cast<const std::byte*>(cell_blocks_.data());
    cells_header.index_crc = crc32_of(p, cells_header.index_size);
    out_->write(p, cells_header.index_size);
  }
  // The time steps after the first (format version 6): times, ranges, per step its node records, then its
  // transfer-function error entries; one checksum over the section.
  StepsHeaderRecord steps_header;
  if (step_count > 0) {
    const bool with_tf = !tf_errors.empty();
    // The later steps' values of the cells: every node with a cell block has them in every later step.
    const bool with_cells = !cell_blocks_.empty() && step_count > 1;
    for (uint64_t s = 1; s < step_count && with_cells; ++s) {
      std::vector<CellBlockRecord>& index = done_steps_[s].cell_values;
      index.resize(count);  // append_cell_values took nodes with cells only, all below count
      for (uint64_t id = 0; id < count; ++id) {
        if (cell_blocks_[id].offset && !index[id].offset)
          fail_in(path_, "commit: time step " + std::to_string(s) + ": node " + std::to_string(id) +
                             " keeps cells but has no values for the step");
      }
    }
    steps_header.section_offset = out_->position();
    steps_header.section_size = steps_section_size(step_count, count, nf, with_tf, with_cells);
    steps_header.step_count = uint32_t(step_count);
    steps_header.flags =
        (with_tf ? store_format::kStepsHaveTfErrors : 0) | (with_cells ? store_format::kStepsHaveCells : 0);
    uint32_t crc = 0;
    auto put = [&](const void* p, size_t n) {
      crc = crc32_of(p, n, crc);
      out_->write(static_cast<const std::byte*>(p), n);
    };
    put(layout_.times.data(), step_count * 8);
    for (const StepTables& t : done_steps_) put(t.ranges.data(), nf * sizeof(StepFieldRange));
    const uint32_t rec_size = uint32_t(sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * nf);
    std::vector<float> step_mins, step_maxs;
    std::vector<std::byte> buf;
    for (uint64_t s = 1; s < step_count; ++s) {
      StepTables& t = done_steps_[s];
      for (uint64_t id = count; id < t.placed.size(); ++id) {
        if (t.placed[id].offset)
          fail_in(path_, "commit: time step " + std::to_string(s) + ": a brick was appended for node " +
                             std::to_string(id) + " but the tree has " + std::to_string(count) + " nodes");
      }
      t.placed.resize(count), t.sizes.resize(count * nf), t.crcs.resize(count * nf);
      t.lo.resize(count * nf), t.hi.resize(count * nf);
      for (uint64_t id = 0; id < count; ++id) {
        if ((t.placed[id].offset != 0) != (placed_[id].offset != 0) ||
            (t.placed[id].offset && t.placed[id].valid != placed_[id].valid))
          fail_in(path_, "commit: time step " + std::to_string(s) + ": node " + std::to_string(id) + " has " +
                             std::to_string(t.placed[id].valid) + " valid samples, step 0 " +
                             std::to_string(placed_[id].valid) + ": the steps' geometry differs");
      }
      subtree_ranges(t.placed, t.lo, t.hi, step_mins, step_maxs);
      for (uint64_t first = 0; first < count; first += 65536) {
        const uint64_t end = std::min(count, first + 65536);
        buf.assign(size_t(end - first) * rec_size, std::byte{0});
        for (uint64_t id = first; id < end; ++id) {
          std::byte* at = buf.data() + size_t(id - first) * rec_size;
          StepNodeRecord r;
          r.brick_offset = t.placed[id].offset;
          write_record(at, r);
          for (size_t f = 0; f < nf; ++f) {
            const size_t e = id * nf + f;
            NodeFieldRecord fr;
            fr.min = step_mins[e];
            fr.max = step_maxs[e];
            fr.error_max = t.errors.empty() ? 0.0f : t.errors[e].max;
            fr.error_rms = t.errors.empty() ? 0.0f : t.errors[e].rms;
            fr.block_size = t.placed[id].offset ? t.sizes[e] : 0;
            fr.block_crc = t.placed[id].offset ? t.crcs[e] : 0;
            write_record(at + sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * f, fr);
          }
        }
        put(buf.data(), buf.size());
      }
    }
    for (uint64_t s = 1; s < step_count && with_tf; ++s)
      put(done_steps_[s].tf_errors.data(), done_steps_[s].tf_errors.size() * sizeof(TfErrorEntry));
    for (uint64_t s = 1; s < step_count && with_cells; ++s)
      put(done_steps_[s].cell_values.data(), count * sizeof(CellBlockRecord));
    steps_header.section_crc = crc;
  }
  uint32_t provenance_size = 0;
  if (!layout_.provenance.empty()) {
    const std::string& text = layout_.provenance;
    const uint32_t crc = crc32_of(reinterpret_cast<const std::byte*>(text.data()), text.size(), 0);
    std::byte crc_bytes[4];
    std::memcpy(crc_bytes, &crc, 4);  // little-endian, as every integer of the format (brick_store_format.h)
    out_->write(reinterpret_cast<const std::byte*>(text.data()), text.size());
    out_->write(crc_bytes, 4);
    provenance_size = uint32_t(text.size() + 4);
  }
  const uint64_t table_offset = out_->position();
  const uint64_t chunk_nodes = std::max<uint64_t>(1, kTableChunkBytes / rec);
  std::vector<std::byte> buf;
  uint32_t table_crc = 0;
  for (uint64_t first = 0; first < count; first += chunk_nodes) {
    const uint64_t end = std::min(count, first + chunk_nodes);
    buf.assign(size_t(end - first) * rec, std::byte{0});
    for (uint64_t id = first; id < end; ++id) {
      std::byte* at = buf.data() + size_t(id - first) * rec;
      const OctreeNode& n = nodes[id];
      NodeRecord r;
      r.parent = n.parent;
      r.first_child = n.first_child;
      r.brick_offset = placed_[id].offset;
      r.i = n.i;
      r.j = n.j;
      r.k = n.k;
      r.level = n.level;
      r.child_mask = n.child_mask;
      r.valid_fraction = float(double(placed_[id].valid) / samples);
      write_record(at, r);
      for (size_t f = 0; f < nf; ++f) {
        const size_t e = id * nf + f;
        NodeFieldRecord fr;
        fr.min = mins[e];
        fr.max = maxs[e];
        fr.error_max = errors.empty() ? 0.0f : errors[e].max;
        fr.error_rms = errors.empty() ? 0.0f : errors[e].rms;
        fr.block_size = placed_[id].offset ? sizes_[e] : 0;
        fr.block_crc = placed_[id].offset ? crcs_[e] : 0;
        write_record(at + node_field_offset(f), fr);
      }
    }
    table_crc = crc32_of(buf.data(), buf.size(), table_crc);
    out_->write(buf.data(), buf.size());
  }
  const uint64_t file_size = out_->position();

  HeaderRecord header;
  std::memcpy(header.magic, store_format::kMagic, sizeof header.magic);
  header.version = written_version(layout_);
  header.header_size = header_size_;
  header.resolution = layout_.resolution;
  header.field_count = uint32_t(nf);
  header.node_record_size = rec;
  header.samples = uint8_t(layout_.encoding.samples);
  header.predictor = uint8_t(layout_.encoding.predictor);
  header.codec = uint8_t(layout_.encoding.codec);
  header.shuffle = layout_.encoding.shuffle ? 1 : 0;
  header.codec_level = layout_.encoding.level;
  header.provenance_size = provenance_size;
  header.tolerance = layout_.tolerance;
  put_corners(layout_.root, header.root_lo, header.root_hi);
  put_corners(layout_.data, header.data_lo, header.data_hi);
  header.node_count = count;
  header.node_table_offset = table_offset;
  header.file_size = file_size;
  header.node_table_crc = table_crc;
  // The checksum covers the field records too, so they go into the buffer first; header_crc is 0 meanwhile.
  std::vector<std::byte> h(header_size_, std::byte{0});
  write_record(h.data() + sizeof(HeaderRecord), tf_header);
  write_record(h.data() + sizeof(HeaderRecord) + sizeof(TfErrorHeaderRecord), boundary_header);
  write_record(h.data() + sizeof(HeaderRecord) + sizeof(TfErrorHeaderRecord) + sizeof(BoundaryHeaderRecord),
               cells_header);
  if (header.version >= 6) write_record(h.data() + header_records_size(5), steps_header);
  size_t at = header_records_size(header.version);
  for (const BrickStoreField& f : layout_.fields) {
    FieldRecord r;
    r.min = f.min;
    r.max = f.max;
    r.association = uint8_t(f.association);
    r.name_length = uint16_t(f.name.size());
    write_record(h.data() + at, r);
    std::memcpy(h.data() + at + sizeof(FieldRecord), f.name.data(), f.name.size());
    at += field_record_size(f.name.size());
  }
  write_record(h.data(), header);
  header.header_crc = crc32_of(h.data(), h.size());
  write_record(h.data(), header);
  out_->write_at(0, h.data(), h.size());
  out_->commit();
}

// ---------------------------------------------------------------------------------------------------------------
// Reader

BrickStoreReader::BrickStoreReader(std::string path) : file_(std::move(path)) {
  const std::vector<std::byte> header_bytes = read_header();
  read_field_records(header_bytes);
  read_node_table();
  read_provenance();
  read_tf_errors();
  read_boundary();
  read_cells_index();
  read_steps();
  check_nodes();
}

// The time steps after the first (version 6): between the blocks and the provenance record, one checksum; the times,
// ranges and each step's node records are checked here, the records' blocks and ranges with step 0's in check_nodes().
void BrickStoreReader::read_steps() {
  const StepsHeaderRecord& h = steps_header_;
  if (h.section_offset == 0 && h.section_size == 0 && h.step_count == 0) return;
  const std::string& name = file_.path();
  const uint64_t at = header_records_size(5);
  const uint64_t n = node_count(), nf = field_count();
  const uint64_t rec = sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * nf;
  const bool with_tf = (h.flags & store_format::kStepsHaveTfErrors) != 0;
  const bool with_cells = (h.flags & store_format::kStepsHaveCells) != 0;
  if ((h.flags & ~(store_format::kStepsHaveTfErrors | store_format::kStepsHaveCells)) != 0 ||
      with_tf != has_tf_errors())
    fail_at_offset(name, at + offsetof(StepsHeaderRecord, flags),
                   "steps flags " + std::to_string(h.flags) +
                       (with_tf != has_tf_errors() ? ": the transfer-function error tables of the "
                                                     "steps and of the node table disagree"
                                                   : ": unknown flags"));
  // The cell blocks hold step 0's values: a store keeping cells has every later step's, and only such a store.
  if (with_cells != (has_cells() && h.step_count > 1))
    fail_at_offset(name, at + offsetof(StepsHeaderRecord, flags),
                   "steps flags " + std::to_string(h.flags) + ": " +
                       (with_cells ? "values of cells for a store that keeps no cells or one step"
                                   : "the store keeps cells but not their values for the steps after the first"));
  const uint64_t end = node_table_offset_ - header_.provenance_size;
  // The step count bounded by the file before any size is computed from it (no overflow, no huge allocation).
  if (h.step_count == 0 || (h.step_count > 1 && uint64_t(h.step_count - 1) > file_.size() / (n * rec)))
    fail_at_offset(name, at + offsetof(StepsHeaderRecord, step_count),
                   std::to_string(h.step_count) + " time steps: impossible in a store of " +
                       std::to_string(file_.size()) + " bytes with " + std::to_string(n) + " nodes");
  const uint64_t expected = steps_section_size(h.step_count, n, nf, with_tf, with_cells);
  if (h.section_size != expected)
    fail_at_offset(name, at + offsetof(StepsHeaderRecord, section_size),
                   "steps section of " + std::to_string(h.section_size) + " bytes; expected " +
                       std::to_string(expected) + " for " + std::to_string(h.step_count) + " steps, " +
                       std::to_string(n) + " nodes and " + std::to_string(nf) + " fields");
  if (h.section_offset < header_.header_size || h.section_offset > end || h.section_size > end - h.section_offset)
    fail_at_offset(name, at + offsetof(StepsHeaderRecord, section_offset),
                   "steps section at offset " + std::to_string(h.section_offset) +
                       " does not fit between the header and the node table");
  std::vector<std::byte> bytes(static_cast<size_t>(h.section_size));
  file_.read_at(h.section_offset, bytes.data(), bytes.size());
  if (const uint32_t crc = crc32_of(bytes.data(), bytes.size()); crc != h.section_crc)
    fail_at_offset(name, h.section_offset,
                   "steps section checksum mismatch (stored " + hex32(h.section_crc) + ", computed " + hex32(crc) +
                       "): the section is corrupt");
  const uint64_t S = h.step_count;
  std::vector<double> times(S);
  std::memcpy(times.data(), bytes.data(), S * 8);
  for (uint64_t t = 0; t < S; ++t) {
    if (!std::isfinite(times[t]) || (t > 0 && times[t] < times[t - 1]))
      fail_at_offset(name, h.section_offset + 8 * t,
                     "time step " + std::to_string(t) + ": time " + std::to_string(times[t]) +
                         " is not finite or is before the previous step's");
  }
  std::vector<StepFieldRange> ranges(S * nf);
  std::memcpy(ranges.data(), bytes.data() + 8 * S, ranges.size() * sizeof(StepFieldRange));
  for (uint64_t e = 0; e < ranges.size(); ++e) {
    const StepFieldRange& r = ranges[e];
    const BrickStoreField& field = layout_.fields[e % nf];
    if (!std::isfinite(r.min) || !std::isfinite(r.max) || !(r.min <= r.max) || r.min < field.min || r.max > field.max)
      fail_at_offset(name, h.section_offset + 8 * S + e * sizeof(StepFieldRange),
                     "time step " + std::to_string(e / nf) + " field '" + field.name + "': range [" +
                         std::to_string(r.min) + ", " + std::to_string(r.max) +
                         "] is not a finite range inside the field's");
  }
  steps_nodes_offset_ = h.section_offset + 8 * S + sizeof(StepFieldRange) * nf * S;
  const std::byte* p = bytes.data() + (steps_nodes_offset_ - h.section_offset);
  stats_.resize(S * n * nf);
  blocks_.resize(S * n * nf);
  for (uint64_t t = 1; t < S; ++t) {
    for (uint64_t id = 0; id < n; ++id, p += rec) {
      const StepNodeRecord r = read_record<StepNodeRecord>(p);
      if ((r.brick_offset != 0) != nodes_[id].has_brick())
        fail_at_offset(name, step_record_offset(id, uint32_t(t)),
                       "time step " + std::to_string(t) + " node " + std::to_string(id) +
                           (r.brick_offset ? ": a brick where step 0 has none" : ": no brick where step 0 has one"));
      uint64_t offset = r.brick_offset;
      for (uint64_t f = 0; f < nf; ++f) {
        const NodeFieldRecord fr = read_record<NodeFieldRecord>(p + sizeof(StepNodeRecord) + sizeof(fr) * f);
        const uint64_t e = (t * n + id) * nf + f;
        stats_[e] = {fr.min, fr.max, fr.error_max, fr.error_rms};
        blocks_[e] = {offset, fr.block_size, fr.block_crc};
        offset += fr.block_size;
      }
    }
  }
  if (with_tf) {
    const size_t step_entries = size_t(n * nf);
    tf_errors_.resize(size_t(S) * step_entries);
    std::memcpy(tf_errors_.data() + step_entries, p, (S - 1) * step_entries * sizeof(TfErrorEntry));
    p += (S - 1) * step_entries * sizeof(TfErrorEntry);
  }
  if (with_cells) {
    // Each later step's values blocks: exactly the nodes with a cell block have one, among the blocks (before the
    // cell index, which follows them all); the blocks themselves are checked when read.
    std::vector<CellBlockRecord> values(size_t((S - 1) * n));
    std::memcpy(values.data(), p, values.size() * sizeof(CellBlockRecord));
    const uint64_t records_at = h.section_offset + uint64_t(p - bytes.data());
    for (uint64_t e = 0; e < values.size(); ++e) {
      const CellBlockRecord& r = values[e];
      const uint64_t id = e % n;
      const std::string what = "time step " + std::to_string(e / n + 1) + " node " + std::to_string(id) + ": ";
      if ((r.offset != 0) != (cell_blocks_[id].offset != 0))
        fail_at_offset(name, records_at + e * sizeof(CellBlockRecord),
                       what + (r.offset ? "values of cells where the node keeps none" : "no values of its cells"));
      if (r.offset != 0 && (r.offset < header_.header_size || r.size == 0 || r.offset > cells_header_.index_offset ||
                            r.size > cells_header_.index_offset - r.offset))
        fail_at_offset(name, records_at + e * sizeof(CellBlockRecord),
                       what + "the values of its cells (offset " + std::to_string(r.offset) + ", " +
                           std::to_string(r.size) + " bytes) do not lie among the blocks");
    }
    cell_values_ = std::move(values);
  }
  times_ = std::move(times);
  ranges_ = std::move(ranges);
}

uint64_t BrickStoreReader::step_record_offset(uint64_t node, uint32_t step) const {
  if (step == 0) return record_offset(node);
  const uint64_t rec = sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * field_count();
  return steps_nodes_offset_ + ((step - 1) * node_count() + node) * rec;
}

void BrickStoreReader::set_step(uint32_t step) {
  check_node_field(0, 0, step);
  step_ = step;
}

double BrickStoreReader::step_time(uint32_t step) const {
  if (step >= step_count())
    fail_in(path(),
            "time step " + std::to_string(step) + " out of range (the store has " + std::to_string(step_count()) + ")");
  return times_.empty() ? 0.0 : times_[step];
}

StepFieldRange BrickStoreReader::step_range(uint32_t step, uint32_t field) const {
  check_node_field(0, field, step);
  if (ranges_.empty()) return {layout_.fields[field].min, layout_.fields[field].max};
  return ranges_[size_t(step) * field_count() + field];
}

std::span<const TfErrorEntry> BrickStoreReader::tf_errors(uint32_t step) const {
  if (tf_errors_.empty()) return {};
  check_node_field(0, 0, step);
  const size_t per_step = size_t(node_count() * field_count());
  return std::span<const TfErrorEntry>(tf_errors_).subspan(size_t(step) * per_step, per_step);
}

// The boundary faces, if any (version 4): between the blocks and the provenance record, checked as a whole by its
// checksum and each reference against the triangle count.
void BrickStoreReader::read_boundary() {
  const BoundaryHeaderRecord& b = boundary_header_;
  if (b.section_offset == 0 && b.section_size == 0) return;
  const std::string& name = file_.path();
  const uint64_t at = sizeof(HeaderRecord) + sizeof(TfErrorHeaderRecord);
  const uint64_t n = node_count(), entries = n + b.virtual_nodes;
  if (b.virtual_nodes % 8 || entries >= store_format::kBoundaryOverflow)
    fail_at_offset(name, at + offsetof(BoundaryHeaderRecord, virtual_nodes),
                   std::to_string(b.virtual_nodes) + " virtual nodes (a multiple of 8 expected)");
  const uint64_t expected = entries * sizeof(store_format::BoundaryNodeEntry) + uint64_t(b.reference_count) * 4 +
                            uint64_t(b.triangle_count) * sizeof(store_format::BoundaryTriangleRecord);
  if (b.section_size != expected) {
    fail_at_offset(name, at + offsetof(BoundaryHeaderRecord, section_size),
                   "boundary face section of " + std::to_string(b.section_size) + " bytes; expected " +
                       std::to_string(expected) + " for " + std::to_string(entries) + " nodes, " +
                       std::to_string(b.reference_count) + " references and " + std::to_string(b.triangle_count) +
                       " triangles");
  }
  const uint64_t end = node_table_offset_ - header_.provenance_size;
  if (b.section_offset < header_.header_size || b.section_offset > end || b.section_size > end - b.section_offset) {
    fail_at_offset(name, at + offsetof(BoundaryHeaderRecord, section_offset),
                   "boundary face section at offset " + std::to_string(b.section_offset) +
                       " does not fit between the header and the node table");
  }
  StoreBoundary& s = boundary_;
  s.nodes.resize(size_t(entries));
  s.refs.resize(b.reference_count);
  s.triangles.resize(b.triangle_count);
  const size_t n0 = s.nodes.size() * sizeof(s.nodes[0]), n1 = s.refs.size() * 4,
               n2 = s.triangles.size() * sizeof(s.triangles[0]);
  file_.read_at(b.section_offset, s.nodes.data(), n0);
  file_.read_at(b.section_offset + n0, s.refs.data(), n1);
  file_.read_at(b.section_offset + n0 + n1, s.triangles.data(), n2);
  const uint32_t crc = crc32_of(s.triangles.data(), n2, crc32_of(s.refs.data(), n1, crc32_of(s.nodes.data(), n0)));
  auto fail = [&](uint64_t offset, const std::string& what) {
    boundary_ = {};
    fail_at_offset(name, offset, what);
  };
  if (crc != b.section_crc) {
    fail(b.section_offset, "boundary face section checksum mismatch (stored " + hex32(b.section_crc) + ", computed " +
                               hex32(crc) + "): the section is corrupt");
  }
  s.max_per_node = b.max_per_node;
  // Overflow: an interior node of the tree (first 0), or 8 virtual children after the entry itself (so that a walk
  // down them ends).
  for (uint64_t id = 0; id < entries; ++id) {
    const auto& e = s.nodes[id];
    const bool children_ok = e.first == 0 ? id < n && !nodes_[id].is_leaf()
                                          : e.first >= n && e.first > id && uint64_t(e.first) + 8 <= entries;
    if (e.count == store_format::kBoundaryOverflow
            ? !children_ok
            : e.count > b.max_per_node || uint64_t(e.first) + e.count > s.refs.size())
      fail(b.section_offset + id * sizeof(e), "boundary faces of node " + std::to_string(id) + ": entry (first " +
                                                  std::to_string(e.first) + ", count " + std::to_string(e.count) +
                                                  ") names no valid run of the " + std::to_string(s.refs.size()) +
                                                  " references nor valid children");
  }
  for (size_t r = 0; r < s.refs.size(); ++r) {
    if (s.refs[r] >= b.triangle_count)
      fail(b.section_offset + n0 + r * 4, "boundary face reference " + std::to_string(s.refs[r]) + " past the " +
                                              std::to_string(b.triangle_count) + " triangles");
  }
  for (size_t t = 0; t < s.triangles.size(); ++t) {
    for (float v : s.triangles[t].p) {
      if (!std::isfinite(v))
        fail(b.section_offset + n0 + n1 + t * sizeof(s.triangles[0]),
             "boundary triangle " + std::to_string(t) + " has a corner that is not finite");
    }
  }
}

// The cells' index, if any (version 5): between the blocks and the provenance record, its checksum in its header
// record; each entry's block must lie among the blocks (the blocks themselves are checked when read).
void BrickStoreReader::read_cells_index() {
  const CellsHeaderRecord& c = cells_header_;
  if (c.index_offset == 0 && c.index_size == 0) return;
  const std::string& name = file_.path();
  const uint64_t at = sizeof(HeaderRecord) + sizeof(TfErrorHeaderRecord) + sizeof(BoundaryHeaderRecord);
  if (c.index_size != node_count() * sizeof(CellBlockRecord))
    fail_at_offset(name, at + offsetof(CellsHeaderRecord, index_size),
                   "cell index of " + std::to_string(c.index_size) + " bytes; expected " +
                       std::to_string(node_count() * sizeof(CellBlockRecord)) + " for " + std::to_string(node_count()) +
                       " nodes");
  const uint64_t end = node_table_offset_ - header_.provenance_size;
  if (c.index_offset < header_.header_size || c.index_offset > end || c.index_size > end - c.index_offset)
    fail_at_offset(name, at + offsetof(CellsHeaderRecord, index_offset),
                   "cell index at offset " + std::to_string(c.index_offset) +
                       " does not fit between the header and the node table");
  std::vector<CellBlockRecord> index(static_cast<size_t>(node_count()));
  file_.read_at(c.index_offset, index.data(), c.index_size);
  if (const uint32_t crc = crc32_of(index.data(), c.index_size); crc != c.index_crc)
    fail_at_offset(name, c.index_offset,
                   "cell index checksum mismatch (stored " + hex32(c.index_crc) + ", computed " + hex32(crc) +
                       "): the index is corrupt");
  uint32_t blocks = 0;
  for (uint64_t id = 0; id < index.size(); ++id) {
    const CellBlockRecord& r = index[id];
    if (r.offset == 0 && r.size == 0) continue;
    if (r.offset < header_.header_size || r.size == 0 || r.offset > c.index_offset ||
        r.size > c.index_offset - r.offset)
      fail_at_offset(name, c.index_offset + id * sizeof(CellBlockRecord),
                     "cell block of node " + std::to_string(id) + " (offset " + std::to_string(r.offset) + ", " +
                         std::to_string(r.size) + " bytes) does not lie among the blocks");
    ++blocks;
  }
  if (blocks != c.block_count)
    fail_at_offset(name, at + offsetof(CellsHeaderRecord, block_count),
                   std::to_string(c.block_count) + " cell blocks declared, the index has " + std::to_string(blocks));
  cell_blocks_ = std::move(index);
}

CellBlockRecord BrickStoreReader::cell_block(uint64_t node) const {
  if (node >= node_count()) fail_in(file_.path(), "node " + std::to_string(node) + " out of range");
  return cell_blocks_.empty() ? CellBlockRecord{} : cell_blocks_[node];
}

store_format::CellBlockHeader BrickStoreReader::cell_block_header(uint64_t node) const {
  const std::string& name = file_.path();
  const CellBlockRecord r = cell_block(node);
  if (r.offset == 0) fail_in(name, "node " + std::to_string(node) + " keeps no cells");
  auto fail = [&](const std::string& what) {
    fail_at_offset(name, r.offset, "cell block of node " + std::to_string(node) + ": " + what);
  };
  std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(), &ZSTD_freeDCtx);
  if (!dctx) fail("no zstd context");
  // A zstd block is at most 128 KiB: the header's bytes come out of the first one, read in chunks of that size.
  constexpr uint64_t kChunk = uint64_t(128) << 10;
  std::vector<std::byte> chunk;
  std::byte out_bytes[sizeof(CellBlockHeader)];
  ZSTD_outBuffer out{out_bytes, sizeof out_bytes, 0};
  for (uint64_t at = 0; at < r.size && out.pos < out.size;) {
    const uint64_t n = std::min<uint64_t>(kChunk, r.size - at);
    chunk.resize(size_t(n));
    file_.read_at(r.offset + at, chunk.data(), chunk.size());
    ZSTD_inBuffer in{chunk.data(), chunk.size(), 0};
    while (in.pos < in.size && out.pos < out.size) {
      const size_t rc = ZSTD_decompressStream(dctx.get(), &out, &in);
      if (ZSTD_isError(rc)) fail(std::string("the zstd frame does not decode: ") + ZSTD_getErrorName(rc));
      if (rc == 0) break;  // the frame ended
    }
    at += n;
  }
  if (out.pos < out.size) fail("the block is shorter than its header");
  const CellBlockHeader h = read_record<CellBlockHeader>(out_bytes);
  if (h.cell_count == 0 || h.point_count == 0 || h.field_count != field_count())
    fail(std::to_string(h.cell_count) + " cells, " + std::to_string(h.point_count) + " points, " +
         std::to_string(h.field_count) + " fields (the store has " + std::to_string(field_count()) + ")");
  return h;
}

CellBlockRecord BrickStoreReader::cell_values_block(uint64_t node, uint32_t step) const {
  check_node_field(node, 0, step);
  if (step == 0 || cell_values_.empty()) return {};
  return cell_values_[size_t((uint64_t(step) - 1) * node_count() + node)];
}

std::vector<float> BrickStoreReader::read_values_block(uint64_t node, uint32_t step, uint64_t count) const {
  const CellBlockRecord r = cell_values_block(node, step);
  const std::string where =
      "time step " + std::to_string(step) + " values of the cells of node " + std::to_string(node);
  if (r.offset == 0) fail_in(file_.path(), where + ": none stored");
  auto fail = [&](const std::string& what) { fail_at_offset(file_.path(), r.offset, where + ": " + what); };
  if (4 * count > kMaxCellBlockBytes) fail(std::to_string(count) + " values are too many");
  std::vector<std::byte> frame(r.size);
  file_.read_at(r.offset, frame.data(), frame.size());
  if (const uint32_t crc = crc32_of(frame.data(), frame.size()); crc != r.crc)
    fail("checksum mismatch (stored " + hex32(r.crc) + ", computed " + hex32(crc) + "): the block is corrupt");
  const unsigned long long raw_size = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (raw_size != 4 * count)
    fail("a zstd frame of " + std::to_string(raw_size) + " bytes, not " + std::to_string(4 * count) + " (" +
         std::to_string(count) + " values, as the cell block holds)");
  std::vector<float> values(static_cast<size_t>(count));
  const size_t got = ZSTD_decompress(values.data(), 4 * values.size(), frame.data(), frame.size());
  if (ZSTD_isError(got) || got != 4 * values.size()) fail("the zstd frame does not decode");
  for (float v : values)
    if (!std::isfinite(v)) fail("a value is not finite");
  return values;
}

std::vector<float> BrickStoreReader::read_cell_values(uint64_t node, uint32_t step) const {
  check_node_field(node, 0, step);
  if (step == 0) return read_cells(node, 0).values;
  const CellBlockHeader h = cell_block_header(node);
  return read_values_block(node, step, cell_value_count(layout_, h.cell_count, h.point_count));
}

NodeCells BrickStoreReader::read_cells(uint64_t node, uint32_t step) const {
  check_node_field(node, 0, step);
  const std::string& name = file_.path();
  const CellBlockRecord r = cell_block(node);
  if (r.offset == 0) fail_in(name, "node " + std::to_string(node) + " keeps no cells");
  auto fail = [&](const std::string& what) {
    fail_at_offset(name, r.offset, "cell block of node " + std::to_string(node) + ": " + what);
  };
  std::vector<std::byte> frame(r.size);
  file_.read_at(r.offset, frame.data(), frame.size());
  if (const uint32_t crc = crc32_of(frame.data(), frame.size()); crc != r.crc)
    fail("checksum mismatch (stored " + hex32(r.crc) + ", computed " + hex32(crc) + "): the block is corrupt");
  const unsigned long long raw_size = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (raw_size == ZSTD_CONTENTSIZE_ERROR || raw_size == ZSTD_CONTENTSIZE_UNKNOWN || raw_size > kMaxCellBlockBytes ||
      raw_size < sizeof(CellBlockHeader))
    fail("not a zstd frame of a valid size");
  std::vector<std::byte> raw(static_cast<size_t>(raw_size));
  const size_t got = ZSTD_decompress(raw.data(), raw.size(), frame.data(), frame.size());
  if (ZSTD_isError(got) || got != raw.size()) fail("the zstd frame does not decode");
  const CellBlockHeader h = read_record<CellBlockHeader>(raw.data());
  const uint64_t C = h.cell_count, V = h.point_count;
  if (C == 0 || V == 0 || h.field_count != field_count())
    fail(std::to_string(C) + " cells, " + std::to_string(V) + " points, " + std::to_string(h.field_count) +
         " fields (the store has " + std::to_string(field_count()) + ")");
  const CellBlockSizes z = cell_block_sizes(h, cell_value_count(layout_, C, V));
  if (z.total != raw.size())
    fail("its arrays take " + std::to_string(z.total) + " bytes, the block holds " + std::to_string(raw.size()));
  NodeCells c;
  const std::byte* p = raw.data() + sizeof h;
  c.ids.resize(C);
  std::memcpy(c.ids.data(), p, z.ids);
  p += z.ids;
  c.types.resize(C);
  uint64_t refs = 0, faces = 0;
  for (uint64_t i = 0; i < C; ++i) {
    const uint8_t t = uint8_t(p[i]);
    if (!is_valid_cell_type(t)) fail("cell " + std::to_string(i) + " has type " + std::to_string(t));
    c.types[i] = CellType(t);
    refs += cell_vertex_count(c.types[i]);
    faces += cell_face_count(c.types[i]);
    if (i > 0 && c.ids[i] <= c.ids[i - 1]) fail("cell ids are not ascending at cell " + std::to_string(i));
  }
  p += z.types;
  if (refs != h.vertex_references || faces != h.face_slots) fail("the types do not match the array sizes");
  c.connectivity.resize(refs);
  std::memcpy(c.connectivity.data(), p, z.connectivity);
  p += z.connectivity;
  for (uint32_t v : c.connectivity)
    if (v >= V) fail("a vertex index " + std::to_string(v) + " past the " + std::to_string(V) + " points");
  c.across.resize(faces);
  std::memcpy(c.across.data(), p, z.across);
  p += z.across;
  for (uint32_t a : c.across)
    if (a >= C && a != store_format::kCellAcrossBoundary && a != store_format::kCellAcrossOutside)
      fail("a face names cell " + std::to_string(a) + " of " + std::to_string(C));
  c.points.resize(V);
  std::memcpy(c.points.data(), p, z.points);
  p += z.points;
  for (const Vec3f& q : c.points)
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) fail("a point is not finite");
  if (step > 0) {
    c.values = read_values_block(node, step, z.values / 4);
    return c;
  }
  c.values.resize(z.values / 4);
  std::memcpy(c.values.data(), p, z.values);
  for (float v : c.values)
    if (!std::isfinite(v)) fail("a value is not finite");
  return c;
}

// The transfer-function error table, if any: between the blocks and the provenance record, its checksum in its header
// record.
void BrickStoreReader::read_tf_errors() {
  const TfErrorHeaderRecord& t = tf_error_header_;
  if (t.table_offset == 0 && t.table_size == 0) return;
  const std::string& name = file_.path();
  const uint64_t at = sizeof(HeaderRecord);
  const uint64_t expected = node_count() * field_count() * sizeof(TfErrorEntry);
  if (t.entry_size != sizeof(TfErrorEntry) || t.table_size != expected) {
    fail_at_offset(name, at + offsetof(TfErrorHeaderRecord, table_size),
                   "transfer-function error table of " + std::to_string(t.table_size) + " bytes in entries of " +
                       std::to_string(t.entry_size) + "; expected " + std::to_string(expected) + " in entries of " +
                       std::to_string(sizeof(TfErrorEntry)));
  }
  const uint64_t end = node_table_offset_ - header_.provenance_size;
  if (t.table_offset < header_.header_size || t.table_offset > end || t.table_size > end - t.table_offset) {
    fail_at_offset(name, at + offsetof(TfErrorHeaderRecord, table_offset),
                   "transfer-function error table at offset " + std::to_string(t.table_offset) +
                       " does not fit between the header and the node table");
  }
  tf_errors_.resize(size_t(node_count() * field_count()));
  file_.read_at(t.table_offset, tf_errors_.data(), t.table_size);
  if (const uint32_t crc = crc32_of(tf_errors_.data(), t.table_size); crc != t.table_crc) {
    tf_errors_.clear();
    fail_at_offset(name, t.table_offset,
                   "transfer-function error table checksum mismatch (stored " + hex32(t.table_crc) + ", computed " +
                       hex32(crc) + "): the table is corrupt");
  }
}

// The provenance record, if any: just before the node table, after the header, its checksum last.
void BrickStoreReader::read_provenance() {
  const uint64_t size = header_.provenance_size;
  if (size == 0) return;
  const std::string& name = file_.path();
  if (size < 4 || size > node_table_offset_ - header_.header_size)
    fail_at_offset(name, offsetof(HeaderRecord, provenance_size),
                   "provenance record of " + std::to_string(size) + " bytes does not fit before the node table");
  const uint64_t at = node_table_offset_ - size;
  std::vector<std::byte> bytes(size);
  file_.read_at(at, bytes.data(), bytes.size());
  uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + size - 4, 4);
  if (crc32_of(bytes.data(), size - 4) != stored) fail_at_offset(name, at, "provenance record checksum mismatch");
  layout_.provenance.assign(reinterpret_cast<const char*>(bytes.data()), size - 4);
}

// The header record and the field records' bytes, checked: magic, version, header size and checksum, then the fixed
// fields.
std::vector<std::byte> BrickStoreReader::read_header() {
  const std::string& name = file_.path();
  const uint64_t size = file_.size();
  std::byte fixed[sizeof(HeaderRecord)] = {};
  const size_t got = file_.read_some_at(0, fixed, sizeof fixed);
  const HeaderRecord h = read_record<HeaderRecord>(fixed);
  if (got < sizeof h.magic || std::memcmp(h.magic, store_format::kMagic, sizeof h.magic) != 0) {
    const bool blank =
        got >= sizeof h.magic && std::all_of(std::begin(h.magic), std::end(h.magic), [](uint8_t b) { return b == 0; });
    fail_at_offset(name, offsetof(HeaderRecord, magic),
                   blank ? "not a ugvr brick store: the header is blank (the temporary file of an unfinished build?)"
                         : "not a ugvr brick store (wrong magic number)");
  }
  if (got < offsetof(HeaderRecord, version) + sizeof h.version)
    fail_at_offset(name, got, "truncated brick store header");
  if (h.version < kOldestReadableBrickStoreVersion || h.version > kBrickStoreVersion) {
    fail_at_offset(name, offsetof(HeaderRecord, version),
                   "brick store format version " + std::to_string(h.version) + "; this build reads versions " +
                       std::to_string(kOldestReadableBrickStoreVersion) + " to " + std::to_string(kBrickStoreVersion) +
                       (h.version < kBrickStoreVersion
                            ? " only (older stores quantize each brick on its own grid): rebuild it with `ugvr build`"
                            : " (written by a newer ugvr)"));
  }
  if (got < sizeof(HeaderRecord)) {
    fail_at_offset(name, got, "truncated brick store: " + std::to_string(size) + " bytes, shorter than its header");
  }
  if (h.header_size < header_records_size(h.version) || h.header_size % 8 || h.header_size > kMaxHeaderSize ||
      h.header_size > size) {
    fail_at_offset(
        name, offsetof(HeaderRecord, header_size),
        "header size " + std::to_string(h.header_size) + " impossible (file of " + std::to_string(size) + " bytes)");
  }
  std::vector<std::byte> bytes(h.header_size);
  file_.read_at(0, bytes.data(), bytes.size());
  std::memset(bytes.data() + offsetof(HeaderRecord, header_crc), 0, sizeof h.header_crc);
  if (const uint32_t crc = crc32_of(bytes.data(), bytes.size()); crc != h.header_crc) {
    fail_at_offset(name, offsetof(HeaderRecord, header_crc),
                   "header checksum mismatch (stored " + hex32(h.header_crc) + ", computed " + hex32(crc) +
                       "): the header is corrupt");
  }
  header_ = h;
  if (h.version >= 3) tf_error_header_ = read_record<TfErrorHeaderRecord>(bytes.data() + sizeof(HeaderRecord));
  if (h.version >= 4)
    boundary_header_ =
        read_record<BoundaryHeaderRecord>(bytes.data() + sizeof(HeaderRecord) + sizeof(TfErrorHeaderRecord));
  if (h.version >= 5)
    cells_header_ = read_record<CellsHeaderRecord>(bytes.data() + sizeof(HeaderRecord) + sizeof(TfErrorHeaderRecord) +
                                                   sizeof(BoundaryHeaderRecord));
  if (h.version >= 6) steps_header_ = read_record<StepsHeaderRecord>(bytes.data() + header_records_size(5));

  // From here on the header is as the writer wrote it; the checks guard against a writer of another make.
  BrickStoreLayout& l = layout_;
  l.resolution = h.resolution;
  if (l.resolution < kMinBrickResolution || l.resolution > kMaxBrickResolution) {
    fail_at_offset(name, offsetof(HeaderRecord, resolution),
                   "brick resolution " + std::to_string(l.resolution) + " outside [2, 512]");
  }
  if (h.field_count == 0 || h.field_count > kMaxStoreFields) {
    fail_at_offset(name, offsetof(HeaderRecord, field_count),
                   std::to_string(h.field_count) + " fields (1 to 1024 allowed)");
  }
  if (h.node_record_size != node_record_size(h.field_count)) {
    fail_at_offset(name, offsetof(HeaderRecord, node_record_size),
                   "node record size " + std::to_string(h.node_record_size) + ", expected " +
                       std::to_string(node_record_size(h.field_count)) + " for " + std::to_string(h.field_count) +
                       " fields");
  }
  if (h.samples < 1 || h.samples > 2 || h.predictor > 2 || h.codec > 2 || h.shuffle > 1) {
    fail_at_offset(name, offsetof(HeaderRecord, samples), "unknown encoding settings");
  }
  l.encoding = {SampleEncoding(h.samples), Predictor(h.predictor), h.shuffle != 0, BrickCodec(h.codec), h.codec_level};
  l.tolerance = h.tolerance;
  l.root = corners_bounds(h.root_lo, h.root_hi);
  l.data = corners_bounds(h.data_lo, h.data_hi);
  if (l.root.empty() || !(l.root.size().x > 0 && l.root.size().y > 0 && l.root.size().z > 0)) {
    fail_at_offset(name, offsetof(HeaderRecord, root_lo), "empty octree root cell");
  }
  // What the writer refuses to write, refused here too: a header with its checksum recomputed must not get a value
  // past the reader that the format cannot hold (an infinite root cell divides into NaN node boxes, a bad tolerance
  // into a wrong error bound).
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(h.root_lo[a]) || !std::isfinite(h.root_hi[a])) {
      fail_at_offset(name, offsetof(HeaderRecord, root_lo) + 8 * a + (std::isfinite(h.root_lo[a]) ? 24 : 0),
                     "octree root cell [" + std::to_string(h.root_lo[a]) + ", " + std::to_string(h.root_hi[a]) +
                         "] on axis " + std::to_string(a) + " is not finite");
    }
  }
  // The dataset's bounds: a finite box, or the empty box (+inf, -inf) of a writer that was given none.
  const bool data_unset =
      std::all_of(std::begin(h.data_lo), std::end(h.data_lo), [](double v) { return v == INFINITY; }) &&
      std::all_of(std::begin(h.data_hi), std::end(h.data_hi), [](double v) { return v == -INFINITY; });
  for (int a = 0; a < 3 && !data_unset; ++a) {
    if (!std::isfinite(h.data_lo[a]) || !std::isfinite(h.data_hi[a]) || !(h.data_lo[a] <= h.data_hi[a])) {
      fail_at_offset(name, offsetof(HeaderRecord, data_lo) + 8 * a,
                     "dataset bounds [" + std::to_string(h.data_lo[a]) + ", " + std::to_string(h.data_hi[a]) +
                         "] on axis " + std::to_string(a) + " are not a finite range with min <= max");
    }
  }
  const bool float32 = h.samples == uint8_t(SampleEncoding::Float32);
  if (!std::isfinite(h.tolerance) ||
      (float32 ? h.tolerance != 0 : !(h.tolerance == 0 || h.tolerance >= kQuant16Tolerance))) {
    fail_at_offset(name, offsetof(HeaderRecord, tolerance),
                   "tolerance " + std::to_string(h.tolerance) +
                       (float32 ? " in a float32 store (0 expected)" : " outside {0} and [1/131070, inf)"));
  }
  return bytes;
}

// The field records that follow the header record, into layout_.fields.
void BrickStoreReader::read_field_records(std::span<const std::byte> bytes) {
  const std::string& name = file_.path();
  const uint64_t header_size = bytes.size();
  uint64_t at = header_records_size(header_.version);
  for (uint32_t f = 0; f < header_.field_count; ++f) {
    if (at + sizeof(FieldRecord) > header_size) {
      fail_at_offset(name, at, "field record " + std::to_string(f) + " past the header");
    }
    const FieldRecord r = read_record<FieldRecord>(bytes.data() + at);
    BrickStoreField field;
    field.min = r.min;
    field.max = r.max;
    if (!std::isfinite(r.min) || !std::isfinite(r.max) || !(r.min <= r.max)) {
      fail_at_offset(name, at + offsetof(FieldRecord, min),
                     "field record " + std::to_string(f) + ": range [" + std::to_string(r.min) + ", " +
                         std::to_string(r.max) + "] is not a finite range with min <= max");
    }
    if (r.association > 1) {
      fail_at_offset(name, at + offsetof(FieldRecord, association),
                     "unknown field association " + std::to_string(r.association));
    }
    field.association = Association(r.association);
    if (r.name_length == 0 || r.name_length > kMaxNameLength || at + field_record_size(r.name_length) > header_size) {
      fail_at_offset(name, at + offsetof(FieldRecord, name_length),
                     "field name length " + std::to_string(r.name_length) + " impossible");
    }
    field.name.assign(reinterpret_cast<const char*>(bytes.data() + at + sizeof(FieldRecord)), r.name_length);
    layout_.fields.push_back(std::move(field));
    at += field_record_size(r.name_length);
  }
}

// The file's size against the header, then the node table, in chunks: the checksum runs over the raw bytes, the
// records are parsed as they come.
void BrickStoreReader::read_node_table() {
  const std::string& name = file_.path();
  const uint64_t size = file_.size(), count = header_.node_count, rec = header_.node_record_size;
  const uint32_t nf = header_.field_count;
  node_table_offset_ = header_.node_table_offset;
  if (header_.file_size != size) {
    fail_at_offset(name, std::min(header_.file_size, size),
                   "the file has " + std::to_string(size) + " bytes, its header says " +
                       std::to_string(header_.file_size) +
                       (size < header_.file_size ? ": truncated" : ": data appended after its end"));
  }
  if (count == 0) fail_at_offset(name, offsetof(HeaderRecord, node_count), "no nodes");
  if (node_table_offset_ < header_.header_size || node_table_offset_ > size ||
      count > (size - node_table_offset_) / rec || count * rec != size - node_table_offset_) {
    fail_at_offset(name, offsetof(HeaderRecord, node_table_offset),
                   "node table of " + std::to_string(count) + " records of " + std::to_string(rec) +
                       " bytes at offset " + std::to_string(node_table_offset_) + " does not end the " +
                       std::to_string(size) + "-byte file");
  }
  nodes_.resize(count);
  stats_.resize(count * nf);
  blocks_.resize(count * nf);
  const uint64_t chunk_nodes = std::max<uint64_t>(1, kTableChunkBytes / rec);
  std::vector<std::byte> buf;
  uint32_t table_crc = 0;
  for (uint64_t first = 0; first < count; first += chunk_nodes) {
    const uint64_t end = std::min(count, first + chunk_nodes);
    buf.resize(size_t(end - first) * rec);
    file_.read_at(node_table_offset_ + first * rec, buf.data(), buf.size());
    table_crc = crc32_of(buf.data(), buf.size(), table_crc);
    for (uint64_t id = first; id < end; ++id) {
      const std::byte* p = buf.data() + size_t(id - first) * rec;
      const NodeRecord r = read_record<NodeRecord>(p);
      BrickNode& n = nodes_[id];
      n.parent = r.parent;
      n.first_child = r.first_child;
      n.brick_offset = r.brick_offset;
      n.i = r.i;
      n.j = r.j;
      n.k = r.k;
      n.level = r.level;
      n.child_mask = r.child_mask;
      n.valid_fraction = r.valid_fraction;
      for (uint32_t f = 0; f < nf; ++f) {
        const NodeFieldRecord fr = read_record<NodeFieldRecord>(p + node_field_offset(f));
        stats_[id * nf + f] = {fr.min, fr.max, fr.error_max, fr.error_rms};
        blocks_[id * nf + f] = {0, fr.block_size, fr.block_crc};
      }
    }
  }
  if (table_crc != header_.node_table_crc) {
    fail_at_offset(name, node_table_offset_,
                   "node table checksum mismatch (stored " + hex32(header_.node_table_crc) + ", computed " +
                       hex32(table_crc) + "): the node table is corrupt");
  }
}

// The tree's structure, each node's valid fraction against its brick, and where its blocks lie.
void BrickStoreReader::check_nodes() {
  const std::string& name = file_.path();
  const uint64_t count = nodes_.size(), header_size = header_.header_size;
  const uint32_t nf = field_count();
  if (auto issue = check_tree(std::span<const BrickNode>(nodes_))) {
    fail_at_offset(name, record_offset(issue->node) + issue->record_offset,
                   "node " + std::to_string(issue->node) + ": " + issue->what);
  }
  for (uint64_t id = 0; id < count; ++id) {
    const BrickNode& n = nodes_[id];
    if (!(n.valid_fraction >= 0 && n.valid_fraction <= 1) || (n.has_brick() != (n.valid_fraction > 0))) {
      fail_at_offset(name, record_offset(id) + offsetof(NodeRecord, valid_fraction),
                     "node " + std::to_string(id) + ": valid fraction " + std::to_string(n.valid_fraction) +
                         (n.has_brick() ? " with a brick" : " without a brick"));
    }
    for (uint32_t t = 0; t < step_count(); ++t) {
      for (uint32_t f = 0; f < nf; ++f) check_node_stats(id, f, t);
      uint64_t offset = t == 0 ? n.brick_offset : blocks_[(t * count + id) * nf].offset;
      for (uint32_t f = 0; f < nf; ++f) {
        BlockRef& b = blocks_[(t * count + id) * nf + f];
        const uint64_t size_at =
            step_record_offset(id, t) +
            (t == 0 ? node_field_offset(f) : sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * f) +
            offsetof(NodeFieldRecord, block_size);
        const std::string step_name = t == 0 ? std::string() : "time step " + std::to_string(t) + " ";
        if (!n.has_brick()) {
          if (b.size)
            fail_at_offset(name, size_at, step_name + "node " + std::to_string(id) + " has no brick but a block size");
          continue;
        }
        if (b.size < kBlockHeaderSize || offset < header_size || offset > node_table_offset_ ||
            b.size > node_table_offset_ - offset) {
          fail_at_offset(name, size_at,
                         step_name + "node " + std::to_string(id) + " field '" + layout_.fields[f].name +
                             "': block of " + std::to_string(b.size) + " bytes at offset " + std::to_string(offset) +
                             " outside the block area [" + std::to_string(header_size) + ", " +
                             std::to_string(node_table_offset_) + ")");
        }
        b.offset = offset;
        offset += b.size;
      }
    }
  }
}

// A node's value range and errors for one field, as the writer makes them: a finite range with min <= max, or
// (+inf, -inf) where the subtree has no data (never for a node with a brick), containing each child's range (culling
// a node by value range culls its subtree); errors finite and >= 0. Children come after their parent, so checking
// each node against its parent covers the tree.
void BrickStoreReader::check_node_stats(uint64_t id, uint32_t f, uint32_t step) const {
  const uint32_t nf = field_count();
  const uint64_t base = uint64_t(step) * node_count() * nf;
  const FieldStats& s = stats_[base + id * nf + f];
  const uint64_t at = step_record_offset(id, step) +
                      (step == 0 ? node_field_offset(f) : sizeof(StepNodeRecord) + sizeof(NodeFieldRecord) * f);
  auto where = [&] {
    return (step ? "time step " + std::to_string(step) + " " : std::string()) + "node " + std::to_string(id) +
           " field '" + layout_.fields[f].name + "': ";
  };
  auto range = [](const FieldStats& r) { return "[" + std::to_string(r.min) + ", " + std::to_string(r.max) + "]"; };
  const bool no_data = s.min == INFINITY && s.max == -INFINITY;
  if (!(no_data || (std::isfinite(s.min) && std::isfinite(s.max) && s.min <= s.max))) {
    fail_at_offset(file_.path(), at + offsetof(NodeFieldRecord, min),
                   where() + "value range " + range(s) + " is neither a finite range with min <= max nor (inf, -inf)");
  }
  if (no_data && nodes_[id].has_brick()) {
    fail_at_offset(file_.path(), at + offsetof(NodeFieldRecord, min),
                   where() + "value range (inf, -inf) says no data, but the node has a brick");
  }
  if (!(std::isfinite(s.error_max) && s.error_max >= 0 && std::isfinite(s.error_rms) && s.error_rms >= 0)) {
    fail_at_offset(file_.path(), at + offsetof(NodeFieldRecord, error_max),
                   where() + "errors (max " + std::to_string(s.error_max) + ", rms " + std::to_string(s.error_rms) +
                       ") are not finite and >= 0");
  }
  if (id > 0 && !no_data) {
    const uint64_t parent = nodes_[id].parent;  // check_tree: parent < id
    const FieldStats& p = stats_[base + parent * nf + f];
    if (!(p.min <= s.min && s.max <= p.max)) {
      fail_at_offset(file_.path(), at + offsetof(NodeFieldRecord, min),
                     where() + "value range " + range(s) + " is not inside its parent node " + std::to_string(parent) +
                         "'s " + range(p));
    }
  }
}

uint64_t BrickStoreReader::record_offset(uint64_t node) const {
  return node_table_offset_ + node * header_.node_record_size;
}

int BrickStoreReader::field_index(std::string_view field_name) const {
  for (size_t f = 0; f < layout_.fields.size(); ++f) {
    if (layout_.fields[f].name == field_name) return int(f);
  }
  return -1;
}

void BrickStoreReader::check_node_field(uint64_t node, uint32_t field, uint32_t step) const {
  if (step >= step_count()) {
    fail_in(path(),
            "time step " + std::to_string(step) + " out of range (the store has " + std::to_string(step_count()) + ")");
  }
  if (node >= nodes_.size()) {
    fail_in(path(), "node " + std::to_string(node) + " out of range (the store has " + std::to_string(nodes_.size()) +
                        " nodes)");
  }
  if (field >= field_count()) {
    fail_in(path(), "field " + std::to_string(field) + " out of range (the store has " + std::to_string(field_count()) +
                        " fields)");
  }
}

const BrickNode& BrickStoreReader::node(uint64_t id) const {
  check_node_field(id, 0);
  return nodes_[id];
}

const FieldStats& BrickStoreReader::stats(uint64_t node, uint32_t field, uint32_t step) const {
  check_node_field(node, field, step);
  return stats_[(step * node_count() + node) * field_count() + field];
}

BlockRef BrickStoreReader::block(uint64_t node, uint32_t field, uint32_t step) const {
  check_node_field(node, field, step);
  return blocks_[(step * node_count() + node) * field_count() + field];
}

void BrickStoreReader::read_block(uint64_t node, uint32_t field, std::byte* dst, uint32_t step) const {
  const BlockRef b = block(node, field, step);
  if (b.size == 0) {
    fail_in(path(), "node " + std::to_string(node) + " has no brick: its cell holds no data (valid fraction 0)");
  }
  file_.read_at(b.offset, dst, b.size);
  if (const uint32_t crc = crc32_of(dst, b.size); crc != b.crc32) {
    fail_at_offset(path(), b.offset,
                   "node " + std::to_string(node) + " field '" + layout_.fields[field].name +
                       "': brick checksum mismatch (stored " + hex32(b.crc32) + ", computed " + hex32(crc) +
                       "): the brick is corrupt");
  }
}

void BrickStoreReader::decode_block(uint64_t node, uint32_t field, std::span<const std::byte> block, float* samples,
                                    uint8_t* mask, uint32_t step) const {
  const BlockRef b = this->block(node, field, step);
  try {
    // The block's range against its node's (which the writer made to contain it): a block that claims values its
    // node's range excludes would be culled wrongly or rendered out of range.
    const BlockHeader h = parse_block_header(block, layout_.resolution, path(), b.offset);
    const FieldStats& s = stats(node, field, step);
    if (!(s.min <= h.lo && h.hi <= s.max)) {
      fail_at_offset(path(), b.offset + offsetof(store_format::BlockRecord, lo),
                     "brick range [" + std::to_string(h.lo) + ", " + std::to_string(h.hi) +
                         "] outside the node's value range [" + std::to_string(s.min) + ", " + std::to_string(s.max) +
                         "]");
    }
    decode_brick(block, layout_.resolution, samples, mask, path(), b.offset);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " (node " + std::to_string(node) + ", field '" + layout_.fields[field].name +
                "')");
  }
}

void BrickStoreReader::read_brick(uint64_t node, uint32_t field, float* samples, uint8_t* mask, uint32_t step) const {
  thread_local std::vector<std::byte> buffer;
  const BlockRef b = block(node, field, step);
  buffer.resize(b.size);
  read_block(node, field, buffer.data(), step);
  decode_block(node, field, buffer, samples, mask, step);
}

}  // namespace ugvr
