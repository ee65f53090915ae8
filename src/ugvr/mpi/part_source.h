// The pieces of an input that one rank can read alone, for read_part (mpi_part_read.h): under
// `mpirun -np N ugvr render MESH --engine exact` each piece is read once in the job, by one rank (docs/mpi.md,
// "Reading only a rank's part"). One implementation per format:
//   pvtu_part_source    a .pvtu: a piece is one of its piece files                          (--stats: "pvtu-part")
//   exodus_part_source  Exodus II: a piece is a range of the volume blocks' cells: a run of   ("exodus-blocks")
//                       small blocks or a slice of a large one (exodus_parts.h)
//   vtu_piece_source    a .vtu of several <Piece>s: a piece is a <Piece> (vtu_pieces.h)      ("vtu-pieces")
//   vtu_range_source    a .vtu of one <Piece>, raw appended: a piece is a range of its cells    ("vtu-ranges")
// No MPI here: the sources are tested on their own (tests/test_part_sources.cpp).
#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/reader.h"

namespace ugvr::mpi {

// A vertex field a source adds to its pieces when they number points as the whole input does (Exodus nodes, a
// .vtu's point ids): each point's number in the input (UInt32). read_part joins a rank's cuts on it (join_blocks of
// mesh_part.h) and drops it; it is no field of the data.
inline constexpr const char* kPartPointIdField = "ugvr_part_point_id";

class PartSource {
 public:
  virtual ~PartSource() = default;
  // What --stats' mpi.read says: "pvtu-part", "exodus-blocks", "vtu-pieces", "vtu-ranges".
  virtual std::string kind() const = 0;
  virtual const std::string& path() const = 0;
  // The part's Dataset::format.
  virtual std::string format() const = 0;
  virtual size_t pieces() const = 0;
  // The volume cells of all pieces from headers, where that is cheap (the kd-tree's sample stride); nullopt if not.
  virtual std::optional<uint64_t> cells_from_headers() const = 0;
  // Piece k (< pieces()): one unstructured block whose cells are the whole read's cells of that piece, in the whole
  // read's order, with the whole read's fields (and kPartPointIdField where the source has it); pieces in order
  // number the cells as a whole read does. Throws ugvr::Error naming the file.
  virtual Dataset read_piece(size_t k) const = 0;
  // The file piece k is read from (the part's Dataset::sources, error messages).
  virtual std::string piece_file(size_t k) const = 0;
};

std::unique_ptr<PartSource> pvtu_part_source(const std::string& path);
std::unique_ptr<PartSource> vtu_piece_source(const std::string& path);
// `pieces` ranges of equal cell counts (fewer for fewer cells).
std::unique_ptr<PartSource> vtu_range_source(const std::string& path, uint64_t pieces);
// About `pieces` pieces (exodus_cell_ranges), of time step `time_step` (-1: the last).
std::unique_ptr<PartSource> exodus_part_source(const std::string& path, int64_t time_step, uint64_t pieces);

// The source reading `path` by parts, for `ranks` ranks, when its format has one (nullptr otherwise: read whole).
// Throws ugvr::Error naming the file when its header cannot be read.
std::unique_ptr<PartSource> open_part_source(const std::string& path, const ReadOptions& read, int ranks);

}  // namespace ugvr::mpi
