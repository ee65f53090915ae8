// The hybrid engine's time-step switch on a store with time and cells (issue 18; `ugvr build SERIES --time all
// --cells`) against opening the store afresh at that step.
//   bench_hybrid_time_switch STORE [--field NAME] [--size PIXELS (128)] [--rounds N (3)]
// Per round, alternately which goes first, for each step s = 1 .. S-1 then 0:
//   switch  an engine kept open (its cells prepared for the previous step) set to step s, then one converged frame
//           (cut = leaves): the granted nodes keep their prepared cells and get step s's values (cell_cache.h)
//   fresh   a new engine on the store (the store opened, the shaders built), set to step s, then the same frame: every
//           granted node read and prepared
// Prints one JSON line: medians of `cells_seconds` (the frame's choosing, reading, preparing or swapping and uploading
// of cells, LodRenderStats::cells_seconds) and of `seconds` (switch: set_time_step and the frame; fresh: the open,
// set_time_step and the frame), the exact nodes, and `speedup_cells`, `speedup` (fresh / switch).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/store/brick_store.h"

using namespace ugvr;

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Times {
  std::vector<double> cells, seconds;
  uint64_t exact = 0, prepared = 0, swapped = 0;
};
}  // namespace

int main(int argc, char** argv) {
  std::string store_path, field;
  int size = 128, rounds = 3;
  for (int i = 1; i < argc; ++i) {
    const bool more = i + 1 < argc;
    if (!std::strcmp(argv[i], "--field") && more) {
      field = argv[++i];
    } else if (!std::strcmp(argv[i], "--size") && more) {
      size = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--rounds") && more) {
      rounds = std::max(1, std::atoi(argv[++i]));
    } else {
      store_path = argv[i];
    }
  }
  if (store_path.empty()) {
    std::fprintf(stderr, "usage: bench_hybrid_time_switch STORE [--field NAME] [--size N] [--rounds N]\n");
    return 2;
  }
  try {
    const BrickStoreReader store(store_path);
    if (store.step_count() < 2 || !store.has_cells())
      throw Error(store_path +
                  ": a store with several time steps and cells is needed (ugvr build SERIES --time all "
                  "--cells)");
    if (field.empty()) field = store.layout().fields.at(0).name;
    const int f = store.field_index(field);
    if (f < 0) throw Error(store_path + ": no field " + field);
    const BrickStoreField& fd = store.layout().fields[size_t(f)];
    const auto at = [&](double u) { return fd.min + u * (fd.max - fd.min); };
    TransferFunction tf;
    tf.color_points = {{at(0), {0.1, 0.2, 0.9}}, {at(0.5), {0.2, 0.9, 0.3}}, {at(1), {0.95, 0.2, 0.1}}};
    tf.opacity_points = {{at(0), 0.0}, {at(0.3), 0.2}, {at(0.6), 0.9}, {at(1), 0.9}};
    tf.opacity_unit_distance = 0.05 * store.layout().data.size().x;
    RenderSettings rs;
    rs.width = rs.height = size;
    const CutSpec leaves{CutSpec::Kind::Leaves, 0};
    const Camera cam = camera_preset("iso", store.layout().data);
    LodOptions lo;
    lo.hybrid = true;
    GlContext gl;
    LodEngine kept(store_path, gl, lo);
    kept.set_field(field);
    kept.render(cam, tf, rs, leaves);  // step 0 prepared
    Times sw, fr;
    auto measure = [&](bool fresh, uint32_t step) {
      LodRenderStats st;
      const auto t0 = std::chrono::steady_clock::now();
      if (fresh) {
        LodEngine e(store_path, gl, lo);
        e.set_field(field);
        e.set_time_step(step);
        e.render(cam, tf, rs, leaves, &st);
      } else {
        kept.set_time_step(step);
        kept.render(cam, tf, rs, leaves, &st);
      }
      Times& t = fresh ? fr : sw;
      t.seconds.push_back(seconds_since(t0));
      t.cells.push_back(st.cells_seconds);
      t.exact = st.exact_nodes, t.prepared = st.cells_prepared, t.swapped = st.cells_swapped;
      std::fprintf(stderr, "%s step %u: %.3f s, cells %.3f s, %llu exact, %llu prepared, %llu swapped\n",
                   fresh ? "fresh " : "switch", step, t.seconds.back(), st.cells_seconds,
                   (unsigned long long)st.exact_nodes, (unsigned long long)st.cells_prepared,
                   (unsigned long long)st.cells_swapped);
    };
    for (int round = 0; round < rounds; ++round) {
      for (uint32_t k = 1; k <= store.step_count(); ++k) {
        const uint32_t step = k % store.step_count();
        for (int j = 0; j < 2; ++j) measure((round + j) % 2 == 1, step);  // alternate which goes first
      }
    }
    std::printf(
        "{\"store\": \"%s\", \"field\": \"%s\", \"steps\": %u, \"size\": %d, \"rounds\": %d, \"gl\": \"%s\", "
        "\"switch\": {\"cells_seconds\": %.4f, \"seconds\": %.4f, \"exact\": %llu, \"prepared\": %llu, \"swapped\": "
        "%llu}, \"fresh\": {\"cells_seconds\": %.4f, \"seconds\": %.4f, \"exact\": %llu, \"prepared\": %llu}, "
        "\"speedup_cells\": %.2f, \"speedup\": %.2f}\n",
        store_path.c_str(), field.c_str(), store.step_count(), size, rounds, gl.renderer().c_str(), median(sw.cells),
        median(sw.seconds), (unsigned long long)sw.exact, (unsigned long long)sw.prepared,
        (unsigned long long)sw.swapped, median(fr.cells), median(fr.seconds), (unsigned long long)fr.exact,
        (unsigned long long)fr.prepared, median(fr.cells) / std::max(1e-9, median(sw.cells)),
        median(fr.seconds) / std::max(1e-9, median(sw.seconds)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_hybrid_time_switch: %s\n", e.what());
    return 1;
  }
  return 0;
}
