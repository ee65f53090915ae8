// VtkCellImporter: the one place where cells listed the VTK way (a VTK type id and point ids per cell) become
// UnstructuredMesh cells, shared by the XML and legacy VTK readers so both apply the same policy (cell_type.h):
// linear volume cells are kept, quadratic ones linearised to their corners, VTK_VOXEL reordered to a hexahedron,
// lower-dimensional cells dropped with one summary warning, anything else refused with the file and cell index.
// When cells are dropped, cell fields read from the file must go through filter_cell_data() to stay aligned.
// A cell listing more points than its type has (writers that label 20-node hexahedra as VTK_HEXAHEDRON, such as the
// notch example) keeps its first points, which are the corners, as VTK's linear cells do; one warning counts them.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ugvr/grid/cell_type.h"
#include "ugvr/grid/data_array.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

class VtkCellImporter {
 public:
  // `source` names the file in messages; `point_count` bounds the point ids.
  VtkCellImporter(std::string source, uint64_t point_count);

  void reserve(uint64_t cells, uint64_t indices);
  // Adds the file's cell number `file_cell` (used only in messages). Throws ugvr::Error for unsupported types, a
  // wrong number of point ids, or ids outside [0, point_count) in any slot the file stores (also the mid-edge slots
  // that linearisation drops, extra points, and the ids of dropped lower-dimensional cells).
  template <class Id>
  void add(int vtk_type, std::span<const Id> ids, uint64_t file_cell);
  // Counts the file's cell number `file_cell` as kept or dropped by its type alone, for cell data read without the
  // mesh (a fields-only step read, io/step_fields.h): filter_cell_data then keeps what a full read's would. Throws for
  // unsupported types as add() does; nothing is added to the mesh (call finish() only after add()).
  void add_type_only(int vtk_type, uint64_t file_cell);

  // Hands the cells to `mesh` (whose points the caller sets) and appends a warning for dropped cells.
  // Throws if the file had cells but none of them is a volume cell.
  void finish(UnstructuredMesh& mesh, std::vector<std::string>& warnings);

  bool dropped_any() const { return dropped_ > 0; }
  uint64_t file_cell_count() const { return file_cells_; }
  // Cell data from the file (one tuple per file cell) restricted to the kept cells.
  DataArray filter_cell_data(DataArray data) const;

 private:
  [[noreturn]] void fail_cell(uint64_t file_cell, const std::string& message) const;
  void note_kept(uint64_t file_cell);
  // Whether the importer's policy keeps a cell of this type; counts a dropped one, fails for an unsupported one.
  bool keeps(const VtkCellMapping& m, int vtk_type, uint64_t file_cell);

  std::string source_;
  uint64_t point_count_;
  UnstructuredMesh cells_;
  uint64_t file_cells_ = 0;
  uint64_t dropped_ = 0;
  uint64_t extra_point_cells_ = 0;
  std::string extra_point_example_;
  std::array<uint64_t, 128> dropped_by_type_{};
  std::vector<uint64_t> kept_;  // filled only once something has been dropped
};

}  // namespace ugvr
