// Tests of the VTK XML reader: real files from ../shared/data (skipped when absent), every encoding through a small
// test-side writer, structured formats, and malformed files that must fail with ugvr::Error naming the file.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/base64.h"
#include "ugvr/io/codec.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// ---------------------------------------------------------------------------------------------------------------
// A small VTK XML writer covering the encodings the reader accepts.

struct Encoding {
  const char* name;
  const char* format;  // "ascii", "binary" or "appended"
  bool header64 = false;
  Codec codec = Codec::None;
  bool appended_base64 = false;
  bool big_endian = false;
  size_t block_size = 40;  // small, so that arrays span several compressed blocks
};

struct Array {
  std::string name, type;
  int components = 1;
  size_t value_size = 0;
  std::vector<std::byte> bytes;  // little-endian values
  std::string ascii;
};

template <class T>
Array make_array(const std::string& name, int components, const std::vector<T>& values) {
  Array a;
  a.name = name;
  a.type = std::string(scalar_type_name(scalar_type_of<T>()));
  a.components = components;
  a.value_size = sizeof(T);
  a.bytes.resize(values.size() * sizeof(T));
  if (!values.empty()) std::memcpy(a.bytes.data(), values.data(), a.bytes.size());
  std::ostringstream s;
  s << std::setprecision(17);
  for (size_t i = 0; i < values.size(); ++i) {
    if constexpr (sizeof(T) == 1)
      s << int(values[i]);
    else
      s << values[i];
    s << (i % 6 == 5 ? "\n" : " ");
  }
  a.ascii = s.str();
  return a;
}

std::vector<std::byte> header_word(uint64_t v, const Encoding& e) {
  std::vector<std::byte> out(e.header64 ? 8 : 4);
  for (size_t i = 0; i < out.size(); ++i) {
    const size_t shift = 8 * (e.big_endian ? out.size() - 1 - i : i);
    out[i] = std::byte((v >> shift) & 0xff);
  }
  return out;
}

void append(std::vector<std::byte>& dst, const std::vector<std::byte>& src) {
  dst.insert(dst.end(), src.begin(), src.end());
}

// [header] and [data] of an array as VTK lays them out (data compressed block by block when a codec is set).
std::pair<std::vector<std::byte>, std::vector<std::byte>> encode(const Array& a, const Encoding& e) {
  std::vector<std::byte> data = a.bytes;
  if (e.big_endian && a.value_size > 1) {
    for (size_t i = 0; i < data.size(); i += a.value_size)
      std::reverse(data.begin() + ptrdiff_t(i), data.begin() + ptrdiff_t(i + a.value_size));
  }
  std::vector<std::byte> header, body;
  if (e.codec == Codec::None) {
    header = header_word(data.size(), e);
    body = data;
    return {header, body};
  }
  const size_t nblocks = (data.size() + e.block_size - 1) / e.block_size;
  append(header, header_word(nblocks, e));
  append(header, header_word(e.block_size, e));
  append(header, header_word(data.size() % e.block_size, e));
  for (size_t b = 0; b < nblocks; ++b) {
    const size_t begin = b * e.block_size, len = std::min(e.block_size, data.size() - begin);
    const std::vector<std::byte> packed = compress(e.codec, std::span(data).subspan(begin, len));
    append(header, header_word(packed.size(), e));
    append(body, packed);
  }
  return {header, body};
}

std::string as_string(const std::vector<std::byte>& b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

// base64 of header and data: one stream when uncompressed, two separately padded streams when compressed (as VTK).
std::string encode_base64(const std::pair<std::vector<std::byte>, std::vector<std::byte>>& hd, const Encoding& e) {
  if (e.codec != Codec::None) return base64_encode(hd.first) + base64_encode(hd.second);
  std::vector<std::byte> all = hd.first;
  append(all, hd.second);
  return base64_encode(all);
}

class Writer {
 public:
  explicit Writer(Encoding e) : e_(e) {}

  std::string data_array(const Array& a) {
    std::string head = "<DataArray type=\"" + a.type + "\" Name=\"" + a.name + "\" NumberOfComponents=\"" +
                       std::to_string(a.components) + "\" format=\"" + e_.format + "\"";
    const std::string format = e_.format;
    if (format == "ascii") return head + ">\n" + a.ascii + "\n</DataArray>\n";
    const auto hd = encode(a, e_);
    if (format == "binary") return head + ">\n  " + encode_base64(hd, e_) + "\n</DataArray>\n";
    head += " offset=\"" + std::to_string(appended_.size()) + "\"/>\n";
    appended_ += e_.appended_base64 ? encode_base64(hd, e_) : as_string(hd.first) + as_string(hd.second);
    return head;
  }

  std::string file(const std::string& type, const std::string& body) const {
    std::string s = "<?xml version=\"1.0\"?>\n<!-- written by the ugvr tests <with> markup in a comment -->\n";
    s += "<VTKFile type=\"" + type + "\" version=\"1.0\" byte_order=\"" +
         (e_.big_endian ? "BigEndian" : "LittleEndian") + "\" header_type=\"" + (e_.header64 ? "UInt64" : "UInt32") +
         "\"";
    if (e_.codec == Codec::Zlib) s += " compressor=\"vtkZLibDataCompressor\"";
    if (e_.codec == Codec::Lz4) s += " compressor=\"vtkLZ4DataCompressor\"";
    s += ">\n" + body;
    if (!appended_.empty()) {
      s += std::string("<AppendedData encoding=\"") + (e_.appended_base64 ? "base64" : "raw") + "\">\n   _" +
           appended_ + "\n  </AppendedData>\n";
    }
    return s + "</VTKFile>\n";
  }

 private:
  Encoding e_;
  std::string appended_;
};

void write_file(const std::string& path, const std::string& contents) {
  std::ofstream f(path, std::ios::binary);
  f << contents;
  ASSERT_TRUE(f.good());
}

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// ---------------------------------------------------------------------------------------------------------------
// The test mesh: a hexahedron, a pyramid on top, a triangle (dropped) and a tetrahedron.

const std::vector<float> kPoints = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1,    0,    0, 0,
                                    1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 0.5f, 0.5f, 2};
const std::vector<int64_t> kConnectivity = {0, 1, 2, 3, 4, 5, 6, 7, 4, 5, 6, 7, 8, 0, 1, 2, 0, 1, 3, 4};
const std::vector<int64_t> kOffsets = {8, 13, 16, 20};
const std::vector<uint8_t> kTypes = {12, 14, 5, 10};

std::vector<double> temp_values() {
  std::vector<double> v;
  for (int i = 0; i < 9; ++i) v.push_back(1.5 * i - 0.125);
  return v;
}
std::vector<float> vel_values() {
  std::vector<float> v;
  for (int i = 0; i < 9; ++i) {
    v.push_back(float(i));
    v.push_back(-float(i));
    v.push_back(0.25f * float(i));
  }
  return v;
}

struct PieceOptions {
  bool conn64 = true;
  bool points64 = false;
  std::vector<int64_t> connectivity = kConnectivity;
  std::vector<int64_t> offsets = kOffsets;
};

template <class To, class From>
std::vector<To> cast(const std::vector<From>& v) {
  return std::vector<To>(v.begin(), v.end());
}

std::string test_piece(Writer& w, PieceOptions o = {}) {
  std::string s = "<Piece NumberOfPoints=\"9\" NumberOfCells=\"4\">\n<PointData Scalars=\"temp\">\n";
  s += w.data_array(make_array("temp", 1, temp_values()));
  s += w.data_array(make_array("vel", 3, vel_values()));
  s += "</PointData>\n<CellData>\n";
  s += w.data_array(make_array("id", 1, std::vector<int32_t>{100, 101, 102, 103}));
  s += w.data_array(make_array("flag", 1, std::vector<uint8_t>{1, 2, 3, 4}));
  s += "</CellData>\n<Points>\n";
  s += o.points64 ? w.data_array(make_array("Points", 3, cast<double>(kPoints)))
                  : w.data_array(make_array("Points", 3, kPoints));
  s += "</Points>\n<Cells>\n";
  s += o.conn64 ? w.data_array(make_array("connectivity", 1, o.connectivity))
                : w.data_array(make_array("connectivity", 1, cast<int32_t>(o.connectivity)));
  s += o.conn64 ? w.data_array(make_array("offsets", 1, o.offsets))
                : w.data_array(make_array("offsets", 1, cast<int32_t>(o.offsets)));
  s += w.data_array(make_array("types", 1, kTypes));
  return s + "</Cells>\n</Piece>\n";
}

std::string test_vtu(const Encoding& e, PieceOptions o = {}) {
  Writer w(e);
  const std::string body = "<UnstructuredGrid>\n" + test_piece(w, o) + "</UnstructuredGrid>\n";
  return w.file("UnstructuredGrid", body);
}

void expect_test_mesh(const Dataset& ds) {
  ASSERT_EQ(ds.blocks.size(), 1u);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  ASSERT_EQ(mesh.point_count(), 9u);
  for (size_t i = 0; i < 9; ++i) {
    EXPECT_EQ(mesh.points[i].x, kPoints[3 * i]);
    EXPECT_EQ(mesh.points[i].y, kPoints[3 * i + 1]);
    EXPECT_EQ(mesh.points[i].z, kPoints[3 * i + 2]);
  }
  EXPECT_EQ(mesh.cell_types, (std::vector<CellType>{CellType::Hexahedron, CellType::Pyramid, CellType::Tetra}));
  EXPECT_EQ(mesh.cell_offsets, (std::vector<uint64_t>{0, 8, 13, 17}));
  EXPECT_EQ(mesh.connectivity, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6, 7, 4, 5, 6, 7, 8, 0, 1, 3, 4}));
  const FieldSet& f = ds.blocks[0].fields;
  ASSERT_EQ(f.size(), 4u);
  const Field* temp = f.find("temp", Association::Vertex);
  ASSERT_NE(temp, nullptr);
  EXPECT_EQ(temp->data().type(), ScalarType::Float64);
  EXPECT_EQ(std::vector<double>(temp->data().values<double>().begin(), temp->data().values<double>().end()),
            temp_values());
  const Field* vel = f.find("vel", Association::Vertex);
  ASSERT_NE(vel, nullptr);
  EXPECT_EQ(vel->components(), 3);
  EXPECT_EQ(std::vector<float>(vel->data().values<float>().begin(), vel->data().values<float>().end()), vel_values());
  const Field* id = f.find("id", Association::Cell);
  ASSERT_NE(id, nullptr);
  EXPECT_EQ(id->data().type(), ScalarType::Int32);
  EXPECT_EQ(std::vector<int32_t>(id->data().values<int32_t>().begin(), id->data().values<int32_t>().end()),
            (std::vector<int32_t>{100, 101, 103}));
  const Field* flag = f.find("flag", Association::Cell);
  ASSERT_NE(flag, nullptr);
  EXPECT_EQ(flag->data().type(), ScalarType::UInt8);
  EXPECT_EQ(std::vector<uint8_t>(flag->data().values<uint8_t>().begin(), flag->data().values<uint8_t>().end()),
            (std::vector<uint8_t>{1, 2, 4}));
  ASSERT_EQ(ds.warnings.size(), 1u);
  EXPECT_NE(ds.warnings[0].find("VTK_TRIANGLE"), std::string::npos) << ds.warnings[0];
}

// The reader reserves the mesh exactly from a first pass over the cell types: no slack capacity (which would count
// against the memory budget) even when cells are dropped or linearised.
void expect_exact_capacity(const UnstructuredMesh& mesh) {
  EXPECT_EQ(mesh.points.capacity(), mesh.points.size());
  EXPECT_EQ(mesh.cell_types.capacity(), mesh.cell_types.size());
  EXPECT_EQ(mesh.cell_offsets.capacity(), mesh.cell_offsets.size());
  EXPECT_EQ(mesh.connectivity.capacity(), mesh.connectivity.size());
}

// ---------------------------------------------------------------------------------------------------------------
// Every encoding reads the same mesh.

class VtkXmlEncodingTest : public ::testing::TestWithParam<Encoding> {};

TEST_P(VtkXmlEncodingTest, ReadsTheTestMesh) {
  ScratchDir dir;
  for (const bool conn64 : {false, true}) {
    for (const bool points64 : {false, true}) {
      SCOPED_TRACE(std::string("conn64=") + (conn64 ? "1" : "0") + " points64=" + (points64 ? "1" : "0"));
      const std::string path = dir.file("mesh.vtu");
      write_file(path, test_vtu(GetParam(), {conn64, points64}));
      const Dataset ds = read_vtk_xml(path);
      EXPECT_EQ(ds.format, "VTK XML UnstructuredGrid (.vtu)");
      EXPECT_EQ(ds.sources, std::vector<std::string>{path});
      expect_test_mesh(ds);
      expect_exact_capacity(std::get<UnstructuredMesh>(ds.blocks[0].grid));
    }
  }
}

// A time step's fields read without its mesh (io/step_fields.h) are the full read's, bit for bit, in every encoding;
// the read never decodes the points or the connectivity (a file whose connectivity is corrupt still gives them),
// while the stored geometry key sees the corruption.
TEST_P(VtkXmlEncodingTest, FieldsOnlyReadIsTheFullReadsFields) {
  ScratchDir dir;
  const std::string good = dir.file("good.vtu"), corrupt = dir.file("corrupt.vtu");
  write_file(good, test_vtu(GetParam()));
  PieceOptions bad;
  bad.connectivity[2] = 99;  // a point id beyond the 9 points
  write_file(corrupt, test_vtu(GetParam(), bad));
  const Dataset full = read_vtk_xml(good);
  std::vector<std::string> warnings;
  const FieldSet fields = read_vtu_fields(good, warnings);
  EXPECT_TRUE(fields == full.blocks[0].fields);
  ASSERT_EQ(fields.size(), 4u);  // the triangle's cell values dropped as the full read drops them
  EXPECT_EQ(fields.find("id", Association::Cell)->tuples(), 3u);
  EXPECT_NE(test::error_of([&] { read_vtk_xml(corrupt); }).find("point id 99"), std::string::npos);
  EXPECT_TRUE(read_vtu_fields(corrupt, warnings) == full.blocks[0].fields);
  const std::optional<uint64_t> key = vtu_geometry_key(good);
  if (GetParam().appended_base64) {
    EXPECT_FALSE(key.has_value()) << "appended base64 has no stored length: read whole";
    return;
  }
  ASSERT_TRUE(key.has_value());
  const std::string again = dir.file("again.vtu");
  write_file(again, test_vtu(GetParam()));
  EXPECT_EQ(vtu_geometry_key(again), key);
  EXPECT_NE(vtu_geometry_key(corrupt), key);
}

INSTANTIATE_TEST_SUITE_P(
    Encodings, VtkXmlEncodingTest,
    ::testing::Values(Encoding{"ascii", "ascii"}, Encoding{"binary32", "binary"}, Encoding{"binary64", "binary", true},
                      Encoding{"binary_zlib", "binary", false, Codec::Zlib},
                      Encoding{"binary64_lz4", "binary", true, Codec::Lz4}, Encoding{"raw32", "appended"},
                      Encoding{"raw64", "appended", true}, Encoding{"raw_zlib", "appended", false, Codec::Zlib},
                      Encoding{"raw64_lz4", "appended", true, Codec::Lz4},
                      Encoding{"base64_appended", "appended", false, Codec::None, true},
                      Encoding{"base64_appended64_zlib", "appended", true, Codec::Zlib, true},
                      Encoding{"raw_bigendian", "appended", false, Codec::None, false, true},
                      Encoding{"raw64_bigendian_zlib", "appended", true, Codec::Zlib, false, true},
                      Encoding{"binary_bigendian_lz4", "binary", false, Codec::Lz4, false, true},
                      Encoding{"raw_zlib_one_block", "appended", false, Codec::Zlib, false, false, 1 << 16}),
    [](const ::testing::TestParamInfo<Encoding>& p) { return std::string(p.param.name); });

TEST(VtkXmlReader, LineWrappedBase64AndPlusSignedCounts) {
  // Some writers wrap base64 text and write counts with a '+' (blood_vessels does).
  ScratchDir dir;
  const Encoding e{"binary", "binary"};
  std::string text = test_vtu(e);
  text.replace(text.find("NumberOfPoints=\"9\""), 18, "NumberOfPoints=\"+9\"");
  // Wrap every base64 text at 16 characters.
  std::string wrapped;
  size_t run = 0;
  bool in_text = false;
  for (char c : text) {
    if (c == '<') in_text = false;
    wrapped += c;
    if (in_text && c != '\n' && c != ' ' && ++run % 16 == 0) wrapped += "\n   ";
    if (c == '>') in_text = true, run = 0;
  }
  const std::string path = dir.file("wrapped.vtu");
  write_file(path, wrapped);
  expect_test_mesh(read_vtk_xml(path));
}

TEST(VtkXmlReader, SeveralPiecesInOneFileAreConcatenated) {
  ScratchDir dir;
  Writer w(Encoding{"raw", "appended"});
  std::string body = "<UnstructuredGrid>\n" + test_piece(w);
  body += "<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<PointData>\n";
  body += w.data_array(make_array("temp", 1, std::vector<double>{10, 11, 12, 13}));
  body += w.data_array(make_array("vel", 3, std::vector<float>(12, 0.5f)));
  body += "</PointData>\n<CellData>\n";
  body += w.data_array(make_array("flag", 1, std::vector<uint8_t>{9}));  // other order than piece 0
  body += w.data_array(make_array("id", 1, std::vector<int32_t>{200}));
  body += "</CellData>\n<Points>\n";
  body += w.data_array(make_array("Points", 3, std::vector<float>{5, 0, 0, 6, 0, 0, 5, 1, 0, 5, 0, 1}));
  body += "</Points>\n<Cells>\n";
  body += w.data_array(make_array("connectivity", 1, std::vector<int32_t>{0, 1, 2, 3}));
  body += w.data_array(make_array("offsets", 1, std::vector<int32_t>{4}));
  body += w.data_array(make_array("types", 1, std::vector<uint8_t>{10}));
  body += "</Cells>\n</Piece>\n</UnstructuredGrid>\n";
  const std::string path = dir.file("two_pieces.vtu");
  write_file(path, w.file("UnstructuredGrid", body));
  const Dataset ds = read_vtk_xml(path);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 13u);
  EXPECT_EQ(mesh.cell_count(), 4u);
  EXPECT_EQ(mesh.points[9].x, 5.0f);
  const auto last = mesh.cell(3);
  EXPECT_EQ(std::vector<uint32_t>(last.begin(), last.end()), (std::vector<uint32_t>{9, 10, 11, 12}));
  const Field* id = ds.blocks[0].fields.find("id", Association::Cell);
  ASSERT_NE(id, nullptr);
  EXPECT_EQ(id->data().get(3, 0), 200);
  EXPECT_EQ(ds.blocks[0].fields.find("temp")->data().get(12, 0), 13);
  EXPECT_EQ(ds.blocks[0].fields.find("flag")->data().get(3, 0), 9);
}

TEST(VtkXmlReader, PiecesMustAgreeOnArrays) {
  ScratchDir dir;
  Writer w(Encoding{"ascii", "ascii"});
  std::string body = "<UnstructuredGrid>\n" + test_piece(w);
  body += "<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<Points>\n";
  body += w.data_array(make_array("Points", 3, std::vector<float>(12, 0.0f)));
  body += "</Points>\n<Cells>\n";
  body += w.data_array(make_array("connectivity", 1, std::vector<int32_t>{0, 1, 2, 3}));
  body += w.data_array(make_array("offsets", 1, std::vector<int32_t>{4}));
  body += w.data_array(make_array("types", 1, std::vector<uint8_t>{10}));
  body += "</Cells>\n</Piece>\n</UnstructuredGrid>\n";
  const std::string path = dir.file("disagree.vtu");
  write_file(path, w.file("UnstructuredGrid", body));
  try {
    read_vtk_xml(path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("disagree.vtu"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("lacks point array 'temp'"), std::string::npos) << e.what();
  }
}

TEST(VtkXmlReader, PvtuConcatenatesPieceFiles) {
  ScratchDir dir;
  std::filesystem::create_directories(dir.file("parts"));
  write_file(dir.file("parts/a.vtu"), test_vtu(Encoding{"zlib", "appended", false, Codec::Zlib}));
  Writer w(Encoding{"ascii", "ascii"});
  std::string body = "<UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<PointData>\n";
  body += w.data_array(make_array("temp", 1, std::vector<double>{10, 11, 12, 13}));
  body += w.data_array(make_array("vel", 3, std::vector<float>(12, 0.5f)));
  body += "</PointData>\n<CellData>\n";
  body += w.data_array(make_array("id", 1, std::vector<int32_t>{200}));
  body += w.data_array(make_array("flag", 1, std::vector<uint8_t>{9}));
  body += "</CellData>\n<Points>\n";
  body += w.data_array(make_array("Points", 3, std::vector<float>{5, 0, 0, 6, 0, 0, 5, 1, 0, 5, 0, 1}));
  body += "</Points>\n<Cells>\n";
  body += w.data_array(make_array("connectivity", 1, std::vector<int64_t>{3, 1, 2, 0}));
  body += w.data_array(make_array("offsets", 1, std::vector<int64_t>{4}));
  body += w.data_array(make_array("types", 1, std::vector<uint8_t>{10}));
  body += "</Cells>\n</Piece>\n</UnstructuredGrid>\n";
  write_file(dir.file("parts/b.vtu"), w.file("UnstructuredGrid", body));
  write_file(dir.file("whole.pvtu"), R"(<?xml version="1.0"?>
<VTKFile type="PUnstructuredGrid" version="0.1" byte_order="LittleEndian">
  <PUnstructuredGrid GhostLevel="0">
    <PPoints><PDataArray type="Float32" NumberOfComponents="3"/></PPoints>
    <PPointData><PDataArray type="Float64" Name="temp"/><PDataArray type="Float32" Name="vel" NumberOfComponents="3"/></PPointData>
    <PCellData><PDataArray type="Int32" Name="id"/></PCellData>
    <Piece Source="parts/a.vtu"/>
    <Piece Source="parts/b.vtu"/>
  </PUnstructuredGrid>
</VTKFile>
)");
  const Dataset ds = read_vtk_xml(dir.file("whole.pvtu"));
  EXPECT_EQ(ds.format, "VTK XML PUnstructuredGrid (.pvtu)");
  EXPECT_EQ(ds.sources.size(), 3u);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 13u);
  ASSERT_EQ(mesh.cell_count(), 4u);
  const auto last = mesh.cell(3);
  EXPECT_EQ(std::vector<uint32_t>(last.begin(), last.end()), (std::vector<uint32_t>{12, 10, 11, 9}));
  EXPECT_EQ(ds.blocks[0].fields.find("id")->data().get(3, 0), 200);
  EXPECT_EQ(ds.blocks[0].fields.find("vel")->data().get(12, 2), 0.5);
  EXPECT_EQ(ds.warnings.size(), 1u);  // the dropped triangle of a.vtu

  // A piece that refers to another piece's points is refused.
  const std::string bad = read_text(dir.file("parts/b.vtu"));
  std::string text = bad;
  text.replace(text.find("3 1 2 0"), 7, "3 1 2 9");
  write_file(dir.file("parts/b.vtu"), text);
  EXPECT_THROW(read_vtk_xml(dir.file("whole.pvtu")), Error);

  // A missing piece file is named in the error.
  std::filesystem::remove(dir.file("parts/b.vtu"));
  try {
    read_vtk_xml(dir.file("whole.pvtu"));
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("b.vtu"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Structured formats

TEST(VtkXmlReader, StructuredGrid) {
  ScratchDir dir;
  Writer w(Encoding{"lz4", "appended", true, Codec::Lz4});
  std::vector<double> pts;
  std::vector<float> p;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 3; ++i) {
        pts.insert(pts.end(), {double(i), 2.0 * j, 3.0 * k});
        p.push_back(float(p.size()));
      }
  std::string body = "<StructuredGrid WholeExtent=\"0 2 0 1 0 1\">\n<Piece Extent=\"0 2 0 1 0 1\">\n<PointData>\n";
  body += w.data_array(make_array("p", 1, p));
  body += "</PointData>\n<CellData>\n" + w.data_array(make_array("c", 1, std::vector<int16_t>{7, 9}));
  body += "</CellData>\n<Points>\n" + w.data_array(make_array("Points", 3, pts)) + "</Points>\n</Piece>\n";
  body += "</StructuredGrid>\n";
  const std::string path = dir.file("grid.vts");
  write_file(path, w.file("StructuredGrid", body));
  const Dataset ds = read_vtk_xml(path);
  EXPECT_EQ(ds.format, "VTK XML StructuredGrid (.vts)");
  const auto& g = std::get<StructuredGrid>(ds.blocks[0].grid);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{3, 2, 2}));
  ASSERT_EQ(g.points.size(), 12u);
  EXPECT_EQ(g.points[g.dims.point_index(2, 1, 1)], (Vec3f{2, 2, 3}));
  EXPECT_EQ(ds.blocks[0].fields.find("p")->data().get(11, 0), 11);
  const Field* c = ds.blocks[0].fields.find("c", Association::Cell);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->data().type(), ScalarType::Int16);
  EXPECT_EQ(c->data().get(1, 0), 9);
}

TEST(VtkXmlReader, ImageData) {
  ScratchDir dir;
  Writer w(Encoding{"binary", "binary", false, Codec::Zlib});
  std::vector<float> v(12);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float(i) * 0.5f;
  std::string body =
      "<ImageData WholeExtent=\"2 4 0 1 0 1\" Origin=\"1 2 3\" Spacing=\"0.5 1 2\" Direction=\"1 0 0 0 1 0 0 0 1\">\n"
      "<Piece Extent=\"2 4 0 1 0 1\">\n<PointData>\n" +
      w.data_array(make_array("density", 1, v)) + "</PointData>\n</Piece>\n</ImageData>\n";
  const std::string path = dir.file("image.vti");
  write_file(path, w.file("ImageData", body));
  const Dataset ds = read_vtk_xml(path);
  EXPECT_EQ(ds.format, "VTK XML ImageData (.vti)");
  const auto& g = std::get<ImageGrid>(ds.blocks[0].grid);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{3, 2, 2}));
  // The extent starts at i = 2: the first point is Origin + 2 * Spacing along x.
  EXPECT_EQ(g.origin, (Vec3d{2, 2, 3}));
  EXPECT_EQ(g.spacing, (Vec3d{0.5, 1, 2}));
  EXPECT_EQ(ds.blocks[0].fields.find("density")->data().get(11, 0), 5.5);

  // A rotated image is refused.
  std::string rotated = read_text(path);
  rotated.replace(rotated.find("Direction=\"1 0 0"), 16, "Direction=\"0 1 0");
  write_file(path, rotated);
  try {
    read_vtk_xml(path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("image.vti"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Direction"), std::string::npos) << e.what();
  }
}

TEST(VtkXmlReader, ImageDataPiecesArePlacedByExtent) {
  ScratchDir dir;
  Writer w(Encoding{"ascii", "ascii"});
  // Whole grid 4 x 2 x 2 points, split at i = 1 (the pieces share the points at i = 1); value = whole point index.
  auto values = [](int i0, int i1) {
    std::vector<int32_t> v;
    for (int k = 0; k < 2; ++k)
      for (int j = 0; j < 2; ++j)
        for (int i = i0; i <= i1; ++i) v.push_back(i + 4 * (j + 2 * k));
    return v;
  };
  auto cells = [](int i0, int i1) {
    std::vector<double> v;
    for (int i = i0; i < i1; ++i) v.push_back(10.0 * i);
    return v;
  };
  std::string body = "<ImageData WholeExtent=\"0 3 0 1 0 1\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\n";
  body += "<Piece Extent=\"0 1 0 1 0 1\"><PointData>" + w.data_array(make_array("idx", 1, values(0, 1))) +
          "</PointData><CellData>" + w.data_array(make_array("c", 1, cells(0, 1))) + "</CellData></Piece>\n";
  body += "<Piece Extent=\"1 3 0 1 0 1\"><PointData>" + w.data_array(make_array("idx", 1, values(1, 3))) +
          "</PointData><CellData>" + w.data_array(make_array("c", 1, cells(1, 3))) + "</CellData></Piece>\n";
  body += "</ImageData>\n";
  const std::string path = dir.file("pieces.vti");
  write_file(path, w.file("ImageData", body));
  const Dataset ds = read_vtk_xml(path);
  const Field* idx = ds.blocks[0].fields.find("idx");
  ASSERT_NE(idx, nullptr);
  for (uint64_t i = 0; i < 16; ++i) EXPECT_EQ(idx->data().get(i, 0), double(i));
  const Field* c = ds.blocks[0].fields.find("c");
  ASSERT_EQ(c->tuples(), 3u);
  EXPECT_EQ(c->data().get(2, 0), 20.0);

  // Pieces that leave a gap are refused.
  std::string gap = read_text(path);
  gap.replace(gap.find("Extent=\"1 3 0 1 0 1\""), 20, "Extent=\"2 3 0 1 0 1\"");
  write_file(path, gap);
  EXPECT_THROW(read_vtk_xml(path), Error);
}

TEST(VtkXmlReader, RectilinearGrid) {
  ScratchDir dir;
  Writer w(Encoding{"base64", "appended", false, Codec::None, true});
  std::string body = "<RectilinearGrid WholeExtent=\"0 2 0 1 0 1\">\n<Piece Extent=\"0 2 0 1 0 1\">\n<PointData>\n";
  body += w.data_array(make_array("u", 1, std::vector<uint16_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}));
  body += "</PointData>\n<Coordinates>\n";
  body += w.data_array(make_array("x", 1, std::vector<double>{0, 1, 3}));
  body += w.data_array(make_array("y", 1, std::vector<float>{0, 2}));
  body += w.data_array(make_array("z", 1, std::vector<int32_t>{-1, 5}));
  body += "</Coordinates>\n</Piece>\n</RectilinearGrid>\n";
  const std::string path = dir.file("rect.vtr");
  write_file(path, w.file("RectilinearGrid", body));
  const Dataset ds = read_vtk_xml(path);
  EXPECT_EQ(ds.format, "VTK XML RectilinearGrid (.vtr)");
  const auto& g = std::get<RectilinearGrid>(ds.blocks[0].grid);
  EXPECT_EQ(g.coords[0], (std::vector<double>{0, 1, 3}));
  EXPECT_EQ(g.coords[1], (std::vector<double>{0, 2}));
  EXPECT_EQ(g.coords[2], (std::vector<double>{-1, 5}));
  EXPECT_EQ(ds.blocks[0].fields.find("u")->data().type(), ScalarType::UInt16);
  EXPECT_EQ(ds.blocks[0].fields.find("u")->data().get(11, 0), 12);
}

// ---------------------------------------------------------------------------------------------------------------
// Malformed files: ugvr::Error naming the file, never a crash.

void expect_error(const std::string& path, const std::string& needle = {}) {
  try {
    read_vtk_xml(path);
    ADD_FAILURE() << "expected ugvr::Error reading " << path;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(base_name(path)), std::string::npos) << what;
    if (!needle.empty()) {
      EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
  }
}

TEST(VtkXmlReaderErrors, TruncatedAppendedData) {
  ScratchDir dir;
  for (const Encoding& e : {Encoding{"raw", "appended"}, Encoding{"zlib", "appended", false, Codec::Zlib},
                            Encoding{"b64", "appended", true, Codec::None, true}}) {
    SCOPED_TRACE(e.name);
    std::string text = test_vtu(e);
    text.resize(text.find("\n   _") + 60);
    const std::string path = dir.file("truncated.vtu");
    write_file(path, text);
    expect_error(path);
  }
}

TEST(VtkXmlReaderErrors, BadOffsetsAndIds) {
  ScratchDir dir;
  const std::string good = test_vtu(Encoding{"ascii", "ascii"});
  // The ascii writer breaks lines every 6 values: connectivity reads "0 1 2 3 4 5\n6 7 4 5 6 7\n8 0 1 2 0 1\n3 4".
  const size_t at = good.find("8 13 16 20", good.find("Name=\"offsets\""));
  const size_t apex = good.find("8 0 1 2 0 1", good.find("Name=\"connectivity\""));
  const size_t types = good.find("12 14 5 10", good.find("Name=\"types\""));
  ASSERT_NE(at, std::string::npos);
  ASSERT_NE(apex, std::string::npos);
  ASSERT_NE(types, std::string::npos);
  struct Case {
    const char* name;
    std::string text;
    const char* needle;
  };
  std::string past_end = good, decreasing = good, bad_id = good, bad_type = good, short_offsets = good;
  past_end.replace(at, 10, "8 13 16 99");
  decreasing.replace(at, 10, "8 5 16 20");
  bad_id.replace(apex, 1, "42");
  bad_type.replace(types, 10, "12 14 5 99");
  short_offsets.replace(at, 10, "8 13 16");
  // Needles are chosen not to occur in the file names.
  const Encoding raw{"raw", "appended"};
  const std::vector<int64_t> conn_bad_id = {0, 1, 2, 3, 4, 5, 6, 7, 4, 5, 6, 7, 9, 0, 1, 2, 0, 1, 3, 4};
  const std::vector<int64_t> conn_extra = {0, 1, 2, 3, 4, 5, 6, 7, 4, 5, 6, 7, 8, 0, 1, 2, 0, 1, 3, 4, 0};
  for (const Case& c :
       {Case{"past_end.vtu", past_end, "ascii text ends after 20 values"},
        Case{"decreasing.vtu", decreasing, "smaller"}, Case{"bad_id.vtu", bad_id, "outside"},
        Case{"bad_type.vtu", bad_type, "type 99"}, Case{"short_offsets.vtu", short_offsets, "ends after 3 values"},
        Case{"raw_past_end.vtu", test_vtu(raw, {.offsets = {8, 13, 16, 99}}), "beyond the connectivity"},
        Case{"raw_decreasing.vtu", test_vtu(raw, {.conn64 = false, .offsets = {8, 13, 12, 20}}), "smaller"},
        Case{"raw_unused.vtu", test_vtu(raw, {.connectivity = conn_extra}), "offsets use 20"},
        Case{"raw_bad_id.vtu", test_vtu(raw, {.connectivity = conn_bad_id}), "point id 9 is outside"}}) {
    SCOPED_TRACE(c.name);
    write_file(dir.file(c.name), c.text);
    expect_error(dir.file(c.name), c.needle);
  }
}

TEST(VtkXmlReaderErrors, AbsurdCounts) {
  ScratchDir dir;
  for (const Encoding& e :
       {Encoding{"ascii", "ascii"}, Encoding{"raw", "appended"}, Encoding{"zlib", "binary", false, Codec::Zlib}}) {
    SCOPED_TRACE(e.name);
    std::string text = test_vtu(e);
    text.replace(text.find("NumberOfPoints=\"9\""), 18, "NumberOfPoints=\"1000000000000\"");
    write_file(dir.file("absurd.vtu"), text);
    expect_error(dir.file("absurd.vtu"));
    text = test_vtu(e);
    text.replace(text.find("NumberOfCells=\"4\""), 17, "NumberOfCells=\"4000000000000\"");
    write_file(dir.file("absurd_cells.vtu"), text);
    expect_error(dir.file("absurd_cells.vtu"));
  }
}

// A compressed block header that claims a gigabyte from a few bytes is refused before anything is allocated.
TEST(VtkXmlReaderErrors, CompressedHeaderClaimingHugeBlocks) {
  ScratchDir dir;
  const Encoding e{"zlib", "binary", false, Codec::Zlib};
  std::vector<std::byte> header;
  for (uint64_t w : {uint64_t(1), uint64_t(1) << 30, uint64_t(0), uint64_t(16)}) append(header, header_word(w, e));
  std::string text = test_vtu(e);
  const size_t points = text.find("Name=\"Points\"");
  const size_t begin = text.find('>', points) + 4, end = text.find('\n', begin);
  text.replace(begin, end - begin, base64_encode(header) + base64_encode(std::vector<std::byte>(16)));
  write_file(dir.file("huge_block.vtu"), text);
  expect_error(dir.file("huge_block.vtu"), "cannot expand");
}

TEST(VtkXmlReaderErrors, CorruptZlibAndLz4Blocks) {
  ScratchDir dir;
  for (const Codec codec : {Codec::Zlib, Codec::Lz4}) {
    const Encoding e{"c", "appended", false, codec, false, false, 1 << 16};
    std::string text = test_vtu(e);
    // The first array (temp) starts right after '_': header of 4 words, then its compressed block.
    const size_t data = text.find("\n   _") + 5 + 16;
    for (size_t i = 0; i < 6; ++i) text[data + i] = char(0xA5 ^ i);
    write_file(dir.file("damaged.vtu"), text);
    expect_error(dir.file("damaged.vtu"), "corrupt");
  }
}

TEST(VtkXmlReaderErrors, BadBase64) {
  ScratchDir dir;
  std::string text = test_vtu(Encoding{"binary", "binary"});
  const size_t points = text.find("Name=\"Points\"");
  const size_t begin = text.find('>', points) + 4;
  text[begin + 8] = '!';
  write_file(dir.file("bad_base64.vtu"), text);
  expect_error(dir.file("bad_base64.vtu"), "invalid character '!'");
}

TEST(VtkXmlReaderErrors, MalformedMarkup) {
  ScratchDir dir;
  const std::string good = test_vtu(Encoding{"raw", "appended"});
  struct Case {
    const char* name;
    std::string text;
    const char* needle;
  };
  std::string no_marker = good, cut_tag = good.substr(0, good.find("<Cells>") + 4), mismatched = good,
              not_vtk = "<?xml version=\"1.0\"?>\n<html><body>hi</body></html>\n",
              polydata = "<VTKFile type=\"PolyData\"><PolyData></PolyData></VTKFile>";
  no_marker[no_marker.find("\n   _") + 4] = ' ';
  mismatched.replace(mismatched.find("</Points>"), 9, "</Pts>");
  for (const Case& c : {Case{"no_marker.vtu", no_marker, "expected '_'"}, Case{"cut_tag.vtu", cut_tag, "unterminated"},
                        Case{"mismatched.vtu", mismatched, "</Pts>"}, Case{"not_vtk.vtu", not_vtk, "VTKFile"},
                        Case{"polydata.vtp", polydata, "PolyData"}, Case{"empty.vtu", "", "no XML element"}}) {
    SCOPED_TRACE(c.name);
    write_file(dir.file(c.name), c.text);
    expect_error(dir.file(c.name), c.needle);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Base64 decoder details VTK files rely on.

TEST(Base64, DecodesConcatenatedPaddedStreamsAndWhitespace) {
  const std::string text = "SGVs bG8=\n LCB3\tb3JsZA==";  // "Hello" and ", world" encoded separately
  Base64Decoder d;
  std::vector<std::byte> out(64);
  const auto r = d.decode(text, out);
  EXPECT_FALSE(r.stopped_at_invalid);
  EXPECT_EQ(r.consumed, text.size());
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(out.data()), r.produced), "Hello, world");
  EXPECT_EQ(d.finish(out), 0);
}

TEST(Base64, StopsAtInvalidCharactersAndRoundTrips) {
  Base64Decoder d;
  std::vector<std::byte> out(16);
  const auto r = d.decode("QUJD<", out);
  EXPECT_TRUE(r.stopped_at_invalid);
  EXPECT_EQ(r.consumed, 4u);
  EXPECT_EQ(r.produced, 3u);
  std::vector<std::byte> data;
  for (int i = 0; i < 100; ++i) data.push_back(std::byte(i * 37));
  for (size_t n = 0; n < 7; ++n) {
    const std::string enc = base64_encode(std::span(data).first(n));
    Base64Decoder e;
    std::vector<std::byte> back(16);
    const auto rr = e.decode(enc, back);
    ASSERT_EQ(rr.produced, n);
    EXPECT_TRUE(std::equal(back.begin(), back.begin() + ptrdiff_t(n), data.begin()));
  }
  Base64Decoder unpadded;
  const auto ru = unpadded.decode("QUJDRA", out);  // "ABCD" without its "=="
  EXPECT_EQ(ru.produced, 3u);
  EXPECT_EQ(unpadded.finish(std::span(out).subspan(3)), 1);
  EXPECT_EQ(char(out[3]), 'D');
}

// ---------------------------------------------------------------------------------------------------------------
// Real datasets

TEST(VtkXmlRealData, Can) {
  UGVR_REQUIRE_DATA("can/can.vtu");
  const Dataset ds = read_vtk_xml(relative_data_path);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 6724u);
  EXPECT_EQ(mesh.cell_count(), 4800u);
  EXPECT_EQ(mesh.cell_type_counts().hexahedron, 4800u);
  const Field* eqps = ds.blocks[0].fields.find("EQPS", Association::Cell);
  ASSERT_NE(eqps, nullptr);
  EXPECT_NEAR(eqps->range().min, 0.0216, 1e-4);
  EXPECT_NEAR(eqps->range().max, 2.894, 1e-3);
  for (const char* name : {"DISPL", "VEL", "ACCL"}) {
    const Field* f = ds.blocks[0].fields.find(name, Association::Vertex);
    ASSERT_NE(f, nullptr) << name;
    EXPECT_EQ(f->components(), 3);
    EXPECT_EQ(f->data().type(), ScalarType::Float64);
  }
  // The magnitude range VTK records in the file.
  EXPECT_NEAR(ds.blocks[0].fields.find("DISPL")->range().max, 18.594444351, 1e-6);
  EXPECT_TRUE(ds.warnings.empty());
}

TEST(VtkXmlRealData, KieferBracketQuadraticTets) {
  UGVR_REQUIRE_DATA("fea-kiefer-bracket/dataset.vtu");
  const Dataset ds = read_vtk_xml(relative_data_path);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 102578u);
  EXPECT_EQ(mesh.cell_count(), 56786u);
  EXPECT_EQ(mesh.cell_type_counts().tetra, 56786u);
  EXPECT_EQ(mesh.connectivity.size(), 56786u * 4);
  expect_exact_capacity(mesh);
  const Field* s = ds.blocks[0].fields.find("Equivalent (von-Mises) Stress (psi)", Association::Cell);
  ASSERT_NE(s, nullptr);
  EXPECT_NEAR(s->range().min, 0.014035, 1e-5);
  EXPECT_NEAR(s->range().max, 23.269, 1e-3);
}

TEST(VtkXmlRealData, NotchQuadraticHexesAndWedges) {
  UGVR_REQUIRE_DATA("notch-stress/notch_disp.vtu");
  const Dataset ds = read_vtk_xml(relative_data_path);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 12717u);
  const CellTypeCounts counts = mesh.cell_type_counts();
  EXPECT_EQ(counts.hexahedron, 2188u);
  EXPECT_EQ(counts.wedge, 4u);
  EXPECT_EQ(counts.total(), 2192u);
  const Field* d = ds.blocks[0].fields.find("Nodal Displacement");
  ASSERT_NE(d, nullptr);
  EXPECT_NEAR(d->range().max, 2.79363190936612e-06, 1e-12);
}

TEST(VtkXmlRealData, SmallUgrids) {
  {
    UGVR_REQUIRE_DATA("vtk-small-ugrids/Tetrahedron.vtu");
    const Dataset ds = read_vtk_xml(relative_data_path);
    const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
    EXPECT_EQ(mesh.point_count(), 35u);
    EXPECT_EQ(mesh.cell_type_counts().tetra, 96u);
    EXPECT_EQ(mesh.cell_count(), 96u);
    EXPECT_NE(ds.blocks[0].fields.find("Polynomial"), nullptr);
    EXPECT_NEAR(ds.blocks[0].fields.find("Polynomial")->range().max, 7.0, 1e-6);
  }
  {
    UGVR_REQUIRE_DATA("vtk-small-ugrids/tetra.vtu");
    const Dataset ds = read_vtk_xml(relative_data_path);
    const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
    EXPECT_EQ(mesh.cell_count(), 1u);
    EXPECT_EQ(mesh.cell_type_counts().tetra, 1u);
    ASSERT_EQ(ds.warnings.size(), 1u);
    EXPECT_NE(ds.warnings[0].find("2 lower-dimensional"), std::string::npos) << ds.warnings[0];
  }
  {
    UGVR_REQUIRE_DATA("vtk-small-ugrids/polyhedron2pieces.vtu");
    try {
      read_vtk_xml(relative_data_path);
      FAIL() << "polyhedra must be refused";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("polyhedron2pieces.vtu"), std::string::npos) << what;
      EXPECT_NE(what.find("POLYHEDRON"), std::string::npos) << what;
    }
  }
}

TEST(VtkXmlRealData, BloodVesselsPvtu) {
  UGVR_REQUIRE_DATA("blood-vessels-pvtu/blood_vessels.zip");
  ScratchDir dir;
  const std::string cmd = "cd '" + dir.file("") + "' && /usr/bin/python3 -m zipfile -e '" + relative_data_path + "' .";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Dataset ds = read_vtk_xml(dir.file("blood_vessels/T0000000500.pvtu"));
  EXPECT_EQ(ds.format, "VTK XML PUnstructuredGrid (.pvtu)");
  EXPECT_EQ(ds.sources.size(), 5u);
  const auto& mesh = std::get<UnstructuredMesh>(ds.blocks[0].grid);
  EXPECT_EQ(mesh.point_count(), 48823u);
  EXPECT_EQ(mesh.cell_count(), 39353u);
  EXPECT_EQ(mesh.cell_type_counts().hexahedron, 39353u);
  // Voxels are reordered into hexahedra: every cell has positive volume.
  EXPECT_GT(cell_volume(mesh, 0), 0.0);
  EXPECT_GT(cell_volume(mesh, mesh.cell_count() - 1), 0.0);
  const Field* density = ds.blocks[0].fields.find("density", Association::Cell);
  ASSERT_NE(density, nullptr);
  EXPECT_NEAR(density->range().min, 0.22, 0.01);
  EXPECT_NEAR(density->range().max, 0.52, 0.01);
  EXPECT_EQ(ds.blocks[0].fields.find("velocity")->components(), 3);
  EXPECT_EQ(ds.blocks[0].fields.find("node_value", Association::Vertex)->data().type(), ScalarType::Int32);
}

}  // namespace
}  // namespace ugvr
