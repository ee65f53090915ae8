// libFuzzer target for the OpenFOAM FoamFile parser (src/ugvr/io/openfoam_reader.h): the input is one FoamFile, plain
// or gzip-compressed, parsed as what its header's class says (points, faces, owner/neighbour labels, boundary,
// cellZones, a vol/point field). Any input must either parse or fail with ugvr::Error, never crash, hang or allocate
// without bound. Seeds: the files of the cases in tests/data/openfoam (scripts/fuzz.sh).
#include <algorithm>

#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/openfoam_reader.h"

namespace {

// The counts a case would check the parsed values against (small, so that a uniform list cannot ask for much).
constexpr uint64_t kPoints = 882, kCells = 400;  // the cavity case's

void parse(const std::string& path) {
  ugvr::openfoam::FoamFile f(path);
  const std::string& cls = f.header().class_name;
  volatile uint64_t sink = 0;
  if (cls == "vectorField") {
    for (const auto& p : f.points()) sink = sink + uint64_t(p.x != 0);
  } else if (cls == "faceList" || cls == "faceCompactList") {
    const auto faces = f.faces(kPoints);
    for (uint32_t v : faces.vertices) sink = sink + v;
    sink = sink + faces.offsets.back();
  } else if (cls == "labelList") {
    for (int64_t l : f.labels(int64_t(kCells) - 1, true)) sink = sink + uint64_t(l);
  } else if (cls == "polyBoundaryMesh") {
    for (const auto& p : f.patches()) sink = sink + p.n_faces + p.start_face;
  } else if (cls == "regIOobject" || f.header().object == "cellZones") {
    for (const auto& z : f.cell_zones(kCells)) sink = sink + z.cells.size();
  } else if (auto v = f.internal_field(kCells)) {
    for (double x : v->values) sink = sink + uint64_t(x != 0);
  }
  (void)sink;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ugvr::fuzz::MemFile file("fuzz_openfoam", data, size);
  try {
    parse(file.path());
  } catch (const ugvr::Error&) {
    // Rejected input, reported the way a user would see it: fine.
  }
  return 0;
}
