// Fields-only step reads of PLOT3D series (io/step_fields.h). A series is one grid file and one solution (.q) file per
// step: the grid is the same file for every step, so a step whose grid file is still the one read (same path, size and
// modification time) has that mesh. What a step's solution needs of the grid (the layout detected from it: byte order,
// record style, blocking, precision, IBLANK, each block's dimensions) is a Plot3dLayout, kept from a whole read of the
// grid; a later step's .q file is then checked and decoded by the whole read's own code, the grid file not opened.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

struct Plot3dLayout;

// The stored identity of a PLOT3D grid file: a hash of its path, size and modification time (not of its bytes: that
// would cost the read it saves; a grid rewritten to the same size within the time stamp granularity keeps its key).
// Stats the file. Throws ugvr::Error naming the file when it cannot be stat'ed.
uint64_t plot3d_mesh_key(const std::string& xyz_path);
// read_plot3d (io/reader.h), and where `kept` is given, the layout detected from the grid for read_plot3d_fields. The
// layout has no mesh key (no fields-only reads) when the grid's size alone did not decide it (a tiny grid that several
// layouts fit, told apart by this solution file): another step's solution might decide otherwise.
Dataset read_plot3d(const std::string& xyz_path, const std::string& q_path, std::shared_ptr<const Plot3dLayout>* kept);
// The mesh key the layout was read with (plot3d_mesh_key, taken before the grid was read); nullopt as said above.
const std::optional<uint64_t>& plot3d_layout_mesh_key(const Plot3dLayout& layout);
// The solution file `q_path` on the layout's grid: bit for bit the blocks' fields read_plot3d gives, in block order;
// `format`, `sources` and `warnings` as it sets the dataset's. The caller has checked that the grid's mesh key is the
// layout's. Throws ugvr::Error naming the .q file (and the offset) as the whole read does for a damaged solution.
std::vector<FieldSet> read_plot3d_fields(const Plot3dLayout& layout, const std::string& q_path, std::string& format,
                                         std::vector<std::string>& sources, std::vector<std::string>& warnings);

}  // namespace ugvr
