// What the readers of a one-file, one-block format (AVS UCD, Gmsh, legacy VTK, NASTRAN, OFF, UGRID) share around
// their parsing: the progress bar of a large file, and the Dataset they return.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/dataset.h"

namespace ugvr {

// Starts `progress` ("reading NAME", in bytes of the file) when the file is large enough to want one: small files
// load in a blink, and a progress bar for them would only be noise.
void start_reading_progress(std::optional<Progress>& progress, const InputFile& file);

// The dataset read from the file at `path`: `block`, whose fields are checked against its grid first (errors name
// `path`), in the given format, with the reader's warnings.
Dataset single_block_dataset(std::string format, const std::string& path, Block block,
                             std::vector<std::string> warnings);

}  // namespace ugvr
