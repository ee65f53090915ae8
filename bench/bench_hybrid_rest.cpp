// Progressive refinement to exact cells at rest (issue 17 [hybrid]): how long a resting view takes from its first
// exact node to every candidate exact, with fixed batches (TimeCriticalOptions::exact_growth 1, the schedule before)
// against the geometric one (exact_growth 2, the default).
//   bench_hybrid_rest STORE [--field NAME] [--size PIXELS (512)] [--rounds N (3)] [--batch B (64)] [--pixels P (1)]
// STORE is built with its leaves' cells (`ugvr build ... --cells`). Per round, alternately each schedule: a fresh
// hybrid engine and time-critical session (10 fps target) at the `iso` camera; frames until the session says
// converged. The transfer function rises steeply over the middle tenth of the field's range (as tests/test_hybrid.cpp).
// Prints one JSON line: per schedule the medians of `rest_seconds` (first resting frame with an exact node to the
// converged frame, inclusive), `frames` (those frames), `last_frame_seconds`, and the exact nodes at the end.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/render/lod/time_critical.h"
#include "ugvr/store/brick_store.h"

using namespace ugvr;

namespace {
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Run {
  double rest_seconds = 0, last_frame_seconds = 0;
  int frames = 0;
  uint64_t exact = 0, candidates = 0;
};

Run rest_to_exact(const std::string& store_path, const std::string& field, GlContext& gl, int size, uint64_t batch,
                  double growth, double pixels) {
  const BrickStoreReader store(store_path);
  LodOptions lo;
  lo.hybrid = true;
  LodEngine engine(store_path, gl, lo);
  engine.set_field(field);
  const BrickStoreField* fd = nullptr;
  for (const BrickStoreField& f : store.layout().fields)
    if (f.name == field) fd = &f;
  if (!fd) throw Error(store_path + ": no field " + field);
  const auto at = [&](double u) { return fd->min + u * (fd->max - fd->min); };
  TransferFunction tf;
  tf.color_points = {{at(0), {0.1, 0.2, 0.9}}, {at(0.5), {0.2, 0.9, 0.3}}, {at(1), {0.95, 0.2, 0.1}}};
  tf.opacity_points = {{at(0), 0.0}, {at(0.45), 0.0}, {at(0.55), 0.9}, {at(1), 0.9}};
  tf.opacity_unit_distance = 0.05 * store.layout().data.size().x;
  RenderSettings rs;
  rs.width = rs.height = size;
  TimeCriticalOptions tco;
  tco.target_fps = 10;
  tco.exact_batch = batch;
  tco.exact_growth = growth;
  tco.pixels = pixels;
  TimeCriticalRenderer session(engine, tco);
  const Camera cam = camera_preset("iso", store.layout().data);
  Run r;
  TimeCriticalFrame fr;
  for (int i = 0; i < 100000; ++i) {
    session.frame(cam, tf, rs, &fr);
    if (fr.render.exact_nodes > 0 || r.frames > 0) {
      r.rest_seconds += fr.seconds;
      r.frames += 1;
    }
    if (fr.converged) break;
  }
  if (!fr.converged) throw Error(store_path + ": the resting view did not converge");
  r.last_frame_seconds = fr.seconds;
  r.exact = fr.render.exact_nodes;
  r.candidates = fr.render.exact_candidates;
  return r;
}
}  // namespace

int main(int argc, char** argv) {
  std::string store, field;
  int size = 512, rounds = 3;
  uint64_t batch = 64;
  double pixels = 1;
  for (int i = 1; i < argc; ++i) {
    const bool more = i + 1 < argc;
    if (!std::strcmp(argv[i], "--field") && more) {
      field = argv[++i];
    } else if (!std::strcmp(argv[i], "--size") && more) {
      size = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--rounds") && more) {
      rounds = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--batch") && more) {
      batch = uint64_t(std::max(1, std::atoi(argv[++i])));
    } else if (!std::strcmp(argv[i], "--pixels") && more) {
      pixels = std::atof(argv[++i]);
    } else {
      store = argv[i];
    }
  }
  if (store.empty()) {
    std::fprintf(stderr, "usage: bench_hybrid_rest STORE [--field NAME] [--size N] [--rounds N] [--batch B]\n");
    return 2;
  }
  try {
    if (field.empty()) field = BrickStoreReader(store).layout().fields.at(0).name;
    GlContext gl;
    const double growths[2] = {1, 2};
    std::vector<double> secs[2], frames[2], last[2];
    Run end[2];
    for (int round = 0; round < rounds; ++round)
      for (int k = 0; k < 2; ++k) {
        const int s = round % 2 ? 1 - k : k;  // alternate which schedule goes first
        const Run r = rest_to_exact(store, field, gl, size, batch, growths[s], pixels);
        secs[s].push_back(r.rest_seconds), frames[s].push_back(r.frames), last[s].push_back(r.last_frame_seconds);
        end[s] = r;
        std::fprintf(stderr, "round %d growth %g: %.2f s, %d frames, last %.2f s, %llu of %llu exact\n", round,
                     growths[s], r.rest_seconds, r.frames, r.last_frame_seconds, (unsigned long long)r.exact,
                     (unsigned long long)r.candidates);
      }
    std::printf("{\"store\": \"%s\", \"field\": \"%s\", \"size\": %d, \"batch\": %llu, \"rounds\": %d, \"gl\": \"%s\"",
                store.c_str(), field.c_str(), size, (unsigned long long)batch, rounds, gl.renderer().c_str());
    for (int s = 0; s < 2; ++s)
      std::printf(
          ", \"growth_%g\": {\"rest_seconds\": %.3f, \"frames\": %g, \"last_frame_seconds\": %.3f, "
          "\"exact\": %llu, \"candidates\": %llu}",
          growths[s], median(secs[s]), median(frames[s]), median(last[s]), (unsigned long long)end[s].exact,
          (unsigned long long)end[s].candidates);
    std::printf(", \"speedup\": %.2f}\n", median(secs[0]) / std::max(1e-9, median(secs[1])));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_hybrid_rest: %s\n", e.what());
    return 1;
  }
  return 0;
}
