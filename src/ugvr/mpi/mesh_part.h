// A rank's part of a mesh read piece by piece (docs/mpi.md, "Reading only a rank's part"), the part without MPI:
// cutting an unstructured block down to the cells that meet a box, and writing a mesh as a `.pvtu` of pieces or a
// `.vtu` of several <Piece>s (the tests' and the benchmark's input; ugvr has no writer of either otherwise).
#pragma once
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/dataset.h"

namespace ugvr {

// The cells of an unstructured block whose bounding boxes (of their float32 vertices, in double) meet the closed box
// `box` (faces may be infinite): the same test as restrict_walk_mesh (render/exact/walk_mesh.h), so a part made
// here holds the cells that restricting the whole mesh's walk mesh would keep from this block. Cells keep their
// order; the points they use are compacted in order; vertex fields follow the points, cell fields the cells. Throws
// ugvr::Error for a block that is not unstructured.
Block cells_meeting_box(const Block& block, const Bounds& box);

// The same for an explicit choice: the cells with keep[c] set (keep.size() == the block's cell count).
Block block_subset(const Block& block, std::span<const uint8_t> keep);

// The bounds of the block's points (float32 positions, in double): every point, used by a cell or not, as the exact
// engine's walk mesh counts them.
Bounds block_point_bounds(const Block& block);

// A cell's bounding box (its float32 vertices, in double) and its centroid (the mean of its vertices, as
// cell_centroids of kd_partition.h computes them), for the pieces' and the parts' kd-trees.
Bounds cell_bounds(const UnstructuredMesh& mesh, uint64_t c);
Vec3d cell_centroid(const UnstructuredMesh& mesh, uint64_t c);

// Cell centroids (the mean of each cell's vertices, as cell_centroids of kd_partition.h computes them) of the cells
// c = first, first + stride, ... of an unstructured block: the sample the kd-tree of a part read is built from.
std::vector<Vec3d> sampled_cell_centroids(const Block& block, uint64_t first, uint64_t stride);

// Writes `block` (unstructured) as `path` (a .pvtu) and its pieces `<stem>_<k>.vtu` beside it: cell c goes to piece
// piece_of_cell[c] (< pieces); each piece holds the points its cells use (shared points are written in every piece
// that uses them, as VTK's parallel writers do). Returns the piece files' paths. Throws ugvr::Error.
std::vector<std::string> write_pvtu(const Block& block, const std::string& path,
                                    std::span<const uint32_t> piece_of_cell, uint32_t pieces);

// The blocks (unstructured, with the same fields) joined into one: cells in block order, each block's points in
// order, but a point whose `id_field` value (a vertex field: its number in the input) a block before already has is
// that point; the id field is dropped. A rank's cuts of an input whose pieces number points alike (part_source.h)
// become one block whose cells meet across the pieces as in the whole read's walk mesh (faces match by vertex
// number). Throws ugvr::Error naming `source` when the blocks' fields differ or one lacks the id field.
Block join_blocks(std::vector<Block> blocks, const std::string& id_field, const std::string& source);

// Writes `block` (unstructured) as one .vtu at `path` holding `pieces` <Piece>s (raw appended data): cell c goes to
// <Piece> piece_of_cell[c], with the points its cells use, as write_pvtu's piece files. Throws ugvr::Error.
void write_vtu_pieces(const Block& block, const std::string& path, std::span<const uint32_t> piece_of_cell,
                      uint32_t pieces);

// An unstructured block as bytes, to send a part to the rank that draws it (mpi_part_read.cpp), appended to `out`.
// Layout (host byte order: the ranks of one job share it), all counts uint64:
//   points, cells, indices, fields
//   points x Vec3f | cells x uint8 type | (cells + 1) x uint64 offset | indices x uint32 connectivity
//   per field: name length, name bytes, uint8 association, uint8 scalar type, uint64 components, uint64 tuples, values
void append_block_bytes(const Block& block, std::vector<std::byte>& out);
// The block at `bytes` (advanced past it). Throws ugvr::Error naming `source` when the bytes run short or the mesh
// does not validate.
Block read_block_bytes(std::span<const std::byte>& bytes, std::string_view source);

// Two ways to deal cells into pieces by their centroids: `pieces` slabs of equal cell counts along `axis` (a solver's
// one-dimensional decomposition), or the boxes of a kd-tree balanced by count (a partitioner's compact pieces).
std::vector<uint32_t> slab_pieces(const Block& block, uint32_t pieces, int axis);
std::vector<uint32_t> kd_pieces(const Block& block, uint32_t pieces);

}  // namespace ugvr
