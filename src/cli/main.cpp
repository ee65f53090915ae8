// ugvr command-line front end: one subcommand per job; each lives in its own cmd_*.cpp and registers here.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/core/progress.h"
#include "ugvr/core/temp_files.h"
#ifdef UGVR_HAVE_MPI
#include "ugvr/mpi/mpi_session.h"
#endif

namespace {

int run(int argc, char** argv) {
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
  ugvr::cli::register_cache(app);

  // Under MPI a failing rank must take the job down (mpi::abort_job): the others may be waiting for it in a
  // collective, and a plain return would leave them hanging.
  auto fail = [](const char* kind, const std::string& message, int code) {
#ifdef UGVR_HAVE_MPI
    if (ugvr::mpi::active()) ugvr::mpi::abort_job(std::string(kind) + ": " + message, code);
#endif
    std::fprintf(stderr, "ugvr: %s: %s\n", kind, message.c_str());
    return code;
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
#ifdef UGVR_HAVE_MPI
    if (code != 0 && ugvr::mpi::active()) ugvr::mpi::abort_job("bad command line", code);
#endif
    return code;
  } catch (const ugvr::Error& e) {
    return fail("error", e.what(), 1);
  } catch (const std::bad_alloc&) {
    return fail("error", "out of memory", 1);
  } catch (const std::exception& e) {
    return fail("internal error", e.what(), 2);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // First, so that no temporary outlives an interrupted job (`view` blocks these signals and handles them itself).
  ugvr::install_temp_cleanup_on_signals();
#ifdef UGVR_HAVE_MPI
  // Only when mpirun started us: plain `ugvr` never initialises MPI.
  ugvr::mpi::init(&argc, &argv);
#endif
  const int code = run(argc, argv);
#ifdef UGVR_HAVE_MPI
  ugvr::mpi::finalize();
#endif
  return code;
}
