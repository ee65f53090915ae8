// Exodus II reader: the four real files (counts, ranges, time steps, block ids, no inverted cells), and small
// synthetic files written with a minimal netCDF-3 classic writer below (the tests do not link netCDF) for element
// orderings, dropped / refused element types, truth tables and malformed input, which must fail with ugvr::Error
// naming the file and the variable.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

using test::ScratchDir;

const UnstructuredMesh& mesh_of(const Dataset& ds) { return std::get<UnstructuredMesh>(ds.blocks.at(0).grid); }

uint64_t inverted_cells(const UnstructuredMesh& m) {
  uint64_t n = 0;
  for (uint64_t c = 0; c < m.cell_count(); ++c) n += cell_volume(m, c) <= 0;
  return n;
}

using test::error_of;

// ---- Real files ----

TEST(ExodusReader, DiskOutRef) {
  UGVR_REQUIRE_DATA("disk-out-ref/disk_out_ref.ex2");
  const Dataset ds = read_exodus(relative_data_path, -1);
  const UnstructuredMesh& m = mesh_of(ds);
  EXPECT_EQ(m.point_count(), 8499u);
  EXPECT_EQ(m.cell_count(), 7472u);
  EXPECT_EQ(m.cell_type_counts().hexahedron, 7472u);
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_NE(ds.format.find("time step 0 of 1"), std::string::npos) << ds.format;
  const FieldSet& f = ds.blocks[0].fields;
  // Temp, V (VX VY VZ grouped), Pres, AsH3, GaMe3, CH4, H2 are the 7 point fields; block_id the cell field.
  uint64_t vertex_fields = 0;
  for (const Field& field : f) vertex_fields += field.association() == Association::Vertex;
  EXPECT_EQ(vertex_fields, 7u);
  const Field* temp = f.find("Temp", Association::Vertex);
  ASSERT_NE(temp, nullptr);
  EXPECT_EQ(temp->data().type(), ScalarType::Float32);  // stored as float in the file
  EXPECT_NEAR(temp->range().min, 293.15, 0.01);
  EXPECT_NEAR(temp->range().max, 913.15, 0.01);
  const Field* v = f.find("V", Association::Vertex);
  ASSERT_NE(v, nullptr);
  EXPECT_EQ(v->components(), 3);
  EXPECT_GT(v->range(kMagnitude).max, 1.0);
  for (const char* name : {"Pres", "AsH3", "GaMe3", "CH4", "H2"}) EXPECT_NE(f.find(name), nullptr) << name;
  const Field* block = f.find("block_id", Association::Cell);
  ASSERT_NE(block, nullptr);
  EXPECT_EQ(block->data().type(), ScalarType::Int32);
  EXPECT_EQ(block->range().min, 1);
  EXPECT_EQ(block->range().max, 1);
}

TEST(ExodusReader, MugTimeStepsAndBlocks) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  const Dataset last = read_exodus(relative_data_path, -1);
  const UnstructuredMesh& m = mesh_of(last);
  EXPECT_EQ(m.point_count(), 3774u);
  EXPECT_EQ(m.cell_count(), 1716u + 760u);
  EXPECT_EQ(inverted_cells(m), 0u);
  EXPECT_NE(last.format.find("time step 20 of 21 (t = 2)"), std::string::npos) << last.format;
  const Field* block = last.blocks[0].fields.find("block_id");
  ASSERT_NE(block, nullptr);
  // Cells in block order: 1,716 of block 1, then 760 of block 76.
  EXPECT_EQ(block->data().get(0, 0), 1);
  EXPECT_EQ(block->data().get(1715, 0), 1);
  EXPECT_EQ(block->data().get(1716, 0), 76);
  EXPECT_EQ(block->data().get(2475, 0), 76);
  const Field* aux = last.blocks[0].fields.find("aux_elem", Association::Cell);
  ASSERT_NE(aux, nullptr);
  EXPECT_EQ(aux->data().type(), ScalarType::Float64);
  EXPECT_GE(aux->range().min, 0.009);
  EXPECT_LE(aux->range().max, 9.992);
  EXPECT_GT(aux->range().max, 9.9);

  const Dataset first = read_exodus(relative_data_path, 0);
  EXPECT_NE(first.format.find("time step 0 of 21 (t = 0)"), std::string::npos) << first.format;
  const Field* convected = first.blocks[0].fields.find("convected");
  ASSERT_NE(convected, nullptr);
  EXPECT_EQ(convected->range().min, 0);  // all 0 at step 0
  EXPECT_EQ(convected->range().max, 0);
  const Field* convected_last = last.blocks[0].fields.find("convected");
  ASSERT_NE(convected_last, nullptr);
  EXPECT_GT(convected_last->range().max, 0.5);

  const std::string e = error_of([&] { read_exodus(relative_data_path, 21); });
  EXPECT_NE(e.find("mug.e"), std::string::npos) << e;
  EXPECT_NE(e.find("21 time steps"), std::string::npos) << e;
  EXPECT_NE(e.find("0 0.1 0.2"), std::string::npos) << e;
  EXPECT_NE(error_of([&] { read_exodus(relative_data_path, -2); }).find("does not exist"), std::string::npos);
}

TEST(ExodusReader, BoxNoglomTetra) {
  UGVR_REQUIRE_DATA("exodus-misc/box-noglom.ex2");
  const Dataset ds = read_exodus(relative_data_path, -1);
  const UnstructuredMesh& m = mesh_of(ds);
  EXPECT_EQ(m.point_count(), 27u);
  EXPECT_EQ(m.cell_type_counts().tetra, 40u);
  EXPECT_EQ(inverted_cells(m), 0u);
  const FieldSet& f = ds.blocks[0].fields;
  EXPECT_EQ(f.size(), 1u + 3u + 6u);
  EXPECT_EQ(f.find("block_id")->range().min, 10);
  ASSERT_NE(f.find("First Cell Array", Association::Cell), nullptr);
  EXPECT_NEAR(f.find("First Cell Array")->range().max, 0.0807692, 1e-6);
  EXPECT_NE(f.find("Third Point Array", Association::Vertex), nullptr);
}

TEST(ExodusReader, MeshFs8WedgesNotInverted) {
  UGVR_REQUIRE_DATA("exodus-misc/mesh_fs8.exo");
  const Dataset ds = read_exodus(relative_data_path, -1);
  const UnstructuredMesh& m = mesh_of(ds);
  EXPECT_EQ(m.point_count(), 1000u);
  EXPECT_EQ(m.cell_type_counts().wedge, 1344u);
  EXPECT_EQ(inverted_cells(m), 0u);  // Exodus wedges are reordered to VTK's orientation
  EXPECT_NE(ds.format.find("no time steps"), std::string::npos) << ds.format;
  ASSERT_EQ(ds.blocks[0].fields.size(), 1u);  // only block_id: the file has no variables
  const DataArray& ids = ds.blocks[0].fields[0].data();
  uint64_t per_block[4] = {};
  for (uint64_t c = 0; c < ids.tuples(); ++c) per_block[int(ids.get(c, 0))]++;
  EXPECT_EQ(per_block[1], 336u);
  EXPECT_EQ(per_block[2], 336u);
  EXPECT_EQ(per_block[3], 672u);
  // A time step on a file without any is an error naming the count.
  EXPECT_NE(error_of([&] { read_exodus(relative_data_path, 0); }).find("0 time steps"), std::string::npos);
}

TEST(ExodusReader, TruncatedRealFileFails) {
  UGVR_REQUIRE_DATA("exodus-misc/box-noglom.ex2");
  ScratchDir dir;
  std::ifstream in(relative_data_path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (size_t cut : {size_t(3), size_t(200), bytes.size() / 2}) {
    const std::string path = dir.file("cut.ex2");
    std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(cut));
    const std::string e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find("cut.ex2"), std::string::npos) << cut << ": " << e;
  }
}

// ---- Synthetic files: a minimal netCDF-3 classic (CDF-1) writer ----

enum NcType : int32_t { kChar = 2, kInt = 4, kFloat = 5, kDouble = 6 };

struct NcVar {
  std::string name;
  std::vector<int> dims;
  NcType type;
  std::vector<double> values;  // numbers (kInt, kFloat, kDouble)
  std::string text;            // kChar
  std::string elem_type;       // attribute, when not empty
};

class NcWriter {
 public:
  int dim(const std::string& name, int32_t len) {
    dims_.push_back({name, len});
    return int(dims_.size() - 1);
  }
  void var(NcVar v) { vars_.push_back(std::move(v)); }
  // Names padded to `len` characters per row.
  void names(const std::string& var_name, int rows_dim, int len_dim, const std::vector<std::string>& rows) {
    std::string text;
    for (const std::string& r : rows) text += r + std::string(size_t(dims_[size_t(len_dim)].second) - r.size(), '\0');
    var({var_name, {rows_dim, len_dim}, kChar, {}, text, ""});
  }

  std::string bytes() const {
    std::string header = "CDF\x01";
    i32(header, 0);  // numrecs: no record variables
    i32(header, 10);
    i32(header, int32_t(dims_.size()));
    for (const auto& [name, len] : dims_) {
      str(header, name);
      i32(header, len);
    }
    i32(header, 0);  // no global attributes
    i32(header, 0);
    i32(header, 11);
    i32(header, int32_t(vars_.size()));
    std::vector<size_t> begin_at;
    std::vector<std::string> data;
    for (const NcVar& v : vars_) {
      str(header, v.name);
      i32(header, int32_t(v.dims.size()));
      for (int d : v.dims) i32(header, d);
      if (v.elem_type.empty()) {
        i32(header, 0);
        i32(header, 0);
      } else {
        i32(header, 12);
        i32(header, 1);
        str(header, "elem_type");
        i32(header, kChar);
        str(header, v.elem_type);
      }
      i32(header, v.type);
      std::string d = values(v);
      while (d.size() % 4) d.push_back('\0');
      i32(header, int32_t(d.size()));
      begin_at.push_back(header.size());
      i32(header, 0);  // begin, patched below
      data.push_back(std::move(d));
    }
    std::string out = header;
    for (size_t i = 0; i < vars_.size(); ++i) {
      const std::string b = be(uint32_t(out.size()));
      out.replace(begin_at[i], 4, b);
      out += data[i];
    }
    return out;
  }

 private:
  static std::string be(uint32_t v) { return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; }
  static void i32(std::string& s, int32_t v) { s += be(uint32_t(v)); }
  static void str(std::string& s, const std::string& t) {
    i32(s, int32_t(t.size()));
    s += t;
    while (s.size() % 4) s.push_back('\0');
  }
  static std::string values(const NcVar& v) {
    if (v.type == kChar) return v.text;
    std::string s;
    for (double x : v.values) {
      if (v.type == kInt) {
        i32(s, int32_t(x));
      } else if (v.type == kFloat) {
        s += be(std::bit_cast<uint32_t>(float(x)));
      } else {
        const uint64_t u = std::bit_cast<uint64_t>(x);
        s += be(uint32_t(u >> 32)) + be(uint32_t(u));
      }
    }
    return s;
  }

  std::vector<std::pair<std::string, int32_t>> dims_;
  std::vector<NcVar> vars_;
};

// One unit cube's 8 corners plus an apex above it (node 9) as separate coordx/y/z.
struct Model {
  NcWriter w;
  int d_nodes, d_time, d_len;
  explicit Model(int blocks) {
    d_len = w.dim("len_name", 8);
    w.dim("num_dim", 3);
    d_nodes = w.dim("num_nodes", 9);
    d_time = w.dim("time_step", 2);  // fixed length here; the reader does not care whether it is unlimited
    const int d_blk = w.dim("num_el_blk", blocks);
    w.var({"time_whole", {d_time}, kDouble, {0.5, 1.5}, "", ""});
    w.var({"coordx", {d_nodes}, kDouble, {0, 1, 1, 0, 0, 1, 1, 0, 0.5}, "", ""});
    w.var({"coordy", {d_nodes}, kDouble, {0, 0, 1, 1, 0, 0, 1, 1, 0.5}, "", ""});
    w.var({"coordz", {d_nodes}, kDouble, {0, 0, 0, 0, 1, 1, 1, 1, 2}, "", ""});
    std::vector<double> ids;
    for (int b = 0; b < blocks; ++b) ids.push_back(100 + b);
    w.var({"eb_prop1", {d_blk}, kInt, ids, "", ""});
  }
  // Block b (1-based) of `rows` elements with `per` nodes each.
  void block(int b, const std::string& type, int per, const std::vector<double>& connect) {
    const std::string n = std::to_string(b);
    const int d_el = w.dim("num_el_in_blk" + n, int32_t(connect.size() / size_t(per)));
    const int d_per = w.dim("num_nod_per_el" + n, per);
    w.var({"connect" + n, {d_el, d_per}, kInt, connect, "", type});
    el_dims.push_back(d_el);
  }
  std::string write(const ScratchDir& dir, const std::string& name) const {
    const std::string path = dir.file(name);
    const std::string b = w.bytes();
    std::ofstream(path, std::ios::binary).write(b.data(), std::streamsize(b.size()));
    return path;
  }
  std::vector<int> el_dims;
};

TEST(ExodusReader, SyntheticOrderingsAndVariables) {
  ScratchDir dir;
  Model m(4);
  m.block(1, "HEX8", 8, {1, 2, 3, 4, 5, 6, 7, 8});
  m.block(2, "WEDGE6", 6, {1, 2, 3, 5, 6, 7});  // Exodus order: first triangle's normal points to the second
  m.block(3, "PYRAMID5", 5, {5, 6, 7, 8, 9});
  m.block(4, "SHELL4", 4, {1, 2, 3, 4});  // dropped
  // Nodal variables VelX/VelY/VelZ (float) become one vector; T stays a scalar.
  const int d_nv = m.w.dim("num_nod_var", 4);
  m.w.names("name_nod_var", d_nv, m.d_len, {"VelX", "VelY", "VelZ", "T"});
  for (int v = 1; v <= 4; ++v) {
    std::vector<double> vals;
    for (int t = 0; t < 2; ++t)
      for (int i = 0; i < 9; ++i) vals.push_back(100 * t + 10 * v + i);
    m.w.var({"vals_nod_var" + std::to_string(v), {m.d_time, m.d_nodes}, kFloat, vals, "", ""});
  }
  // Element variable "e": defined on blocks 1 and 3, not on block 2 (truth table 0).
  const int d_ev = m.w.dim("num_elem_var", 1);
  m.w.names("name_elem_var", d_ev, m.d_len, {"e"});
  m.w.var({"vals_elem_var1eb1", {m.d_time, m.el_dims[0]}, kDouble, {1, 2}, "", ""});
  m.w.var({"vals_elem_var1eb3", {m.d_time, m.el_dims[2]}, kDouble, {3, 4}, "", ""});
  m.w.var({"elem_var_tab", {4, d_ev}, kInt, {1, 0, 1, 0}, "", ""});  // dim 4 = num_el_blk
  const std::string path = m.write(dir, "synth.exo");

  const Dataset ds = read_exodus(path, 0);
  const UnstructuredMesh& mesh = mesh_of(ds);
  ASSERT_EQ(mesh.cell_count(), 3u);
  EXPECT_EQ(mesh.cell_types[0], CellType::Hexahedron);
  EXPECT_EQ(mesh.cell_types[1], CellType::Wedge);
  EXPECT_EQ(mesh.cell_types[2], CellType::Pyramid);
  EXPECT_EQ(inverted_cells(mesh), 0u);
  EXPECT_NEAR(cell_volume(mesh, 0), 1.0, 1e-6);
  EXPECT_NEAR(cell_volume(mesh, 1), 0.5, 1e-6);
  EXPECT_NEAR(cell_volume(mesh, 2), 1.0 / 3.0, 1e-6);
  const FieldSet& f = ds.blocks[0].fields;
  const Field* vel = f.find("Vel");
  ASSERT_NE(vel, nullptr);
  EXPECT_EQ(vel->components(), 3);
  EXPECT_EQ(vel->data().type(), ScalarType::Float32);
  EXPECT_EQ(vel->data().get(2, 0), 12);
  EXPECT_EQ(vel->data().get(2, 2), 32);
  EXPECT_EQ(f.find("T")->data().get(8, 0), 48);
  const Field* e = f.find("e", Association::Cell);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->data().get(0, 0), 1);
  EXPECT_EQ(e->data().get(1, 0), 0);  // block 101 lacks it
  EXPECT_EQ(e->data().get(2, 0), 3);
  EXPECT_EQ(f.find("block_id")->data().get(2, 0), 102);
  std::string warnings;
  for (const std::string& w : ds.warnings) warnings += w + "\n";
  EXPECT_NE(warnings.find("SHELL4"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("block(s) 101"), std::string::npos) << warnings;

  const Dataset last = read_exodus(path, -1);
  EXPECT_EQ(last.blocks[0].fields.find("T")->data().get(0, 0), 140);
  EXPECT_EQ(last.blocks[0].fields.find("e")->data().get(2, 0), 4);
  EXPECT_NE(last.format.find("t = 1.5"), std::string::npos) << last.format;
}

// Issue 23: libnetcdf fills reads past the end of a truncated netCDF-3 file with zeros instead of failing, so a file
// cut inside its data must be refused by the reader, naming the variable and the missing bytes. connect1 is the last
// variable: 8 ints, 32 bytes.
TEST(ExodusReader, SyntheticTruncatedVariableIsRefused) {
  ScratchDir dir;
  Model m(1);
  m.block(1, "HEX8", 8, {1, 2, 3, 4, 5, 6, 7, 8});
  const std::string path = m.write(dir, "whole.exo");
  ASSERT_EQ(mesh_of(read_exodus(path, -1)).cell_count(), 1u);  // the whole file reads
  const uint64_t size = std::filesystem::file_size(path);
  for (uint64_t missing : {uint64_t(1), uint64_t(8), uint64_t(32)}) {
    SCOPED_TRACE(missing);
    std::filesystem::resize_file(path, size - missing);
    const std::string e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find("whole.exo"), std::string::npos) << e;
    EXPECT_NE(e.find("variable connect1 is truncated"), std::string::npos) << e;
    EXPECT_NE(e.find("(" + std::to_string(missing) + " bytes missing)"), std::string::npos) << e;
    std::filesystem::resize_file(path, size);
  }
  // Cut inside coordz (after time_whole, coordx, coordy: 16 + 3 x 72 bytes of data before it ends): coordz is the
  // first variable read that is short.
  std::filesystem::resize_file(path, size - 32 - 4 - 40);  // connect1, eb_prop1 and 40 bytes of coordz
  const std::string e = error_of([&] { read_exodus(path, -1); });
  EXPECT_NE(e.find("variable coordz is truncated"), std::string::npos) << e;
  EXPECT_NE(e.find("(40 bytes missing)"), std::string::npos) << e;
}

// netCDF-4 (HDF5) files: libhdf5 refuses a file shorter than its superblock's end-of-file address with a bare "HDF
// error"; the reader names the truncation first. Superblocks of version 2 and 0 built by hand (8-byte addresses).
TEST(ExodusReader, TruncatedHdf5SuperblockIsNamed) {
  ScratchDir dir;
  auto le64 = [](uint64_t v) {
    std::string s;
    for (int k = 0; k < 8; ++k) s.push_back(char(v >> (8 * k)));
    return s;
  };
  const std::string sig("\x89HDF\r\n\x1a\n", 8);
  // v2: version, offsets size, lengths size, flags, base, extension, end of file, root group, checksum.
  const std::string v2 = sig + std::string("\x02\x08\x08\x00", 4) + le64(0) + le64(UINT64_MAX) + le64(4096) + le64(48);
  // v0: versions and sizes (16 bytes with the K values), flags, then base, free-space, end of file, driver.
  const std::string v0 = sig + std::string("\x00\x00\x00\x00\x00\x08\x08\x00\x04\x00\x10\x00", 12) +
                         std::string(4, '\0') + le64(0) + le64(UINT64_MAX) + le64(4096) + le64(UINT64_MAX);
  for (const std::string& head : {v2, v0}) {
    const std::string path = dir.file("short.exo");
    std::string bytes = head + std::string(100 - head.size(), '\0');
    std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    std::string e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find("short.exo"), std::string::npos) << e;
    EXPECT_NE(e.find("truncated HDF5"), std::string::npos) << e;
    EXPECT_NE(e.find("(3996 bytes missing)"), std::string::npos) << e;
    // As long as the file: no truncation to name (libhdf5 then refuses the garbage itself).
    bytes.resize(4096, '\0');
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
    e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find("short.exo"), std::string::npos) << e;
    EXPECT_EQ(e.find("truncated"), std::string::npos) << e;
  }
}

TEST(ExodusReader, SyntheticErrors) {
  ScratchDir dir;
  auto expect_error = [&](const std::string& name, auto&& build, std::vector<std::string> needles) {
    Model m(1);
    build(m);
    const std::string path = m.write(dir, name);
    const std::string e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find(name), std::string::npos) << e;
    for (const std::string& n : needles) EXPECT_NE(e.find(n), std::string::npos) << name << ": " << e;
  };
  expect_error("range.exo", [](Model& m) { m.block(1, "TETRA", 4, {1, 2, 3, 10}); }, {"connect1", "10", "1..9"});
  // A mid-edge node of a TETRA10 (only the corners are kept) out of range: checked all the same (issue 23).
  expect_error("midedge.exo",
               [](Model& m) {
                 m.block(1, "TETRA10", 10, {1, 2, 3, 5, 6, 7, 8, 9, 4, 12});
               },
               {"connect1", "node 10 is 12", "1..9"});
  expect_error("zero.exo", [](Model& m) { m.block(1, "TET4", 4, {0, 2, 3, 4}); }, {"connect1", "outside"});
  expect_error("nsided.exo", [](Model& m) { m.block(1, "NSIDED", 4, {1, 2, 3, 4}); }, {"connect1", "NSIDED"});
  expect_error("shells.exo", [](Model& m) { m.block(1, "SHELL4", 4, {1, 2, 3, 4}); }, {"no volume elements"});
  expect_error("few.exo", [](Model& m) { m.block(1, "HEX8", 4, {1, 2, 3, 4}); }, {"connect1", "at least 8"});
  expect_error("shape.exo",
               [](Model& m) {
                 m.w.dim("num_el_in_blk1", 2);  // disagrees with connect1's own dimension
                 const int d_el = m.w.dim("other", 1);
                 const int d_per = m.w.dim("num_nod_per_el1", 4);
                 m.w.var({"connect1", {d_el, d_per}, kInt, {1, 2, 3, 4}, "", "TETRA"});
               },
               {"connect1", "shape"});
  expect_error("nodevar.exo",
               [](Model& m) {
                 m.block(1, "TETRA", 4, {1, 2, 3, 5});
                 const int d_nv = m.w.dim("num_nod_var", 1);
                 m.w.names("name_nod_var", d_nv, m.d_len, {"p"});
               },
               {"vals_nod_var1"});

  // Not netCDF at all.
  const std::string junk = dir.file("junk.exo");
  std::ofstream(junk) << "hello, this is not netCDF\n";
  EXPECT_NE(error_of([&] { read_exodus(junk, -1); }).find("not a netCDF file"), std::string::npos);
  // Absurd sizes in a valid container: num_nodes far beyond what the file could hold.
  {
    NcWriter w;
    w.dim("num_dim", 3);
    const int d = w.dim("num_nodes", 2000000000);
    w.dim("num_el_blk", 1);
    w.var({"coordx", {d}, kDouble, {}, "", ""});
    w.var({"coordy", {d}, kDouble, {}, "", ""});
    w.var({"coordz", {d}, kDouble, {}, "", ""});
    const std::string path = dir.file("huge.exo");
    const std::string b = w.bytes();
    std::ofstream(path, std::ios::binary).write(b.data(), std::streamsize(b.size()));
    const std::string e = error_of([&] { read_exodus(path, -1); });
    EXPECT_NE(e.find("huge.exo"), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace ugvr
