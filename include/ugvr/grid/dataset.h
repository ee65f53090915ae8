// Dataset: what a reader returns. One or more Blocks (PLOT3D multi-block files have several; everything else has
// one), each a grid plus the fields defined on it, and the notes a reader made on the way (dropped cells, ...).
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "ugvr/grid/field.h"
#include "ugvr/grid/structured_grid.h"
#include "ugvr/grid/unstructured_mesh.h"

namespace ugvr {

using Grid = std::variant<UnstructuredMesh, StructuredGrid, ImageGrid, RectilinearGrid>;

std::string_view grid_kind_name(const Grid& g);  // "unstructured", "curvilinear", "uniform", "rectilinear"
uint64_t grid_point_count(const Grid& g);
uint64_t grid_cell_count(const Grid& g);
Bounds grid_bounds(const Grid& g);
uint64_t grid_memory_bytes(const Grid& g);

struct Block {
  std::string name;
  Grid grid;
  FieldSet fields;

  // Checks that every field has one tuple per vertex or per cell; throws ugvr::Error naming `source` and the field.
  void validate_fields(std::string_view source) const;
  uint64_t memory_bytes() const;
};

struct Dataset {
  std::string format;                // e.g. "VTK XML UnstructuredGrid (.vtu)"
  std::vector<std::string> sources;  // the files it was read from
  std::vector<Block> blocks;
  std::vector<std::string> warnings;  // what the reader dropped or changed, for the user

  uint64_t point_count() const;
  uint64_t cell_count() const;
  Bounds bounds() const;
  uint64_t memory_bytes() const;
};

}  // namespace ugvr
