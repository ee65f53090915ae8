// Face-topology build time and memory for a tetrahedral mesh of N cells.
//   bench_topology [TETS=10000000] [INPUT...]
// Without INPUT, builds an N-tet mesh in memory (a curvilinear box split 6 tets per hex, its vertices jittered and
// renumbered randomly so the memory access pattern is that of a real unstructured mesh, not of a grid). With INPUT,
// reads that dataset (first block must be unstructured). Prints one JSON line.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "ugvr/core/memory.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/topology.h"
#include "ugvr/io/reader.h"

using namespace ugvr;

static UnstructuredMesh synthetic_tets(uint64_t target) {
  const uint32_t n = uint32_t(std::cbrt(double(target) / 6.0)) + 1;
  ImageGrid g{GridDims{{n + 1, n + 1, n + 1}}, {0, 0, 0}, {1, 1, 1}};
  UnstructuredMesh m = make_explicit_cells(g, StructuredCellShape::SixTetrahedra).mesh;
  // Random vertex numbering: destroys the grid's locality like a real mesh generator's output would.
  std::vector<uint32_t> perm(m.point_count());
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(42));
  std::vector<Vec3f> pts(m.point_count());
  for (size_t i = 0; i < perm.size(); ++i) pts[perm[i]] = m.points[i];
  m.points = std::move(pts);
  for (uint32_t& v : m.connectivity) v = perm[v];
  return m;
}

int main(int argc, char** argv) {
  const uint64_t target = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 10'000'000;
  UnstructuredMesh mesh;
  std::string source = "synthetic";
  if (argc > 2) {
    std::vector<std::string> inputs(argv + 2, argv + argc);
    Dataset ds = read_dataset(inputs);
    mesh = std::move(std::get<UnstructuredMesh>(ds.blocks.at(0).grid));
    source = inputs[0];
  } else {
    mesh = synthetic_tets(target);
  }
  const uint64_t rss_before = current_rss_bytes();
  const auto t0 = std::chrono::steady_clock::now();
  const MeshTopology topo = build_topology(mesh);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "{\"bench\":\"topology\",\"source\":\"%s\",\"cells\":%llu,\"points\":%llu,\"seconds\":%.3f,"
      "\"cells_per_second\":%.0f,\"boundary_faces\":%llu,\"nonmanifold_faces\":%llu,\"mesh_bytes\":%llu,"
      "\"topology_bytes\":%llu,\"rss_before_bytes\":%llu,\"peak_rss_bytes\":%llu}\n",
      source.c_str(), (unsigned long long)mesh.cell_count(), (unsigned long long)mesh.point_count(), seconds,
      double(mesh.cell_count()) / seconds, (unsigned long long)topo.boundary.size(),
      (unsigned long long)topo.nonmanifold_faces, (unsigned long long)mesh.memory_bytes(),
      (unsigned long long)topo.memory_bytes(), (unsigned long long)rss_before, (unsigned long long)peak_rss_bytes());
  return 0;
}
