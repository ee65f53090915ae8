// Polyhedral cells (OpenFOAM cells, EnSight nfaced, CGNS NFACE_n, VTK_POLYHEDRON) brought into the mesh model, whose
// cells are tetrahedra, pyramids, wedges and hexahedra.
//
// Decision: a polyhedron is *decomposed*, not walked natively. A polyhedron whose faces form one of the four native
// shapes (OpenFOAM's blockMesh hexahedra, prisms from extrusion, ...) becomes that cell, in VTK's vertex order, so its
// interpolant is the native cell's. Any other polyhedron is split around a new point at its centre (the mean of its
// vertices): a tetrahedron per triangular face, a pyramid per quadrilateral face, and for a face of five or more
// vertices a tetrahedron per edge around a new point at the face's centre (shared by the two cells on that face, so
// the decomposition stays conforming and the exact engine walks across it). This is ParaView's "decompose polyhedra"
// with the face-centre variant for polygons. Why not natively: the walk, the octree builder's cell tests and the
// GPU engine all assume a cell of at most 8 vertices and 6 faces with a defined interpolant; a polyhedron has no
// standard interpolant (mean value coordinates are one choice of many), and non-planar faces would need a split rule
// anyway. The centre values are means of the vertices' values (point data) and cell data is repeated on each piece,
// so cell-centred fields (OpenFOAM's) stay exactly per original cell.
//
// Use: create one decomposer per mesh, add every cell in file order (native cells with add_native, polyhedra with
// add_polyhedron), then expand each field with expand_point_field / expand_cell_field. Input cell i may become
// several output cells; source_cell(o) names the input cell of output cell o.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "ugvr/grid/field.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

// What a decomposer did to its input cells and points, kept apart from the mesh: later fields on the same mesh (a time
// series' steps read without their mesh) are expanded from it exactly as the decomposer expands its own.
class CellExpansion {
 public:
  Field expand_point_field(const Field& f) const;  // as PolyhedronDecomposer::expand_point_field
  Field expand_cell_field(const Field& f) const;   // as PolyhedronDecomposer::expand_cell_field
  uint64_t input_cells() const { return input_cells_; }
  uint64_t original_points() const { return original_points_; }

 private:
  friend class PolyhedronDecomposer;
  std::string source_;  // names the file in error messages
  uint64_t input_cells_ = 0;
  uint64_t original_points_ = 0;
  std::vector<uint64_t> source_cell_;  // input cell of each output cell; empty while the map is the identity
  // Added points: point original_points_ + k is the mean of new_point_sources_[new_point_offsets_[k] .. k+1).
  std::vector<uint64_t> new_point_offsets_{0};
  std::vector<uint32_t> new_point_sources_;
};

class PolyhedronDecomposer {
 public:
  // `mesh` must hold its points already; cells are appended, and centre points appended after the original points.
  // `source` names the file in error messages.
  PolyhedronDecomposer(UnstructuredMesh& mesh, std::string source);

  void add_native(CellType type, std::span<const uint32_t> vertices);
  // A closed polyhedron: face f has face_sizes[f] vertices, listed in order around the face in face_vertices
  // (concatenated). Face orientation does not matter. Throws ugvr::Error naming the source and the input cell for a
  // face of fewer than 3 vertices, fewer than 4 faces or a vertex index out of range.
  void add_polyhedron(std::span<const uint32_t> face_sizes, std::span<const uint32_t> face_vertices);

  uint64_t input_cells() const { return map_.input_cells_; }
  uint64_t output_cells() const { return mesh_.cell_count() - first_cell_; }
  uint64_t polyhedra() const { return polyhedra_; }    // cells given as polyhedra
  uint64_t recognised() const { return recognised_; }  // ... of which had a native shape
  uint64_t decomposed() const { return polyhedra_ - recognised_; }
  uint64_t added_points() const { return map_.new_point_offsets_.size() - 1; }
  uint64_t original_points() const { return map_.original_points_; }
  // Input cell of output cell `o` (counted from the first cell this decomposer added).
  uint64_t source_cell(uint64_t o) const { return identity() ? o : map_.source_cell_[o]; }
  // True while every input cell is one output cell (nothing decomposed): fields need no expansion.
  bool identity() const { return map_.source_cell_.empty(); }
  // The expansion of fields so far, for fields read after the decomposer is gone (copy it once all cells are in).
  const CellExpansion& expansion() const { return map_; }

  // A field on the original points, extended to the added centre points (means of their source vertices, computed in
  // double and stored in the field's type).
  Field expand_point_field(const Field& f) const;
  // A field on the input cells, repeated on every piece of each decomposed cell.
  Field expand_cell_field(const Field& f) const;
  // A line for Dataset::warnings ("" when no cell was decomposed).
  std::string summary() const;

 private:
  uint32_t add_centre_point(std::span<const uint32_t> sources);
  void add_piece(CellType type, std::span<uint32_t> vertices);
  bool try_native_shape(std::span<const uint32_t> face_sizes, std::span<const uint32_t> face_vertices);
  void note_output_cell();

  UnstructuredMesh& mesh_;
  uint64_t first_cell_ = 0;
  uint64_t polyhedra_ = 0;
  uint64_t recognised_ = 0;
  CellExpansion map_;  // the source name, input cell and point counts, the output-to-input maps
  // Face centres already added, by the face's sorted vertex list (so the two cells on a face share its centre).
  std::unordered_map<std::string, uint32_t> face_centres_;
};

}  // namespace ugvr
