// Fields-only step reads of EnSight Gold cases (io/step_fields.h). A case whose geometry ("model:") has no '*'
// wildcards and no file set (or no time set) has one geometry for all steps. What a step's variables need of it (each
// part's node and element counts, its element sections in order, which are volume cells, its polyhedra decomposition,
// a structured block's cell count, the geometry file's encoding and notes) is an EnsightLayout, kept from a whole read
// of the geometry; a later step's variables are then read from their files alone, through the whole read's own
// decoding, the geometry file not opened.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"

namespace ugvr {

struct EnsightLayout;

// The stored identity of a .case's one geometry: a hash of the geometry file's path, size and modification time;
// nullopt when the geometry changes per step ('*' wildcards, a file set) and for a .sos. Parses the .case, stats the
// geometry file. Throws ugvr::Error naming the file for a bad .case or a geometry that cannot be stat'ed.
std::optional<uint64_t> ensight_mesh_key(const std::string& path);
// read_ensight (io/reader.h), and where `kept` is given (a .case), the layout of its geometry for read_ensight_fields.
Dataset read_ensight(const std::string& path, int64_t time_step, std::shared_ptr<const EnsightLayout>* kept);
// The mesh key the layout was read with (ensight_mesh_key, taken before the geometry was read).
const std::optional<uint64_t>& ensight_layout_mesh_key(const EnsightLayout& layout);
// Step `time_step`'s variables on the layout's geometry: bit for bit the blocks' fields read_ensight gives for that
// step, in its block order; `format`, `sources` and `warnings` as it sets the dataset's. The caller has checked that
// the case's mesh key is the layout's. Throws ugvr::Error naming the file for a missing or damaged variable file.
std::vector<FieldSet> read_ensight_fields(const EnsightLayout& layout, const std::string& path, int64_t time_step,
                                          std::string& format, std::vector<std::string>& sources,
                                          std::vector<std::string>& warnings);

}  // namespace ugvr
