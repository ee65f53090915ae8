#include <cstdio>

#include "cli/cli_codec.h"
#include "cli/commands.h"
#include "cli/dataset_input.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/memory.h"
#include "ugvr/io/reader.h"
#include "ugvr/refine/refine.h"

namespace ugvr::cli {

void register_refine(CLI::App& app) {
  struct Options {
    DatasetInput input;
    std::string output, split = "five", compress;
    RefineOptions refine;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "refine",
      "Uniformly refine a mesh N levels (each tet, hex, wedge into 8; pyramid into 6 pyramids + 4 tets), keeping it "
      "conforming and interpolating its fields; structured grids are first cut into tets. Streaming .vtu output");
  add_dataset_input(*cmd, opts->input);
  cmd->add_option("-o,--output", opts->output, "Output .vtu file")->required();
  cmd->add_option("--levels", opts->refine.levels, "Refinement levels: cells x 8^N")
      ->required()
      ->check(CLI::Range(0, kMaxRefineLevels));
  cmd->add_option("--split", opts->split, "Structured inputs: five (default) or six (Kuhn) tets per hexahedron")
      ->check(CLI::IsMember({"five", "six"}, CLI::ignore_case))
      ->default_val("five");
  add_compress_option(*cmd, opts->compress);
  cmd->callback([opts] {
    if (extension_lower(opts->output) != ".vtu") throw Error(opts->output + ": the output must be a .vtu file");
    opts->refine.split =
        opts->split == "six" ? StructuredCellShape::SixTetrahedra : StructuredCellShape::FiveTetrahedra;
    opts->refine.codec = parse_codec_name(opts->compress);
    const Dataset ds = read_dataset_input(opts->input);
    const RefineStats s = refine_to_vtu(ds, opts->refine, opts->output);
    const RefinePlan& p = s.plan;
    std::printf(
        "wrote %s: %llu cells (%llu tetra, %llu pyramid, %llu wedge, %llu hexahedron) from %llu, %llu points, %s in "
        "%.2f s (%.3g cells/s), peak RSS %s\n",
        opts->output.c_str(), (unsigned long long)p.cells, (unsigned long long)p.types.tetra,
        (unsigned long long)p.types.pyramid, (unsigned long long)p.types.wedge, (unsigned long long)p.types.hexahedron,
        (unsigned long long)p.input_cells, (unsigned long long)p.points, format_bytes(s.bytes).c_str(), s.seconds,
        double(p.cells) / s.seconds, format_bytes(peak_rss_bytes()).c_str());
  });
}

}  // namespace ugvr::cli
