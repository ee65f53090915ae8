// The sort-last compositor alone (src/ugvr/mpi/mpi_compositor.h): every rank holds a premultiplied RGBA float image of
// WIDTHxHEIGHT (a disc of partly transparent colour, different per rank, transparent around it, as a volume's box
// projects), the ranks composite it in a kd-tree-like order REPEAT times, and rank 0 prints the median over the
// repeats of the slowest rank's time in the compositor. The algorithm is UGVR_COMPOSITOR's (mpi_compositor.h).
// "dense": every pixel of every rank is partly opaque (no transparent pixels for IceT's run-length encoding to skip:
// the worst case, a rank whose box covers the whole frame).
//   mpirun -np N bench_mpi_composite [WIDTH HEIGHT REPEAT [dense]]
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <string_view>
#include <vector>

#include "ugvr/mpi/mpi_compositor.h"
#include "ugvr/mpi/mpi_session.h"

int main(int argc, char** argv) {
  ugvr::mpi::init(&argc, &argv);
  const int width = argc > 1 ? std::atoi(argv[1]) : 1920, height = argc > 2 ? std::atoi(argv[2]) : 1080;
  const int repeat = argc > 3 ? std::atoi(argv[3]) : 11;
  const bool dense = argc > 4 && std::string_view(argv[4]) == "dense";
  const int n = ugvr::mpi::size(), me = ugvr::mpi::rank();
  std::vector<float> image(size_t(width) * size_t(height) * 4, 0.0f);
  // Rank r's disc: centred along a diagonal, radius a third of the height.
  const double cx = width * (0.25 + 0.5 * (me + 0.5) / n), cy = height * (0.25 + 0.5 * (me + 0.5) / n);
  const double radius = height / 3.0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double d = dense ? 0.5 : std::hypot(x - cx, y - cy) / radius;
      if (d >= 1) continue;
      const float a = float(0.6 * (1 - d));
      float* px = image.data() + (size_t(y) * size_t(width) + size_t(x)) * 4;
      px[0] = a * float(me % 3 == 0), px[1] = a * float(me % 3 == 1), px[2] = a * float(me % 3 == 2), px[3] = a;
    }
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::vector<double> times;
  for (int r = 0; r < repeat + 1; ++r) {
    MPI_Barrier(MPI_COMM_WORLD);
    double seconds = 0, slowest = 0;
    ugvr::mpi::composite(image, width, height, order, &seconds);
    MPI_Reduce(&seconds, &slowest, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    if (r > 0) times.push_back(slowest);  // the first pays for buffers and IceT's context
  }
  if (me == 0) {
    std::sort(times.begin(), times.end());
    std::printf(
        "{\"compositor\": \"%s\", \"ranks\": %d, \"width\": %d, \"height\": %d, \"repeat\": %d, "
        "\"dense\": %s, \"median_seconds\": %.5f, \"min_seconds\": %.5f, \"max_seconds\": %.5f}\n",
        ugvr::mpi::compositor_name().c_str(), n, width, height, repeat, dense ? "true" : "false",
        times[times.size() / 2], times.front(), times.back());
  }
  ugvr::mpi::finalize();
  return 0;
}
