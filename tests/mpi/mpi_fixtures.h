// What the MPI tests share: mpirun of the ugvr binary and the non-convex fixture.
#pragma once
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "test_data.h"

namespace ugvr::test {

// `ranks` processes of `ugvr ARGS` under mpirun, killed after 120 s (a hang fails the test rather than the suite).
inline CommandResult mpirun(int ranks, const std::string& args) {
  // Open MPI refuses root unless told (CI containers run as root); one thread per rank.
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  return run_command("timeout 120 " + std::string(UGVR_MPIEXEC) + " --oversubscribe -np " + std::to_string(ranks) +
                     " " + UGVR_BINARY + " --quiet " + args);
}

// A U-shaped block of n^3 hexahedra (a slot cut out of a cube) as legacy VTK, with a smooth vertex field "s": rays
// leave the data and enter it again, and kd planes cut through the gap.
inline void write_u_shaped_mesh(const std::string& path, int n = 8) {
  std::ofstream out(path);
  out << "# vtk DataFile Version 3.0\nU\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS " << (n + 1) * (n + 1) * (n + 1)
      << " double\n";
  auto id = [&](int i, int j, int k) { return (k * (n + 1) + j) * (n + 1) + i; };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) out << i << " " << j << " " << k << "\n";
  std::vector<std::array<int, 8>> cells;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        if (i >= n / 4 && i < n - n / 4 && k >= 3 * n / 8) continue;  // the slot
        cells.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                         id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
      }
  out << "CELLS " << cells.size() << " " << cells.size() * 9 << "\n";
  for (const auto& c : cells) {
    out << 8;
    for (int v : c) out << " " << v;
    out << "\n";
  }
  out << "CELL_TYPES " << cells.size() << "\n";
  for (size_t c = 0; c < cells.size(); ++c) out << "12\n";
  out << "POINT_DATA " << (n + 1) * (n + 1) * (n + 1) << "\nSCALARS s double 1\nLOOKUP_TABLE default\n";
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) out << std::sin(0.7 * i) * std::cos(0.5 * j) + 0.1 * k << "\n";
}

}  // namespace ugvr::test
