// A single-piece raw-appended .vtu's pieces for read_part: equal ranges of its cells, each read at its own bytes
// (vtu_pieces.h: read_vtu_cells; part_source.h).
#include <algorithm>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/io/vtu_pieces.h"
#include "ugvr/mpi/part_source.h"

namespace ugvr::mpi {
namespace {

class VtuRangeSource final : public PartSource {
 public:
  VtuRangeSource(const std::string& path, uint64_t pieces) : path_(path) {
    const std::optional<GridCounts> counts = grid_counts_from_headers(std::vector<std::string>{path});
    if (!counts) fail_in(path, "its <Piece> does not say NumberOfCells");
    cells_ = counts->cells;
    const uint64_t n = std::clamp<uint64_t>(pieces, 1, std::max<uint64_t>(cells_, 1));
    for (uint64_t k = 0; k <= n; ++k) starts_.push_back(cells_ * k / n);
  }
  std::string kind() const override { return "vtu-ranges"; }
  const std::string& path() const override { return path_; }
  std::string format() const override { return "VTK XML UnstructuredGrid (.vtu), this rank's part"; }
  size_t pieces() const override { return starts_.size() - 1; }
  std::optional<uint64_t> cells_from_headers() const override { return cells_; }
  Dataset read_piece(size_t k) const override {
    uint64_t first_point = 0;
    Dataset ds = read_vtu_cells(path_, starts_.at(k), starts_.at(k + 1) - starts_.at(k), &first_point);
    Block& block = ds.blocks.at(0);
    std::vector<uint32_t> ids(std::get<UnstructuredMesh>(block.grid).point_count());
    for (size_t i = 0; i < ids.size(); ++i) ids[i] = uint32_t(first_point + i);
    block.fields.add(Field(kPartPointIdField, Association::Vertex, DataArray::from(std::move(ids), 1)));
    return ds;
  }
  std::string piece_file(size_t) const override { return path_; }

 private:
  std::string path_;
  uint64_t cells_ = 0;
  std::vector<uint64_t> starts_;  // piece k: cells [starts_[k], starts_[k + 1])
};

}  // namespace

std::unique_ptr<PartSource> vtu_range_source(const std::string& path, uint64_t pieces) {
  return std::make_unique<VtuRangeSource>(path, pieces);
}

}  // namespace ugvr::mpi
