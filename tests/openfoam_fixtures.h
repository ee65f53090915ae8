// OpenFOAM cases for the tests of step reads (fields-only reads, stores with time): copies of the fixtures in
// tests/data/openfoam, with fields added to their time directories.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include "test_data.h"

namespace ugvr::test {

// A copy of the fixture case `name` in `dir`.
inline std::string copy_openfoam_case(const ScratchDir& dir, const std::string& name) {
  const std::filesystem::path root = dir.file(name);
  std::filesystem::copy(std::string(UGVR_SOURCE_DIR) + "/tests/data/openfoam/" + name, root,
                        std::filesystem::copy_options::recursive);
  return root.string();
}

// An ascii pointScalarField "pw" of `n` values (i * scale) in `time_dir`, as OpenFOAM writes one.
inline void write_point_field(const std::filesystem::path& time_dir, int n, double scale) {
  std::string text =
      "FoamFile\n{\n    version     2.0;\n    format      ascii;\n    class       pointScalarField;\n"
      "    object      pw;\n}\n\ndimensions      [0 0 0 0 0 0 0];\n\ninternalField   nonuniform List<scalar> \n" +
      std::to_string(n) + "\n(\n";
  for (int i = 0; i < n; ++i) text += std::to_string(scale * i) + "\n";
  text += ")\n;\n\nboundaryField\n{\n}\n";
  std::ofstream(time_dir / "pw") << text;
}

// The bytes of the regular files under `dir`.
inline uint64_t bytes_under(const std::filesystem::path& dir) {
  uint64_t n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file()) n += e.file_size();
  return n;
}

}  // namespace ugvr::test
