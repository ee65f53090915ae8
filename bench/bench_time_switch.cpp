// The exact engine's time-step switch against loading the mesh again (issue 18).
//   bench_time_switch INPUT... [--field NAME] [--rounds N] [--size PIXELS (256)] [--read-pairs]
// INPUT is any time series (an Exodus file, a .pvd, a .series, a numbered pattern, PLOT3D grid + solutions). Times,
// each the median over N rounds that walk the steps 0, 1, ..., n-1, 0, ...:
//   reload   read the step, build the walk mesh, bind the field (what a viewer without series support does)
//   switch   ExactScene::set_step: read the step, compare its geometry (fingerprint, unless the format says static),
//            swap the field values on the walk mesh built once
//   bind     the field swap alone (the step already in memory): ExactEngine::set_field
//   playback set_step after ExactScene::prefetch of that step and a --size frame of the current one (what `ugvr render
//            --time` does): the read overlaps the frame, the switch waits only for what is left of it
//   --read-pairs  the step's read alone, alternated round by round on the same step: whole (read_time_step and, where
//            the series detects its geometry, the geometry fingerprint: what a switch read before fields-only reads; a
//            series static by its format, PLOT3D's, was not fingerprinted) then fields only (StepFieldReader::read
//            with the mesh's layout kept by read_whole of step 0); `whole_read_seconds`, `fields_read_seconds` and
//            `speedup_fields_read` (their medians' ratio) are added, and `read_pairs`: each pair's two seconds
// Prints one JSON line (`rebuilds`, `fields_only`: the switches that rebuilt the walk mesh, that read the step without
// its mesh); `speedup` = reload / switch, `speedup_playback` = reload / playback, `speedup_bind` = reload /
// bind.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/render/exact/exact_renderer.h"

using namespace ugvr;

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> inputs;
  std::string field;
  int rounds = 5, size = 256;
  bool read_pairs = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--read-pairs")) {
      read_pairs = true;
    } else if (!std::strcmp(argv[i], "--field") && i + 1 < argc) {
      field = argv[++i];
    } else if (!std::strcmp(argv[i], "--size") && i + 1 < argc) {
      size = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--rounds") && i + 1 < argc) {
      rounds = std::max(1, std::atoi(argv[++i]));
    } else {
      inputs.push_back(argv[i]);
    }
  }
  if (inputs.empty()) {
    std::fprintf(stderr, "usage: bench_time_switch INPUT... [--field NAME] [--rounds N]\n");
    return 2;
  }
  try {
    auto series = std::make_shared<const TimeSeries>(list_time_steps(inputs));
    const size_t n = series->size();
    if (n < 2) throw Error(inputs[0] + ": one step, nothing to switch");
    std::vector<double> reload, sw, bind;
    // Reload: a new scene per step, as if each step were a separate dataset.
    for (int r = 0; r < rounds; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      ExactScene fresh(series, uint32_t((r + 1) % n));
      fresh.bind(field);
      reload.push_back(seconds_since(t0));
    }
    ExactScene scene(series, 0);
    scene.bind(field);
    uint64_t cells = scene.engine.cell_count();
    for (int r = 0; r < rounds; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      scene.set_step(uint32_t((r + 1) % n));
      sw.push_back(seconds_since(t0));
      const auto t1 = std::chrono::steady_clock::now();
      scene.engine.set_field(*scene.dataset, scene.bound.value_or(field));
      bind.push_back(seconds_since(t1));
    }
    // Playback: prefetch the next step, render this one, then switch.
    std::vector<double> playback, frame;
    RenderSettings settings;
    settings.width = settings.height = size;
    const Camera camera = default_camera(scene.engine.bounds());
    const TransferFunction tf =
        default_transfer_function(scene.engine.field_min(), scene.engine.field_max(), scene.engine.bounds());
    for (int r = 0; r < rounds; ++r) {
      const uint32_t next = uint32_t((scene.step + 1) % n);
      scene.prefetch(next);
      const auto t0 = std::chrono::steady_clock::now();
      (void)scene.engine.render(camera, tf, settings);
      frame.push_back(seconds_since(t0));
      const auto t1 = std::chrono::steady_clock::now();
      scene.set_step(next);
      playback.push_back(seconds_since(t1));
    }
    std::vector<double> whole_read, fields_read;
    if (read_pairs) {
      StepFieldReader reader(series);
      (void)reader.read_whole(0);
      for (int r = 0; r < rounds; ++r) {
        const uint32_t k = uint32_t((r + 1) % n);
        if (!reader.has_mesh_of(k, 0)) throw Error(inputs[0] + ": step " + std::to_string(k) + " has another mesh");
        const auto t0 = std::chrono::steady_clock::now();
        {
          const Dataset whole = read_time_step(*series, k);
          if (series->geometry == SeriesGeometry::Detect) {
            volatile uint64_t fingerprint = geometry_fingerprint(whole);
            (void)fingerprint;
          }
        }
        whole_read.push_back(seconds_since(t0));
        const auto t1 = std::chrono::steady_clock::now();
        { const StepFields fields = reader.read(k); }
        fields_read.push_back(seconds_since(t1));
      }
    }
    const double m_reload = median(reload), m_switch = median(sw), m_bind = median(bind), m_playback = median(playback);
    std::printf(
        "{\"bench\":\"time_switch\",\"input\":\"%s\",\"kind\":\"%s\",\"steps\":%zu,\"cells\":%llu,\"field\":\"%s\","
        "\"geometry\":\"%s\",\"rounds\":%d,\"reload_seconds\":%.6f,\"switch_seconds\":%.6f,\"bind_seconds\":%.6f,"
        "\"playback_seconds\":%.6f,\"frame_seconds\":%.4f,\"frame_size\":%d,\"speedup\":%.1f,\"speedup_playback\":%.1f,"
        "\"speedup_bind\":%.1f,\"rebuilds\":%llu,\"fields_only\":%llu,\"peak_rss_bytes\":%llu",
        inputs[0].c_str(), std::string(series_kind_name(series->kind)).c_str(), n, (unsigned long long)cells,
        scene.engine.field_name().c_str(), series->geometry == SeriesGeometry::Static ? "static" : "detected", rounds,
        m_reload, m_switch, m_bind, m_playback, median(frame), size, m_reload / m_switch, m_reload / m_playback,
        m_reload / m_bind, (unsigned long long)scene.rebuilds, (unsigned long long)scene.fields_only,
        (unsigned long long)peak_rss_bytes());
    if (read_pairs) {
      std::printf(",\"whole_read_seconds\":%.6f,\"fields_read_seconds\":%.6f,\"speedup_fields_read\":%.1f",
                  median(whole_read), median(fields_read), median(whole_read) / median(fields_read));
      // Each pair (whole, fields), in the order run: the median of their ratios is the steadier figure under load.
      std::printf(",\"read_pairs\":[");
      for (size_t r = 0; r < whole_read.size(); ++r)
        std::printf("%s[%.4f,%.4f]", r ? "," : "", whole_read[r], fields_read[r]);
      std::printf("]");
    }
    std::printf("}\n");
  } catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
