// A .vtu file read for the out-of-core builder: its cells are streamed, never held. The points and the selected vertex
// scalars are read whole (12 + 4 bytes per point and scalar: a sixth of a tetrahedral mesh's size, since a
// tetrahedral mesh has about 6 cells per point), the cells and the selected cell scalars chunk by chunk, each cell
// written out as a self-contained soup record (octree_soup.h) with its vertices' positions and values.
//
// Scope: one <Piece> of an UnstructuredGrid, any encoding the reader takes (ascii, base64, appended raw or base64,
// zlib or lz4 compressed: vtk_xml_array.h). Cells follow the reader's policy (vtk_cell_import.h): linear volume cells
// kept, quadratic ones linearised to their corners, voxels reordered, lower-dimensional cells dropped, anything else
// refused naming the file and the cell.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/core/vec.h"
#include "ugvr/lod/brick_store.h"
#include "ugvr/lod/octree_soup.h"

namespace ugvr {

class VtuCellSource {
 public:
  // Where a selected scalar sits in the soup's records: the index among the vertex or among the cell scalars.
  struct Slot {
    Association association = Association::Vertex;
    uint32_t index = 0;
  };

  // Parses the markup and reads the points and the vertex scalars. `selectors` as FieldSet::scalar takes them; empty:
  // the first vertex field that is not constant, else the first field. Throws ugvr::Error naming the file.
  VtuCellSource(std::string path, std::span<const std::string> selectors);
  ~VtuCellSource();
  VtuCellSource(const VtuCellSource&) = delete;
  VtuCellSource& operator=(const VtuCellSource&) = delete;

  uint64_t point_count() const { return points_.size(); }
  uint64_t file_cell_count() const { return cells_; }
  const Bounds& bounds() const { return bounds_; }
  const SoupLayout& layout() const { return layout_; }
  const std::vector<Slot>& slots() const { return slots_; }
  // The selected scalars; a cell scalar's range is known once write_soup has run.
  const std::vector<BrickStoreField>& fields() const { return fields_; }

  // Streams every volume cell into `soup`; returns the count. Fails on NaN or infinite selected values.
  uint64_t write_soup(SoupWriter& soup, Progress* progress = nullptr);
  // Frees the points and the vertex scalars.
  void release();

  struct Markup;  // the parsed file (pugixml), private to the implementation

 private:
  std::string path_;
  std::unique_ptr<Markup> markup_;
  uint64_t cells_ = 0;
  std::vector<Vec3f> points_;
  std::vector<std::vector<float>> vertex_values_;  // per vertex scalar
  Bounds bounds_;
  SoupLayout layout_;
  std::vector<Slot> slots_;
  std::vector<BrickStoreField> fields_;
};

}  // namespace ugvr
