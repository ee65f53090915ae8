#include "ugvr/io/file_dataset.h"

#include <utility>

namespace ugvr {

void start_reading_progress(std::optional<Progress>& progress, const InputFile& file) {
  constexpr uint64_t kProgressMinBytes = uint64_t(16) << 20;
  if (file.size() >= kProgressMinBytes) progress.emplace("reading " + file.name(), file.size());
}

Dataset single_block_dataset(std::string format, const std::string& path, Block block,
                             std::vector<std::string> warnings) {
  block.validate_fields(path);
  Dataset d;
  d.format = std::move(format);
  d.sources = {path};
  d.blocks.push_back(std::move(block));
  d.warnings = std::move(warnings);
  return d;
}

}  // namespace ugvr
