// Synthetic CFD-like datasets of any size (10 thousand to a billion cells), written as .vtu in bounded memory.
//
// Geometry: a tapered, swept wing of elliptic section standing on a floor (z = 0) and spanning the domain up to its
// top (z = span), inside a graded curvilinear O-grid, as a CFD mesh around a blunt fin would be:
//   i  around the body, periodic (ni cells, ni points: the last cell wraps back to i = 0), clockwise seen from +z
//      so that (i, j, k) is a right-handed frame. Uniform in the elliptic angle, which clusters the points at the
//      leading and trailing edges.
//   j  wall-normal, from the body (j = 0) to a far-field circle of radius 15 chords (j = nj), along the lines of
//      confocal elliptic coordinates (mu, theta); the distance from the wall grows geometrically from a small first
//      cell (a few 1e-5 chord on large grids, coarser on small ones where the growth ratio is capped at 1.4).
//   k  spanwise, from the floor (k = 0) to the top (k = nk), clustered towards the floor (its boundary layer).
// The section's chord shrinks towards the top (taper) and its centre moves downstream (sweep); both blend away
// smoothly towards the far field, which stays a circular cylinder about the z axis.
//
// Cells (--cells-kind): every hexahedron of the index space becomes
//   hex    1 hexahedron;
//   tet    6 Kuhn tetrahedra (the split of structured_cells.h, conforming by construction);
//   mixed  by wall-normal layer: prism layers on the wall (2 wedges: the hexahedron cut by the diagonal of its
//          (i,k) faces from (i,k) to (i+1,k+1), extruded along j, which is the diagonal the Kuhn split draws there),
//          then a band of Kuhn tetrahedra, then one transition layer of 1 pyramid + 4 tetrahedra (the two Kuhn tets
//          on the outer j+1 face share the apex (i,j,k) and merge into a pyramid on that quad face), then hexahedra.
// All cells are positively oriented in VTK's convention and the mesh is conforming: every interior face is shared by
// exactly two cells with the same vertices.
//
// Fields (smooth, deterministic for a seed, features at several scales):
//   pressure       (vertex, Float32) pressure coefficient of potential flow around the section at 6 degrees
//                  incidence, with circulation setting the rear stagnation point on the trailing edge, plus the low
//                  pressure cores of a Karman vortex street in the wake and small-scale fluctuations;
//   velocity       (vertex, Float32 x 3) the potential flow, slowed to zero in thin boundary layers on the wing and
//                  the floor (with cross-flow from the sweep), a wake deficit downstream of the trailing edge, the
//                  vortex street (shed obliquely along the span) and multi-octave "turbulence" (sums of sine waves,
//                  divergence-free, strongest in the wake and boundary layers);
//   wall_distance  (cell, Float32) distance from the cell to the nearest wall (wing or floor).
//
// Streaming: the arrays are generated in file order (points, connectivity, offsets, types, pressure, velocity,
// wall_distance) in fixed-size chunks, recomputing the geometry analytically in each pass; only per-axis tables
// (O(ni + nj + nk)) and chunk buffers are held, so memory does not grow with the cell count.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/codec.h"

namespace ugvr {

enum class GenCellKind : uint8_t { Hex, Tet, Mixed };

std::string_view gen_cell_kind_name(GenCellKind kind);  // "hex", "tet", "mixed"
std::optional<GenCellKind> parse_gen_cell_kind(std::string_view name);

struct GenerateOptions {
  uint64_t cells = 1'000'000;  // target number of output cells; the result is within a few % (exact dims: the plan)
  GenCellKind kind = GenCellKind::Hex;
  uint64_t seed = 1;  // phases and directions of the fluctuations, phase of the vortex street
  // Time in shedding periods: the vortex street moves downstream by one vortex pair (a period) per unit, forming at
  // the trailing edge and decaying downstream as it goes; the rest of the flow is steady. Same grid at any time.
  double time = 0;
  Codec codec = Codec::None;  // compression of the .vtu appended data
  int level = 0;              // codec level, <= 0 for the codec's default
};

// The grid a request resolves to.
struct GeneratePlan {
  GenCellKind kind = GenCellKind::Hex;
  uint32_t ni = 0, nj = 0, nk = 0;  // cells around the body (periodic), wall-normal, spanwise
  uint32_t wedge_layers = 0;        // mixed: j-layers [0, wedge_layers) are prisms,
  uint32_t tet_layers = 0;          //   then tet_layers of tetrahedra, then one pyramid transition layer, then hexes
  uint64_t points = 0, cells = 0, connectivity = 0;
  uint64_t tetra = 0, pyramid = 0, wedge = 0, hexahedron = 0;
};

// Throws ugvr::Error for a target outside [1000, 1e10] cells.
GeneratePlan plan_generation(const GenerateOptions& options);

struct GenerateStats {
  GeneratePlan plan;
  uint64_t cells = 0, points = 0;
  uint64_t bytes = 0;  // size of the file written
  double seconds = 0;  // wall time
};

// Generates the dataset and writes it to `out_path` as a .vtu (atomically: temporary file + rename), reporting
// progress through ugvr::Progress.
GenerateStats generate_dataset(const GenerateOptions& options, const std::string& out_path);

// The same dataset in memory (one unstructured block), from the same chunked passes; for tests and small demos.
// Refuses plans above 50 million cells.
Dataset generate_in_memory(const GenerateOptions& options);

}  // namespace ugvr
