// A cell soup: cells as self-contained records in a flat temporary file, the unit the out-of-core builder streams
// (Leven et al. 2002, section 4.1: "a flat, unindexed tetrahedron file", one per octree node). Each record carries
// its vertex positions and field values, so a node needs nothing but its own file; the vertex ids are kept so that a
// leaf can weld its cells back into a small mesh for the sampler and count each data point once.
//
// Record layout (native byte order: a temporary file, never kept or moved between machines):
//   0     u64  cell id in the input mesh
//   8     u8   cell type (CellType)
//   9     u8   vertex count n (4..8)
//   10    u16  reserved, 0
//   12    u32  reserved, 0
//   16    n x u32         vertex ids
//   ..    n x 3 x f32     vertex positions
//   ..    Fv x n x f32    values of the vertex fields at the vertices, field by field
//   ..    Fc x f32        values of the cell fields
// so a record has 16 + 16 n + 4 (Fv n + Fc) bytes: 96 bytes for a tetrahedron with one vertex field.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/cell_type.h"

namespace ugvr {

struct SoupLayout {
  uint32_t vertex_fields = 0, cell_fields = 0;

  size_t record_bytes(int n) const { return 16 + 16 * size_t(n) + 4 * (vertex_fields * size_t(n) + cell_fields); }
  // Where a value sits in a record of n vertices (the layout above).
  size_t vertex_value_offset(int n, uint32_t field, int i) const {
    return 16 + 16 * size_t(n) + 4 * (field * size_t(n) + size_t(i));
  }
  size_t cell_value_offset(int n, uint32_t field) const {
    return 16 + 16 * size_t(n) + 4 * (vertex_fields * size_t(n) + field);
  }
  bool operator==(const SoupLayout&) const = default;
};

// A view of one record in a buffer.
class SoupCell {
 public:
  SoupCell(const std::byte* p, const SoupLayout& layout) : p_(p), layout_(&layout) {}

  uint64_t id() const { return load<uint64_t>(0); }
  CellType type() const { return CellType(uint8_t(p_[8])); }
  int vertex_count() const { return int(uint8_t(p_[9])); }
  uint32_t vertex(int i) const { return load<uint32_t>(16 + 4 * size_t(i)); }
  Vec3f position(int i) const { return load<Vec3f>(16 + 4 * size_t(vertex_count()) + 12 * size_t(i)); }
  float vertex_value(uint32_t field, int i) const {
    return load<float>(layout_->vertex_value_offset(vertex_count(), field, i));
  }
  float cell_value(uint32_t field) const { return load<float>(layout_->cell_value_offset(vertex_count(), field)); }
  size_t bytes() const { return layout_->record_bytes(vertex_count()); }
  const SoupLayout& layout() const { return *layout_; }
  const std::byte* data() const { return p_; }

 private:
  template <class T>
  T load(size_t offset) const {
    T v;
    std::memcpy(&v, p_ + offset, sizeof v);
    return v;
  }
  const std::byte* p_;
  const SoupLayout* layout_;
};

// What a soup writer and reader share: the open file, its layout and a block buffer; the file closes with the object.
class SoupFile {
 public:
  SoupFile(const SoupFile&) = delete;
  SoupFile& operator=(const SoupFile&) = delete;
  const SoupLayout& layout() const { return layout_; }

 protected:
  // `mode` as fopen takes it; `what` says what failed ("cannot create the temporary cell file").
  SoupFile(std::string path, const SoupLayout& layout, const char* mode, const char* what);
  ~SoupFile();
  std::string path_;
  SoupLayout layout_;
  std::FILE* file_ = nullptr;
  std::vector<std::byte> buffer_;
};

// Appends records to a new file (truncating one that exists). Throws ugvr::Error naming the file on I/O failure.
class SoupWriter : public SoupFile {
 public:
  SoupWriter(std::string path, const SoupLayout& layout);

  // A record from its parts: ids, positions (n each), vertex values (Fv x n, field-major), cell values (Fc).
  void add(uint64_t id, CellType type, int n, const uint32_t* vertices, const Vec3f* positions,
           const float* vertex_values, const float* cell_values);
  // A record copied as it is.
  void add(const SoupCell& cell);
  // Flushes and closes; the destructor does it too, without reporting errors.
  void close();
  uint64_t records() const { return records_; }
  uint64_t bytes() const { return bytes_; }

 private:
  void write(const void* data, size_t n);
  void flush();

  uint64_t records_ = 0, bytes_ = 0;
};

// Reads a soup file front to back in large blocks.
class SoupReader : public SoupFile {
 public:
  SoupReader(std::string path, const SoupLayout& layout);

  // The next record, valid until the next call; false at the end of the file.
  bool next(const std::byte*& record);

 private:
  bool fill(size_t need);

  size_t begin_ = 0, end_ = 0;
  bool eof_ = false;
};

}  // namespace ugvr
