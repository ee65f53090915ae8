// `ugvr view STORE.ugvr`: serves the browser viewer (src/ugvr/view/view_server.h) until SIGINT or SIGTERM.
#include <csignal>
#include <cstdio>
#include <filesystem>

#include "cli/cli_numbers.h"
#include "cli/commands.h"
#include "ugvr/core/error.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_server.h"

namespace ugvr::cli {
namespace {

struct Options {
  std::string store;
  std::string host = "127.0.0.1", size = "512", gpu = "auto", fps = "10";
  int port = 0;
  uint64_t gpu_memory = uint64_t(2) << 30;
};

void run_view(const Options& o) {
  if (std::filesystem::path(o.store).extension() != ".ugvr")
    fail_in(o.store, "not a brick store: `ugvr view` shows a .ugvr file made by `ugvr build`");
  if (o.port < 0 || o.port > 65535) fail_in("--port", "must be in [0, 65535] (0: a free port)");
  view::ViewServerOptions vo;
  vo.store = o.store;
  vo.host = o.host;
  vo.port = uint16_t(o.port);
  vo.gpu = o.gpu;
  vo.gpu_memory = o.gpu_memory;
  const ImageSize size = parse_size(o.size, "--size");
  if (size.width < view::kMinViewSide || size.width > view::kMaxViewSide || size.height < view::kMinViewSide ||
      size.height > view::kMaxViewSide)
    fail_in("--size", "each side must be in [" + std::to_string(view::kMinViewSide) + ", " +
                          std::to_string(view::kMaxViewSide) + "]");
  vo.width = size.width, vo.height = size.height;
  vo.fps = parse_number(o.fps, "--fps");
  if (!(vo.fps >= 0) || vo.fps > view::kMaxFps)
    fail_in("--fps", "must be in [0, " + std::to_string(int(view::kMaxFps)) + "]");

  // Blocked before any thread starts, so that every thread inherits the mask and only sigwait below sees them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  view::ViewServer server(vo);
  // Printed even with --quiet: it is the command's output (scripts read the URL from it).
  std::printf("ugvr view: serving %s (%s)\n", server.url().c_str(), server.renderer().c_str());
  std::fflush(stdout);
  int sig = 0;
  sigwait(&signals, &sig);
  std::fprintf(stderr, "ugvr view: stopping\n");
  server.stop();
}

}  // namespace

void register_view(CLI::App& app) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "view", "Serve an interactive browser viewer of a brick store at http://127.0.0.1:PORT/ until interrupted");
  cmd->add_option("STORE", opts->store, "Brick store (.ugvr, made by `ugvr build`)")->required();
  cmd->add_option("--port", opts->port, "TCP port (default 0: a free port)");
  cmd->add_option("--host", opts->host,
                  "Address to listen on (default 127.0.0.1); any other needs the printed URL's random token")
      ->default_str("127.0.0.1");
  cmd->add_option("--size", opts->size, "Initial image size: N or WxH, sides in [16, 4096] (the page then sets it)")
      ->default_str("512");
  cmd->add_option("--gpu", opts->gpu, "EGL device index, or auto (first GPU, else Mesa's llvmpipe)")
      ->default_str("auto");
  cmd->add_option("--gpu-memory", opts->gpu_memory, "GPU memory for bricks (e.g. 512MiB, 4GiB)")
      ->transform(CLI::AsSizeValue(true))
      ->default_str("2GiB");
  cmd->add_option("--fps", opts->fps, "Frame-rate target while interacting (0: every frame at full quality)")
      ->default_str("10");
  cmd->callback([opts] { run_view(*opts); });
}

}  // namespace ugvr::cli
