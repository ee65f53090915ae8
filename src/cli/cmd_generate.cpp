#include "cli/commands.h"
#include "ugvr/core/error.h"
namespace ugvr::cli {
// PLACEHOLDER until the generator lands.
void register_generate(CLI::App& app) {
  app.add_subcommand("generate", "Write a synthetic CFD-like dataset (not yet available)")->callback([] {
    throw Error("generate: not yet implemented");
  });
}
}  // namespace ugvr::cli
