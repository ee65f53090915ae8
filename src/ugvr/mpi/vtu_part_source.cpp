// A .vtu's <Piece>s for read_part: piece k is its k-th <Piece>, read alone (vtu_pieces.h, part_source.h).
#include "ugvr/io/vtu_pieces.h"
#include "ugvr/mpi/part_source.h"

namespace ugvr::mpi {
namespace {

class VtuPieceSource final : public PartSource {
 public:
  explicit VtuPieceSource(const std::string& path) : path_(path), pieces_(vtu_piece_count(path)) {}
  std::string kind() const override { return "vtu-pieces"; }
  const std::string& path() const override { return path_; }
  std::string format() const override { return "VTK XML UnstructuredGrid (.vtu), this rank's part"; }
  size_t pieces() const override { return pieces_; }
  std::optional<uint64_t> cells_from_headers() const override {
    const std::optional<GridCounts> counts = grid_counts_from_headers(std::vector<std::string>{path_});
    return counts ? std::optional<uint64_t>(counts->cells) : std::nullopt;
  }
  Dataset read_piece(size_t k) const override { return read_vtu_piece(path_, k); }
  std::string piece_file(size_t) const override { return path_; }

 private:
  std::string path_;
  size_t pieces_;
};

}  // namespace

std::unique_ptr<PartSource> vtu_piece_source(const std::string& path) { return std::make_unique<VtuPieceSource>(path); }

}  // namespace ugvr::mpi
