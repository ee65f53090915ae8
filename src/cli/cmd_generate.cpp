#include <cstdio>
#include <filesystem>

#include "cli/cli_codec.h"
#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/time_series.h"

namespace ugvr::cli {

namespace {
struct Options {
  std::string output;
  GenerateOptions gen;
  std::string kind = "hex", compress;
  uint32_t time_steps = 0;
};

// --time-steps N: one .vtu per step and the .pvd naming them (written last, so it never names a missing file).
void write_series(const Options& o) {
  const std::filesystem::path pvd(o.output);
  if (pvd.extension() != ".pvd") throw Error("-o: with --time-steps the output is a .pvd collection, not " + o.output);
  std::vector<std::pair<double, std::string>> steps;
  uint64_t bytes = 0;
  double seconds = 0;
  for (uint32_t i = 0; i < o.time_steps; ++i) {
    GenerateOptions g = o.gen;
    g.time = double(i) / double(o.time_steps);
    char name[32];
    std::snprintf(name, sizeof name, "_%04u.vtu", i);
    const std::string file = pvd.stem().string() + name;
    const GenerateStats s = generate_dataset(g, (pvd.parent_path() / file).string());
    bytes += s.bytes;
    seconds += s.seconds;
    steps.emplace_back(g.time, file);
    if (i + 1 == o.time_steps)
      std::printf("wrote %s: %u steps of %llu cells (%llu points), %s in %.2f s, peak RSS %s\n", o.output.c_str(),
                  o.time_steps, (unsigned long long)s.cells, (unsigned long long)s.points, format_bytes(bytes).c_str(),
                  seconds, format_bytes(peak_rss_bytes()).c_str());
  }
  write_pvd(o.output, steps);
}
}  // namespace

void register_generate(CLI::App& app) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "generate",
      "Write a synthetic CFD-like dataset (.vtu): a graded curvilinear O-grid around a tapered wing on a floor, with "
      "a flow-like pressure, velocity and a per-cell wall distance; streaming, in bounded memory, 10K to 1B+ cells");
  cmd->add_option("-o,--output", opts->output, "Output .vtu file (with --time-steps: a .pvd)")->required();
  cmd->add_option(
         "--time-steps", opts->time_steps,
         "Write a time series of N steps instead: OUT.pvd and OUT_NNNN.vtu beside it, the wake's vortex street "
         "moving downstream over one shedding period (t = i/N; the grid is the same at every step)")
      ->check(CLI::Range(uint32_t(1), uint32_t(100000)));
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
    if (opts->time_steps > 0) {
      write_series(*opts);
      return;
    }
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
