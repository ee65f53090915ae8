// Readers never return data they did not read (issue 23): each finding of the hostile-input probe reproduced and
// refused with ugvr::Error naming the file. Hostile files are made in a ScratchDir from real data (skipped when it is
// absent) or from small generated meshes:
//   - a truncated Exodus file (netCDF fills reads past the end with zeros or hands out the next variable's bytes);
//   - single bit flips in NRRD gzip data (the reader stopped when the array was full, before the CRC);
//   - duplicated XML elements in .vtu files, and point ids out of range in slots that linearisation drops;
//   - a .pvtu listing one piece 20,000 times, more pieces than the cap, and pieces larger than the memory budget;
//   - EnSight Gold: geometry files cut short (binary and ASCII), absurd counts and Fortran record markers.
//   - OpenFOAM cases with truncated lists, absurd counts, face indices out of range, cut binary and gzip files.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/codec.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/octree/vtu_cells.h"

namespace ugvr {
namespace {

using test::ScratchDir;

using test::error_of;

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// ---------------------------------------------------------------------------------------------------------------
// Exodus: the probe's truncations of disk_out_ref (400,000 bytes read fields [0, 0]; at 450,000 five fields came back
// as another variable's values). Every cut inside the data must fail naming the file, a variable and the missing
// bytes.

TEST(HostileReaders, TruncatedExodusIsRefusedNamingTheVariable) {
  UGVR_REQUIRE_DATA("disk-out-ref/disk_out_ref.ex2");
  ScratchDir dir;
  const std::string bytes = read_bytes(relative_data_path);
  ASSERT_GT(bytes.size(), 450000u);
  // vals_nod_var, the last variable, ends 4 bytes before the end of the file: cut 5 bytes off, one of its bytes is
  // missing.
  for (size_t cut : {size_t(400000), size_t(450000), size_t(600000), bytes.size() - 5}) {
    SCOPED_TRACE(cut);
    const std::string path = dir.file("cut.ex2");
    write_file(path, bytes.substr(0, cut));
    const std::string e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find("cut.ex2"), std::string::npos) << e;
    EXPECT_NE(e.find("is truncated"), std::string::npos) << e;
    EXPECT_NE(e.find("bytes missing"), std::string::npos) << e;
  }
  // Cutting only the 4 bytes after the last variable loses nothing: that file reads.
  write_file(dir.file("tail.ex2"), bytes.substr(0, bytes.size() - 4));
  EXPECT_EQ(std::get<UnstructuredMesh>(read_exodus(dir.file("tail.ex2"), -1).blocks.at(0).grid).cell_count(),
            std::get<UnstructuredMesh>(read_exodus(relative_data_path, -1).blocks.at(0).grid).cell_count());
  // The CLI fails too (the probe's `render` exited 0).
  const std::string path = dir.file("cut.ex2");
  write_file(path, bytes.substr(0, 450000));
  const test::CommandResult r = test::run_ugvr("info " + path);
  EXPECT_NE(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("is truncated"), std::string::npos) << r.out;
}

// ---------------------------------------------------------------------------------------------------------------
// NRRD gzip: every single bit flip in the compressed stream must either fail or leave the values exactly as written
// (a flip in the gzip header's MTIME, XFL or OS bytes changes nothing and is not covered by the CRC).

// zlib's stream rewrapped as gzip (header, raw deflate, CRC-32, length), as `gzip` writes it.
std::string gzip_bytes(const std::string& data) {
  const std::vector<std::byte> z =
      compress(Codec::Zlib, std::span(reinterpret_cast<const std::byte*>(data.data()), data.size()), 6);
  uint32_t crc = 0xffffffffu;
  for (unsigned char c : data) {
    crc ^= c;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc = ~crc;
  std::string out("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff", 10);
  out.append(reinterpret_cast<const char*>(z.data()) + 2, z.size() - 6);
  for (uint32_t v : {crc, uint32_t(data.size())})
    for (int k = 0; k < 4; ++k) out.push_back(char((v >> (8 * k)) & 0xff));
  return out;
}

TEST(HostileReaders, NrrdGzipBitFlipsNeverGiveWrongValues) {
  ScratchDir dir;
  std::vector<float> values(4 * 4 * 8);
  for (size_t i = 0; i < values.size(); ++i) values[i] = float(std::round(100 * std::sin(0.37 * double(i)))) / 8;
  const std::string raw(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  const std::string header = "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 8\nencoding: gzip\nendian: little\n\n";
  const std::string gz = gzip_bytes(raw);
  const std::string path = dir.file("flip.nrrd");

  auto read_values = [&](const std::string& payload) {
    write_file(path, header + payload);
    const Dataset ds = read_nrrd(path);
    const auto v = ds.blocks.at(0).fields[0].data().values<float>();
    return std::vector<float>(v.begin(), v.end());
  };
  ASSERT_EQ(read_values(gz), values);

  size_t refused = 0, same = 0, wrong = 0, trailer_refused = 0;
  std::string example;
  for (size_t byte = 0; byte < gz.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string flipped = gz;
      flipped[byte] = char(flipped[byte] ^ (1 << bit));
      try {
        if (read_values(flipped) == values) {
          ++same;
        } else {
          ++wrong;
          if (example.empty()) example = "byte " + std::to_string(byte) + " bit " + std::to_string(bit);
        }
      } catch (const Error& e) {
        ++refused;
        trailer_refused += byte >= gz.size() - 8;
        EXPECT_NE(std::string(e.what()).find("flip.nrrd"), std::string::npos) << e.what();
      }
    }
  }
  EXPECT_EQ(wrong, 0u) << "first accepted flip with wrong values: " << example;
  // Flips that give the same values are harmless: the gzip header's MTIME, XFL, OS and FTEXT bits (no check covers
  // them), the padding bits of the deflate stream's last byte, and a few in the deflate data that turn a match into
  // another one copying equal bytes (the CRC then agrees, rightly). Nearly all flips are refused.
  EXPECT_GT(refused, 9 * (refused + same) / 10);
  // Every flip in the CRC-32 and length is refused: the reader used to stop before reading them.
  EXPECT_EQ(trailer_refused, 64u);

  // A flip in the CRC alone (the values themselves intact): refused naming the check.
  std::string bad_crc = gz;
  bad_crc[gz.size() - 8] = char(bad_crc[gz.size() - 8] ^ 1);
  std::string e = error_of([&] { read_values(bad_crc); });
  EXPECT_NE(e.find("flip.nrrd"), std::string::npos) << e;
  EXPECT_NE(e.find("incorrect data check"), std::string::npos) << e;
  // The values complete but the trailer cut off: the data cannot be verified.
  e = error_of([&] { read_values(gz.substr(0, gz.size() - 8)); });
  EXPECT_NE(e.find("flip.nrrd"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot be verified"), std::string::npos) << e;
  // More data after the values than the header describes, within the limit, is still read (and its CRC checked).
  const std::string longer = raw + std::string(4096, '\x7f');
  EXPECT_EQ(read_values(gzip_bytes(longer)), values);
}

// ---------------------------------------------------------------------------------------------------------------
// VTU: duplicated elements, and ids in every stored slot.

// A unit cube split into points 0..7 plus an apex 8, as an ASCII .vtu. `cells` is the <Cells> section's three arrays'
// text (connectivity, offsets, types); `piece_extra` is inserted before </Piece>, `grid_extra` before
// </UnstructuredGrid>.
std::string ascii_vtu(const std::string& connectivity, const std::string& offsets, const std::string& types,
                      uint64_t cells, const std::string& piece_extra = "", const std::string& grid_extra = "") {
  const std::string piece =
      "<Piece NumberOfPoints=\"9\" NumberOfCells=\"" + std::to_string(cells) +
      "\">\n"
      "<PointData><DataArray type=\"Float32\" Name=\"t\" format=\"ascii\">0 1 2 3 4 5 6 7 8</DataArray></PointData>\n"
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">\n"
      "0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1 0.5 0.5 2</DataArray></Points>\n"
      "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">" +
      connectivity +
      "</DataArray>\n"
      "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">" +
      offsets +
      "</DataArray>\n"
      "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">" +
      types + "</DataArray>\n</Cells>\n" + piece_extra + "</Piece>\n";
  return "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
         "<UnstructuredGrid>\n" +
         piece + grid_extra + "</UnstructuredGrid>\n</VTKFile>\n";
}

std::string hex_vtu(const std::string& piece_extra = "", const std::string& grid_extra = "") {
  return ascii_vtu("0 1 2 3 4 5 6 7", "8", "12", 1, piece_extra, grid_extra);
}

void expect_refused(const std::string& path, const std::vector<std::string>& needles) {
  const std::string e = error_of([&] { read_vtk_xml(path); });
  EXPECT_NE(e.find(std::filesystem::path(path).filename().string()), std::string::npos) << e;
  for (const std::string& n : needles) EXPECT_NE(e.find(n), std::string::npos) << e;
}

TEST(HostileReaders, VtuDuplicatedElementsAreRefused) {
  ScratchDir dir;
  const std::string good = dir.file("good.vtu");
  write_file(good, hex_vtu());
  ASSERT_EQ(std::get<UnstructuredMesh>(read_vtk_xml(good).blocks.at(0).grid).cell_count(), 1u);

  const std::string points2 =
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">"
      "9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9</DataArray></Points>\n";
  const std::string cells2 =
      "<Cells><DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">8 1 2 3 4 5 6 "
      "7</DataArray><DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">8</DataArray>"
      "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">12</DataArray></Cells>\n";
  const std::string point_data2 =
      "<PointData><DataArray type=\"Float32\" Name=\"u\" format=\"ascii\">0 0 0 0 0 0 0 0 0</DataArray></PointData>\n";
  const std::string cell_data2 =
      "<CellData><DataArray type=\"Float32\" Name=\"c\" format=\"ascii\">1</DataArray>"
      "</CellData><CellData><DataArray type=\"Float32\" Name=\"d\" format=\"ascii\">2"
      "</DataArray></CellData>\n";
  struct Case {
    const char* file;
    std::string text;
    const char* needle;
  };
  std::string second_points_array = hex_vtu();
  second_points_array.insert(second_points_array.find("</Points>"),
                             "<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">"
                             "1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1</DataArray>");
  std::string second_connectivity = hex_vtu();
  second_connectivity.insert(second_connectivity.find("</Cells>"),
                             "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">7 6 5 4 3 2 1 0"
                             "</DataArray>");
  std::string second_grid = hex_vtu();
  second_grid.insert(second_grid.find("</VTKFile>"), "<UnstructuredGrid></UnstructuredGrid>\n");
  for (const Case& c : {Case{"points.vtu", hex_vtu(points2), "more than one <Points>"},
                        Case{"cells.vtu", hex_vtu(cells2), "more than one <Cells>"},
                        Case{"pointdata.vtu", hex_vtu(point_data2), "more than one <PointData>"},
                        Case{"celldata.vtu", hex_vtu(cell_data2), "more than one <CellData>"},
                        Case{"pointsarray.vtu", second_points_array, "<Points> has more than one <DataArray>"},
                        Case{"conn.vtu", second_connectivity, "more than one <DataArray> named 'connectivity'"},
                        Case{"grid.vtu", second_grid, "more than one <UnstructuredGrid>"}}) {
    SCOPED_TRACE(c.file);
    write_file(dir.file(c.file), c.text);
    expect_refused(dir.file(c.file), {c.needle});
  }
}

// A <Piece> copied whole: its appended offsets point at the same bytes as the original's, or its inline arrays hold
// the same text. Read, it would double the mesh with coincident cells. Made from a generated mesh (ASCII, and
// appended by the project's own writer) and from a real file (inline binary).
TEST(HostileReaders, VtuDuplicatedPieceIsRefused) {
  ScratchDir dir;
  const std::string ascii = dir.file("hex.vtu");
  write_file(ascii, hex_vtu());
  const std::string appended = dir.file("appended.vtu");
  write_vtu(read_vtk_xml(ascii), appended);
  std::vector<std::string> sources = {ascii, appended};
  const std::string real = test::data_path("fea-kiefer-bracket/dataset.vtu");
  if (std::filesystem::exists(real)) sources.push_back(real);
  for (const std::string& source : sources) {
    SCOPED_TRACE(source);
    std::string text = read_bytes(source);
    ASSERT_EQ(read_vtk_xml(source).blocks.size(), 1u);
    const size_t begin = text.find("<Piece"), end = text.find("</Piece>");
    ASSERT_NE(begin, std::string::npos);
    ASSERT_NE(end, std::string::npos);
    ASSERT_LT(end, text.find("<AppendedData"));  // npos (no appended data) when the arrays are inline
    const std::string piece = text.substr(begin, end + 8 - begin);
    text.insert(end + 8, "\n" + piece);
    const std::string path = dir.file("twice.vtu");
    write_file(path, text);
    expect_refused(path, {"Piece 1 <Piece> is a duplicate of Piece 0"});
  }
}

// Quadratic cells keep only their corners, but every id the file stores must name a point: an out-of-range id in a
// mid-edge slot means the connectivity is corrupt.
TEST(HostileReaders, VtuIdsInEverySlotAreChecked) {
  ScratchDir dir;
  // VTK_QUADRATIC_TETRA (24): corners 0 1 3 8, then six mid-edge ids (points 2 4 5 6 7 and a sixth).
  const std::string path = dir.file("quad.vtu");
  write_file(path, ascii_vtu("0 1 3 8 2 4 5 6 7 2", "10", "24", 1));
  ASSERT_EQ(std::get<UnstructuredMesh>(read_vtk_xml(path).blocks.at(0).grid).cell_count(), 1u);
  write_file(path, ascii_vtu("0 1 3 8 2 4 5 6 7 99", "10", "24", 1));
  expect_refused(path, {"point id 99 is outside [0, 9)", "slot 9"});
  write_file(path, ascii_vtu("0 1 3 8 2 4 5 -1 7 2", "10", "24", 1));
  expect_refused(path, {"point id -1 is outside", "slot 7"});
  // Extra ids after a hexahedron's eight (cut off, as VTK's linear cells do) and a dropped triangle's ids.
  write_file(path, ascii_vtu("0 1 2 3 4 5 6 7 12", "9", "12", 1));
  expect_refused(path, {"point id 12 is outside", "slot 8"});
  write_file(path, ascii_vtu("0 1 2 3 4 5 6 7 0 1 50", "8 11", "12 5", 2));
  expect_refused(path, {"cell 1", "point id 50 is outside"});
}

// ---------------------------------------------------------------------------------------------------------------
// .pvtu: piece counts and sizes are checked before any piece is read.

std::string pvtu_listing(const std::vector<std::string>& sources) {
  std::string s =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\">\n"
      "<PUnstructuredGrid GhostLevel=\"0\">\n<PPointData><PDataArray type=\"Float32\" Name=\"t\"/>"
      "</PPointData>\n<PPoints><PDataArray type=\"Float32\" NumberOfComponents=\"3\"/></PPoints>\n";
  s.reserve(s.size() + sources.size() * 40);
  for (const std::string& src : sources) s += "<Piece Source=\"" + src + "\"/>\n";
  return s + "</PUnstructuredGrid>\n</VTKFile>\n";
}

TEST(HostileReaders, PvtuListingOnePieceTwentyThousandTimesIsRefused) {
  ScratchDir dir;
  write_file(dir.file("p0.vtu"), hex_vtu());
  write_file(dir.file("p1.vtu"), hex_vtu());
  write_file(dir.file("two.pvtu"), pvtu_listing({"p0.vtu", "p1.vtu"}));
  ASSERT_EQ(std::get<UnstructuredMesh>(read_vtk_xml(dir.file("two.pvtu")).blocks.at(0).grid).cell_count(), 2u);

  write_file(dir.file("many.pvtu"), pvtu_listing(std::vector<std::string>(20000, "p0.vtu")));
  expect_refused(dir.file("many.pvtu"), {"p0.vtu", "already listed"});
  // The same file by another spelling of its path, and through a hard link.
  write_file(dir.file("again.pvtu"), pvtu_listing({"p0.vtu", "p1.vtu", "./p0.vtu"}));
  expect_refused(dir.file("again.pvtu"), {"./p0.vtu", "already listed"});
  std::filesystem::create_hard_link(dir.file("p1.vtu"), dir.file("link.vtu"));
  write_file(dir.file("linked.pvtu"), pvtu_listing({"p0.vtu", "p1.vtu", "link.vtu"}));
  expect_refused(dir.file("linked.pvtu"), {"link.vtu", "already listed"});
}

TEST(HostileReaders, PvtuPieceCountAndSizeAreCappedBeforeReading) {
  ScratchDir dir;
  // More entries than the cap: refused from the listing alone (none of these files exists).
  std::vector<std::string> names;
  for (int i = 0; i < 70000; ++i) names.push_back("p" + std::to_string(i) + ".vtu");
  write_file(dir.file("count.pvtu"), pvtu_listing(names));
  expect_refused(dir.file("count.pvtu"), {"lists 70000 pieces", "65536"});

  // A piece larger than any machine's memory (a sparse file: it takes no disk space): refused by its size before it
  // is opened, naming the total and the budget.
  write_file(dir.file("p0.vtu"), hex_vtu());
  const std::string huge = dir.file("huge.vtu");
  write_file(huge, hex_vtu());
  std::error_code ec;
  std::filesystem::resize_file(huge, uint64_t(4) << 40, ec);
  if (ec) GTEST_SKIP() << "this file system cannot hold a sparse 4 TiB file: " << ec.message();
  write_file(dir.file("size.pvtu"), pvtu_listing({"p0.vtu", "huge.vtu"}));
  expect_refused(dir.file("size.pvtu"), {"2 piece files add up to", "memory budget"});
}

// The out-of-core builder's own .vtu parser (octree/vtu_cells.h) refuses repeated elements as the reader does.
TEST(HostileReaders, OutOfCoreVtuDuplicatedElementsAreRefused) {
  ScratchDir dir;
  const std::string good = dir.file("good.vtu");
  write_file(good, hex_vtu());
  const std::vector<std::string> field = {"t"};
  EXPECT_EQ(VtuCellSource(good, field).file_cell_count(), 1u);
  const std::string points2 =
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">"
      "9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9</DataArray></Points>\n";
  const std::string point_data2 =
      "<PointData><DataArray type=\"Float32\" Name=\"u\" format=\"ascii\">0 0 0 0 0 0 0 0 0</DataArray></PointData>\n";
  for (const std::string& extra : {points2, point_data2}) {
    const std::string bad = dir.file("bad.vtu");
    write_file(bad, hex_vtu(extra));
    const std::string e = error_of([&] { VtuCellSource source(bad, field); });
    EXPECT_NE(e.find("bad.vtu"), std::string::npos) << e;
    EXPECT_NE(e.find("<" + extra.substr(1, extra.find('>') - 1) + ">"), std::string::npos) << e;
  }
}

// ---------------------------------------------------------------------------------------------------------------
// EnSight Gold: every cut of a real binary and a real ASCII geometry file is refused naming the file and the byte
// offset (binary) or line (ASCII); absurd counts are refused before anything is allocated for them.

std::string ensight_case(const std::string& geo, const std::string& variables = "") {
  return "FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: " + geo + "\n" + variables;
}

TEST(HostileReaders, EnSightTruncatedGeometryIsNamed) {
  UGVR_REQUIRE_DATA("ensight-samples/office_bin.geo");
  ScratchDir dir;
  const std::string binary = read_bytes(relative_data_path);
  const std::string ascii = read_bytes(test::data_path("ensight-samples/test.geo"));
  write_file(dir.file("cut.case"), ensight_case("cut.geo"));
  for (size_t cut = 0; cut < binary.size(); cut += 53) {
    SCOPED_TRACE(cut);
    write_file(dir.file("cut.geo"), binary.substr(0, cut));
    const std::string e = error_of([&] { read_ensight(dir.file("cut.case"), -1); });
    EXPECT_NE(e.find("cut.geo"), std::string::npos) << e;
    if (cut >= 80) {
      EXPECT_NE(e.find("byte"), std::string::npos) << e;
    }
  }
  // ASCII: cut inside the second part's lines and earlier. A cut between parts leaves a valid file with fewer
  // parts; the case's per-element variable for part 2 then names the missing part.
  write_file(dir.file("cut.case"),
             ensight_case("cut.geo", "VARIABLE\nscalar per element: p " +
                                         test::data_path("ensight-samples/test.extr_pressure.0001") + "\n"));
  for (size_t cut = 0; cut + 16 < ascii.size(); cut += 997) {
    SCOPED_TRACE(cut);
    write_file(dir.file("cut.geo"), ascii.substr(0, cut));
    const std::string e = error_of([&] { read_ensight(dir.file("cut.case"), -1); });
    EXPECT_TRUE(e.find("cut.geo:") != std::string::npos || e.find("not in the geometry") != std::string::npos) << e;
  }
}

// C binary: "C Binary", two descriptions, node/element id lines, then a part header and whatever follows.
std::string ensight_binary_geo(const std::vector<std::pair<bool, std::string>>& items) {
  std::string out;
  auto str = [&](const std::string& s) {
    std::string b = s;
    b.resize(80, '\0');
    out += b;
  };
  for (const char* s : {"C Binary", "d1", "d2", "node id off", "element id off", "part"}) str(s);
  for (const auto& [is_string, v] : items) {
    if (is_string) {
      str(v);
    } else {
      out += v;
    }
  }
  return out;
}

std::string le32(int32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }

TEST(HostileReaders, EnSightAbsurdCountsAreRefusedBeforeAllocating) {
  ScratchDir dir;
  write_file(dir.file("x.case"), ensight_case("x.geo"));
  const std::string coords = le32(1) + std::string("p");
  struct Bad {
    std::string geo;
    std::vector<std::string> needles;
  };
  const std::string part_head = le32(1);
  const std::vector<Bad> bad = {
      // 2^31-1 nodes in a file of a few hundred bytes.
      {ensight_binary_geo({{false, part_head}, {true, "p"}, {true, "coordinates"}, {false, le32(0x7fffffff)}}),
       {"x.geo", "byte", "node count 2147483647", "needs at least"}},
      // A tetra section of 2^31-1 elements after 4 real nodes.
      {ensight_binary_geo({{false, part_head},
                           {true, "p"},
                           {true, "coordinates"},
                           {false, le32(4) + std::string(48, '\0')},
                           {true, "tetra4"},
                           {false, le32(0x7fffffff)}}),
       {"x.geo", "tetra4 element count 2147483647", "needs at least"}},
      // An nfaced element claiming 2^30 faces.
      {ensight_binary_geo({{false, part_head},
                           {true, "p"},
                           {true, "coordinates"},
                           {false, le32(4) + std::string(48, '\0')},
                           {true, "nfaced"},
                           {false, le32(1) + le32(1 << 30)}}),
       {"x.geo", "nfaced face count", "needs at least"}},
      // A block of 65536^3 points.
      {ensight_binary_geo(
           {{false, part_head}, {true, "p"}, {true, "block"}, {false, le32(65536) + le32(65536) + le32(65536)}}),
       {"x.geo", "block point count", "needs at least"}},
      // A node index beyond the part's nodes.
      {ensight_binary_geo({{false, part_head},
                           {true, "p"},
                           {true, "coordinates"},
                           {false, le32(4) + std::string(48, '\0')},
                           {true, "tetra4"},
                           {false, le32(1) + le32(1) + le32(2) + le32(3) + le32(9)}}),
       {"x.geo", "node 9 is out of range 1..4"}},
      // An unknown element type.
      {ensight_binary_geo({{false, part_head}, {true, "p"}, {true, "coordinates"}, {false, le32(0)}, {true, "hexa27"}}),
       {"x.geo", "unknown element type 'hexa27'"}},
  };
  for (const Bad& b : bad) {
    write_file(dir.file("x.geo"), b.geo);
    const std::string e = error_of([&] { read_ensight(dir.file("x.case"), -1); });
    for (const std::string& n : b.needles) EXPECT_NE(e.find(n), std::string::npos) << n << " in: " << e;
  }
  // Fortran: a record marker larger than the file.
  std::string fortran;
  auto rec = [&](const std::string& payload) {
    fortran += le32(int32_t(payload.size())) + payload + le32(int32_t(payload.size()));
  };
  auto str80 = [](std::string s) {
    s.resize(80, ' ');
    return s;
  };
  for (const char* s : {"Fortran Binary", "d1", "d2", "node id off", "element id off", "part"}) rec(str80(s));
  fortran += le32(1 << 30) + le32(1);
  write_file(dir.file("x.geo"), fortran);
  const std::string e = error_of([&] { read_ensight(dir.file("x.case"), -1); });
  EXPECT_NE(e.find("x.geo"), std::string::npos) << e;
  EXPECT_NE(e.find("Fortran record marker 1073741824"), std::string::npos) << e;
}

// OpenFOAM: hostile edits of the generated cavity case (tests/data/openfoam) are refused naming the file and where.
std::string openfoam_case_copy(const ScratchDir& dir, const std::string& name) {
  const std::string to = dir.file(name);
  std::filesystem::copy(std::string(UGVR_SOURCE_DIR) + "/tests/data/openfoam/" + name, to,
                        std::filesystem::copy_options::recursive);
  return to;
}

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

TEST(HostileReaders, OpenFoamBadListsAreRefusedNamingFileAndLine) {
  struct Case {
    const char* file;  // in constant/polyMesh
    std::string (*edit)(const std::string&);
    std::vector<std::string> expected;
  };
  const std::vector<Case> cases = {
      // Truncated: the file ends inside the points list.
      {"points",
       [](const std::string& s) { return s.substr(0, s.size() / 2); },
       {"points", "byte ", "count 882 needs at least"}},
      // An absurd count, refused before anything is allocated for it.
      {"points",
       [](const std::string& s) { return replaced(s, "\n882\n", "\n99999999999\n"); },
       {"points", "count 99999999999 needs at least"}},
      // A face naming a point that does not exist.
      {"faces",
       [](const std::string& s) { return replaced(s, "4(1 22 463 442)", "4(1 22 463 99999)"); },
       {"faces", "line 21", "vertex 99999 is outside 0..881"}},
      // A face of 2 vertices, and a cell index beyond the others' in owner (a label out of range: negative).
      {"faces",
       [](const std::string& s) { return replaced(s, "4(1 22 463 442)", "2(1 22)"); },
       {"faces", "has 2 vertices (at least 3)"}},
      {"owner",
       [](const std::string& s) { return replaced(s, "(\n0\n", "(\n-5\n"); },
       {"owner", "label -5 is outside"}},
      {"owner", [](const std::string& s) { return replaced(s, "\n1640\n", "\n1639\n"); }, {"owner"}},
  };
  for (const Case& c : cases) {
    ScratchDir dir;
    const std::string root = openfoam_case_copy(dir, "cavity");
    const std::string file = root + "/constant/polyMesh/" + c.file;
    write_file(file, c.edit(read_bytes(file)));
    const std::string e = error_of([&] { read_dataset(std::vector<std::string>{root}); });
    SCOPED_TRACE(e);
    ASSERT_FALSE(e.empty()) << c.file;
    for (const std::string& x : c.expected) EXPECT_NE(e.find(x), std::string::npos) << x;
  }
}

// A file larger than half of the machine's memory is streamed, not refused (the reader holds a window of it, never
// the whole): padded after its list, the case reads; cut where the list's values should be, it fails there at once.
// The files are sparse: no disk or memory is used.
TEST(HostileReaders, OpenFoamFileLargerThanMemoryIsStreamed) {
  ScratchDir dir;
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  ASSERT_GT(pages, 0);
  const uint64_t huge = uint64_t(pages) * uint64_t(page) / 2 + (uint64_t(1) << 20);
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  {
    const std::string root = openfoam_case_copy(dir, "cavity");
    std::filesystem::resize_file(root + "/constant/polyMesh/points", huge);
    const Dataset ds = read_dataset(std::vector<std::string>{root});
    EXPECT_EQ(std::get<UnstructuredMesh>(ds.blocks.at(0).grid).points.size(), 882u);
  }
  {
    const std::string root = openfoam_case_copy(dir, "cavity_binary");
    const std::string points = root + "/constant/polyMesh/points";
    const std::string s = read_bytes(points);
    write_file(points, s.substr(0, s.find("882\n(") + 5));
    std::filesystem::resize_file(points, huge);
    const std::string e = error_of([&] { read_dataset(std::vector<std::string>{root}); });
    EXPECT_NE(e.find("points: byte "), std::string::npos) << e;
    EXPECT_NE(e.find("expected ')' after the binary values of points"), std::string::npos) << e;
  }
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256L << 10) << "KiB";  // far below the file's size
}

TEST(HostileReaders, OpenFoamBinaryAndGzipDamageIsRefused) {
  ScratchDir dir;
  {
    // A binary faces file cut inside its raw labels.
    const std::string root = openfoam_case_copy(dir, "cavity_binary");
    const std::string file = root + "/constant/polyMesh/faces";
    const std::string s = read_bytes(file);
    write_file(file, s.substr(0, s.size() - 3000));
    const std::string e = error_of([&] { read_dataset(std::vector<std::string>{root}); });
    EXPECT_NE(e.find("faces"), std::string::npos) << e;
    EXPECT_NE(e.find("face vertices count 6560 needs at least 4 bytes each"), std::string::npos) << e;
  }
  {
    // A gzip stream cut short, and one with its deflate data damaged.
    const std::string root = openfoam_case_copy(dir, "cavity_gzip");
    const std::string file = root + "/constant/polyMesh/points.gz";
    const std::string s = read_bytes(file);
    write_file(file, s.substr(0, s.size() / 2));
    std::string e = error_of([&] { read_dataset(std::vector<std::string>{root}); });
    EXPECT_NE(e.find("points.gz"), std::string::npos) << e;
    EXPECT_NE(e.find("truncated"), std::string::npos) << e;
    std::string flipped = s;
    for (size_t i = 20; i < 60; ++i) flipped[i] = char(~flipped[i]);
    write_file(file, flipped);
    e = error_of([&] { read_dataset(std::vector<std::string>{root}); });
    EXPECT_NE(e.find("points.gz"), std::string::npos) << e;
  }
  {
    // A field whose internalField count disagrees with the mesh.
    const std::string root = openfoam_case_copy(dir, "cavity");
    const std::string file = root + "/0.3/p";
    write_file(file, replaced(read_bytes(file), "\n400\n", "\n401\n"));
    const std::string e = error_of([&] { read_dataset(std::vector<std::string>{root}); });
    EXPECT_NE(e.find("0.3/p"), std::string::npos) << e;
    EXPECT_NE(e.find("internalField has 401 values, expected 400"), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace ugvr
