#include "ugvr/octree/boundary_faces.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/grid/topology.h"

namespace ugvr {
namespace {

using store_format::BoundaryNodeEntry;
using store_format::BoundaryTriangleRecord;
using store_format::kBoundaryOverflow;

bool position_less(Vec3f a, Vec3f b, uint32_t ia, uint32_t ib) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  if (a.z != b.z) return a.z < b.z;
  return ia < ib;
}

Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// The triangles of `tris` that are not one of a pair of coincident triangles of opposite orientation. Such a pair is
// no boundary: it is the face two blocks of a multi-block grid share without being welded (each block's copy of the
// points has its own ids, so the topology finds no neighbour), and the mesh lies on both sides of it. Their crossings
// cancel in the shader (leaving one block, entering the other, within u_nudge), but each pair costs two ray-triangle
// tests wherever a ray is near it, fills the node's list towards the cap (more nodes over it, longer walks through
// virtual nodes) and can be the nearest face where the line meets none (side_of_faces then picks one of the two at
// random). Matched by the corners' exact coordinates: the two blocks carry the same points, and a quadrilateral is
// split along the diagonal through its lexicographically smallest corner, the same one from either side. Pairs are
// matched greedily among triangles with the same corner set (one of either orientation each).
std::vector<uint32_t> unpaired_triangles(std::span<const MeshFaceTriangle> tris, uint64_t* pairs) {
  using Key = std::array<float, 9>;
  // The corners rotated so that the smallest comes first: triangles with the same corner set and the same orientation
  // then have the same key; swapping the last two corners gives the opposite orientation's key.
  auto key_of = [](const MeshFaceTriangle& t, bool flip) {
    std::array<Vec3f, 3> v = t;
    if (flip) std::swap(v[1], v[2]);
    int s = 0;
    for (int i = 1; i < 3; ++i)
      if (position_less(v[size_t(i)], v[size_t(s)], 0, 0)) s = i;
    Key k{};
    for (int i = 0; i < 3; ++i) {
      const Vec3f& p = v[size_t((s + i) % 3)];
      k[size_t(3 * i)] = p.x, k[size_t(3 * i + 1)] = p.y, k[size_t(3 * i + 2)] = p.z;
    }
    return k;
  };
  std::vector<std::pair<Key, uint32_t>> keyed(tris.size());
  for (uint32_t t = 0; t < tris.size(); ++t) keyed[t] = {key_of(tris[t], false), t};
  std::sort(keyed.begin(), keyed.end());
  std::vector<char> dropped(tris.size(), 0);
  uint64_t n_pairs = 0;
  for (uint32_t t = 0; t < tris.size(); ++t) {
    if (dropped[t]) continue;
    const Key want = key_of(tris[t], true);
    auto it = std::lower_bound(keyed.begin(), keyed.end(), std::make_pair(want, uint32_t(0)));
    for (; it != keyed.end() && it->first == want; ++it) {
      if (it->second == t || dropped[it->second]) continue;
      dropped[t] = dropped[it->second] = 1;
      ++n_pairs;
      break;
    }
  }
  std::vector<uint32_t> kept;
  kept.reserve(tris.size() - 2 * n_pairs);
  for (uint32_t t = 0; t < tris.size(); ++t)
    if (!dropped[t]) kept.push_back(t);
  if (pairs) *pairs = n_pairs;
  return kept;
}

}  // namespace

bool triangle_box_overlap(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Bounds& box) {
  const Vec3d centre = (box.lo + box.hi) * 0.5, half = (box.hi - box.lo) * 0.5;
  const std::array<Vec3d, 3> v{a - centre, b - centre, c - centre};
  // Separated along `axis` when the triangle's projection lies wholly beyond the box's radius on it.
  auto separated = [&](const Vec3d& axis) {
    const double p0 = dot(v[0], axis), p1 = dot(v[1], axis), p2 = dot(v[2], axis);
    const double r = half.x * std::abs(axis.x) + half.y * std::abs(axis.y) + half.z * std::abs(axis.z);
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  const std::array<Vec3d, 3> box_axes{Vec3d{1, 0, 0}, Vec3d{0, 1, 0}, Vec3d{0, 0, 1}};
  for (const Vec3d& e : box_axes)
    if (separated(e)) return false;
  const std::array<Vec3d, 3> edges{v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  if (separated(cross(edges[0], edges[1]))) return false;
  for (const Vec3d& e : edges)
    for (const Vec3d& u : box_axes)
      if (separated(cross(e, u))) return false;
  return true;
}

void append_face_triangles(int size, const uint32_t* ids, const Vec3f* positions, std::vector<MeshFaceTriangle>& out) {
  if (size == 3) {
    out.push_back({positions[0], positions[1], positions[2]});
    return;
  }
  int smallest = 0;
  for (int i = 1; i < 4; ++i)
    if (position_less(positions[i], positions[smallest], ids[i], ids[smallest])) smallest = i;
  if (smallest == 1 || smallest == 3) {
    out.push_back({positions[0], positions[1], positions[3]});
    out.push_back({positions[1], positions[2], positions[3]});
  } else {
    out.push_back({positions[0], positions[1], positions[2]});
    out.push_back({positions[0], positions[2], positions[3]});
  }
}

std::vector<MeshFaceTriangle> mesh_boundary_triangles(const UnstructuredMesh& mesh, const MeshTopology* topology) {
  std::optional<MeshTopology> own;
  if (!topology) topology = &own.emplace(build_topology(mesh));
  const MeshTopology& topo = *topology;
  std::vector<MeshFaceTriangle> tris;
  tris.reserve(topo.boundary.size() * 2);
  for (uint64_t packed : topo.boundary) {
    const uint64_t cell = face_cell(packed);
    const CellFace face = cell_info(mesh.cell_types[cell]).faces[face_local(packed)];
    const auto vs = mesh.cell(cell);
    std::array<uint32_t, 4> ids{};
    std::array<Vec3f, 4> p{};
    for (int i = 0; i < face.size; ++i) {
      ids[size_t(i)] = vs[face.v[size_t(i)]];
      p[size_t(i)] = mesh.points[ids[size_t(i)]];
    }
    append_face_triangles(face.size, ids.data(), p.data(), tris);
  }
  return tris;
}

StoreBoundary store_boundary_faces(const UnstructuredMesh& mesh, const Bounds& root, std::span<const OctreeNode> nodes,
                                   uint32_t max_per_node, BoundaryFaceStats* stats, const MeshTopology* topology) {
  if (max_per_node == 0 || nodes.empty()) {
    if (stats) *stats = {};
    return {};
  }
  const auto start = std::chrono::steady_clock::now();
  const std::vector<MeshFaceTriangle> tris = mesh_boundary_triangles(mesh, topology);
  const double topology_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  StoreBoundary out = store_boundary_faces(tris, root, nodes, max_per_node, stats);
  if (stats) stats->seconds += topology_seconds;
  return out;
}

StoreBoundary store_boundary_faces(std::span<const MeshFaceTriangle> tris, const Bounds& root,
                                   std::span<const OctreeNode> nodes, uint32_t max_per_node, BoundaryFaceStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  StoreBoundary out;
  BoundaryFaceStats st;
  if (max_per_node == 0 || nodes.empty()) {
    if (stats) *stats = st;
    return out;
  }
  if (nodes.size() >= kBoundaryOverflow) throw Error("too many nodes for the boundary face section");
  if (tris.size() >= kBoundaryOverflow) throw Error("too many boundary triangles for the boundary face section");

  // The triangles in the root cell's normalised coordinates.
  const Vec3d size = root.size();
  auto normalised = [&](Vec3f p) {
    return Vec3d{(double(p.x) - root.lo.x) / size.x, (double(p.y) - root.lo.y) / size.y,
                 (double(p.z) - root.lo.z) / size.z};
  };
  st.triangles = tris.size();
  const std::vector<uint32_t> kept = unpaired_triangles(tris, &st.inner_pairs);
  if (kept.empty()) {
    if (stats) *stats = st;
    return out;
  }
  std::vector<std::array<Vec3d, 3>> corners(kept.size());
  out.triangles.resize(kept.size());
  for (size_t t = 0; t < kept.size(); ++t) {
    for (int i = 0; i < 3; ++i) {
      corners[t][size_t(i)] = normalised(tris[kept[t]][size_t(i)]);
      out.triangles[t].p[3 * i] = float(corners[t][size_t(i)].x);
      out.triangles[t].p[3 * i + 1] = float(corners[t][size_t(i)].y);
      out.triangles[t].p[3 * i + 2] = float(corners[t][size_t(i)].z);
    }
  }

  // Top-down, depth first: a node's triangles are those of its parent's that overlap its cell, grown by a hair so
  // that a face lying on a node face belongs to both sides (touching counts). Memory: one list per level in progress.
  // A leaf over the cap is divided further for the faces alone (virtual nodes: 8 entries appended per division,
  // store_format::BoundaryNodeEntry), down to kBoundaryVirtualLevels below it; one still over the cap there lists
  // them all.
  out.nodes.assign(nodes.size(), BoundaryNodeEntry{});
  uint32_t largest = 0;
  std::vector<uint32_t> all(kept.size());
  for (uint32_t t = 0; t < all.size(); ++t) all[t] = t;
  auto overlapping = [&](const Bounds& cell, const std::vector<uint32_t>& parent) {
    const double grow = (cell.hi.x - cell.lo.x) * 1e-6;
    Bounds box;
    box.lo = cell.lo - Vec3d{grow, grow, grow};
    box.hi = cell.hi + Vec3d{grow, grow, grow};
    std::vector<uint32_t> mine;
    for (uint32_t t : parent)
      if (triangle_box_overlap(corners[t][0], corners[t][1], corners[t][2], box)) mine.push_back(t);
    return mine;
  };
  auto list = [&](uint64_t entry, const std::vector<uint32_t>& mine) {
    out.nodes[entry] = {uint32_t(out.refs.size()), uint32_t(mine.size())};
    out.refs.insert(out.refs.end(), mine.begin(), mine.end());
    largest = std::max(largest, uint32_t(mine.size()));
    ++st.listed_nodes;
  };
  // A virtual node's entry (index `entry`, cell `cell`, `depth` levels below its leaf) given its triangles.
  auto divide = [&](auto& self, uint64_t entry, const Bounds& cell, const std::vector<uint32_t>& mine,
                    int depth) -> void {
    if (mine.size() <= max_per_node || depth >= kBoundaryVirtualLevels) {
      list(entry, mine);
      return;
    }
    const uint64_t base = out.nodes.size();
    if (base + 8 > kBoundaryOverflow) {
      list(entry, mine);
      return;
    }
    out.nodes.resize(base + 8);
    out.nodes[entry] = {uint32_t(base), kBoundaryOverflow};
    ++st.virtual_divisions;
    const Vec3d half = (cell.hi - cell.lo) * 0.5;
    for (int o = 0; o < 8; ++o) {
      Bounds c;
      c.lo = cell.lo + Vec3d{(o & 1) * half.x, (o >> 1 & 1) * half.y, (o >> 2 & 1) * half.z};
      c.hi = c.lo + half;
      const std::vector<uint32_t> sub = overlapping(c, mine);
      if (!sub.empty()) self(self, base + uint64_t(o), c, sub, depth + 1);
    }
  };
  auto visit = [&](auto& self, uint64_t id, const std::vector<uint32_t>& parent) -> void {
    const OctreeNode& n = nodes[id];
    const double cell = std::ldexp(1.0, -int(n.level));
    Bounds box;
    box.lo = Vec3d{n.i * cell, n.j * cell, n.k * cell};
    box.hi = box.lo + Vec3d{cell, cell, cell};
    const std::vector<uint32_t> mine = overlapping(box, parent);
    if (mine.empty()) return;  // nor does any descendant's cell
    ++st.crossed_nodes;
    if (mine.size() <= max_per_node) {
      list(id, mine);
    } else if (n.is_leaf()) {
      ++st.overflow_leaves;
      divide(divide, id, box, mine, 0);
    } else {
      out.nodes[id] = {0, kBoundaryOverflow};
      ++st.overflow_nodes;
    }
    if (n.is_leaf()) return;
    const int kids = std::popcount(unsigned(n.child_mask));
    for (int c = 0; c < kids; ++c) self(self, n.first_child + uint64_t(c), mine);
  };
  visit(visit, 0, all);
  out.max_per_node = std::max(max_per_node, largest);
  st.virtual_nodes = out.nodes.size() - nodes.size();
  st.references = out.refs.size();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = st;
  return out;
}

}  // namespace ugvr
