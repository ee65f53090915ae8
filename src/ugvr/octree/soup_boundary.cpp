#include "ugvr/octree/soup_boundary.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <numeric>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/topology.h"

namespace ugvr {
namespace {

// A face: its vertex ids sorted (a triangle's fourth is kPad, so it never equals a quadrilateral), then
// pack_face(cell, local face). 24 bytes, no padding: written to the bucket files as it is.
constexpr uint32_t kPad = ~uint32_t(0);
struct FaceRecord {
  std::array<uint32_t, 4> v;
  uint64_t ref;
  bool operator<(const FaceRecord& o) const { return v != o.v ? v < o.v : ref < o.ref; }
};
static_assert(sizeof(FaceRecord) == 24);

[[noreturn]] void fail_io(const std::string& path, const char* what) {
  fail_in(path, std::string(what) + ": " + std::strerror(errno));
}

FaceRecord face_record(const SoupCell& cell, const CellFace& f, uint32_t local) {
  std::array<uint32_t, 4> v{cell.vertex(f.v[0]), cell.vertex(f.v[1]), cell.vertex(f.v[2]),
                            f.size == 4 ? cell.vertex(f.v[3]) : kPad};
  std::sort(v.begin(), v.end());
  return {v, pack_face(cell.id(), local)};
}

// One bucket file being written, with its own buffer.
class BucketWriter {
 public:
  BucketWriter(std::string path, size_t buffer_records) : path_(std::move(path)) {
    file_ = std::fopen(path_.c_str(), "wb");
    if (!file_) fail_io(path_, "cannot create the temporary face file");
    buffer_.reserve(buffer_records);
  }
  ~BucketWriter() {
    if (file_) std::fclose(file_);
  }
  BucketWriter(const BucketWriter&) = delete;
  BucketWriter& operator=(const BucketWriter&) = delete;
  void add(const FaceRecord& r) {
    buffer_.push_back(r);
    if (buffer_.size() == buffer_.capacity()) flush();
  }
  void close() {
    flush();
    if (std::fclose(file_) != 0) {
      file_ = nullptr;
      fail_io(path_, "cannot write the temporary face file");
    }
    file_ = nullptr;
  }
  uint64_t records() const { return records_; }

 private:
  void flush() {
    if (buffer_.empty()) return;
    if (std::fwrite(buffer_.data(), sizeof(FaceRecord), buffer_.size(), file_) != buffer_.size())
      fail_io(path_, "cannot write the temporary face file");
    records_ += buffer_.size();
    buffer_.clear();
  }
  std::string path_;
  std::FILE* file_ = nullptr;
  std::vector<FaceRecord> buffer_;
  uint64_t records_ = 0;
};

// A bucket's records, read whole; the file is removed.
std::vector<FaceRecord> read_bucket(const std::string& path, uint64_t records) {
  std::vector<FaceRecord> out(records);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail_io(path, "cannot open the temporary face file");
  const size_t got = std::fread(out.data(), sizeof(FaceRecord), out.size(), f);
  std::fclose(f);
  if (got != out.size()) fail_in(path, "the temporary face file is shorter than written");
  std::filesystem::remove(path);
  return out;
}

}  // namespace

std::vector<MeshFaceTriangle> soup_boundary_triangles(const std::string& soup_path, const SoupLayout& layout,
                                                      uint64_t cells, uint64_t memory_budget,
                                                      const std::string& temp_dir, const Progress::Observer& observer,
                                                      SoupBoundaryStats* stats, std::vector<uint64_t>* boundary_faces) {
  SoupBoundaryStats st;
  // Buckets: at most 6 faces a cell; a bucket is sorted in memory, within a third of the budget (at least 64 KiB),
  // and each open bucket buffers 4096 records (96 KiB); at most 512 files open at once.
  const uint64_t face_bytes = std::max<uint64_t>(cells, 1) * 6 * sizeof(FaceRecord);
  const uint64_t bucket_bytes = std::max<uint64_t>(memory_budget / 3, uint64_t(64) << 10);
  const uint32_t buckets = uint32_t(std::clamp<uint64_t>((face_bytes + bucket_bytes - 1) / bucket_bytes, 1, 512));
  st.buckets = buckets;
  auto bucket_path = [&](uint32_t b) {
    return (std::filesystem::path(temp_dir) / ("faces-" + std::to_string(b))).string();
  };

  // 1. Faces to buckets, by smallest vertex id: all faces of one vertex set meet in one bucket.
  std::vector<uint64_t> counts(buckets, 0);
  {
    Progress progress("boundary: faces", cells, observer);
    std::vector<std::unique_ptr<BucketWriter>> writers(buckets);
    for (uint32_t b = 0; b < buckets; ++b) writers[b] = std::make_unique<BucketWriter>(bucket_path(b), 4096);
    SoupReader reader(soup_path, layout);
    const std::byte* p = nullptr;
    uint64_t seen = 0;
    while (reader.next(p)) {
      const SoupCell cell(p, layout);
      const CellInfo info = cell_info(cell.type());
      for (uint32_t f = 0; f < info.face_count; ++f) {
        const FaceRecord r = face_record(cell, info.faces[f], f);
        writers[r.v[0] % buckets]->add(r);
      }
      st.faces += info.face_count;
      if (++seen % 65536 == 0) progress.set(seen);
    }
    for (uint32_t b = 0; b < buckets; ++b) {
      writers[b]->close();
      counts[b] = writers[b]->records();
    }
    progress.finish();
  }

  // 2. Per bucket: sets not met exactly twice are boundary.
  std::vector<uint64_t> boundary;
  {
    Progress progress("boundary: matching", buckets, observer);
    for (uint32_t b = 0; b < buckets; ++b) {
      std::vector<FaceRecord> records = read_bucket(bucket_path(b), counts[b]);
      std::sort(records.begin(), records.end());
      for (size_t run = 0; run < records.size();) {
        size_t end = run + 1;
        while (end < records.size() && records[end].v == records[run].v) ++end;
        if (end - run != 2)
          for (size_t i = run; i < end; ++i) boundary.push_back(records[i].ref);
        if (end - run > 2) st.nonmanifold_faces += end - run;
        run = end;
      }
      progress.add(1);
    }
    progress.finish();
  }
  std::sort(boundary.begin(), boundary.end());
  st.boundary_faces = boundary.size();

  // 3. The boundary faces' triangles, from their cells' records, in (cell, face) order as in core.
  std::vector<std::pair<uint64_t, MeshFaceTriangle>> keyed;
  {
    Progress progress("boundary: triangles", cells, observer);
    std::vector<MeshFaceTriangle> tris;
    SoupReader reader(soup_path, layout);
    const std::byte* p = nullptr;
    uint64_t seen = 0;
    while (reader.next(p)) {
      const SoupCell cell(p, layout);
      auto it = std::lower_bound(boundary.begin(), boundary.end(), pack_face(cell.id(), 0));
      const CellInfo info = cell_info(cell.type());
      for (; it != boundary.end() && face_cell(*it) == cell.id(); ++it) {
        const CellFace& face = info.faces[face_local(*it)];
        std::array<uint32_t, 4> ids{};
        std::array<Vec3f, 4> pos{};
        for (int i = 0; i < face.size; ++i) {
          ids[size_t(i)] = cell.vertex(face.v[size_t(i)]);
          pos[size_t(i)] = cell.position(face.v[size_t(i)]);
        }
        tris.clear();
        append_face_triangles(face.size, ids.data(), pos.data(), tris);
        for (const MeshFaceTriangle& t : tris) keyed.emplace_back(*it, t);
      }
      if (++seen % 65536 == 0) progress.set(seen);
    }
    progress.finish();
  }
  if (boundary_faces) {
    *boundary_faces = std::move(boundary);
  }
  boundary = {};
  // Stable: a quadrilateral's two triangles keep their order.
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<MeshFaceTriangle> out(keyed.size());
  for (size_t i = 0; i < keyed.size(); ++i) out[i] = keyed[i].second;
  if (stats) *stats = st;
  return out;
}

}  // namespace ugvr
