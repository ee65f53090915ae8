// An Exodus II file's pieces for read_part: ranges of the volume blocks' cells (exodus_parts.h), each read with the
// nodes it uses (part_source.h).
#include "ugvr/io/exodus_parts.h"
#include "ugvr/mpi/part_source.h"

namespace ugvr::mpi {
namespace {

class ExodusPartSource final : public PartSource {
 public:
  ExodusPartSource(const std::string& path, int64_t time_step, uint64_t pieces)
      : path_(path),
        time_step_(time_step),
        layout_(read_exodus_layout(path)),
        ranges_(exodus_cell_ranges(layout_, pieces)) {}
  std::string kind() const override { return "exodus-blocks"; }
  const std::string& path() const override { return path_; }
  std::string format() const override { return "Exodus II, this rank's part"; }
  size_t pieces() const override { return ranges_.size(); }
  std::optional<uint64_t> cells_from_headers() const override { return layout_.cells; }
  Dataset read_piece(size_t k) const override {
    std::vector<uint32_t> nodes;
    Dataset ds = read_exodus_cells(path_, time_step_, ranges_.at(k), &nodes);
    ds.blocks.at(0).fields.add(Field(kPartPointIdField, Association::Vertex, DataArray::from(std::move(nodes), 1)));
    return ds;
  }
  std::string piece_file(size_t) const override { return path_; }

 private:
  std::string path_;
  int64_t time_step_;
  ExodusLayout layout_;
  std::vector<ExodusCellRange> ranges_;
};

}  // namespace

std::unique_ptr<PartSource> exodus_part_source(const std::string& path, int64_t time_step, uint64_t pieces) {
  return std::make_unique<ExodusPartSource>(path, time_step, pieces);
}

}  // namespace ugvr::mpi
