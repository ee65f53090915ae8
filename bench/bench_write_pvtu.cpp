// Writes a mesh as a .pvtu of pieces, or as one .vtu of several <Piece>s (OUT ending in .vtu), the input of the MPI
// part-read benchmark (bench/run_mpi_part_read.sh) and of trying `mpirun -np N ugvr render X.pvtu` by hand: ugvr has
// no writer of either of its own.
// Usage: bench_write_pvtu IN OUT.pvtu|OUT.vtu PIECES [kd|slab-x|slab-y|slab-z]
//   kd (default): the boxes of a kd-tree over the cells' centroids, balanced by count (a partitioner's pieces);
//   slab-A: equal-count slabs along axis A (a solver's one-dimensional decomposition).
#include <cstdio>
#include <cstdlib>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
#include "ugvr/mpi/mesh_part.h"

int main(int argc, char** argv) {
  if (argc < 4 || argc > 5) {
    std::fprintf(stderr, "usage: %s IN OUT.pvtu|OUT.vtu PIECES [kd|slab-x|slab-y|slab-z]\n", argv[0]);
    return 2;
  }
  const std::string layout = argc == 5 ? argv[4] : "kd";
  const long pieces = std::strtol(argv[3], nullptr, 10);
  if (pieces < 1 || pieces > 4096 || !(layout == "kd" || layout.starts_with("slab-"))) {
    std::fprintf(stderr, "PIECES must be 1 to 4096 and the layout kd or slab-x|y|z\n");
    return 2;
  }
  try {
    const ugvr::Dataset ds = ugvr::read_dataset(std::vector<std::string>{argv[1]});
    if (ds.blocks.size() != 1) throw ugvr::Error(std::string(argv[1]) + ": one unstructured block expected");
    const ugvr::Block& block = ds.blocks[0];
    const std::vector<uint32_t> piece_of_cell = layout == "kd" ? ugvr::kd_pieces(block, uint32_t(pieces))
                                                               : ugvr::slab_pieces(block, uint32_t(pieces),
                                                                                   layout.back() == 'x'   ? 0
                                                                                   : layout.back() == 'y' ? 1
                                                                                                          : 2);
    const std::string out = argv[2];
    if (out.ends_with(".vtu")) {
      ugvr::write_vtu_pieces(block, out, piece_of_cell, uint32_t(pieces));
      std::printf("%s: %ld <Piece>s (%s)\n", argv[2], pieces, layout.c_str());
    } else {
      const auto files = ugvr::write_pvtu(block, out, piece_of_cell, uint32_t(pieces));
      std::printf("%s: %zu pieces (%s)\n", argv[2], files.size(), layout.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
