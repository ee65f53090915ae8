#include "ugvr/grid/dataset.h"

#include "ugvr/core/error.h"

namespace ugvr {

namespace {
template <class... Ts>
struct Overload : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overload(Ts...) -> Overload<Ts...>;
}  // namespace

std::string_view grid_kind_name(const Grid& g) {
  return std::visit(Overload{[](const UnstructuredMesh&) { return std::string_view("unstructured"); },
                             [](const StructuredGrid&) { return std::string_view("curvilinear"); },
                             [](const ImageGrid&) { return std::string_view("uniform"); },
                             [](const RectilinearGrid&) { return std::string_view("rectilinear"); }},
                    g);
}

uint64_t grid_point_count(const Grid& g) {
  return std::visit(Overload{[](const UnstructuredMesh& m) { return m.point_count(); },
                             [](const auto& s) { return s.dims.point_count(); }},
                    g);
}

uint64_t grid_cell_count(const Grid& g) {
  return std::visit(Overload{[](const UnstructuredMesh& m) { return m.cell_count(); },
                             [](const auto& s) { return s.dims.cell_count(); }},
                    g);
}

Bounds grid_bounds(const Grid& g) {
  return std::visit([](const auto& x) { return x.bounds(); }, g);
}

uint64_t grid_memory_bytes(const Grid& g) {
  return std::visit(
      Overload{[](const UnstructuredMesh& m) { return m.memory_bytes(); },
               [](const StructuredGrid& s) { return s.memory_bytes(); },
               [](const ImageGrid&) { return uint64_t(sizeof(ImageGrid)); },
               [](const RectilinearGrid& r) {
                 return uint64_t((r.coords[0].size() + r.coords[1].size() + r.coords[2].size()) * sizeof(double));
               }},
      g);
}

void Block::validate_fields(std::string_view source) const {
  const uint64_t np = grid_point_count(grid), nc = grid_cell_count(grid);
  for (const Field& f : fields) {
    const uint64_t want = f.association() == Association::Vertex ? np : nc;
    if (f.tuples() != want) {
      fail_in(source, std::string(association_name(f.association())) + " field '" + f.name() + "' has " +
                          std::to_string(f.tuples()) + " tuples, expected " + std::to_string(want));
    }
  }
}

uint64_t Block::memory_bytes() const {
  uint64_t b = grid_memory_bytes(grid);
  for (const Field& f : fields) b += f.data().byte_size();
  return b;
}

uint64_t Dataset::point_count() const {
  uint64_t n = 0;
  for (const Block& b : blocks) n += grid_point_count(b.grid);
  return n;
}

uint64_t Dataset::cell_count() const {
  uint64_t n = 0;
  for (const Block& b : blocks) n += grid_cell_count(b.grid);
  return n;
}

Bounds Dataset::bounds() const {
  Bounds bb;
  for (const Block& b : blocks) bb.add(grid_bounds(b.grid));
  return bb;
}

uint64_t Dataset::memory_bytes() const {
  uint64_t n = 0;
  for (const Block& b : blocks) n += b.memory_bytes();
  return n;
}

}  // namespace ugvr
