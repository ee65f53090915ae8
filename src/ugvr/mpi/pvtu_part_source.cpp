// A .pvtu's pieces for read_part: piece k is its k-th piece file, read whole (part_source.h).
#include "ugvr/io/pvtu_pieces.h"
#include "ugvr/mpi/part_source.h"

namespace ugvr::mpi {
namespace {

class PvtuPartSource final : public PartSource {
 public:
  explicit PvtuPartSource(const std::string& path) : path_(path), files_(pvtu_piece_files(path)) {}
  std::string kind() const override { return "pvtu-part"; }
  const std::string& path() const override { return path_; }
  std::string format() const override { return "VTK XML PUnstructuredGrid (.pvtu), this rank's part"; }
  size_t pieces() const override { return files_.size(); }
  std::optional<uint64_t> cells_from_headers() const override {
    const std::optional<GridCounts> counts = grid_counts_from_headers(std::vector<std::string>{path_});
    return counts ? std::optional<uint64_t>(counts->cells) : std::nullopt;
  }
  Dataset read_piece(size_t k) const override { return read_vtk_xml(files_.at(k)); }
  std::string piece_file(size_t k) const override { return files_.at(k); }

 private:
  std::string path_;
  std::vector<std::string> files_;
};

}  // namespace

std::unique_ptr<PartSource> pvtu_part_source(const std::string& path) { return std::make_unique<PvtuPartSource>(path); }

}  // namespace ugvr::mpi
