// Uniform refinement: a real mesh made N levels finer, keeping its structure, written as .vtu in bounded memory.
//
// Rules (one level; N levels apply them recursively, so a cell becomes 8^N cells, a pyramid 6^N pyramids plus tets):
//   tetrahedron  8 tets, Bey's red refinement: 4 corner tets + the inner octahedron cut into 4 along the diagonal
//                x02-x13, with Bey's child vertex orders (J. Bey, "Tetrahedral grid refinement", Computing 1995).
//                Applied recursively this fixed lattice choice yields at most 3 similarity classes, so repeated levels
//                stay well shaped. Children are written positively oriented (two vertices swapped where Bey's order
//                is inverted).
//   hexahedron   8 hexahedra (edge midpoints, face centres, body centre).
//   wedge        8 wedges: each triangle into 4 (3 corners + the medial triangle) times 2 layers.
//   pyramid      6 pyramids (4 at the base corners, 1 at the apex, 1 upside down between them with its apex at the
//                base centre) + 4 tets filling the gaps along the 4 sides.
// Structured inputs (curvilinear, uniform, rectilinear) are first cut into tets by make_explicit_cells (five or six
// per hexahedron; IBLANK honoured, and not written since interpolating it would mean nothing).
//
// Lattice: every cell type has an integer reference polytope with edges of n = 2^N steps (tet: the corner simplex of
// (x,y,z) = barycentric (l1,l2,l3); hex: [0,n]^3; wedge: triangle x,y >= 0, x+y <= n, times z in [0,n]; pyramid:
// square base [0,n]^2, apex at (0,0,n)). Every vertex of the refined cell is a lattice point, and the refinement
// pattern (the "template") is the same for every cell of a type; only the mapping lattice point -> global vertex id
// depends on the cell.
//
// Vertex numbering (no hash of the output: ids come from the input entity a new vertex lies on):
//   [0, V)                       the input vertices (all of them, used or not)
//   V + e*(n-1) + k-1            the k-th interior point of unique edge e, k counted from its lower vertex id
//   face_base[f] + rank          interior points of unique face f, in coordinates canonicalised for the face:
//                                triangle: barycentrics (u0,u1,u2) of its vertices sorted by id, ranked by (u1,u2);
//                                quad: (s,t) from its lowest-id corner towards its lower-id neighbour (s) and the
//                                other neighbour (t). Both cells sharing a face therefore name its points alike.
//   cell_base[c] + rank          interior points of input cell c, in the type's fixed lattice order.
// Positions and vertex fields at a new vertex are interpolated from the entity it lies on: linear on edges and
// triangles, bilinear on quads, the cell's own map inside (linear, trilinear, linear x linear, collapsed-hex pyramid).
// Each vertex is computed once, so shared vertices are identical. Integer fields are rounded. Cell fields are copied
// to every child.
//
// Streaming passes, in file order, each regenerating its values chunk by chunk from the input mesh and the tables:
// Points, connectivity, offsets, types, each vertex field, each cell field. Memory: the input dataset, the edge table
// (sorted unique edges, 4 bytes each + 8 per vertex), the face table (one id per cell face slot, a base per face),
// per-cell prefix counts, per-type templates (at most 8^6 leaves) and the chunk buffers; nothing scales with the
// output.
#pragma once

#include <cstdint>
#include <string>

#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/codec.h"

namespace ugvr {

inline constexpr int kMaxRefineLevels = 6;  // 8^6 = 262,144 children per cell (templates stay small)
inline constexpr uint64_t kMaxRefineCells = uint64_t(1) << 40;  // refuse absurd outputs
inline constexpr uint64_t kMaxRefinePoints = UINT32_MAX;        // our in-memory meshes use 32-bit vertex indices

struct RefineOptions {
  int levels = 1;
  StructuredCellShape split = StructuredCellShape::FiveTetrahedra;  // for structured inputs: Five or Six tets
  Codec codec = Codec::None;
  int codec_level = 0;
};

struct RefinePlan {
  int levels = 0;
  uint64_t input_cells = 0, input_points = 0;    // after splitting structured inputs into tets
  uint64_t edges = 0, triangles = 0, quads = 0;  // unique entities of the input mesh
  uint64_t cells = 0, points = 0, connectivity = 0;
  CellTypeCounts types;  // of the output
};

struct RefineStats {
  RefinePlan plan;
  uint64_t bytes = 0;  // file size
  double seconds = 0;  // wall time, reading excluded
};

// Counts of the output. Throws ugvr::Error for levels outside [0, kMaxRefineLevels], more than kMaxRefineCells cells
// or more than kMaxRefinePoints points (checked in 64 bits, cells before any table is built), a dataset with several
// blocks or no volume cells.
RefinePlan plan_refinement(const Dataset& ds, const RefineOptions& options);

// Refines the dataset and writes it to `out_path` (.vtu, atomically), with ugvr::Progress.
RefineStats refine_to_vtu(const Dataset& ds, const RefineOptions& options, const std::string& out_path);

}  // namespace ugvr
