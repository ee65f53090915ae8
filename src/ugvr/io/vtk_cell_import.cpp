#include "ugvr/io/vtk_cell_import.h"

#include <numeric>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_type.h"

namespace ugvr {

VtkCellImporter::VtkCellImporter(std::string source, uint64_t point_count)
    : source_(std::move(source)), point_count_(point_count) {}

void VtkCellImporter::reserve(uint64_t cells, uint64_t indices) { cells_.reserve(cells, indices); }

void VtkCellImporter::fail_cell(uint64_t file_cell, const std::string& message) const {
  fail_in(source_, "cell " + std::to_string(file_cell) + ": " + message);
}

void VtkCellImporter::note_kept(uint64_t file_cell) {
  if (dropped_ > 0) kept_.push_back(file_cell);
}

bool VtkCellImporter::keeps(const VtkCellMapping& m, int vtk_type, uint64_t file_cell) {
  switch (m.kind) {
    case VtkCellMapping::Kind::Unsupported:
      fail_cell(file_cell, std::string(m.vtk_name) + " (type " + std::to_string(vtk_type) +
                               ") is not supported: ugvr renders tetrahedra, pyramids, wedges and hexahedra "
                               "(quadratic ones linearised); convert polyhedra and higher-order cells first");
    case VtkCellMapping::Kind::DropLowerDimension:
      if (dropped_ == 0) {
        // From now on kept cells are listed explicitly; the cells before this one were all kept.
        kept_.resize(file_cell);
        std::iota(kept_.begin(), kept_.end(), uint64_t(0));
      }
      ++dropped_;
      ++dropped_by_type_[size_t(vtk_type) & 127];
      return false;
    case VtkCellMapping::Kind::Keep: break;
  }
  return true;
}

void VtkCellImporter::add_type_only(int vtk_type, uint64_t file_cell) {
  ++file_cells_;
  if (keeps(map_vtk_cell_type(vtk_type), vtk_type, file_cell)) note_kept(file_cell);
}

template <class Id>
void VtkCellImporter::add(int vtk_type, std::span<const Id> ids, uint64_t file_cell) {
  ++file_cells_;
  const VtkCellMapping m = map_vtk_cell_type(vtk_type);
  const std::span<const Id> stored = ids;  // every id the file lists, before extra points are cut off
  if (m.kind != VtkCellMapping::Kind::Unsupported && m.expected_points >= 0 && ids.size() > size_t(m.expected_points)) {
    if (extra_point_cells_++ == 0) {
      extra_point_example_ = "cell " + std::to_string(file_cell) + ", " + std::string(m.vtk_name) + " with " +
                             std::to_string(ids.size()) + " points";
    }
    ids = ids.first(size_t(m.expected_points));
  }
  if (m.expected_points >= 0 && ids.size() != size_t(m.expected_points)) {
    fail_cell(file_cell, std::string(m.vtk_name) + " (type " + std::to_string(vtk_type) + ") needs " +
                             std::to_string(m.expected_points) + " points, the file lists " +
                             std::to_string(ids.size()));
  }
  // Every stored id must name a point, also those that are not used: the mid-edge ids of a linearised quadratic
  // cell, the extra ids cut off above, the ids of a dropped lower-dimensional cell. An id out of range there means
  // the connectivity is corrupt (or misaligned with the offsets), so the corners read beside it cannot be trusted.
  if (m.kind != VtkCellMapping::Kind::Unsupported) {
    for (size_t i = 0; i < stored.size(); ++i) {
      const Id id = stored[i];
      if (id < 0 || uint64_t(id) >= point_count_) {
        fail_cell(file_cell, "point id " + std::to_string(int64_t(id)) + " is outside [0, " +
                                 std::to_string(point_count_) + ") (slot " + std::to_string(i) + " of its " +
                                 std::string(m.vtk_name) + ")");
      }
    }
  }
  if (!keeps(m, vtk_type, file_cell)) return;
  std::array<uint32_t, 8> v{};
  for (size_t i = 0; i < m.corner_count; ++i) v[i] = uint32_t(ids[i]);  // range-checked above
  if (m.voxel_order) {
    std::swap(v[2], v[3]);
    std::swap(v[6], v[7]);
  }
  cells_.add_cell(m.type, std::span<const uint32_t>(v.data(), m.corner_count));
  note_kept(file_cell);
}

template void VtkCellImporter::add<int32_t>(int, std::span<const int32_t>, uint64_t);
template void VtkCellImporter::add<int64_t>(int, std::span<const int64_t>, uint64_t);
template void VtkCellImporter::add<uint32_t>(int, std::span<const uint32_t>, uint64_t);
template void VtkCellImporter::add<uint64_t>(int, std::span<const uint64_t>, uint64_t);

void VtkCellImporter::finish(UnstructuredMesh& mesh, std::vector<std::string>& warnings) {
  if (file_cells_ > 0 && cells_.cell_count() == 0) {
    fail_in(source_, "none of its " + std::to_string(file_cells_) +
                         " cells is a volume cell (tetra, pyramid, wedge, hexahedron); ugvr renders volumes only");
  }
  if (dropped_ > 0) {
    std::string detail;
    for (size_t t = 0; t < dropped_by_type_.size(); ++t) {
      if (dropped_by_type_[t] == 0) continue;
      detail += (detail.empty() ? "" : ", ") + std::to_string(dropped_by_type_[t]) + " " +
                std::string(map_vtk_cell_type(int(t)).vtk_name);
    }
    warnings.push_back(source_ + ": ignored " + std::to_string(dropped_) + " lower-dimensional cell(s) (" + detail +
                       "); their cell data is dropped with them");
  }
  if (extra_point_cells_ > 0) {
    warnings.push_back(source_ + ": " + std::to_string(extra_point_cells_) +
                       " cell(s) list more points than their type has (first: " + extra_point_example_ +
                       "); their first (corner) points were used, as VTK's linear cells do");
  }
  mesh.cell_types = std::move(cells_.cell_types);
  mesh.cell_offsets = std::move(cells_.cell_offsets);
  mesh.connectivity = std::move(cells_.connectivity);
  cells_ = UnstructuredMesh{};
}

DataArray VtkCellImporter::filter_cell_data(DataArray data) const {
  if (data.tuples() != file_cells_) {
    fail_in(source_, "cell data has " + std::to_string(data.tuples()) + " tuples but the file has " +
                         std::to_string(file_cells_) + " cells");
  }
  if (dropped_ == 0) return data;
  return data.gather(kept_);
}

}  // namespace ugvr
