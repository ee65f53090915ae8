// Uniform refinement; the rules, the vertex numbering and the passes are described in refine.h.
#include "ugvr/refine/refine.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/topology.h"
#include "ugvr/io/vtu_writer.h"

namespace ugvr {

namespace {

using I3 = std::array<int32_t, 3>;

constexpr uint64_t kCellChunk = uint64_t(1) << 18;   // output cells per chunk
constexpr uint64_t kPointChunk = uint64_t(1) << 17;  // output points per chunk
constexpr uint64_t kGrain = 4096;                    // work per task inside a chunk

// VTK hexahedron vertex <-> corner bits (1 = +x, 2 = +y, 4 = +z); the permutation is its own inverse.
constexpr std::array<uint8_t, 8> kHexBits = {0, 1, 3, 2, 4, 5, 7, 6};

constexpr size_t type_slot(CellType t) {
  switch (t) {
    case CellType::Tetra: return 0;
    case CellType::Pyramid: return 1;
    case CellType::Wedge: return 2;
    case CellType::Hexahedron: return 3;
  }
  return 0;
}

uint64_t checked_mul(uint64_t a, uint64_t b, const char* what) {
  uint64_t r = 0;
  if (__builtin_mul_overflow(a, b, &r)) throw Error(std::string("refine: the output ") + what + " overflows 64 bits");
  return r;
}
uint64_t checked_add(uint64_t a, uint64_t b, const char* what) {
  uint64_t r = 0;
  if (__builtin_add_overflow(a, b, &r)) throw Error(std::string("refine: the output ") + what + " overflows 64 bits");
  return r;
}

I3 mid(const I3& a, const I3& b) { return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2}; }
I3 sub(const I3& a, const I3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
int64_t dot(const std::array<int64_t, 3>& a, const I3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
std::array<int64_t, 3> cross(const I3& a, const I3& b) {
  return {int64_t(a[1]) * b[2] - int64_t(a[2]) * b[1], int64_t(a[2]) * b[0] - int64_t(a[0]) * b[2],
          int64_t(a[0]) * b[1] - int64_t(a[1]) * b[0]};
}
int64_t det3(const I3& a, const I3& b, const I3& c) { return dot(cross(a, b), c); }

// ---------------------------------------------------------------------------------------------------------------------
// Reference polytopes (see refine.h), positively oriented in VTK's convention.

std::vector<I3> reference_vertices(CellType t, int32_t n) {
  switch (t) {
    case CellType::Tetra: return {{0, 0, 0}, {n, 0, 0}, {0, n, 0}, {0, 0, n}};
    case CellType::Pyramid: return {{0, 0, 0}, {n, 0, 0}, {n, n, 0}, {0, n, 0}, {0, 0, n}};
    // Vertex 1 on +y and 2 on +x: seen from the top triangle, 0-1-2 turns clockwise, as VTK wants.
    case CellType::Wedge: return {{0, 0, 0}, {0, n, 0}, {n, 0, 0}, {0, 0, n}, {0, n, n}, {n, 0, n}};
    case CellType::Hexahedron: {
      std::vector<I3> v(8);
      for (int i = 0; i < 8; ++i) {
        const int b = kHexBits[size_t(i)];
        v[size_t(i)] = {(b & 1) * n, ((b >> 1) & 1) * n, ((b >> 2) & 1) * n};
      }
      return v;
    }
  }
  return {};
}

// One cell of the refinement tree in reference coordinates.
struct Node {
  CellType type;
  std::array<I3, 8> v;
};

// Children of one refinement step, in a fixed order.
void split(const Node& node, std::vector<Node>& out) {
  const auto& v = node.v;
  switch (node.type) {
    case CellType::Tetra: {
      // Bey's red refinement, his vertex orders (the inner octahedron is cut along x02-x13).
      const I3 m01 = mid(v[0], v[1]), m02 = mid(v[0], v[2]), m03 = mid(v[0], v[3]), m12 = mid(v[1], v[2]),
               m13 = mid(v[1], v[3]), m23 = mid(v[2], v[3]);
      const std::array<std::array<I3, 4>, 8> kids = {{{v[0], m01, m02, m03},
                                                      {m01, v[1], m12, m13},
                                                      {m02, m12, v[2], m23},
                                                      {m03, m13, m23, v[3]},
                                                      {m01, m02, m03, m13},
                                                      {m01, m02, m12, m13},
                                                      {m02, m03, m13, m23},
                                                      {m02, m12, m13, m23}}};
      for (const auto& k : kids) out.push_back({CellType::Tetra, {k[0], k[1], k[2], k[3]}});
      return;
    }
    case CellType::Hexahedron: {
      // The reference hexahedron and its children are boxes, so the 3x3x3 grid is affine in the corners.
      const I3 ex = sub(v[1], v[0]), ey = sub(v[3], v[0]), ez = sub(v[4], v[0]);
      auto grid = [&](int a, int b, int cc) {
        return I3{v[0][0] + (a * ex[0] + b * ey[0] + cc * ez[0]) / 2,
                  v[0][1] + (a * ex[1] + b * ey[1] + cc * ez[1]) / 2,
                  v[0][2] + (a * ex[2] + b * ey[2] + cc * ez[2]) / 2};
      };
      for (int k = 0; k < 8; ++k) {
        Node child{CellType::Hexahedron, {}};
        for (int q = 0; q < 8; ++q) {
          const int b = kHexBits[size_t(q)];
          child.v[size_t(q)] =
              grid((k & 1) + (b & 1), ((k >> 1) & 1) + ((b >> 1) & 1), ((k >> 2) & 1) + ((b >> 2) & 1));
        }
        out.push_back(child);
      }
      return;
    }
    case CellType::Wedge: {
      // Triangle (p, q, r) into its 3 corner triangles and the medial one (same orientation), on each of 2 layers.
      const std::array<I3, 3> bot = {v[0], v[1], v[2]}, top = {v[3], v[4], v[5]};
      const std::array<I3, 3> midl = {mid(v[0], v[3]), mid(v[1], v[4]), mid(v[2], v[5])};
      auto tris = [](const std::array<I3, 3>& t) {
        const I3 a = mid(t[0], t[1]), b = mid(t[1], t[2]), c2 = mid(t[2], t[0]);
        return std::array<std::array<I3, 3>, 4>{{{t[0], a, c2}, {a, t[1], b}, {c2, b, t[2]}, {a, b, c2}}};
      };
      const std::array<std::array<I3, 3>, 2> layers[2] = {{bot, midl}, {midl, top}};
      for (const auto& layer : layers) {
        const auto lo = tris(layer[0]), hi = tris(layer[1]);
        for (int t = 0; t < 4; ++t) {
          const auto& l = lo[size_t(t)];
          const auto& h = hi[size_t(t)];
          out.push_back({CellType::Wedge, {l[0], l[1], l[2], h[0], h[1], h[2]}});
        }
      }
      return;
    }
    case CellType::Pyramid: {
      // Base (0,1,2,3) a parallelogram in reference space at every level, apex 4.
      std::array<I3, 4> m{}, ma{};  // base edge midpoints m[i] = mid(i, i+1); apex edge midpoints ma[i] = mid(i, 4)
      for (int i = 0; i < 4; ++i) {
        m[size_t(i)] = mid(v[size_t(i)], v[size_t((i + 1) % 4)]);
        ma[size_t(i)] = mid(v[size_t(i)], v[4]);
      }
      const I3 c = mid(v[0], v[2]);
      out.push_back({CellType::Pyramid, {v[0], m[0], c, m[3], ma[0]}});
      out.push_back({CellType::Pyramid, {m[0], v[1], m[1], c, ma[1]}});
      out.push_back({CellType::Pyramid, {c, m[1], v[2], m[2], ma[2]}});
      out.push_back({CellType::Pyramid, {m[3], c, m[2], v[3], ma[3]}});
      out.push_back({CellType::Pyramid, {ma[0], ma[1], ma[2], ma[3], v[4]}});
      out.push_back({CellType::Pyramid, {ma[0], ma[3], ma[2], ma[1], c}});  // upside down: base reversed
      for (int i = 0; i < 4; ++i) {
        Node t{CellType::Tetra, {m[size_t(i)], ma[size_t(i)], ma[size_t((i + 1) % 4)], c}};
        if (det3(sub(t.v[1], t.v[0]), sub(t.v[2], t.v[0]), sub(t.v[3], t.v[0])) < 0) std::swap(t.v[1], t.v[2]);
        out.push_back(t);
      }
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------------
// Where a lattice point of a reference cell lies: a vertex, the interior of an edge or a face, or the interior.

struct Locus {
  enum Kind : uint8_t { Vertex, Edge, Face, Interior } kind = Interior;
  uint8_t index = 0;     // local vertex, local edge (Shape::edges) or local face
  int32_t s = 0, t = 0;  // edge: steps from its first local vertex; face: coordinates along its edges 0->1, 0->last
  uint32_t rank = 0;     // interior: index into Template::interior
};

struct Shape {
  CellType type{};
  int32_t n = 0;
  std::vector<I3> ref;
  CellInfo info{};
  std::array<std::array<int64_t, 3>, 6> normal{};  // outward face normals
  std::vector<std::array<uint8_t, 2>> edges;       // local edges (lower local index first)

  Shape(CellType t, int32_t n_) : type(t), n(n_), ref(reference_vertices(t, n_)), info(cell_info(t)) {
    for (int f = 0; f < info.face_count; ++f) {
      const CellFace& face = info.faces[size_t(f)];
      normal[size_t(f)] = cross(sub(ref[face.v[1]], ref[face.v[0]]), sub(ref[face.v[face.size - 1]], ref[face.v[0]]));
      for (int q = 0; q < face.size; ++q) {
        uint8_t a = face.v[size_t(q)], b = face.v[size_t((q + 1) % face.size)];
        if (a > b) std::swap(a, b);
        if (std::find(edges.begin(), edges.end(), std::array<uint8_t, 2>{a, b}) == edges.end()) edges.push_back({a, b});
      }
    }
  }

  bool on_face(int f, const I3& p) const {
    return dot(normal[size_t(f)], sub(p, ref[info.faces[size_t(f)].v[0]])) == 0;
  }

  Locus classify(const I3& p) const {
    std::array<int, 6> on{};
    int count = 0;
    for (int f = 0; f < info.face_count; ++f) {
      if (on_face(f, p)) on[size_t(count++)] = f;
    }
    Locus l;
    if (count == 0) return l;
    if (count >= 3) {
      l.kind = Locus::Vertex;
      l.index = uint8_t(std::find(ref.begin(), ref.end(), p) - ref.begin());
      return l;
    }
    if (count == 2) return edge_locus(on[0], on[1], p);
    // Face interior: p = R0 + (s * (R1 - R0) + t * (Rlast - R0)) / n, solved on a pair of axes with a nonzero minor.
    const CellFace& face = info.faces[size_t(on[0])];
    const I3 r0 = ref[face.v[0]], e1 = sub(ref[face.v[1]], r0), e2 = sub(ref[face.v[face.size - 1]], r0),
             d = sub(p, r0);
    for (int i = 0; i < 3; ++i) {
      for (int j = i + 1; j < 3; ++j) {
        const int64_t det = int64_t(e1[size_t(i)]) * e2[size_t(j)] - int64_t(e1[size_t(j)]) * e2[size_t(i)];
        if (det == 0) continue;
        l.kind = Locus::Face;
        l.index = uint8_t(on[0]);
        l.s = int32_t((int64_t(d[size_t(i)]) * e2[size_t(j)] - int64_t(d[size_t(j)]) * e2[size_t(i)]) * n / det);
        l.t = int32_t((int64_t(e1[size_t(i)]) * d[size_t(j)] - int64_t(e1[size_t(j)]) * d[size_t(i)]) * n / det);
        return l;
      }
    }
    throw Error("refine: internal error: degenerate reference face");
  }

  Locus edge_locus(int f, int g, const I3& p) const {
    std::array<uint8_t, 2> e{};
    int found = 0;
    const CellFace &a = info.faces[size_t(f)], &b = info.faces[size_t(g)];
    for (int i = 0; i < a.size; ++i) {
      for (int j = 0; j < b.size; ++j) {
        if (a.v[size_t(i)] == b.v[size_t(j)] && found < 2) e[size_t(found++)] = a.v[size_t(i)];
      }
    }
    if (e[0] > e[1]) std::swap(e[0], e[1]);
    Locus l;
    l.kind = Locus::Edge;
    l.index = uint8_t(std::find(edges.begin(), edges.end(), e) - edges.begin());
    const I3 d = sub(p, ref[e[0]]);
    l.s = std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])});
    return l;
  }
};

// The refinement of one cell type, N levels deep: its leaves (as lattice point slots) and the lattice points used.
struct Template {
  CellType type{};
  uint64_t leaves = 0;
  std::vector<CellType> leaf_type;
  std::vector<uint32_t> leaf_start;  // leaves + 1 prefix of connectivity entries
  std::vector<uint32_t> leaf_point;  // slot into `points` per leaf vertex
  std::vector<Locus> points;         // lattice points used, in box order (z, y, x)
  std::vector<I3> interior;          // interior lattice points, in rank order
  CellTypeCounts types;
};

void descend(const Node& node, int levels, std::vector<Node>& leaves) {
  if (levels == 0) {
    leaves.push_back(node);
    return;
  }
  std::vector<Node> kids;
  split(node, kids);
  for (const Node& k : kids) descend(k, levels - 1, leaves);
}

Template build_template(const Shape& shape, int levels) {
  Template t;
  t.type = shape.type;
  Node root{shape.type, {}};
  std::copy(shape.ref.begin(), shape.ref.end(), root.v.begin());
  std::vector<Node> leaves;
  descend(root, levels, leaves);

  const int64_t side = shape.n + 1;
  auto box = [&](const I3& p) { return uint64_t(p[0] + side * (p[1] + side * p[2])); };
  std::vector<uint32_t> slot_of(size_t(side * side * side), UINT32_MAX);
  for (const Node& l : leaves) {
    for (int q = 0; q < cell_vertex_count(l.type); ++q) slot_of[box(l.v[size_t(q)])] = 0;
  }
  for (uint64_t b = 0; b < slot_of.size(); ++b) {
    if (slot_of[b] == UINT32_MAX) continue;
    const I3 p = {int32_t(b % uint64_t(side)), int32_t(b / uint64_t(side) % uint64_t(side)),
                  int32_t(b / uint64_t(side * side))};
    slot_of[b] = uint32_t(t.points.size());
    Locus l = shape.classify(p);
    if (l.kind == Locus::Interior) {
      l.rank = uint32_t(t.interior.size());
      t.interior.push_back(p);
    }
    t.points.push_back(l);
  }
  t.leaves = leaves.size();
  t.leaf_start.push_back(0);
  for (Node l : leaves) {
    const int nv = cell_vertex_count(l.type);
    // Bey's vertex orders are kept for the recursion; written tets must be positively oriented.
    if (l.type == CellType::Tetra && det3(sub(l.v[1], l.v[0]), sub(l.v[2], l.v[0]), sub(l.v[3], l.v[0])) < 0) {
      std::swap(l.v[1], l.v[2]);
    }
    for (int q = 0; q < nv; ++q) t.leaf_point.push_back(slot_of[box(l.v[size_t(q)])]);
    t.leaf_type.push_back(l.type);
    t.leaf_start.push_back(uint32_t(t.leaf_point.size()));
    ++t.types[l.type];
  }
  return t;
}

// Interpolation weights of one output point over input vertices.
struct Weights {
  int count = 0;
  std::array<uint32_t, 8> v{};
  std::array<double, 8> w{};
  void add(uint32_t vertex, double weight) {
    v[size_t(count)] = vertex;
    w[size_t(count++)] = weight;
  }
};

// Rank of a triangle-face interior point from its canonical barycentrics (u1, u2), both >= 1, u1 + u2 <= n - 1.
uint64_t tri_rank(int64_t n, int64_t u1, int64_t u2) {
  return uint64_t((u2 - 1) * (n - 1) - (u2 - 1) * u2 / 2 + u1 - 1);
}

// Canonical frame of a quad face: corner p has the lowest id, b is its lower-id neighbour, d the other.
struct QuadFrame {
  int p, b, d;
};
QuadFrame quad_frame(const std::array<uint32_t, 4>& g) {
  const int p = int(std::min_element(g.begin(), g.end()) - g.begin());
  const int next = (p + 1) % 4, prev = (p + 3) % 4;
  return g[size_t(next)] < g[size_t(prev)] ? QuadFrame{p, next, prev} : QuadFrame{p, prev, next};
}

// ---------------------------------------------------------------------------------------------------------------------
// The tables and the passes.

class Refiner {
 public:
  Refiner(const UnstructuredMesh& mesh, int levels) : mesh_(mesh), levels_(levels) {
    if (levels < 0 || levels > kMaxRefineLevels) {
      throw Error("refine: --levels must be between 0 and " + std::to_string(kMaxRefineLevels) + ", got " +
                  std::to_string(levels));
    }
    if (mesh.cell_count() == 0) throw Error("refine: the dataset has no volume cells");
    n_ = int32_t(1) << levels;
    plan_.levels = levels;
    plan_.input_cells = mesh.cell_count();
    plan_.input_points = mesh.point_count();
    build_templates();
    count_cells();
    build_edges();
    build_faces();
    count_points();
  }

  const RefinePlan& plan() const { return plan_; }

  using Sink = std::function<void(std::span<const std::byte>)>;

  void write_points(const Sink& sink) const {
    point_pass<float, 3>(sink, [&](const Weights& w, float* out) {
      double x = 0, y = 0, z = 0;
      for (int i = 0; i < w.count; ++i) {
        const Vec3f& p = mesh_.points[w.v[size_t(i)]];
        x += w.w[size_t(i)] * p.x, y += w.w[size_t(i)] * p.y, z += w.w[size_t(i)] * p.z;
      }
      out[0] = float(x), out[1] = float(y), out[2] = float(z);
    });
  }

  void write_vertex_field(const DataArray& data, const Sink& sink) const {
    data.visit([&](auto values) {
      using T = std::remove_const_t<typename decltype(values)::element_type>;
      const int comps = data.components();
      std::vector<T> buf;
      point_chunks(comps, buf, sink, [&](const Weights& w, T* out) {
        for (int k = 0; k < comps; ++k) {
          double sum = 0;
          for (int i = 0; i < w.count; ++i) sum += w.w[size_t(i)] * double(values[size_t(w.v[size_t(i)]) * comps + k]);
          out[k] = convert<T>(sum);
        }
      });
    });
  }

  template <class Index>
  void write_connectivity(const Sink& sink) const {
    cell_pass<Index>(
        sink, [&](uint64_t o) { return ids_before(o); },
        [&](uint64_t c, uint64_t l0, uint64_t l1, Index* out, std::vector<uint64_t>& gid) {
          const Template& t = *template_of(c);
          map_lattice(c, t, gid);
          for (uint64_t i = t.leaf_start[l0]; i < t.leaf_start[l1]; ++i) *out++ = Index(gid[t.leaf_point[i]]);
        });
  }

  void write_offsets(const Sink& sink) const {
    cell_pass<int64_t>(
        sink, [](uint64_t o) { return o; },
        [&](uint64_t c, uint64_t l0, uint64_t l1, int64_t* out, std::vector<uint64_t>&) {
          const Template& t = *template_of(c);
          for (uint64_t l = l0; l < l1; ++l) *out++ = int64_t(ids_before_[c] + t.leaf_start[l + 1]);
        });
  }

  void write_types(const Sink& sink) const {
    cell_pass<uint8_t>(
        sink, [](uint64_t o) { return o; },
        [&](uint64_t c, uint64_t l0, uint64_t l1, uint8_t* out, std::vector<uint64_t>&) {
          const Template& t = *template_of(c);
          for (uint64_t l = l0; l < l1; ++l) *out++ = uint8_t(t.leaf_type[l]);
        });
  }

  void write_cell_field(const DataArray& data, const Sink& sink) const {
    data.visit([&](auto values) {
      using T = std::remove_const_t<typename decltype(values)::element_type>;
      const int comps = data.components();
      cell_pass<T>(
          sink, [comps](uint64_t o) { return o * uint64_t(comps); },
          [&](uint64_t c, uint64_t l0, uint64_t l1, T* out, std::vector<uint64_t>&) {
            for (uint64_t l = l0; l < l1; ++l) {
              for (int k = 0; k < comps; ++k) *out++ = values[size_t(c) * comps + k];
            }
          });
    });
  }

 private:
  template <class T>
  static T convert(double v) {
    if constexpr (std::is_floating_point_v<T>) {
      return T(v);
    } else {
      const double r = std::round(v);
      const double lo = double(std::numeric_limits<T>::lowest()), hi = double(std::numeric_limits<T>::max());
      return r <= lo ? std::numeric_limits<T>::lowest() : r >= hi ? std::numeric_limits<T>::max() : T(r);
    }
  }

  const Template* template_of(uint64_t c) const { return &*templates_[type_slot(mesh_.cell_types[c])]; }

  void build_templates() {
    for (CellType t : kAllCellTypes) {
      if (mesh_.cell_type_counts()[t] == 0) continue;
      const Shape shape(t, n_);
      templates_[type_slot(t)] = build_template(shape, levels_);
      shapes_[type_slot(t)] = shape;
    }
  }

  // Output cells and connectivity, before any table is built, so absurd requests fail fast.
  void count_cells() {
    const CellTypeCounts in = mesh_.cell_type_counts();
    for (CellType t : kAllCellTypes) {
      if (in[t] == 0) continue;
      const Template& tp = *templates_[type_slot(t)];
      plan_.cells = checked_add(plan_.cells, checked_mul(in[t], tp.leaves, "cell count"), "cell count");
      plan_.connectivity =
          checked_add(plan_.connectivity, checked_mul(in[t], tp.leaf_point.size(), "connectivity"), "connectivity");
      for (CellType k : kAllCellTypes) plan_.types[k] += in[t] * tp.types[k];
    }
    if (plan_.cells > kMaxRefineCells) {
      throw Error("refine: " + std::to_string(levels_) + " levels would make " + std::to_string(plan_.cells) +
                  " cells, more than the limit of 2^40; use fewer levels");
    }
    cells_before_.resize(mesh_.cell_count() + 1, 0);
    ids_before_.resize(mesh_.cell_count() + 1, 0);
    for (uint64_t c = 0; c < mesh_.cell_count(); ++c) {
      const Template& tp = *template_of(c);
      cells_before_[c + 1] = cells_before_[c] + tp.leaves;
      ids_before_[c + 1] = ids_before_[c] + tp.leaf_point.size();
    }
  }

  // Unique edges sorted by (lower id, higher id): edge_hi_ holds the higher ids, first_edge_[v] where v's begin.
  void build_edges() {
    std::vector<uint64_t> keys;
    uint64_t slots = 0;
    for (CellType t : kAllCellTypes) {
      if (shapes_[type_slot(t)]) slots += mesh_.cell_type_counts()[t] * shapes_[type_slot(t)]->edges.size();
    }
    keys.reserve(slots);
    for (uint64_t c = 0; c < mesh_.cell_count(); ++c) {
      const auto v = mesh_.cell(c);
      for (const auto& e : shapes_[type_slot(mesh_.cell_types[c])]->edges) {
        const uint64_t a = v[e[0]], b = v[e[1]];
        keys.push_back(a < b ? (a << 32 | b) : (b << 32 | a));
      }
    }
    tbb::parallel_sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    first_edge_.assign(mesh_.point_count() + 1, 0);
    edge_lo_.resize(keys.size());
    edge_hi_.resize(keys.size());
    for (size_t i = 0; i < keys.size(); ++i) {
      edge_lo_[i] = uint32_t(keys[i] >> 32);
      edge_hi_[i] = uint32_t(keys[i]);
      ++first_edge_[edge_lo_[i] + 1];
    }
    for (uint64_t v = 0; v < mesh_.point_count(); ++v) first_edge_[v + 1] += first_edge_[v];
    plan_.edges = keys.size();
  }

  uint64_t edge_index(uint32_t lo, uint32_t hi) const {
    const auto b = edge_hi_.begin() + int64_t(first_edge_[lo]), e = edge_hi_.begin() + int64_t(first_edge_[lo + 1]);
    return uint64_t(std::lower_bound(b, e, hi) - edge_hi_.begin());
  }

  // Unique faces from the face topology: a face slot takes a new id unless its neighbour's slot came first.
  void build_faces() {
    MeshTopology topo = build_topology(mesh_);
    slot_face_.resize(topo.neighbors.size());
    face_point_base_.push_back(0);
    const uint64_t tri_points = uint64_t(n_ - 1) * uint64_t(std::max(0, n_ - 2)) / 2;
    const uint64_t quad_points = uint64_t(n_ - 1) * uint64_t(n_ - 1);
    for (uint64_t c = 0; c < mesh_.cell_count(); ++c) {
      const CellInfo info = cell_info(mesh_.cell_types[c]);
      for (uint32_t f = 0; f < info.face_count; ++f) {
        const uint64_t slot = topo.face_offsets[c] + f, nb = topo.neighbors[slot];
        if (nb != kNoNeighbor && nb < pack_face(c, f)) {
          slot_face_[slot] = slot_face_[topo.face_offsets[face_cell(nb)] + face_local(nb)];
          continue;
        }
        slot_face_[slot] = face_owner_.size();
        face_owner_.push_back(pack_face(c, f));
        const bool quad = info.faces[f].size == 4;
        (quad ? plan_.quads : plan_.triangles) += 1;
        face_point_base_.push_back(face_point_base_.back() + (quad ? quad_points : tri_points));
      }
    }
    face_offsets_ = std::move(topo.face_offsets);
  }

  void count_points() {
    const uint64_t V = mesh_.point_count();
    face_base_ = checked_add(V, checked_mul(plan_.edges, uint64_t(n_ - 1), "point count"), "point count");
    cell_base_ = checked_add(face_base_, face_point_base_.back(), "point count");
    cell_point_base_.resize(mesh_.cell_count() + 1, 0);
    for (uint64_t c = 0; c < mesh_.cell_count(); ++c) {
      cell_point_base_[c + 1] = cell_point_base_[c] + template_of(c)->interior.size();
    }
    plan_.points = checked_add(cell_base_, cell_point_base_.back(), "point count");
    if (plan_.points > kMaxRefinePoints) {
      throw Error("refine: " + std::to_string(levels_) + " levels would make " + std::to_string(plan_.points) +
                  " points; vertex indices are limited to 32 bits (at most 4294967295 points): use fewer levels");
    }
  }

  uint64_t ids_before(uint64_t o) const {
    if (o >= plan_.cells) return plan_.connectivity;
    const uint64_t c = cell_of(o);
    return ids_before_[c] + template_of(c)->leaf_start[o - cells_before_[c]];
  }
  uint64_t cell_of(uint64_t o) const {
    return uint64_t(std::upper_bound(cells_before_.begin(), cells_before_.end(), o) - cells_before_.begin()) - 1;
  }

  // Global ids of every lattice point of cell c's template, into gid (indexed by template point slot).
  void map_lattice(uint64_t c, const Template& t, std::vector<uint64_t>& gid) const {
    const Shape& sh = *shapes_[type_slot(t.type)];
    const auto v = mesh_.cell(c);
    const int64_t n = n_;
    std::array<uint64_t, 12> edge_first{};
    std::array<bool, 12> flip{};
    for (size_t j = 0; j < sh.edges.size(); ++j) {
      uint32_t a = v[sh.edges[j][0]], b = v[sh.edges[j][1]];
      flip[j] = a > b;
      if (flip[j]) std::swap(a, b);
      edge_first[j] = mesh_.point_count() + edge_index(a, b) * uint64_t(n - 1) - 1;
    }
    gid.resize(t.points.size());
    for (size_t i = 0; i < t.points.size(); ++i) {
      const Locus& l = t.points[i];
      switch (l.kind) {
        case Locus::Vertex: gid[i] = v[l.index]; break;
        case Locus::Edge: gid[i] = edge_first[l.index] + uint64_t(flip[l.index] ? n - l.s : l.s); break;
        case Locus::Interior: gid[i] = cell_base_ + cell_point_base_[c] + l.rank; break;
        case Locus::Face: gid[i] = face_point(c, sh, l, v); break;
      }
    }
  }

  uint64_t face_point(uint64_t c, const Shape& sh, const Locus& l, std::span<const uint32_t> v) const {
    const CellFace& face = sh.info.faces[l.index];
    const uint64_t base = face_base_ + face_point_base_[slot_face_[face_offsets_[c] + l.index]];
    const int64_t n = n_;
    if (face.size == 3) {
      const std::array<uint32_t, 3> g = {v[face.v[0]], v[face.v[1]], v[face.v[2]]};
      const std::array<int64_t, 3> w = {n - l.s - l.t, l.s, l.t};
      std::array<int, 3> o = {0, 1, 2};
      std::sort(o.begin(), o.end(), [&](int a, int b) { return g[size_t(a)] < g[size_t(b)]; });
      return base + tri_rank(n, w[size_t(o[1])], w[size_t(o[2])]);
    }
    const std::array<uint32_t, 4> g = {v[face.v[0]], v[face.v[1]], v[face.v[2]], v[face.v[3]]};
    const QuadFrame fr = quad_frame(g);
    static constexpr std::array<std::array<int64_t, 2>, 4> kCorner = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
    auto along = [&](int to) {
      const auto& a = kCorner[size_t(fr.p)];
      const auto& b = kCorner[size_t(to)];
      return (l.s - a[0] * n) * (b[0] - a[0]) + (l.t - a[1] * n) * (b[1] - a[1]);
    };
    return base + uint64_t(along(fr.b) - 1 + (n - 1) * (along(fr.d) - 1));
  }

  // Runs fill(c, leaf_begin, leaf_end, out, scratch) over output cells in file order, chunk by chunk; pos(o) counts
  // the values before output cell o.
  template <class T, class Pos, class Fill>
  void cell_pass(const Sink& sink, Pos pos, Fill fill) const {
    const uint64_t total = plan_.cells;
    const uint64_t grain = std::max<uint64_t>(kGrain, max_leaves());
    const uint64_t chunk = std::max(kCellChunk, 4 * grain);
    std::vector<T> buf;
    for (uint64_t o0 = 0; o0 < total; o0 += chunk) {
      const uint64_t o1 = std::min(total, o0 + chunk), base = pos(o0);
      buf.resize(size_t(pos(o1) - base));
      tbb::parallel_for(tbb::blocked_range<uint64_t>(o0, o1, grain), [&](const tbb::blocked_range<uint64_t>& r) {
        std::vector<uint64_t> scratch;
        uint64_t o = r.begin(), c = cell_of(o);
        while (o < r.end()) {
          while (cells_before_[c + 1] <= o) ++c;
          const uint64_t l0 = o - cells_before_[c], l1 = std::min(cells_before_[c + 1], r.end()) - cells_before_[c];
          fill(c, l0, l1, buf.data() + (pos(o) - base), scratch);
          o += l1 - l0;
        }
      });
      sink(std::as_bytes(std::span(buf)));
    }
  }

  uint64_t max_leaves() const {
    uint64_t m = 0;
    for (const auto& t : templates_) {
      if (t) m = std::max(m, t->leaves);
    }
    return m;
  }

  template <class T, int Components, class Fill>
  void point_pass(const Sink& sink, Fill fill) const {
    std::vector<T> buf;
    point_chunks(Components, buf, sink, fill);
  }

  // Runs fill(weights, T* tuple) for every output point in file order, chunk by chunk.
  template <class T, class Fill>
  void point_chunks(int comps, std::vector<T>& buf, const Sink& sink, Fill fill) const {
    const uint64_t total = plan_.points;
    for (uint64_t p0 = 0; p0 < total; p0 += kPointChunk) {
      const uint64_t p1 = std::min(total, p0 + kPointChunk);
      buf.resize(size_t(p1 - p0) * size_t(comps));
      tbb::parallel_for(tbb::blocked_range<uint64_t>(p0, p1, kGrain), [&](const tbb::blocked_range<uint64_t>& r) {
        for (uint64_t p = r.begin(); p != r.end(); ++p) fill(weights(p), buf.data() + (p - p0) * uint64_t(comps));
      });
      sink(std::as_bytes(std::span(buf)));
    }
  }

  // Interpolation weights of output point p (see the numbering in refine.h).
  Weights weights(uint64_t p) const {
    Weights w;
    const uint64_t V = mesh_.point_count();
    const double n = n_;
    if (p < V) {
      w.add(uint32_t(p), 1.0);
    } else if (p < face_base_) {
      const uint64_t e = (p - V) / uint64_t(n_ - 1), k = (p - V) % uint64_t(n_ - 1) + 1;
      w.add(edge_lo_[e], (n - double(k)) / n);
      w.add(edge_hi_[e], double(k) / n);
    } else if (p < cell_base_) {
      face_weights(p - face_base_, w);
    } else {
      cell_weights(p - cell_base_, w);
    }
    return w;
  }

  void face_weights(uint64_t q, Weights& w) const {
    const uint64_t f =
        uint64_t(std::upper_bound(face_point_base_.begin(), face_point_base_.end(), q) - face_point_base_.begin()) - 1;
    uint64_t rank = q - face_point_base_[f];
    const uint64_t c = face_cell(face_owner_[f]);
    const CellFace face = cell_info(mesh_.cell_types[c]).faces[face_local(face_owner_[f])];
    const auto v = mesh_.cell(c);
    const int64_t n = n_;
    if (face.size == 3) {
      std::array<uint32_t, 3> g = {v[face.v[0]], v[face.v[1]], v[face.v[2]]};
      std::sort(g.begin(), g.end());
      int64_t u2 = 1;
      while (rank >= uint64_t(n - 1 - u2)) rank -= uint64_t(n - 1 - u2++);
      const int64_t u1 = int64_t(rank) + 1;
      w.add(g[0], double(n - u1 - u2) / double(n));
      w.add(g[1], double(u1) / double(n));
      w.add(g[2], double(u2) / double(n));
      return;
    }
    const std::array<uint32_t, 4> g = {v[face.v[0]], v[face.v[1]], v[face.v[2]], v[face.v[3]]};
    const QuadFrame fr = quad_frame(g);
    const double s = double(rank % uint64_t(n - 1) + 1) / double(n), t = double(rank / uint64_t(n - 1) + 1) / double(n);
    w.add(g[size_t(fr.p)], (1 - s) * (1 - t));
    w.add(g[size_t(fr.b)], s * (1 - t));
    w.add(g[size_t((fr.p + 2) % 4)], s * t);
    w.add(g[size_t(fr.d)], (1 - s) * t);
  }

  // The cell's own map at an interior lattice point.
  void cell_weights(uint64_t q, Weights& w) const {
    const uint64_t c =
        uint64_t(std::upper_bound(cell_point_base_.begin(), cell_point_base_.end(), q) - cell_point_base_.begin()) - 1;
    const Template& t = *template_of(c);
    const I3 p = t.interior[q - cell_point_base_[c]];
    const auto v = mesh_.cell(c);
    const double n = n_, x = p[0] / n, y = p[1] / n, z = p[2] / n;
    switch (t.type) {
      case CellType::Tetra: w.add(v[0], 1 - x - y - z), w.add(v[1], x), w.add(v[2], y), w.add(v[3], z); return;
      case CellType::Hexahedron:
        for (int i = 0; i < 8; ++i) {
          const int b = kHexBits[size_t(i)];
          w.add(v[size_t(i)], ((b & 1) ? x : 1 - x) * ((b & 2) ? y : 1 - y) * ((b & 4) ? z : 1 - z));
        }
        return;
      case CellType::Wedge: {
        const std::array<double, 3> bary = {1 - x - y, y, x};  // vertex 1 is on +y, vertex 2 on +x
        for (int i = 0; i < 3; ++i) {
          w.add(v[size_t(i)], bary[size_t(i)] * (1 - z));
          w.add(v[size_t(i + 3)], bary[size_t(i)] * z);
        }
        return;
      }
      case CellType::Pyramid: {
        // Collapsed hexahedron: bilinear base at height z, shrinking to the apex (z < 1 inside).
        const double u = x / (1 - z), s = y / (1 - z);
        w.add(v[0], (1 - z) * (1 - u) * (1 - s)), w.add(v[1], (1 - z) * u * (1 - s));
        w.add(v[2], (1 - z) * u * s), w.add(v[3], (1 - z) * (1 - u) * s), w.add(v[4], z);
        return;
      }
    }
  }

  const UnstructuredMesh& mesh_;
  int levels_;
  int32_t n_ = 1;
  RefinePlan plan_;
  std::array<std::optional<Template>, 4> templates_;
  std::array<std::optional<Shape>, 4> shapes_;
  std::vector<uint64_t> cells_before_, ids_before_;  // per input cell: output cells / connectivity entries before it
  std::vector<uint64_t> first_edge_;
  std::vector<uint32_t> edge_lo_, edge_hi_;
  std::vector<uint64_t> face_offsets_, slot_face_, face_owner_, face_point_base_;
  std::vector<uint64_t> cell_point_base_;
  uint64_t face_base_ = 0, cell_base_ = 0;  // first output point on a face / inside a cell
};

// The dataset's single block as an unstructured mesh (structured grids cut into tets).
struct Input {
  std::optional<Block> converted;
  const Block* block = nullptr;
  const UnstructuredMesh* mesh = nullptr;
  std::vector<const Field*> fields;
};

Input prepare(const Dataset& ds, const RefineOptions& o) {
  if (ds.blocks.size() != 1) {
    throw Error("refine: the dataset has " + std::to_string(ds.blocks.size()) +
                " blocks; only single-block datasets can be refined");
  }
  if (o.split == StructuredCellShape::Hexahedra) throw Error("refine: --split must be five or six");
  Input in;
  const Block& b = ds.blocks[0];
  const bool structured = !std::holds_alternative<UnstructuredMesh>(b.grid);
  const bool has_iblank =
      structured && std::holds_alternative<StructuredGrid>(b.grid) && std::get<StructuredGrid>(b.grid).has_iblank();
  if (structured) in.converted = to_unstructured_block(b, o.split);
  in.block = structured ? &*in.converted : &b;
  in.mesh = &std::get<UnstructuredMesh>(in.block->grid);
  for (const Field& f : in.block->fields) {
    if (has_iblank && f.name() == "IBLANK" && f.association() == Association::Vertex) continue;
    in.fields.push_back(&f);
  }
  return in;
}

}  // namespace

RefinePlan plan_refinement(const Dataset& ds, const RefineOptions& options) {
  const Input in = prepare(ds, options);
  return Refiner(*in.mesh, options.levels).plan();
}

RefineStats refine_to_vtu(const Dataset& ds, const RefineOptions& options, const std::string& out_path) {
  const auto start = std::chrono::steady_clock::now();
  const Input in = prepare(ds, options);
  const Refiner r(*in.mesh, options.levels);
  RefineStats stats;
  stats.plan = r.plan();
  const RefinePlan& p = stats.plan;

  const ScalarType index_type = vtu_connectivity_type(p.points);
  std::vector<VtuArraySpec> specs = {vtu_points_spec(p.points), vtu_connectivity_spec(p.connectivity, index_type),
                                     vtu_offsets_spec(p.cells), vtu_types_spec(p.cells)};
  for (Association a : {Association::Vertex, Association::Cell}) {
    for (const Field* f : in.fields) {
      if (f->association() != a) continue;
      const bool vertex = a == Association::Vertex;
      specs.push_back({f->name(), f->data().type(), f->components(), vertex ? p.points : p.cells,
                       vertex ? VtuSection::PointData : VtuSection::CellData});
    }
  }
  uint64_t total_bytes = 0;
  for (const VtuArraySpec& s : specs) total_bytes += s.byte_size();

  VtuStreamWriter writer(out_path, p.points, p.cells, specs, {options.codec, options.codec_level});
  Progress progress("refine to " + std::to_string(p.cells) + " cells", total_bytes);
  const Refiner::Sink sink = [&](std::span<const std::byte> bytes) {
    writer.write_bytes(bytes);
    progress.add(bytes.size());
  };
  r.write_points(sink);
  if (index_type == ScalarType::Int32)
    r.write_connectivity<int32_t>(sink);
  else
    r.write_connectivity<int64_t>(sink);
  r.write_offsets(sink);
  r.write_types(sink);
  for (const Field* f : in.fields) {
    if (f->association() == Association::Vertex) r.write_vertex_field(f->data(), sink);
  }
  for (const Field* f : in.fields) {
    if (f->association() == Association::Cell) r.write_cell_field(f->data(), sink);
  }
  stats.bytes = writer.commit();
  progress.finish();
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

}  // namespace ugvr
