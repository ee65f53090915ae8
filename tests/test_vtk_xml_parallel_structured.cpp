// Parallel structured VTK XML files (.pvts, .pvti, .pvtr): pieces placed into the WholeExtent by their Extent read
// to the same dataset as one serial file of the whole grid; pieces that leave a gap, a piece file of another kind
// and a piece of the wrong size are refused naming the file. Fixtures are written here (ASCII arrays), two pieces
// split along i sharing the plane i = 1, as VTK's parallel writers do.
#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <string>

#include "test_data.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

using test::error_of;
using test::ScratchDir;

void write_file(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

using Extent = std::array<int, 6>;

std::string extent_text(const Extent& e) {
  std::string s;
  for (int v : e) s += (s.empty() ? "" : " ") + std::to_string(v);
  return s;
}

// One serial file ("StructuredGrid", "ImageData" or "RectilinearGrid") holding extent `e` of a grid whose values
// are functions of the global (i, j, k): point field p = i + 10 j + 100 k, cell field c = ci + 10 cj + 100 ck,
// curvilinear points (i + 0.1 j, j, 2 k), image origin 0 spacing (1, 0.5, 2), rectilinear axes i^2, j, 3 k.
std::string serial_file(const std::string& type, const Extent& e) {
  std::string p, c, pts, xs, ys, zs;
  for (int k = e[4]; k <= e[5]; ++k)
    for (int j = e[2]; j <= e[3]; ++j)
      for (int i = e[0]; i <= e[1]; ++i) {
        p += std::to_string(i + 10 * j + 100 * k) + " ";
        pts += std::to_string(i + 0.1 * j) + " " + std::to_string(j) + " " + std::to_string(2 * k) + " ";
      }
  for (int k = e[4]; k < e[5]; ++k)
    for (int j = e[2]; j < e[3]; ++j)
      for (int i = e[0]; i < e[1]; ++i) c += std::to_string(i + 10 * j + 100 * k) + " ";
  for (int i = e[0]; i <= e[1]; ++i) xs += std::to_string(i * i) + " ";
  for (int j = e[2]; j <= e[3]; ++j) ys += std::to_string(j) + " ";
  for (int k = e[4]; k <= e[5]; ++k) zs += std::to_string(3 * k) + " ";
  std::string out = "<?xml version=\"1.0\"?>\n<VTKFile type=\"" + type +
                    "\" version=\"0.1\" byte_order=\"LittleEndian\">\n<" + type + " WholeExtent=\"" + extent_text(e) +
                    "\"" + (type == "ImageData" ? " Origin=\"0 0 0\" Spacing=\"1 0.5 2\"" : "") +
                    ">\n<Piece Extent=\"" + extent_text(e) + "\">\n";
  out += "<PointData><DataArray type=\"Float32\" Name=\"p\" format=\"ascii\">" + p + "</DataArray></PointData>\n";
  out += "<CellData><DataArray type=\"Float64\" Name=\"c\" format=\"ascii\">" + c + "</DataArray></CellData>\n";
  if (type == "StructuredGrid") {
    out += "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">" + pts +
           "</DataArray></Points>\n";
  }
  if (type == "RectilinearGrid") {
    out += "<Coordinates><DataArray type=\"Float64\" format=\"ascii\">" + xs +
           "</DataArray><DataArray type=\"Float64\" format=\"ascii\">" + ys +
           "</DataArray><DataArray type=\"Float64\" format=\"ascii\">" + zs + "</DataArray></Coordinates>\n";
  }
  return out + "</Piece>\n</" + type + ">\n</VTKFile>\n";
}

std::string parallel_file(const std::string& type, const Extent& whole,
                          const std::vector<std::pair<Extent, std::string>>& pieces) {
  std::string out = "<?xml version=\"1.0\"?>\n<VTKFile type=\"P" + type + "\" version=\"0.1\">\n<P" + type +
                    " WholeExtent=\"" + extent_text(whole) + "\" GhostLevel=\"0\"" +
                    (type == "ImageData" ? " Origin=\"0 0 0\" Spacing=\"1 0.5 2\"" : "") + ">\n";
  out += "<PPointData><PDataArray type=\"Float32\" Name=\"p\"/></PPointData>\n";
  out += "<PCellData><PDataArray type=\"Float64\" Name=\"c\"/></PCellData>\n";
  if (type == "StructuredGrid") out += "<PPoints><PDataArray type=\"Float32\" NumberOfComponents=\"3\"/></PPoints>\n";
  if (type == "RectilinearGrid") {
    out +=
        "<PCoordinates><PDataArray type=\"Float64\"/><PDataArray type=\"Float64\"/><PDataArray "
        "type=\"Float64\"/></PCoordinates>\n";
  }
  for (const auto& [e, source] : pieces)
    out += "<Piece Extent=\"" + extent_text(e) + "\" Source=\"" + source + "\"/>\n";
  return out + "</P" + type + ">\n</VTKFile>\n";
}

struct Kind {
  const char* type;
  const char* ext;
};
constexpr Kind kKinds[] = {{"StructuredGrid", "vts"}, {"ImageData", "vti"}, {"RectilinearGrid", "vtr"}};

const Extent kWhole = {0, 2, 0, 2, 0, 1};
const Extent kA = {0, 1, 0, 2, 0, 1}, kB = {1, 2, 0, 2, 0, 1};

TEST(VtkXmlParallelStructured, PiecesReadAsTheWholeGrid) {
  ScratchDir dir;
  for (const Kind& k : kKinds) {
    SCOPED_TRACE(k.type);
    const std::string ext = k.ext;
    write_file(dir.file("whole." + ext), serial_file(k.type, kWhole));
    write_file(dir.file("a." + ext), serial_file(k.type, kA));
    write_file(dir.file("b." + ext), serial_file(k.type, kB));
    // Listed in reverse order: placement is by Extent, not by order.
    write_file(dir.file("p.p" + ext), parallel_file(k.type, kWhole, {{kB, "b." + ext}, {kA, "a." + ext}}));
    const Dataset whole = read_dataset(std::vector<std::string>{dir.file("whole." + ext)});
    const Dataset parallel = read_dataset(std::vector<std::string>{dir.file("p.p" + ext)});
    ASSERT_EQ(parallel.blocks.size(), 1u);
    EXPECT_EQ(parallel.blocks[0].grid, whole.blocks[0].grid);
    EXPECT_EQ(parallel.blocks[0].fields, whole.blocks[0].fields);
    EXPECT_EQ(parallel.point_count(), 18u);
    EXPECT_EQ(parallel.cell_count(), 4u);
    EXPECT_EQ(parallel.blocks[0].fields.find("p")->data().get(17, 0), 2 + 20 + 100);
    EXPECT_EQ(parallel.blocks[0].fields.find("c", Association::Cell)->data().get(3, 0), 11);
    EXPECT_NE(parallel.format.find(".p" + ext), std::string::npos) << parallel.format;
    EXPECT_EQ(parallel.sources.size(), 3u);
  }
}

TEST(VtkXmlParallelStructured, BadPiecesAreRefused) {
  ScratchDir dir;
  write_file(dir.file("a.vts"), serial_file("StructuredGrid", kA));
  write_file(dir.file("b.vts"), serial_file("StructuredGrid", kB));
  write_file(dir.file("b.vtr"), serial_file("RectilinearGrid", kB));
  const std::pair<std::string, std::string> bad[] = {
      // Only piece A: the plane i = 2 has no data.
      {parallel_file("StructuredGrid", kWhole, {{kA, "a.vts"}}), "leave parts of the WholeExtent without data"},
      // A rectilinear file as a piece of a .pvts.
      {parallel_file("StructuredGrid", kWhole, {{kA, "a.vts"}, {kB, "b.vtr"}}), "expected StructuredGrid"},
      // Piece A listed with B's extent size differing from its file.
      {parallel_file("StructuredGrid", kWhole, {{{0, 2, 0, 2, 0, 1}, "a.vts"}, {kB, "b.vts"}}),
       "point dimensions of its <Piece> Extent"},
      // An extent outside the whole.
      {parallel_file("StructuredGrid", kWhole, {{kA, "a.vts"}, {{1, 3, 0, 2, 0, 1}, "b.vts"}}),
       "outside the WholeExtent"},
      // The same file twice.
      {parallel_file("StructuredGrid", kWhole, {{kA, "a.vts"}, {kA, "a.vts"}}), "already listed"},
  };
  for (const auto& [text, needle] : bad) {
    SCOPED_TRACE(needle);
    write_file(dir.file("bad.pvts"), text);
    const std::string e = error_of([&] { read_dataset(std::vector<std::string>{dir.file("bad.pvts")}); });
    EXPECT_NE(e.find("bad.pvts"), std::string::npos) << e;
    EXPECT_NE(e.find(needle), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace ugvr
