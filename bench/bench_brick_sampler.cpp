// Leaf sampling throughput: every node of one octree level over the whole mesh sampled at R³, single-threaded and
// with oneTBB over bricks (one scratch per thread).
//   bench_brick_sampler [R=32] [LEVEL=3] [DATA_DIR=$UGVR_DATA or ../shared/data] [REPEATS=3] [ONLY]
// Runs the blunt fin and the oxygen post, each as hexahedra (trilinear) and split 5 tets per hexahedron, one scalar
// each (blunt fin Density, oxygen post StagnationEnergy). Prints one JSON line per run; times are the median of
// REPEATS (ONLY: run just the configurations whose "dataset/cells" name contains it, e.g. "lox-post/hex");
// candidate lists (cells_overlapping_boxes) are timed apart ("setup_s") and not counted in samples/s.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "ugvr/grid/structured_cells.h"
#include "ugvr/io/reader.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/cell_box_overlap.h"

using namespace ugvr;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// CPU time of this thread / of the whole process: on a shared, loaded machine the wall time measures the load as
// much as the code, the CPU time the code.
double cpu_seconds(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double load_average() {
  double l[1] = {0};
  return getloadavg(l, 1) == 1 ? l[0] : -1;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

void run(const std::string& name, const Dataset& ds, StructuredCellShape shape, const char* scalar, uint32_t R,
         int level, int repeats) {
  const Block block = to_unstructured_block(ds.blocks.at(0), shape);
  const auto& mesh = std::get<UnstructuredMesh>(block.grid);
  const BrickSampler sampler(mesh, {block.fields.scalar(scalar)});
  BrickLattice lattice;
  lattice.root = mesh.bounds();
  lattice.resolution = R;
  const uint32_t n = 1u << level;
  const uint64_t bricks = uint64_t(n) * n * n;

  auto t0 = std::chrono::steady_clock::now();
  const BoxCellLists lists = cells_overlapping_boxes(mesh, lattice.root, {n, n, n});
  const double setup = seconds_since(t0);
  auto node_of = [&](uint64_t b) {
    return std::array<uint32_t, 3>{uint32_t(b % n), uint32_t(b / n % n), uint32_t(b / n / n)};
  };

  // Single thread.
  std::vector<double> serial, serial_cpu;
  BrickSamplerStats stats;
  uint64_t valid = 0;
  {
    BrickScratch scratch;
    BrickSamples out;
    for (int r = 0; r < repeats; ++r) {
      BrickSamplerStats st;
      uint64_t v = 0;
      t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_seconds(CLOCK_THREAD_CPUTIME_ID);
      for (uint64_t b = 0; b < bricks; ++b) {
        sampler.sample(lattice, level, node_of(b), lists.box(b), scratch, out, &st);
        v += out.valid;
      }
      serial.push_back(seconds_since(t0));
      serial_cpu.push_back(cpu_seconds(CLOCK_THREAD_CPUTIME_ID) - c0);
      stats = st, valid = v;
    }
  }
  // oneTBB over bricks.
  std::vector<double> parallel, parallel_cpu;
  int threads_used = 0;  // worker threads that sampled at least one brick
  {
    struct Local {
      BrickScratch scratch;
      BrickSamples out;
      uint64_t valid = 0;
    };
    for (int r = 0; r < repeats; ++r) {
      tbb::enumerable_thread_specific<Local> locals;
      t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_seconds(CLOCK_PROCESS_CPUTIME_ID);
      tbb::parallel_for(uint64_t(0), bricks, [&](uint64_t b) {
        Local& l = locals.local();
        sampler.sample(lattice, level, node_of(b), lists.box(b), l.scratch, l.out);
        l.valid += l.out.valid;
      });
      parallel.push_back(seconds_since(t0));
      parallel_cpu.push_back(cpu_seconds(CLOCK_PROCESS_CPUTIME_ID) - c0);
      uint64_t v = 0;
      for (const Local& l : locals) v += l.valid;
      threads_used = std::max(threads_used, int(locals.size()));
      if (v != valid)
        std::fprintf(stderr, "parallel run found %llu valid samples, serial %llu\n", (unsigned long long)v,
                     (unsigned long long)valid);
    }
  }
  const double samples = double(bricks) * R * R * R;
  const double ts = median(serial), tp = median(parallel), cs = median(serial_cpu), cp = median(parallel_cpu);
  std::printf(
      "{\"bench\":\"brick_sampler\",\"dataset\":\"%s\",\"cells\":\"%s\",\"cell_count\":%llu,\"scalar\":\"%s\","
      "\"R\":%u,\"level\":%d,\"bricks\":%llu,\"samples\":%.0f,\"valid_fraction\":%.4f,\"setup_s\":%.3f,"
      "\"serial_s\":%.3f,\"serial_samples_per_s\":%.0f,\"serial_cpu_s\":%.3f,\"samples_per_cpu_s\":%.0f,"
      "\"threads\":%d,\"threads_used\":%d,\"parallel_s\":%.3f,\"parallel_samples_per_s\":%.0f,\"parallel_cpu_s\":%.3f,"
      "\"load_average\":%.2f,\"cache_hit_fraction\":%.4f,\"searches_per_sample\":%.4f,"
      "\"cell_tests_per_sample\":%.3f,\"candidates_per_brick\":%.1f,\"bucket_entries_per_brick\":%.1f}\n",
      name.c_str(), shape == StructuredCellShape::Hexahedra ? "hexahedra" : "5 tets",
      (unsigned long long)mesh.cell_count(), scalar, R, level, (unsigned long long)bricks, samples,
      double(valid) / samples, setup, ts, samples / ts, cs, samples / cs, tbb::info::default_concurrency(),
      threads_used, tp, samples / tp, cp, load_average(), double(stats.cache_hits) / double(stats.samples),
      double(stats.searches) / double(stats.samples), double(stats.cell_tests) / double(stats.samples),
      double(stats.candidates) / double(bricks), double(stats.bucket_entries) / double(bricks));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const uint32_t R = argc > 1 ? uint32_t(std::strtoul(argv[1], nullptr, 10)) : 32;
  const int level = argc > 2 ? std::atoi(argv[2]) : 3;
  std::string dir = argc > 3 ? argv[3] : "";
  if (dir.empty()) dir = std::getenv("UGVR_DATA") ? std::getenv("UGVR_DATA") : "../shared/data";
  const int repeats = argc > 4 ? std::max(1, std::atoi(argv[4])) : 3;
  const std::string only = argc > 5 ? argv[5] : "";
  struct Input {
    const char* name;
    const char* xyz;
    const char* q;
    const char* scalar;
  };
  for (const Input& in : {Input{"blunt-fin", "blunt-fin/bluntfinxyz.bin", "blunt-fin/bluntfinq.bin", "Density"},
                          Input{"lox-post", "lox-post/postxyz.bin", "lox-post/postq.bin", "StagnationEnergy"}}) {
    const Dataset ds = read_dataset(std::vector<std::string>{dir + "/" + in.xyz, dir + "/" + in.q});
    for (auto shape : {StructuredCellShape::Hexahedra, StructuredCellShape::FiveTetrahedra}) {
      const std::string label =
          std::string(in.name) + (shape == StructuredCellShape::Hexahedra ? "/hexahedra" : "/5 tets");
      if (label.find(only) == std::string::npos) continue;
      run(in.name, ds, shape, in.scalar, R, level, repeats);
    }
  }
  return 0;
}
