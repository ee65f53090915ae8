#include <chrono>
#include <cstdio>

#include "cli/commands.h"
#include "ugvr/io/reader.h"
#include "ugvr/report/dataset_report.h"

namespace ugvr::cli {

CLI::Option* add_input(CLI::App& cmd, std::vector<std::string>& inputs) {
  return cmd
      .add_option("INPUT", inputs,
                  "Input file (.vtu .pvtu .vts .vti .vtr .vtk), or a PLOT3D grid file then its solution file")
      ->required()
      ->expected(1, 2)
      ->check(CLI::ExistingFile);
}

void add_read_options(CLI::App& cmd, ReadOptions& o) {
  cmd.add_option("--time-step", o.time_step, "Exodus: time step to read (0-based; -1 = last)")->default_val(-1);
  cmd.add_option("--raw-dims", o.raw.dims, "Raw volume: point dimensions NX NY NZ");
  cmd.add_option("--raw-type", o.raw.type, "Raw volume: value type")
      ->check(CLI::IsMember({"int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"}))
      ->default_val("float32");
  cmd.add_option("--raw-spacing", o.raw.spacing, "Raw volume: voxel spacing SX SY SZ");
  cmd.add_option("--raw-origin", o.raw.origin, "Raw volume: origin OX OY OZ");
  cmd.add_flag("--raw-big-endian", o.raw.big_endian, "Raw volume: values are big-endian");
  cmd.add_option("--raw-header", o.raw.header_bytes, "Raw volume: bytes to skip before the values");
}

void register_info(CLI::App& app) {
  struct Options {
    std::vector<std::string> inputs;
    bool json = false;
    bool topology = false;
    ReadOptions read;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a dataset: format, grid, cell counts, bounds, fields, memory");
  add_input(*cmd, opts->inputs);
  add_read_options(*cmd, opts->read);
  cmd->add_flag("--json", opts->json, "Print the report as JSON");
  cmd->add_flag("--topology", opts->topology, "Also build face connectivity (boundary and non-manifold faces)");
  cmd->callback([opts] {
    const auto t0 = std::chrono::steady_clock::now();
    const Dataset ds = read_dataset(opts->inputs, opts->read);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const nlohmann::json report = dataset_report(ds, seconds, {.topology = opts->topology});
    if (opts->json)
      std::printf("%s\n", report.dump(2).c_str());
    else
      std::fputs(format_report_text(report).c_str(), stdout);
  });
}

}  // namespace ugvr::cli
