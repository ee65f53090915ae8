// Subcommand registration. Each register_* adds its subcommand with options and a callback that does the work;
// callbacks throw ugvr::Error for anything the user can fix.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include "ugvr/io/reader.h"

namespace ugvr::cli {

void register_info(CLI::App& app);
void register_generate(CLI::App& app);
void register_convert(CLI::App& app);
void register_refine(CLI::App& app);
void register_render(CLI::App& app);
void register_build(CLI::App&);
void register_compare(CLI::App& app);
void register_view(CLI::App& app);
void register_cache(CLI::App& app);

// Adds the positional INPUT argument every reading subcommand takes: one file, or a PLOT3D grid file followed by
// its solution file.
CLI::Option* add_input(CLI::App& cmd, std::vector<std::string>& inputs);
// Adds the reading options: --time-step (Exodus, CGNS, EnSight, OpenFOAM) and the --raw-* layout of headerless voxel
// volumes.
void add_read_options(CLI::App& cmd, ReadOptions& options);

// "warning: WHAT" on stderr (a build's note passed up from the library, e.g. a piece's boundary_note).
inline void print_warning(const std::string& what) { std::fprintf(stderr, "warning: %s\n", what.c_str()); }

}  // namespace ugvr::cli
