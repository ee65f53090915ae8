#include "ugvr/grid/polyhedra.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {

// Six times the signed volume of tetrahedron (a, b, c, d): positive when d lies on the side of triangle a, b, c that
// its right-hand normal points to, which is VTK's orientation of a tetrahedron and of a pyramid's base and apex.
double tet_volume6(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
  const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
  const double wx = double(d.x) - a.x, wy = double(d.y) - a.y, wz = double(d.z) - a.z;
  return ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx);
}

struct Edge {
  uint32_t a, b;
};

}  // namespace

PolyhedronDecomposer::PolyhedronDecomposer(UnstructuredMesh& mesh, std::string source)
    : mesh_(mesh), first_cell_(mesh.cell_count()) {
  map_.source_ = std::move(source);
  map_.original_points_ = mesh.point_count();
}

void PolyhedronDecomposer::note_output_cell() {
  if (!map_.source_cell_.empty()) map_.source_cell_.push_back(map_.input_cells_);
}

void PolyhedronDecomposer::add_native(CellType type, std::span<const uint32_t> vertices) {
  mesh_.add_cell(type, vertices);
  note_output_cell();
  ++map_.input_cells_;
}

uint32_t PolyhedronDecomposer::add_centre_point(std::span<const uint32_t> sources) {
  double x = 0, y = 0, z = 0;
  for (uint32_t v : sources) {
    x += mesh_.points[v].x;
    y += mesh_.points[v].y;
    z += mesh_.points[v].z;
  }
  const double n = double(sources.size());
  if (mesh_.points.size() >= uint64_t(UINT32_MAX))
    fail_in(map_.source_, "too many points after adding polyhedron centres (the limit is 2^32-1)");
  mesh_.points.push_back(Vec3f{float(x / n), float(y / n), float(z / n)});
  map_.new_point_sources_.insert(map_.new_point_sources_.end(), sources.begin(), sources.end());
  map_.new_point_offsets_.push_back(map_.new_point_sources_.size());
  return uint32_t(mesh_.points.size() - 1);
}

// Appends a tetrahedron or pyramid whose apex (last vertex) is a centre point, flipping its base if it came out
// inverted: face loops may run either way round.
void PolyhedronDecomposer::add_piece(CellType type, std::span<uint32_t> v) {
  const auto& p = mesh_.points;
  if (type == CellType::Tetra) {
    if (tet_volume6(p[v[0]], p[v[1]], p[v[2]], p[v[3]]) < 0) std::swap(v[1], v[2]);
  } else {  // pyramid: base v0..v3, apex v4; the base's two triangles' volumes with the apex
    const double vol =
        tet_volume6(p[v[0]], p[v[1]], p[v[2]], p[v[4]]) + tet_volume6(p[v[0]], p[v[2]], p[v[3]], p[v[4]]);
    if (vol < 0) std::swap(v[1], v[3]);
  }
  if (map_.source_cell_.empty()) {
    // The first split: from here on the map from output to input cells is no longer the identity.
    map_.source_cell_.resize(mesh_.cell_count() - first_cell_);
    for (uint64_t o = 0; o < map_.source_cell_.size(); ++o) map_.source_cell_[o] = o;
  }
  mesh_.add_cell(type, v);
  map_.source_cell_.push_back(map_.input_cells_);
}

// Recognises the four native shapes from their faces and adds the native cell in VTK's vertex order, or returns
// false. The order is found from the faces' edges; its orientation from the signed volume.
bool PolyhedronDecomposer::try_native_shape(std::span<const uint32_t> face_sizes,
                                            std::span<const uint32_t> face_vertices) {
  const size_t faces = face_sizes.size();
  int tris = 0, quads = 0;
  for (uint32_t s : face_sizes) {
    if (s == 3)
      ++tris;
    else if (s == 4)
      ++quads;
    else
      return false;
  }
  CellType type;
  if (faces == 4 && tris == 4)
    type = CellType::Tetra;
  else if (faces == 5 && tris == 4 && quads == 1)
    type = CellType::Pyramid;
  else if (faces == 5 && tris == 2 && quads == 3)
    type = CellType::Wedge;
  else if (faces == 6 && quads == 6)
    type = CellType::Hexahedron;
  else
    return false;

  std::array<uint32_t, 8> unique{};
  size_t unique_count = 0;
  for (uint32_t v : face_vertices) {
    if (std::find(unique.begin(), unique.begin() + unique_count, v) != unique.begin() + unique_count) continue;
    if (unique_count == cell_vertex_count(type)) return false;
    unique[unique_count++] = v;
  }
  if (unique_count != cell_vertex_count(type)) return false;

  // Edges, each counted once per face using it: a closed cell of this shape uses each exactly twice.
  std::array<Edge, 24> edges{};
  std::array<int, 24> uses{};
  size_t edge_count = 0;
  size_t at = 0;
  for (uint32_t s : face_sizes) {
    for (uint32_t i = 0; i < s; ++i) {
      uint32_t a = face_vertices[at + i], b = face_vertices[at + (i + 1) % s];
      if (a == b) return false;
      if (a > b) std::swap(a, b);
      size_t e = 0;
      while (e < edge_count && !(edges[e].a == a && edges[e].b == b)) ++e;
      if (e == edge_count) {
        if (edge_count == edges.size()) return false;
        edges[edge_count++] = {a, b};
      }
      ++uses[e];
    }
    at += s;
  }
  for (size_t e = 0; e < edge_count; ++e)
    if (uses[e] != 2) return false;
  auto connected = [&](uint32_t a, uint32_t b) {
    if (a > b) std::swap(a, b);
    for (size_t e = 0; e < edge_count; ++e)
      if (edges[e].a == a && edges[e].b == b) return true;
    return false;
  };
  // The face of `size` vertices to use as the base, and for prisms/hexahedra each base vertex's partner on the
  // opposite face: its one neighbour off the base.
  auto first_face_of_size = [&](uint32_t size) -> std::span<const uint32_t> {
    size_t o = 0;
    for (uint32_t s : face_sizes) {
      if (s == size) return face_vertices.subspan(o, s);
      o += s;
    }
    return {};
  };
  std::array<uint32_t, 8> v{};
  const uint32_t base_size = type == CellType::Tetra || type == CellType::Wedge ? 3 : 4;
  const auto base = first_face_of_size(base_size);
  std::copy(base.begin(), base.end(), v.begin());
  const auto on_base = [&](uint32_t x) { return std::find(base.begin(), base.end(), x) != base.end(); };
  if (type == CellType::Tetra || type == CellType::Pyramid) {
    for (size_t i = 0; i < unique_count; ++i)
      if (!on_base(unique[i])) v[base_size] = unique[i];
  } else {
    for (uint32_t i = 0; i < base_size; ++i) {
      int found = 0;
      for (size_t k = 0; k < unique_count; ++k)
        if (!on_base(unique[k]) && connected(base[i], unique[k])) {
          v[base_size + i] = unique[k];
          ++found;
        }
      if (found != 1) return false;
    }
  }
  const uint8_t n = cell_vertex_count(type);
  mesh_.add_cell(type, std::span<const uint32_t>(v.data(), n));
  if (cell_volume(mesh_, mesh_.cell_count() - 1) < 0) {
    // Reverse the base (and the top with it): the same cell in VTK's orientation.
    uint32_t* c = mesh_.connectivity.data() + mesh_.cell_offsets[mesh_.cell_count() - 1];
    if (type == CellType::Tetra || type == CellType::Wedge) {
      std::swap(c[1], c[2]);
      if (type == CellType::Wedge) std::swap(c[4], c[5]);
    } else {
      std::swap(c[1], c[3]);
      if (type == CellType::Hexahedron) std::swap(c[5], c[7]);
    }
  }
  note_output_cell();
  return true;
}

void PolyhedronDecomposer::add_polyhedron(std::span<const uint32_t> face_sizes,
                                          std::span<const uint32_t> face_vertices) {
  const uint64_t cell = map_.input_cells_;
  if (face_sizes.size() < 4)
    fail_in(map_.source_, std::string("polyhedron ") + std::to_string(cell) + " has " +
                              std::to_string(face_sizes.size()) + " faces (a closed cell needs at least 4)");
  uint64_t total = 0;
  for (uint32_t s : face_sizes) {
    if (s < 3)
      fail_in(map_.source_, std::string("polyhedron ") + std::to_string(cell) + " has a face of " + std::to_string(s) +
                                " vertices (at least 3)");
    total += s;
  }
  if (total != face_vertices.size())
    fail_in(map_.source_, std::string("polyhedron ") + std::to_string(cell) + " lists " +
                              std::to_string(face_vertices.size()) + " face vertices, its face sizes add up to " +
                              std::to_string(total));
  for (uint32_t v : face_vertices)
    if (v >= map_.original_points_)
      fail_in(map_.source_, std::string("polyhedron ") + std::to_string(cell) + " uses vertex " + std::to_string(v) +
                                " of " + std::to_string(map_.original_points_));
  ++polyhedra_;
  if (try_native_shape(face_sizes, face_vertices)) {
    ++recognised_;
    ++map_.input_cells_;
    return;
  }

  std::vector<uint32_t> unique(face_vertices.begin(), face_vertices.end());
  std::sort(unique.begin(), unique.end());
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  const uint32_t centre = add_centre_point(unique);
  size_t at = 0;
  std::string key;
  for (uint32_t s : face_sizes) {
    const auto face = face_vertices.subspan(at, s);
    at += s;
    if (s == 3) {
      std::array<uint32_t, 4> t{face[0], face[1], face[2], centre};
      add_piece(CellType::Tetra, t);
    } else if (s == 4) {
      std::array<uint32_t, 5> p{face[0], face[1], face[2], face[3], centre};
      add_piece(CellType::Pyramid, p);
    } else {
      std::vector<uint32_t> sorted(face.begin(), face.end());
      std::sort(sorted.begin(), sorted.end());
      key.assign(reinterpret_cast<const char*>(sorted.data()), sorted.size() * sizeof(uint32_t));
      uint32_t face_centre;
      if (auto it = face_centres_.find(key); it != face_centres_.end()) {
        face_centre = it->second;
        face_centres_.erase(it);  // a face joins at most two cells: this was the second
      } else {
        face_centre = add_centre_point(sorted);
        face_centres_.emplace(key, face_centre);
      }
      for (uint32_t i = 0; i < s; ++i) {
        std::array<uint32_t, 4> t{face[i], face[(i + 1) % s], face_centre, centre};
        add_piece(CellType::Tetra, t);
      }
    }
  }
  ++map_.input_cells_;
}

Field CellExpansion::expand_point_field(const Field& f) const {
  if (f.association() != Association::Vertex || f.tuples() != original_points_)
    fail_in(source_, std::string("field '") + f.name() + "' has " + std::to_string(f.tuples()) + " tuples, the mesh " +
                         std::to_string(original_points_) + " points before decomposition");
  const uint64_t added = new_point_offsets_.size() - 1;
  if (added == 0) return f;
  const int nc = f.components();
  DataArray out(f.data().type(), nc, original_points_ + added);
  f.data().visit([&](auto in) {
    using T = typename decltype(in)::value_type;
    auto dst = out.values<std::remove_const_t<T>>();
    std::copy(in.begin(), in.end(), dst.begin());
    for (uint64_t k = 0; k < added; ++k) {
      const uint64_t b = new_point_offsets_[k], e = new_point_offsets_[k + 1];
      for (int c = 0; c < nc; ++c) {
        double sum = 0;
        for (uint64_t s = b; s < e; ++s) sum += double(in[uint64_t(new_point_sources_[s]) * nc + c]);
        double mean = sum / double(e - b);
        if constexpr (std::is_integral_v<std::remove_const_t<T>>) mean = std::round(mean);
        dst[(original_points_ + k) * nc + c] = static_cast<std::remove_const_t<T>>(mean);
      }
    }
  });
  return Field(f.name(), Association::Vertex, std::move(out));
}

Field CellExpansion::expand_cell_field(const Field& f) const {
  if (f.association() != Association::Cell || f.tuples() != input_cells_)
    fail_in(source_, std::string("field '") + f.name() + "' has " + std::to_string(f.tuples()) + " tuples, the mesh " +
                         std::to_string(input_cells_) + " cells before decomposition");
  if (source_cell_.empty()) return f;  // the identity
  return Field(f.name(), Association::Cell, f.data().gather(source_cell_));
}

Field PolyhedronDecomposer::expand_point_field(const Field& f) const { return map_.expand_point_field(f); }

Field PolyhedronDecomposer::expand_cell_field(const Field& f) const { return map_.expand_cell_field(f); }

std::string PolyhedronDecomposer::summary() const {
  if (polyhedra_ == 0) return "";
  std::string s = std::to_string(polyhedra_) + " polyhedra: " + std::to_string(recognised_) +
                  " with a native shape (tetra, pyramid, wedge, hexahedron)";
  if (decomposed() > 0)
    s += ", " + std::to_string(decomposed()) + " decomposed around their centres into " +
         std::to_string(output_cells() - (map_.input_cells_ - decomposed())) + " tetrahedra and pyramids (" +
         std::to_string(added_points()) +
         " centre points added; cell data repeated on each piece, point data averaged at the centres)";
  return s;
}

}  // namespace ugvr
