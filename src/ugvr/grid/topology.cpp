#include "ugvr/grid/topology.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>

#include <algorithm>
#include <atomic>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

// A face as a sorted vertex set: `lo` (the bucket) plus the other vertices, padded with kPad for triangles so a
// triangle and a quadrilateral never compare equal.
constexpr uint32_t kPad = ~uint32_t(0);

struct FaceKey {
  uint32_t lo;
  std::array<uint32_t, 3> rest;
};

struct FaceRecord {
  std::array<uint32_t, 3> rest;
  uint64_t ref;  // pack_face(cell, local face)
  bool operator<(const FaceRecord& o) const { return rest != o.rest ? rest < o.rest : ref < o.ref; }
};

FaceKey face_key(const UnstructuredMesh& mesh, uint64_t cell, const CellFace& f) {
  const uint32_t* conn = mesh.connectivity.data() + mesh.cell_offsets[cell];
  std::array<uint32_t, 4> v{conn[f.v[0]], conn[f.v[1]], conn[f.v[2]], f.size == 4 ? conn[f.v[3]] : kPad};
  // Sorting network for 4 values.
  auto cs = [&](int a, int b) {
    if (v[size_t(b)] < v[size_t(a)]) std::swap(v[size_t(a)], v[size_t(b)]);
  };
  cs(0, 1), cs(2, 3), cs(0, 2), cs(1, 3), cs(1, 2);
  return {v[0], {v[1], v[2], v[3]}};
}

template <class F>
void for_each_cell(uint64_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, n, 1 << 14), [&](const tbb::blocked_range<uint64_t>& r) {
    for (uint64_t c = r.begin(); c != r.end(); ++c) f(c);
  });
}

// Exclusive prefix sum in parallel; returns the total.
template <class In, class Out>
uint64_t exclusive_scan(const std::vector<In>& in, std::vector<Out>& out) {
  out.resize(in.size() + 1);
  const uint64_t total = tbb::parallel_scan(
      tbb::blocked_range<size_t>(0, in.size(), 1 << 16), uint64_t(0),
      [&](const tbb::blocked_range<size_t>& r, uint64_t sum, bool final) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          if (final) out[i] = Out(sum);
          sum += uint64_t(in[i]);
        }
        return sum;
      },
      [](uint64_t a, uint64_t b) { return a + b; });
  out[in.size()] = Out(total);
  return total;
}

}  // namespace

MeshTopology build_topology(const UnstructuredMesh& mesh) {
  const uint64_t nc = mesh.cell_count(), np = mesh.point_count();
  MeshTopology topo;

  // Face slots per cell.
  std::vector<uint8_t> face_counts(nc);
  for_each_cell(nc, [&](uint64_t c) { face_counts[c] = cell_face_count(mesh.cell_types[c]); });
  const uint64_t nf = exclusive_scan(face_counts, topo.face_offsets);
  face_counts = {};

  // Bucket faces by smallest vertex: count, scan, scatter.
  std::vector<uint32_t> bucket_count(np, 0);
  for_each_cell(nc, [&](uint64_t c) {
    const CellInfo info = cell_info(mesh.cell_types[c]);
    for (uint32_t f = 0; f < info.face_count; ++f) {
      std::atomic_ref<uint32_t>(bucket_count[face_key(mesh, c, info.faces[f]).lo])
          .fetch_add(1, std::memory_order_relaxed);
    }
  });
  std::vector<uint64_t> bucket_start;
  exclusive_scan(bucket_count, bucket_start);
  std::fill(bucket_count.begin(), bucket_count.end(), 0);  // reused as per-bucket fill cursors

  std::vector<FaceRecord> records(nf);
  for_each_cell(nc, [&](uint64_t c) {
    const CellInfo info = cell_info(mesh.cell_types[c]);
    for (uint32_t f = 0; f < info.face_count; ++f) {
      const FaceKey k = face_key(mesh, c, info.faces[f]);
      const uint32_t slot = std::atomic_ref<uint32_t>(bucket_count[k.lo]).fetch_add(1, std::memory_order_relaxed);
      records[bucket_start[k.lo] + slot] = {k.rest, pack_face(c, f)};
    }
  });
  bucket_count = {};

  // Match within buckets. Sorting each bucket makes the result independent of the scatter order above.
  topo.neighbors.assign(nf, kNoNeighbor);
  std::atomic<uint64_t> nonmanifold{0};
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, np, 1 << 12), [&](const tbb::blocked_range<uint64_t>& r) {
    uint64_t local_nonmanifold = 0;
    for (uint64_t b = r.begin(); b != r.end(); ++b) {
      FaceRecord* first = records.data() + bucket_start[b];
      FaceRecord* last = records.data() + bucket_start[b + 1];
      std::sort(first, last);
      for (FaceRecord* run = first; run != last;) {
        FaceRecord* end = run + 1;
        while (end != last && end->rest == run->rest) ++end;
        if (end - run == 2) {
          const uint64_t a = run[0].ref, bref = run[1].ref;
          topo.neighbors[topo.face_offsets[face_cell(a)] + face_local(a)] = bref;
          topo.neighbors[topo.face_offsets[face_cell(bref)] + face_local(bref)] = a;
        } else if (end - run > 2) {
          local_nonmanifold += uint64_t(end - run);
        }
        run = end;
      }
    }
    nonmanifold += local_nonmanifold;
  });
  records = {};
  bucket_start = {};
  topo.nonmanifold_faces = nonmanifold;

  // Boundary faces in cell order.
  for (uint64_t c = 0; c < nc; ++c) {
    for (uint64_t s = topo.face_offsets[c]; s < topo.face_offsets[c + 1]; ++s) {
      if (topo.neighbors[s] == kNoNeighbor) topo.boundary.push_back(pack_face(c, uint32_t(s - topo.face_offsets[c])));
    }
  }
  return topo;
}

}  // namespace ugvr
