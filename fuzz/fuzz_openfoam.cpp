// libFuzzer target for the OpenFOAM FoamFile parser (src/ugvr/io/openfoam_reader.h): the input is one FoamFile, plain
// or gzip-compressed, parsed as what its header's class says (points, faces, owner/neighbour labels, boundary,
// cellZones, a vol/point field). Any input must either parse or fail with ugvr::Error, never crash, hang or allocate
// without bound. The parser streams through a window: each input is parsed twice, through the default window and
// through the smallest one (every token, comment and binary value then crosses a refill), and the two must yield the
// same values or the same error message, else the target aborts. Seeds: the files of the cases in
// tests/data/openfoam (scripts/fuzz.sh).
#include <algorithm>
#include <cstdlib>
#include <string>

#include "fuzz_support.h"
#include "ugvr/core/error.h"
#include "ugvr/io/openfoam_reader.h"

namespace {

// The counts a case would check the parsed values against (small, so that a uniform list cannot ask for much).
constexpr uint64_t kPoints = 882, kCells = 400;  // the cavity case's

template <class T>
void append(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

// What the file yields, or its error message.
std::string parse(const std::string& path, size_t window) {
  std::string out;
  try {
    ugvr::openfoam::FoamFile f(path, window);
    const std::string& cls = f.header().class_name;
    out = cls + "|" + f.header().object + "|";
    if (cls == "vectorField") {
      for (const auto& p : f.points()) append(out, p);
    } else if (cls == "faceList" || cls == "faceCompactList") {
      const auto faces = f.faces(kPoints);
      for (uint32_t v : faces.vertices) append(out, v);
      for (uint64_t o : faces.offsets) append(out, o);
    } else if (cls == "labelList") {
      for (int64_t l : f.labels(int64_t(kCells) - 1, true)) append(out, l);
    } else if (cls == "polyBoundaryMesh") {
      for (const auto& p : f.patches()) out += p.name + "," + p.type + "," + std::to_string(p.n_faces + p.start_face);
    } else if (cls == "regIOobject" || f.header().object == "cellZones") {
      for (const auto& z : f.cell_zones(kCells)) {
        out += z.name;
        for (uint64_t c : z.cells) append(out, c);
      }
    } else if (auto v = f.internal_field(kCells)) {
      for (double x : v->values) append(out, x);
    }
  } catch (const ugvr::Error& e) {
    // Rejected input, reported the way a user would see it: fine.
    out = std::string("error: ") + e.what();
  }
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ugvr::fuzz::MemFile file("fuzz_openfoam", data, size);
  const std::string whole = parse(file.path(), ugvr::openfoam::FoamFile::kDefaultWindow);
  const std::string tiny = parse(file.path(), ugvr::openfoam::FoamFile::kMinWindow);
  // A damaged gzip stream is found when the window reaches it: a large window may reach it before the parser meets an
  // error in the text before it, a small one after. Otherwise the window must not change what is read.
  const bool gzip_error = whole.find("gzip data") != std::string::npos || tiny.find("gzip data") != std::string::npos;
  if (whole != tiny && !gzip_error) std::abort();  // the window changed what was read: a streaming bug
  return 0;
}
