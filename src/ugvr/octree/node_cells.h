// The cells a node keeps in the store (format version 5, store_format::CellBlockRecord; the [hybrid] issue, after
// Muigg 2007: exact cells where they matter, resampled bricks elsewhere). A leaf keeps every cell overlapping it (its
// candidate list from the subdivision, octree/subdivide.h: replicated across node borders), renumbered into a small
// mesh of its own: its points, each cell's vertices as local indices, and per face what lies across — a cell of the
// same node (a local index), nothing (the mesh's boundary), or a cell the node does not keep (the ray leaves the node
// there and continues in a neighbour's cells). The store's fields come along at the points (vertex fields) or cells
// (cell fields), as the same scalars the bricks sample.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ugvr/grid/field.h"
#include "ugvr/grid/topology.h"
#include "ugvr/grid/unstructured_mesh.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// The node's cells from a mesh in memory. `cells`: ascending cell ids; `scalars`: the store's fields in order.
NodeCells gather_node_cells(const UnstructuredMesh& mesh, const MeshTopology& topology,
                            std::span<const ScalarRef> scalars, std::span<const uint64_t> cells);

// The same block from the out-of-core builder's welded leaf (octree/out_of_core.h), without the whole mesh's topology:
// `mesh` holds exactly the node's cells, in ascending order of their input ids `ids`, and `topology` is its own
// (build_topology(mesh)); `boundary_faces`: the whole mesh's boundary faces, pack_face(input cell id, local face),
// ascending (octree/soup_boundary.h). A face is "boundary" when it is one of those, else across a cell of the node when
// the node's topology matches it, else "outside". This gives gather_node_cells' block for the same cells: a face met
// exactly twice in the whole mesh is matched within the node exactly when both its cells are there, and a face met
// more than twice in the whole mesh (its topology's boundary) is in `boundary_faces` even where the node sees it twice.
NodeCells gather_welded_cells(const UnstructuredMesh& mesh, const MeshTopology& topology,
                              std::span<const ScalarRef> scalars, std::span<const uint64_t> ids,
                              std::span<const uint64_t> boundary_faces);

// Only the values of gather_node_cells' block for the same cells (NodeCells::values, its points numbered alike): a
// time store's later step (store_format::kStepsHaveCells), its fields on the first step's mesh.
std::vector<float> gather_node_values(const UnstructuredMesh& mesh, std::span<const ScalarRef> scalars,
                                      std::span<const uint64_t> cells);

struct LeafCellStats {
  uint64_t blocks = 0, cells = 0, bytes = 0;
};

// Appends every leaf's cell block (shape.leaf_cells[id] of each leaf id), leaves in parallel.
LeafCellStats write_leaf_cells(BrickStoreWriter& writer, const UnstructuredMesh& mesh, const MeshTopology& topology,
                               std::span<const ScalarRef> scalars, std::span<const OctreeNode> nodes,
                               std::span<const std::vector<uint64_t>> leaf_cells);

// A time store's later step (begun on the writer): every leaf's values of its cells, as write_leaf_cells wrote their
// blocks (the blocks counted, cells 0).
LeafCellStats write_leaf_cell_values(BrickStoreWriter& writer, const UnstructuredMesh& mesh,
                                     std::span<const ScalarRef> scalars, std::span<const OctreeNode> nodes,
                                     std::span<const std::vector<uint64_t>> leaf_cells);

}  // namespace ugvr
