#include "cli/commands.h"
#include "ugvr/core/error.h"
namespace ugvr::cli {
// PLACEHOLDER until the writer lands.
void register_convert(CLI::App& app) {
  app.add_subcommand("convert", "Convert any readable dataset to .vtu (not yet available)")->callback([] {
    throw Error("convert: not yet implemented");
  });
}
}  // namespace ugvr::cli
