// libFuzzer target for the time-series manifests (io/time_series.h) — a VTK collection (.pvd) or ParaView's .series
// JSON, listed as `ugvr info` and `build --time` list them — and the step selections of `--time`. The first byte
// picks: 0 a .pvd, 1 a .series (the rest is the file's text), 2 a step selection (the second byte is the series'
// step count, the rest the spec). The manifest is written beside a few empty data files (a.vtu, b.vtu, c.vtk) so
// that entries naming them get past the existence check. Only ugvr::Error may escape.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/time_series.h"

namespace {

const std::string& directory() {
  static const std::string dir = [] {
    const char* tmp = std::getenv("TMPDIR");
    const std::string d =
        std::string(tmp && *tmp ? tmp : "/tmp") + "/ugvr-fuzz-time-series-" + std::to_string(getpid());
    std::filesystem::create_directories(d);
    for (const char* name : {"a.vtu", "b.vtu", "c.vtk"}) std::ofstream(d + "/" + name).flush();
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  ugvr::Progress::set_enabled(false);
  const int kind = data[0] % 3;
  try {
    if (kind == 2) {
      const std::string_view spec(reinterpret_cast<const char*>(data + 2), size - 2);
      const auto steps = ugvr::parse_step_selection(spec, data[1], "--time");
      volatile size_t sink = steps.size();
      (void)sink;
      return 0;
    }
    const std::string path = directory() + (kind == 0 ? "/m.pvd" : "/m.series");
    {
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out.write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
    }
    const std::string inputs[] = {path};
    const ugvr::TimeSeries series = ugvr::list_time_steps(inputs);
    volatile size_t sink = series.size();
    for (const ugvr::TimeStep& s : series.steps) sink = sink + s.files.size() + size_t(s.time != 0);
    (void)sink;
  } catch (const ugvr::Error&) {
    // Refused with a message naming the file and the entry.
  }
  return 0;
}
