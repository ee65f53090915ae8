// A CGNS time series for the step-switch benchmark (issue 18 [time], bench/run_cgns_switch.sh):
//   make_cgns_series OUT.cgns [--n N (100)] [--steps S (3)]
// One structured zone of N x N x N points (a gently warped box, float64 coordinates), HDF5, and S vertex
// FlowSolutions "Step0".. (Density and MomentumX/Y/Z, float64) named per step by the zone's FlowSolutionPointers:
// the layout of a CFD code writing its steps beside one static grid. At N=100: 24 MB of coordinates, 32 MB a step.
#include <cgnslib.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

void check(int status, const char* what) {
  if (status == CG_OK) return;
  std::fprintf(stderr, "make_cgns_series: %s: %s\n", what, cg_get_error());
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_cgns_series OUT.cgns [--n N] [--steps S]\n");
    return 2;
  }
  const std::string out = argv[1];
  int n = 100, steps = 3;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--n")) n = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--steps")) steps = std::atoi(argv[i + 1]);
  }
  if (n < 2 || steps < 1) {
    std::fprintf(stderr, "make_cgns_series: --n must be at least 2 and --steps at least 1\n");
    return 2;
  }
  check(cg_set_file_type(CG_FILE_HDF5), "file type");
  int fn = 0, B = 0, Z = 0, C = 0;
  check(cg_open(out.c_str(), CG_MODE_WRITE, &fn), "open");
  check(cg_base_write(fn, "Base", 3, 3, &B), "base");
  cgsize_t size[9] = {n, n, n, n - 1, n - 1, n - 1, 0, 0, 0};
  check(cg_zone_write(fn, B, "Box", size, Structured, &Z), "zone");
  const size_t points = size_t(n) * size_t(n) * size_t(n);
  std::vector<double> x(points), y(points), z(points);
  for (size_t p = 0; p < points; ++p) {
    const double u = double(p % size_t(n)) / (n - 1), v = double(p / size_t(n) % size_t(n)) / (n - 1),
                 w = double(p / (size_t(n) * size_t(n))) / (n - 1);
    x[p] = u + 0.05 * std::sin(M_PI * v) * std::sin(M_PI * w);
    y[p] = v + 0.05 * std::sin(M_PI * u) * std::sin(M_PI * w);
    z[p] = w;
  }
  check(cg_coord_write(fn, B, Z, RealDouble, "CoordinateX", x.data(), &C), "CoordinateX");
  check(cg_coord_write(fn, B, Z, RealDouble, "CoordinateY", y.data(), &C), "CoordinateY");
  check(cg_coord_write(fn, B, Z, RealDouble, "CoordinateZ", z.data(), &C), "CoordinateZ");
  std::vector<double> values(points);
  for (int k = 0; k < steps; ++k) {
    int sol = 0, F = 0;
    const std::string name = "Step" + std::to_string(k);
    check(cg_sol_write(fn, B, Z, name.c_str(), Vertex, &sol), "solution");
    for (const char* field : {"Density", "MomentumX", "MomentumY", "MomentumZ"}) {
      for (size_t p = 0; p < points; ++p) {
        const double r = std::hypot(x[p] - 0.5 - 0.1 * k, y[p] - 0.5);
        values[p] = (1 + 0.5 * std::exp(-20 * r * r)) * (field[0] == 'D' ? 1.0 : 0.1 * (field[8] - 'W'));
      }
      check(cg_field_write(fn, B, Z, sol, RealDouble, field, values.data(), &F), field);
    }
  }
  check(cg_ziter_write(fn, B, Z, "ZoneIterativeData"), "ZoneIterativeData");
  check(cg_goto(fn, B, "Zone_t", Z, "ZoneIterativeData_t", 1, "end"), "goto");
  std::vector<char> pointers(size_t(32) * size_t(steps), ' ');
  for (int k = 0; k < steps; ++k) {
    const std::string name = "Step" + std::to_string(k);
    std::memcpy(pointers.data() + 32 * k, name.data(), name.size());
  }
  cgsize_t dims[2] = {32, steps};
  check(cg_array_write("FlowSolutionPointers", Character, 2, dims, pointers.data()), "FlowSolutionPointers");
  check(cg_biter_write(fn, B, "BaseIterativeData", steps), "BaseIterativeData");
  check(cg_close(fn), "close");
  std::printf("%s: %zu points, %d steps\n", out.c_str(), points, steps);
  return 0;
}
