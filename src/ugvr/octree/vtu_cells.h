// A .vtu file read for the out-of-core builder: its cells are streamed, never held, and written out as self-contained
// soup records (octree/soup.h) with their vertices' positions and values.
//
// Points are referenced at random by the cells, so the points and the selected vertex scalars (12 + 4 bytes per point
// and scalar: a sixth of a tetrahedral mesh's size, which has about 6 cells per point) are held in memory while the
// records are written, as much of them as the given budget allows: when they do not all fit, the cells are streamed
// once per slice of the points, each pass writing the corners whose vertex is in its slice to a corner file (in cell
// order), and once more to assemble the records from those files, read in step. Memory is then bounded by the budget
// whatever the size of the file, for one more pass over the cells per slice.
//
// Scope: one <Piece> of an UnstructuredGrid, any encoding the reader takes (ascii, base64, appended raw or base64,
// zlib or lz4 compressed: vtk_xml_array.h). Cells follow the reader's policy (vtk_cell_import.h): linear volume cells
// kept, quadratic ones linearised to their corners, voxels reordered, lower-dimensional cells dropped, anything else
// refused naming the file and the cell.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/core/vec.h"
#include "ugvr/octree/soup.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

class VtuCellSource {
 public:
  // Where a selected scalar sits in the soup's records: the index among the vertex or among the cell scalars.
  struct Slot {
    Association association = Association::Vertex;
    uint32_t index = 0;
  };

  // Parses the markup and streams the points and the vertex scalars once, for the bounds and the ranges.
  // `selectors` as FieldSet::scalar takes them; empty: the first vertex field that is not constant, else the first
  // field. Throws ugvr::Error naming the file.
  VtuCellSource(std::string path, std::span<const std::string> selectors);
  ~VtuCellSource();
  VtuCellSource(const VtuCellSource&) = delete;
  VtuCellSource& operator=(const VtuCellSource&) = delete;

  uint64_t point_count() const { return points_; }
  uint64_t file_cell_count() const { return cells_; }
  const Bounds& bounds() const { return bounds_; }
  const SoupLayout& layout() const { return layout_; }
  const std::vector<Slot>& slots() const { return slots_; }
  // The selected scalars; a cell scalar's range is known once write_soup has run.
  const std::vector<BrickStoreField>& fields() const { return fields_; }

  // A volume cell as the stream assembles its record, before it is written: its index in the file (the record's id),
  // type, corners' point ids, positions, vertex values (Fv x n, field-major) and cell values (Fc; null when Fc = 0).
  struct StreamedCell {
    uint64_t id = 0;
    CellType type{};
    int n = 0;
    const uint32_t* vertices = nullptr;
    const Vec3f* positions = nullptr;
    const float* vertex_values = nullptr;
    const float* cell_values = nullptr;
  };
  // Which cells a soup takes (a partitioned build's piece: mpi/piece_build_ooc.h); called in file order.
  using CellFilter = std::function<bool(const StreamedCell&)>;

  // Streams every volume cell into `soup` and returns their count, holding at most `point_budget` bytes of points and
  // vertex scalars (at least one point); corner files go to `temp_dir`. Fails on NaN or infinite selected values.
  // With `keep`, only the cells it accepts are written (and counted in the result); every cell is still checked, and
  // the cell scalars' ranges and geometry_hash are the whole file's, whatever `keep` takes.
  uint64_t write_soup(SoupWriter& soup, uint64_t point_budget, const std::string& temp_dir,
                      Progress* progress = nullptr, const CellFilter& keep = {});
  // The volume cells whose index among them (the in-core mesh's numbering) is a multiple of `stride`: f(index, type,
  // corner positions) for each, in order, after one pass over the cells without their points (for the corner ids,
  // the cell scalars' ranges and the checks, as write_soup makes them) and one over the points in slices of at most
  // `point_budget` bytes. Holds the sampled cells' corners only. Returns the volume cells' count.
  uint64_t for_each_sampled_cell(uint64_t stride, uint64_t point_budget, Progress* progress,
                                 const std::function<void(uint64_t, CellType, std::span<const Vec3f>)>& f);
  // A later time step's values for the first step's records (octree/step_values.h: the files "<prefix>v<k>" and
  // "<prefix>c<k>"), in place of a soup: each vertex scalar streamed to its file, then the cells once, for their
  // scalars and for geometry_hash and the cell scalars' ranges (as write_soup finds them). Holds a chunk of values, not
  // the points. Returns the volume cells' count; fails on NaN or infinite selected values.
  uint64_t write_values(const std::string& prefix, Progress* progress = nullptr);
  // Streams the points and the selected vertex scalars in slices of at most `slice_bytes` (at least one point):
  // f(first point index, positions, values) with the slice's values scalar-major (vertex scalars in slot order).
  void for_each_point_slice(
      uint64_t slice_bytes,
      const std::function<void(uint64_t, std::span<const Vec3f>, std::span<const float>)>& f) const;
  // Slices of the points the last write_soup took (1: all points at once; write_values: 1).
  uint64_t passes() const { return passes_; }
  // The geometry as the build sees it, hashed while it is streamed (no step held in memory): the points (as float,
  // from the constructor's pass) and, once write_soup has run, every volume cell's type and corner ids in file order.
  // Two files with equal hashes give the same soup but for its values: what a store with time shares over its steps.
  uint64_t geometry_hash() const { return points_hash_ ^ (cells_hash_ * 0x9e3779b97f4a7c15ull); }

  struct Markup;  // the parsed file (pugixml), private to the implementation

 private:
  std::string path_;
  std::unique_ptr<Markup> markup_;
  uint64_t cells_ = 0;
  uint64_t points_ = 0, passes_ = 0;
  uint64_t points_hash_ = 0, cells_hash_ = 0;  // see geometry_hash
  Bounds bounds_;
  SoupLayout layout_;
  std::vector<Slot> slots_;
  std::vector<BrickStoreField> fields_;
};

}  // namespace ugvr
