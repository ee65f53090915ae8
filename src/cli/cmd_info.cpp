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

void register_info(CLI::App& app) {
  struct Options {
    std::vector<std::string> inputs;
    bool json = false;
    bool topology = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a dataset: format, grid, cell counts, bounds, fields, memory");
  add_input(*cmd, opts->inputs);
  cmd->add_flag("--json", opts->json, "Print the report as JSON");
  cmd->add_flag("--topology", opts->topology, "Also build face connectivity (boundary and non-manifold faces)");
  cmd->callback([opts] {
    const auto t0 = std::chrono::steady_clock::now();
    const Dataset ds = read_dataset(opts->inputs);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const nlohmann::json report = dataset_report(ds, seconds, {.topology = opts->topology});
    if (opts->json) std::printf("%s\n", report.dump(2).c_str());
    else std::fputs(format_report_text(report).c_str(), stdout);
  });
}

}  // namespace ugvr::cli
