#include <chrono>
#include <cstdio>

#include "cli/cli_codec.h"
#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/memory.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"

namespace ugvr::cli {

void register_convert(CLI::App& app) {
  struct Options {
    std::vector<std::string> args;
    VtuWriteOptions write;
    std::string compress;
    ReadOptions read;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "Convert any readable dataset to .vtu (structured grids become hexahedra, IBLANK a vertex field)");
  cmd->add_option("INPUT OUTPUT", opts->args, "Input file (or PLOT3D grid and solution files), then the output .vtu")
      ->required()
      ->expected(2, 3);
  add_compress_option(*cmd, opts->compress);
  add_read_options(*cmd, opts->read);
  cmd->callback([opts] {
    opts->write.codec = parse_codec_name(opts->compress);
    std::vector<std::string> inputs(opts->args.begin(), opts->args.end() - 1);
    const std::string& output = opts->args.back();
    if (extension_lower(output) != ".vtu") throw Error(output + ": the output must be a .vtu file");
    const auto t0 = std::chrono::steady_clock::now();
    const Dataset ds = read_dataset(inputs, opts->read);
    for (const std::string& w : ds.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    const uint64_t bytes = write_vtu(ds, output, opts->write);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("wrote %s: %llu cells, %llu points, %s in %.2f s, peak RSS %s\n", output.c_str(),
                (unsigned long long)ds.cell_count(), (unsigned long long)ds.point_count(), format_bytes(bytes).c_str(),
                seconds, format_bytes(peak_rss_bytes()).c_str());
  });
}

}  // namespace ugvr::cli
