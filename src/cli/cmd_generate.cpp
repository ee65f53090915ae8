#include <cstdio>

#include "cli/cli_codec.h"
#include "cli/commands.h"
#include "ugvr/core/memory.h"
#include "ugvr/gen/generator.h"

namespace ugvr::cli {

void register_generate(CLI::App& app) {
  struct Options {
    std::string output;
    GenerateOptions gen;
    std::string kind = "hex", compress;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "generate",
      "Write a synthetic CFD-like dataset (.vtu): a graded curvilinear O-grid around a tapered wing on a floor, with "
      "a flow-like pressure, velocity and a per-cell wall distance; streaming, in bounded memory, 10K to 1B+ cells");
  cmd->add_option("-o,--output", opts->output, "Output .vtu file")->required();
  cmd->add_option("--cells", opts->gen.cells, "Target number of cells (the result is within a few percent)")
      ->check(CLI::Range(uint64_t(1000), uint64_t(10'000'000'000)))
      ->default_val(opts->gen.cells);
  cmd->add_option("--kind", opts->kind,
                  "Cells: hex (all hexahedra), tet (all tetrahedra), mixed (wedge prism layers on the wall, then "
                  "tetrahedra, a pyramid transition, hexahedra far away)")
      ->check(CLI::IsMember({"hex", "tet", "mixed"}, CLI::ignore_case))
      ->default_val("hex");
  cmd->add_option("--seed", opts->gen.seed, "Seed of the small-scale fluctuations")->default_val(opts->gen.seed);
  add_compress_option(*cmd, opts->compress);
  cmd->callback([opts] {
    opts->gen.kind = *parse_gen_cell_kind(opts->kind);
    opts->gen.codec = parse_codec_name(opts->compress);
    const GenerateStats s = generate_dataset(opts->gen, opts->output);
    const GeneratePlan& p = s.plan;
    std::printf(
        "wrote %s: %llu cells (%llu tetra, %llu pyramid, %llu wedge, %llu hexahedron), %llu points, grid %u x %u x "
        "%u, %s in %.2f s (%.1f MB/s), peak RSS %s\n",
        opts->output.c_str(), (unsigned long long)s.cells, (unsigned long long)p.tetra, (unsigned long long)p.pyramid,
        (unsigned long long)p.wedge, (unsigned long long)p.hexahedron, (unsigned long long)s.points, p.ni, p.nj, p.nk,
        format_bytes(s.bytes).c_str(), s.seconds, double(s.bytes) / 1e6 / s.seconds,
        format_bytes(peak_rss_bytes()).c_str());
  });
}

}  // namespace ugvr::cli
