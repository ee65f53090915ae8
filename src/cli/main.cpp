// ugvr command-line front end: one subcommand per job; each lives in its own cmd_*.cpp and registers here.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/core/temp_files.h"

int main(int argc, char** argv) {
  // First, so that no temporary outlives an interrupted job (`view` blocks these signals and handles them itself).
  ugvr::install_temp_cleanup_on_signals();
  CLI::App app{"ugvr: interactive direct volume rendering of large unstructured grids"};
  app.set_version_flag("--version", std::string("ugvr ") + UGVR_VERSION);
  app.require_subcommand(1);
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "No progress output");
  app.parse_complete_callback([&] { ugvr::Progress::set_enabled(!quiet); });

  ugvr::cli::register_info(app);
  ugvr::cli::register_generate(app);
  ugvr::cli::register_convert(app);
  ugvr::cli::register_refine(app);
  ugvr::cli::register_render(app);
  ugvr::cli::register_build(app);
  ugvr::cli::register_compare(app);
  ugvr::cli::register_view(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const ugvr::Error& e) {
    std::fprintf(stderr, "ugvr: error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "ugvr: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ugvr: internal error: %s\n", e.what());
    return 2;
  }
  return 0;
}
