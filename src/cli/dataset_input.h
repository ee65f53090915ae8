// The dataset a subcommand reads: its INPUT files and the reading options, registered together and read with the
// reader's warnings shown.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "ugvr/io/reader.h"

namespace ugvr::cli {

struct DatasetInput {
  std::vector<std::string> files;
  ReadOptions read;
};

// Adds INPUT (add_input) and the reading options (add_read_options).
inline void add_dataset_input(CLI::App& cmd, DatasetInput& input) {
  add_input(cmd, input.files);
  add_read_options(cmd, input.read);
}

// Reads the dataset, printing the reader's warnings on stderr.
inline Dataset read_dataset_input(const DatasetInput& input) {
  Dataset ds = read_dataset(input.files, input.read);
  for (const std::string& w : ds.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return ds;
}

}  // namespace ugvr::cli
