// Exodus II reader, through the netCDF C library (Exodus II is a netCDF convention; netCDF-3 classic, 64-bit offset,
// CDF5 and netCDF-4/HDF5 containers are all opened by nc_open).
//
// What is read (names as the Exodus II API writes them):
//   dims      num_dim (must be 3), num_nodes, num_el_blk, num_el_in_blk{b}, num_nod_per_el{b}, time_step,
//             num_nod_var, num_elem_var
//   coords    "coord" (num_dim, num_nodes) or "coordx"/"coordy"/"coordz" (num_nodes), converted to float32
//   blocks    "connect{b}" (num_el_in_blk{b}, num_nod_per_el{b}) with attribute elem_type, 1-based node numbers;
//             block ids from "eb_prop1" (1..N when absent). A block with no elements has no connect variable.
//   time      "time_whole" (time_step); the chosen step is named in Dataset::format
//   nodal     "name_nod_var" + "vals_nod_var" (time_step, num_nod_var, num_nodes) or "vals_nod_var{v}" (time_step,
//             num_nodes) -> vertex fields, float32 or float64 as stored
//   element   "name_elem_var" + "vals_elem_var{v}eb{b}" (time_step, num_el_in_blk{b}), with the truth table
//             "elem_var_tab" (num_el_blk, num_elem_var) -> cell fields; a block that lacks a variable gets 0 there
//             (with a warning), because a field needs one value per cell.
// All kept blocks are merged into one mesh, cells in block order, with an Int32 cell field "block_id".
// node_num_map / elem_map (global numbering) are not needed: connectivity uses local 1-based node numbers.
// A part read (read_exodus_cells, exodus_parts.h) reads a range of those cells: hyperslabs of the connect and element
// variables' rows, and of the coordinates and nodal variables over runs of the nodes the range uses.
//
// Element types: HEX*, TET*, WEDGE*, PYRAMID*/PYRA* are kept; higher-order ones (HEX20, TETRA10, WEDGE15, PYRAMID13,
// ...) are linearised to their corner nodes, which Exodus lists first. Exodus corner orderings of hex, tet and pyramid
// are VTK's; the wedge's first triangle turns the other way in Exodus (as in Gmsh), so wedges are reordered (checked
// on the real files: every cell of all four has positive volume, mesh_fs8's wedges were all inverted without it).
// Lower-dimensional blocks (SHELL, QUAD, TRI, BAR, BEAM, TRUSS, SPHERE, CIRCLE, POINT, ...) are dropped with a warning;
// NSIDED / NFACED (polygons, polyhedra) and unknown types are refused.
//
// Vector variables: three consecutive variables named BASE + X/Y/Z (optionally "_X", any case) of one stored type
// become one 3-component field BASE (disk_out_ref's VX VY VZ -> "V"); everything else stays a scalar.
//
// Hostile input: a netCDF-3 header is walked before nc_open and refused unless its counts fit in the file (libnetcdf
// allocates what they say while parsing); netCDF-4/HDF5 containers are left to libhdf5. Every array whose size comes
// from the file is checked against the file size before it is allocated (netCDF-3 stores data uncompressed, so a
// variable cannot hold more values than the file has bytes; for netCDF-4, whose chunks may be compressed, a 1024:1
// ratio is allowed). A netCDF-3 variable whose data (all its records) ends past the end of the file is refused when
// read, naming the missing bytes: libnetcdf fills such reads with zeros or returns whatever bytes are there (a
// truncated disk_out_ref gave fields [0, 0], or another variable's values). An HDF5 file shorter than the end-of-file
// address in its superblock is refused before nc_open with the missing byte count (libhdf5 would refuse it too,
// with a bare "HDF error"). Node numbers, block sizes and variable shapes are checked against the dimensions they
// must agree with.
#include <netcdf.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/exodus_parts.h"
#include "ugvr/io/header_counts.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/step_lists.h"

namespace ugvr {
namespace {

constexpr uint64_t kMaxVertices = std::numeric_limits<uint32_t>::max();
// More blocks / variables than any real model has; bounds the bookkeeping per block and variable.
constexpr size_t kMaxBlocks = size_t(1) << 16;
constexpr size_t kMaxVariables = size_t(1) << 16;
// netCDF-4 chunks may be compressed: how many bytes of data one byte of file may expand to, at most.
constexpr uint64_t kMaxCompressionRatio = 1024;
// A netCDF-3 header longer than this is refused (real Exodus headers are a few KB; thousands of variables stay far
// below it).
constexpr uint64_t kMaxHeaderBytes = uint64_t(64) << 20;

std::string upper(std::string s) {
  for (char& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

bool starts_with_any(const std::string& s, std::initializer_list<const char*> prefixes) {
  for (const char* p : prefixes)
    if (s.starts_with(p)) return true;
  return false;
}

// Walks a netCDF-3 (CDF-1, CDF-2 = 64-bit offset, CDF-5) header before nc_open sees it and fails unless every count in
// it fits in the bytes the file has: libnetcdf allocates what the header's counts say while it parses them (a fuzzed
// ndims of 2^30 made it ask for 7 GB), so absurd headers must be refused before it runs. Layout (netCDF File Format
// Specification): magic, numrecs, then dim, global attribute and variable lists; each list is ABSENT (two zeros) or
// a tag and a count; counts, lengths and dim ids are int32 (int64 in CDF-5); names and values are padded to 4 bytes.
class Cdf3HeaderCheck {
 public:
  Cdf3HeaderCheck(const std::string& path, std::string_view bytes, uint64_t file_size)
      : path_(path), b_(bytes), file_size_(file_size), version_(uint8_t(bytes[3])) {}

  // Where a variable's data lies, from the header: netCDF-3 stores it uncompressed at `begin`; a record variable has
  // one slab of `bytes` per record, records `record_size` apart.
  struct Extent {
    std::string name;
    uint64_t begin = 0;
    uint64_t bytes = 0;  // unpadded: values x type size (one record's worth for a record variable)
    bool record = false;
  };

  // False when the header continues beyond the bytes given (read more and check again).
  bool complete() {
    try {
      run();
      return true;
    } catch (const NeedMore&) {
      return false;
    }
  }

  // The byte just past the data of each variable, as libnetcdf will read it (records 0..numrecs-1): a file shorter
  // than that is truncated, and libnetcdf would return fill values (zeros) or the next variable's bytes for what is
  // missing instead of failing. Valid after complete() returned true. UINT64_MAX when the end overflows.
  std::vector<std::pair<std::string, uint64_t>> data_ends() const {
    // The record size as libnetcdf computes it: the padded slabs of all record variables, except that a lone record
    // variable is packed (no padding).
    uint64_t record_size = 0, records = 0;
    for (const Extent& e : extents_) {
      if (!e.record) continue;
      ++records;
      record_size = sat_add(record_size, (e.bytes + 3) & ~uint64_t(3));
    }
    if (records == 1) {
      for (const Extent& e : extents_)
        if (e.record) record_size = e.bytes;
    }
    std::vector<std::pair<std::string, uint64_t>> ends;
    for (const Extent& e : extents_) {
      if (e.bytes == 0) continue;
      if (!e.record) {
        ends.emplace_back(e.name, sat_add(e.begin, e.bytes));
      } else if (numrecs_ > 0 && !streaming_) {  // STREAMING: libnetcdf counts the records the file holds
        ends.emplace_back(e.name, sat_add(sat_add(e.begin, sat_mul(numrecs_ - 1, record_size)), e.bytes));
      }
    }
    return ends;
  }

 private:
  static uint64_t sat_add(uint64_t a, uint64_t b) {
    uint64_t r;
    return __builtin_add_overflow(a, b, &r) ? UINT64_MAX : r;
  }
  static uint64_t sat_mul(uint64_t a, uint64_t b) {
    uint64_t r;
    return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
  }

  void run() {
    pos_ = 4;
    big_ = version_ == 5;
    numrecs_ = num();  // numrecs (or STREAMING: all ones)
    streaming_ = numrecs_ == (big_ ? UINT64_MAX : uint64_t(UINT32_MAX));
    dims_.clear();
    extents_.clear();
    list(10, [&] {  // dimensions: name, length (0: the record dimension)
      name();
      dims_.push_back(num());
    });
    attributes();
    list(11, [&] {  // variables: name, dim ids, attributes, type, vsize, begin
      Extent e;
      e.name = name();
      const uint64_t ndims = count(big_ ? 8 : 4, "dimension ids of a variable");
      uint64_t values = 1;
      bool known = true;
      for (uint64_t i = 0; i < ndims; ++i) {
        const uint64_t d = num();
        if (d >= dims_.size()) {
          known = false;  // libnetcdf refuses the header itself
          continue;
        }
        if (i == 0 && dims_[d] == 0) {
          e.record = true;
        } else {
          values = sat_mul(values, dims_[d]);
        }
      }
      attributes();
      e.bytes = sat_mul(values, type_size(type()));
      num();  // vsize: libnetcdf recomputes it (it cannot hold sizes >= 4 GiB)
      e.begin = version_ == 1 ? i32() : i64();
      if (known) extents_.push_back(std::move(e));
    });
  }

  [[noreturn]] void fail(const std::string& message) const {
    fail_at_offset(path_, pos_, "invalid netCDF header: " + message);
  }
  // Thrown when the header goes on beyond the bytes given while the file has more: the caller retries with more.
  struct NeedMore {};

  void need(uint64_t n) const {
    if (n > b_.size() - pos_) {
      if (b_.size() < file_size_) throw NeedMore{};
      fail("the file ends inside the header");
    }
  }
  uint64_t i32() {
    need(4);
    uint64_t v = 0;
    for (int k = 0; k < 4; ++k) v = (v << 8) | uint8_t(b_[pos_++]);
    return v;
  }
  uint64_t i64() { return (i32() << 32) | i32(); }
  uint64_t num() { return big_ ? i64() : i32(); }
  // A count of items taking at least `each` bytes of header each; fails when they cannot be there.
  uint64_t count(uint64_t each, const char* what) {
    const uint64_t n = num();
    if (n > (b_.size() - pos_) / each) fail(std::to_string(n) + " " + what + " cannot fit in the header");
    return n;
  }
  void skip_padded(uint64_t n) {
    const uint64_t padded = (n + 3) & ~uint64_t(3);
    need(padded);
    pos_ += padded;
  }
  std::string name() {
    const uint64_t n = count(1, "name characters");
    const std::string text(b_.substr(pos_, n));
    skip_padded(n);
    return text;
  }
  uint64_t type() {
    const uint64_t t = i32();
    if (t < 1 || t > (version_ == 5 ? 11u : 6u)) fail("unknown value type " + std::to_string(t));
    return t;
  }
  static uint64_t type_size(uint64_t t) {
    return (t == 1 || t == 2 || t == 7) ? 1 : (t == 3 || t == 8) ? 2 : (t == 4 || t == 5 || t == 9) ? 4 : 8;
  }
  template <class Item>
  void list(uint64_t tag, Item&& item) {
    const uint64_t t = i32();
    if (t != 0 && t != tag) fail("expected list tag " + std::to_string(tag) + ", found " + std::to_string(t));
    const uint64_t n = count(4, "list entries");
    if (t == 0 && n != 0) fail("an absent list with a non-zero count");
    for (uint64_t i = 0; i < n; ++i) item();
  }
  void attributes() {
    list(12, [&] {  // name, type, values
      name();
      const uint64_t size = type_size(type());
      skip_padded(count(size, "attribute values") * size);
    });
  }

  std::string path_;
  std::string_view b_;
  uint64_t file_size_;
  uint8_t version_;
  uint64_t pos_ = 0;
  bool big_ = false;
  uint64_t numrecs_ = 0;
  bool streaming_ = false;
  std::vector<uint64_t> dims_;
  std::vector<Extent> extents_;
};

// A netCDF file opened read-only; every failure is reported as ugvr::Error naming the file and the variable.
class NcFile {
 public:
  explicit NcFile(const std::string& path) : path_(path) {
    file_size_ = InputFile(path).size();  // also fails cleanly when the file cannot be opened
    check_header();
    if (const int s = nc_open(path.c_str(), NC_NOWRITE, &id_); s != NC_NOERR) {
      id_ = -1;
      fail_in(path_, std::string("cannot open as netCDF: ") + nc_strerror(s));
    }
    int format = 0;
    check(nc_inq_format(id_, &format), "the netCDF format");
    netcdf4_ = format == NC_FORMAT_NETCDF4 || format == NC_FORMAT_NETCDF4_CLASSIC;
    format_name_ = format == NC_FORMAT_CLASSIC        ? "netCDF classic"
                   : format == NC_FORMAT_64BIT_OFFSET ? "netCDF 64-bit offset"
                   : format == NC_FORMAT_CDF5         ? "netCDF CDF5"
                   : netcdf4_                         ? "netCDF-4/HDF5"
                                                      : "netCDF";
  }
  ~NcFile() {
    if (id_ >= 0) nc_close(id_);
  }
  NcFile(const NcFile&) = delete;
  NcFile& operator=(const NcFile&) = delete;

  const std::string& path() const { return path_; }
  const std::string& format_name() const { return format_name_; }

  void check(int status, const std::string& what) const {
    if (status != NC_NOERR) fail_in(path_, what + ": netCDF error: " + nc_strerror(status));
  }
  [[noreturn]] void fail(const std::string& message) const { fail_in(path_, message); }

  std::optional<uint64_t> dim(const std::string& name) const {
    int d;
    if (nc_inq_dimid(id_, name.c_str(), &d) != NC_NOERR) return std::nullopt;
    size_t len = 0;
    check(nc_inq_dimlen(id_, d, &len), "dimension " + name);
    return uint64_t(len);
  }
  uint64_t dim_or(const std::string& name, uint64_t fallback) const { return dim(name).value_or(fallback); }

  std::optional<int> var(const std::string& name) const {
    int v;
    if (nc_inq_varid(id_, name.c_str(), &v) != NC_NOERR) return std::nullopt;
    return v;
  }
  int require_var(const std::string& name, const std::string& why) const {
    if (auto v = var(name)) return *v;
    fail("missing variable " + name + " (" + why + ")");
  }
  nc_type var_type(int v, const std::string& name) const {
    nc_type t;
    check(nc_inq_vartype(id_, v, &t), "variable " + name);
    return t;
  }
  // The lengths of the variable's dimensions.
  std::vector<uint64_t> shape(int v, const std::string& name) const {
    int ndims = 0;
    check(nc_inq_varndims(id_, v, &ndims), "variable " + name);
    if (ndims < 0 || ndims > NC_MAX_VAR_DIMS) fail("variable " + name + " has " + std::to_string(ndims) + " dims");
    std::vector<int> ids(static_cast<size_t>(ndims));
    check(nc_inq_vardimid(id_, v, ids.data()), "variable " + name);
    std::vector<uint64_t> lens;
    for (int d : ids) {
      size_t len = 0;
      check(nc_inq_dimlen(id_, d, &len), "variable " + name);
      lens.push_back(len);
    }
    return lens;
  }
  // Fails unless the variable's shape is exactly `want`.
  void expect_shape(int v, const std::string& name, const std::vector<uint64_t>& want, const std::string& dims) const {
    const std::vector<uint64_t> got = shape(v, name);
    if (got == want) return;
    auto text = [](const std::vector<uint64_t>& s) {
      std::string t = "(";
      for (size_t i = 0; i < s.size(); ++i) t += (i ? ", " : "") + std::to_string(s[i]);
      return t + ")";
    };
    fail("variable " + name + " has shape " + text(got) + ", expected " + dims + " = " + text(want));
  }

  // Values of the hyperslab start/count of variable `v`, converted by netCDF to T. The size is checked against the
  // file before allocating.
  template <class T>
  std::vector<T> read(int v, const std::string& name, const std::vector<size_t>& start,
                      const std::vector<size_t>& count) const {
    uint64_t n = 1;
    for (size_t c : count) {
      if (__builtin_mul_overflow(n, uint64_t(c), &n)) fail("variable " + name + " is impossibly large");
    }
    check_fits(n, stored_size(var_type(v, name)), "variable " + name);
    check_not_truncated(v);
    std::vector<T> out(static_cast<size_t>(n));
    if (n == 0) return out;
    int s;
    if constexpr (std::is_same_v<T, double>) {
      s = nc_get_vara_double(id_, v, start.data(), count.data(), out.data());
    } else if constexpr (std::is_same_v<T, float>) {
      s = nc_get_vara_float(id_, v, start.data(), count.data(), out.data());
    } else if constexpr (std::is_same_v<T, long long>) {
      s = nc_get_vara_longlong(id_, v, start.data(), count.data(), out.data());
    } else if constexpr (std::is_same_v<T, int>) {
      s = nc_get_vara_int(id_, v, start.data(), count.data(), out.data());
    } else {
      static_assert(std::is_same_v<T, char>);
      s = nc_get_vara_text(id_, v, start.data(), count.data(), out.data());
    }
    check(s, "reading variable " + name);
    return out;
  }
  template <class T>
  std::vector<T> read_all(int v, const std::string& name) const {
    const std::vector<uint64_t> s = shape(v, name);
    return read<T>(v, name, std::vector<size_t>(s.size(), 0), std::vector<size_t>(s.begin(), s.end()));
  }

  // A (rows, len) char variable as trimmed strings; fails unless it has `rows` rows.
  std::vector<std::string> read_names(const std::string& name, uint64_t rows) const {
    const int v = require_var(name, "the variable names");
    const std::vector<uint64_t> s = shape(v, name);
    if (s.size() != 2 || s[0] != rows) {
      fail("variable " + name + " should be (" + std::to_string(rows) + ", name length) characters");
    }
    const std::vector<char> text = read_all<char>(v, name);
    std::vector<std::string> names;
    for (uint64_t r = 0; r < rows; ++r) {
      std::string n(text.data() + r * s[1], size_t(s[1]));
      n.resize(std::min(n.size(), n.find('\0')));
      while (!n.empty() && std::isspace(static_cast<unsigned char>(n.back()))) n.pop_back();
      names.push_back(n);
    }
    return names;
  }

  std::optional<std::string> text_attribute(int v, const char* name) const {
    nc_type t;
    size_t len = 0;
    if (nc_inq_att(id_, v, name, &t, &len) != NC_NOERR || t != NC_CHAR) return std::nullopt;
    std::string s(len, '\0');  // attribute text is already in memory (netCDF read the header)
    check(nc_get_att_text(id_, v, name, s.data()), std::string("attribute ") + name);
    s.resize(std::min(s.size(), s.find('\0')));
    return s;
  }

  // `values` values of `bytes_each` bytes must fit in the file (see the top of the file).
  void check_fits(uint64_t values, uint64_t bytes_each, const std::string& what) const {
    const uint64_t budget = netcdf4_ ? file_size_ * kMaxCompressionRatio : file_size_;
    if (values > budget / std::max<uint64_t>(bytes_each, 1)) {
      fail(what + ": " + std::to_string(values) + " values of " + std::to_string(bytes_each) +
           " bytes cannot be stored in a file of " + std::to_string(file_size_) + " bytes");
    }
  }

 private:
  static uint64_t stored_size(nc_type t) {
    switch (t) {
      case NC_BYTE:
      case NC_CHAR:
      case NC_UBYTE: return 1;
      case NC_SHORT:
      case NC_USHORT: return 2;
      case NC_INT:
      case NC_UINT:
      case NC_FLOAT: return 4;
      default: return 8;
    }
  }

  // nc_open is only handed containers it recognises, so that an arbitrary file fails with a clear message.
  void check_header() {
    char head[64] = {};
    const size_t n = InputFile(path_).read_some_at(0, head, sizeof head);
    const std::string_view h(head, n);
    const bool cdf3 = h.starts_with("CDF\x01") || h.starts_with("CDF\x02") || h.starts_with("CDF\x05");
    if (!cdf3 && !h.starts_with("\x89HDF\r\n\x1a\n")) {
      fail("not a netCDF file (no CDF or HDF5 signature), so not Exodus II");
    }
    if (!cdf3) check_hdf5_end(h);
    if (cdf3) {
      // Headers are small (a few KB even for large models): read 1 MiB, and more only if the header goes on.
      for (uint64_t limit : {uint64_t(1) << 20, kMaxHeaderBytes}) {
        const uint64_t length = std::min(file_size_, limit);
        std::string bytes(static_cast<size_t>(length), '\0');
        InputFile(path_).read_at(0, bytes.data(), bytes.size());
        if (Cdf3HeaderCheck header(path_, bytes, file_size_); header.complete()) {
          data_ends_ = header.data_ends();
          return;
        }
      }
      fail("netCDF header longer than " + std::to_string(kMaxHeaderBytes) + " bytes");
    }
  }

  // An HDF5 superblock at the start of the file records the end-of-file address; libhdf5 refuses a shorter file with
  // a bare "HDF error", so the truncation is named here first. Superblock layout (HDF5 File Format Specification,
  // little-endian): signature (8), version (1); versions 0 and 1: ..., size of offsets at byte 13, base address at 24
  // (v0) or 28 (v1), then the free-space, end-of-file and driver addresses; versions 2 and 3: size of offsets at
  // byte 9, base address at 12, then the extension and end-of-file addresses. An undefined address is all ones. Only
  // a superblock at byte 0 is looked at (netCDF-4 writes no user block); others are left to libhdf5.
  void check_hdf5_end(std::string_view h) const {
    if (h.size() < 9) return;
    const uint8_t version = uint8_t(h[8]);
    const size_t offsets_size =
        version <= 1 ? (h.size() > 13 ? uint8_t(h[13]) : 0) : (h.size() > 9 ? uint8_t(h[9]) : 0);
    if (version > 3 || (offsets_size != 2 && offsets_size != 4 && offsets_size != 8)) return;  // left to libhdf5
    const size_t base_at = version == 0 ? 24 : version == 1 ? 28 : 12;
    const size_t eof_at = base_at + 2 * offsets_size;
    if (eof_at + offsets_size > h.size()) return;
    auto address = [&](size_t at) {
      uint64_t v = 0;
      for (size_t k = offsets_size; k-- > 0;) v = (v << 8) | uint8_t(h[at + k]);
      return v;
    };
    const uint64_t undefined = offsets_size == 8 ? UINT64_MAX : (uint64_t(1) << (8 * offsets_size)) - 1;
    // libhdf5 compares the stored end-of-file address with the file's size as it is (H5F__super_read: eof + base
    // address < stored eof, where its eof excludes the base), so the address counts from the start of the file.
    const uint64_t end = address(eof_at);
    if (end != undefined && end > file_size_) {
      fail("truncated HDF5 (netCDF-4) file: its superblock puts the end of the data at byte " + std::to_string(end) +
           " but the file has " + std::to_string(file_size_) + " bytes (" + std::to_string(end - file_size_) +
           " bytes missing)");
    }
  }

  // netCDF-3 only (libhdf5 itself refuses an HDF5 file shorter than the end address its superblock records): fails
  // when the file ends before the variable's data does, naming the missing bytes.
  void check_not_truncated(int v) const {
    char buf[NC_MAX_NAME + 1] = {};
    check(nc_inq_varname(id_, v, buf), "a variable name");
    for (const auto& [name, end] : data_ends_) {
      if (name != buf || end <= file_size_) continue;
      fail("variable " + name + " is truncated: its data ends at byte " +
           (end == UINT64_MAX ? std::string("(overflow)") : std::to_string(end)) + " but the file has " +
           std::to_string(file_size_) + " bytes" +
           (end == UINT64_MAX ? std::string() : " (" + std::to_string(end - file_size_) + " bytes missing)"));
    }
  }

  std::string path_;
  std::string format_name_;
  std::vector<std::pair<std::string, uint64_t>> data_ends_;  // netCDF-3: variable name -> end of its data
  int id_ = -1;
  uint64_t file_size_ = 0;
  bool netcdf4_ = false;
};

struct ElementKind {
  enum Kind { Keep, Drop, Refuse } kind = Refuse;
  CellType type{};
  uint8_t corners = 0;
};

ElementKind classify(const std::string& elem_type) {
  const std::string t = upper(elem_type);
  if (t.starts_with("HEX")) return {ElementKind::Keep, CellType::Hexahedron, 8};
  if (t.starts_with("TET")) return {ElementKind::Keep, CellType::Tetra, 4};
  if (t.starts_with("WEDGE")) return {ElementKind::Keep, CellType::Wedge, 6};
  if (t.starts_with("PYRA")) return {ElementKind::Keep, CellType::Pyramid, 5};
  if (starts_with_any(t, {"SHELL", "QUAD", "TRI", "BAR", "BEAM", "TRUSS", "SPHERE", "CIRCLE", "POINT", "EDGE", "ROD",
                          "SPRING", "TRISHELL"})) {
    return {ElementKind::Drop, {}, 0};
  }
  return {ElementKind::Refuse, {}, 0};
}

struct BlockInfo {
  int index = 0;  // 1-based, as in variable names
  int32_t id = 0;
  std::string elem_type;
  uint64_t elements = 0;
  bool kept = false;
  uint64_t first_cell = 0;  // in the merged mesh (the whole read's numbering)
  // The elements read (all of them in a whole read; those in the cell range of a part read) and where they land in
  // the mesh read.
  uint64_t row_first = 0, rows = 0, out_first = 0;
};

// A variable's values at one time step, in its stored type (float or double).
struct Values {
  std::string name;
  bool is_double = true;
  std::vector<double> d;
  std::vector<float> f;
};

class ExodusReader {
 public:
  ExodusReader(const std::string& path, int64_t time_step, std::optional<ExodusCellRange> range = std::nullopt)
      : nc_(path), requested_step_(time_step), range_(range) {}

  // The 0-based file node number of each point read (after read()).
  std::vector<uint32_t> node_numbers() const {
    std::vector<uint32_t> out;
    out.reserve(size_t(node_count_));
    for (const auto& [first, count] : node_runs_)
      for (uint64_t i = 0; i < count; ++i) out.push_back(uint32_t(first + i));
    return out;
  }

  ExodusLayout layout() const {
    ExodusLayout out;
    for (const BlockInfo& b : blocks_)
      if (b.kept) out.block_starts.push_back(b.first_cell);
    out.cells = cells_;
    return out;
  }

  // For fields_at: the dimensions, the element blocks' layout (which are kept, where their cells start) and the times,
  // without the coordinates or the connectivity.
  void read_layout() {
    check_dimensions();
    read_node_count();
    layout_only_ = true;
    read_blocks();
    requested_step_ = -1;
    choose_time_step();
  }

  // The fields of time index `step` (after read_layout), as read() gives them; `format` as read() sets it.
  FieldSet fields_at(uint64_t step, std::string& format, std::vector<std::string>& warnings) {
    requested_step_ = int64_t(step);
    choose_time_step();
    FieldSet fields;
    add_block_ids(fields);
    warnings_.clear();
    add_nodal_variables(fields);
    add_element_variables(fields);
    format = format_text();
    warnings = std::move(warnings_);
    return fields;
  }

  Dataset read() {
    check_dimensions();
    read_node_count();
    // A whole read takes the points first (the peak is lower: the coordinates' doubles are freed before the
    // connectivity is read); a part read needs its cells first, to know which nodes they use.
    if (!range_) read_points();
    read_blocks();
    if (range_) choose_node_runs(), read_points();
    choose_time_step();
    Block block;
    block.name = base_name(nc_.path());
    if (range_) block.name += " cells " + std::to_string(range_->first) + "+" + std::to_string(range_->count);
    add_block_ids(block.fields);
    if (step_) {
      add_nodal_variables(block.fields);
      add_element_variables(block.fields);
    }
    block.grid = std::move(mesh_);
    block.validate_fields(nc_.path());
    Dataset ds;
    ds.format = format_text();
    ds.sources.push_back(nc_.path());
    ds.blocks.push_back(std::move(block));
    ds.warnings = std::move(warnings_);
    return ds;
  }

 private:
  void check_dimensions() const {
    if (const auto dims = nc_.dim("num_dim"); !dims || *dims != 3) {
      nc_.fail(dims ? "num_dim is " + std::to_string(*dims) + ": only 3-D Exodus meshes have volume cells"
                    : "missing dimension num_dim: not an Exodus II file");
    }
  }

  std::string format_text() const { return "Exodus II (" + nc_.format_name() + ")" + time_text(); }

  void read_node_count() {
    const auto nodes = nc_.dim("num_nodes");
    if (!nodes || *nodes == 0) nc_.fail("the file has no nodes (dimension num_nodes missing or 0)");
    if (*nodes > kMaxVertices) nc_.fail("num_nodes = " + std::to_string(*nodes) + " is over the limit of 2^32-1");
    nodes_ = *nodes;
    node_runs_ = {{0, nodes_}};
    node_count_ = nodes_;
  }

  // A part read holds the nodes its cells use, read as runs of consecutive node numbers (one netCDF hyperslab per run
  // and variable): used nodes fewer than kNodeGap apart share a run, the nodes between them read too, so that a file
  // whose blocks number their nodes together reads a few slabs, and one whose numbering is scattered (mug.e,
  // disk_out_ref) reads its used nodes and little more. The first run starts at node 1 and the last ends at
  // num_nodes when the range asks (the first and the last range: the pieces then cover the nodes no volume cell uses
  // at the ends, which a whole read's bounds count). Connectivity is renumbered to the runs' concatenation.
  static constexpr uint64_t kNodeGap = 64;
  void choose_node_runs() {
    std::vector<uint32_t> used(mesh_.connectivity.begin(), mesh_.connectivity.end());
    std::sort(used.begin(), used.end());
    used.erase(std::unique(used.begin(), used.end()), used.end());
    node_runs_.clear();
    for (const uint32_t id : used) {
      if (!node_runs_.empty() && id - (node_runs_.back().first + node_runs_.back().second) < kNodeGap)
        node_runs_.back().second = id + 1 - node_runs_.back().first;
      else
        node_runs_.push_back({id, 1});
    }
    if (node_runs_.empty()) node_runs_.push_back({0, 1});
    if (range_->from_first_node) node_runs_.front().second += node_runs_.front().first, node_runs_.front().first = 0;
    if (range_->to_last_node) node_runs_.back().second = nodes_ - node_runs_.back().first;
    std::vector<uint64_t> run_start;  // each run's first node in the concatenation
    node_count_ = 0;
    for (const auto& [first, count] : node_runs_) run_start.push_back(node_count_), node_count_ += count;
    for (uint32_t& v : mesh_.connectivity) {
      const auto run = std::upper_bound(node_runs_.begin(), node_runs_.end(), v,
                                        [](uint32_t id, const auto& r) { return id < r.first; }) -
                       1;
      v = uint32_t(run_start[size_t(run - node_runs_.begin())] + (v - run->first));
    }
  }

  // Variable v's values over the runs' nodes, concatenated: `start` and `count` give its leading indices (the
  // time step, the variable), the node index last.
  template <class T>
  std::vector<T> read_nodes(int v, const std::string& name, std::vector<size_t> start,
                            std::vector<size_t> count) const {
    start.push_back(0), count.push_back(0);
    if (node_runs_.size() == 1) {  // a whole read: no copy
      start.back() = size_t(node_runs_[0].first), count.back() = size_t(node_runs_[0].second);
      return nc_.read<T>(v, name, start, count);
    }
    std::vector<T> out;
    out.reserve(size_t(node_count_));
    for (const auto& [first, n] : node_runs_) {
      start.back() = size_t(first), count.back() = size_t(n);
      const std::vector<T> run = nc_.read<T>(v, name, start, count);
      out.insert(out.end(), run.begin(), run.end());
    }
    return out;
  }

  void read_points() {
    std::array<std::vector<double>, 3> xyz;
    if (const auto v = nc_.var("coord")) {
      nc_.expect_shape(*v, "coord", {3, nodes_}, "(num_dim, num_nodes)");
      for (size_t a = 0; a < 3; ++a) xyz[a] = read_nodes<double>(*v, "coord", {a}, {1});
    } else {
      const char* names[3] = {"coordx", "coordy", "coordz"};
      for (size_t a = 0; a < 3; ++a) {
        const int cv = nc_.require_var(names[a], "node coordinates: neither coord nor coordx/coordy/coordz");
        nc_.expect_shape(cv, names[a], {nodes_}, "(num_nodes)");
        xyz[a] = read_nodes<double>(cv, names[a], {}, {});
      }
    }
    mesh_.points.resize(size_t(node_count_));
    for (size_t i = 0; i < node_count_; ++i) {
      mesh_.points[i] = Vec3f{float(xyz[0][i]), float(xyz[1][i]), float(xyz[2][i])};
    }
  }

  void read_blocks() {
    const uint64_t count = nc_.dim_or("num_el_blk", 0);
    if (count == 0) nc_.fail("the file has no element blocks (dimension num_el_blk missing or 0)");
    if (count > kMaxBlocks) nc_.fail("num_el_blk = " + std::to_string(count) + " is over the limit");
    std::vector<int> ids(static_cast<size_t>(count));
    for (size_t b = 0; b < count; ++b) ids[b] = int(b + 1);
    if (const auto v = nc_.var("eb_prop1")) {
      nc_.expect_shape(*v, "eb_prop1", {count}, "(num_el_blk)");
      ids = nc_.read_all<int>(*v, "eb_prop1");
    }
    uint64_t dropped = 0;
    std::string dropped_types;
    for (size_t b = 0; b < count; ++b) {
      BlockInfo info;
      info.index = int(b + 1);
      info.id = ids[b];
      read_block(info);
      if (!info.kept && info.elements > 0) {
        dropped += info.elements;
        if (dropped_types.find(info.elem_type) == std::string::npos) {
          dropped_types += (dropped_types.empty() ? "" : ", ") + info.elem_type;
        }
      }
      blocks_.push_back(info);
    }
    if (range_ && range_->first + range_->count > cells_)
      nc_.fail("cells " + std::to_string(range_->first) + "+" + std::to_string(range_->count) +
               " asked for, the volume blocks have " + std::to_string(cells_));
    if (cells_ == 0) {
      nc_.fail(dropped ? "no volume elements: all " + std::to_string(dropped) + " elements are lower-dimensional (" +
                             dropped_types + ")"
                       : "no elements in any block");
    }
    if (dropped > 0) {
      warnings_.push_back(nc_.path() + ": dropped " + std::to_string(dropped) + " lower-dimensional elements (" +
                          dropped_types + "); only volume cells are rendered");
    }
  }

  void read_block(BlockInfo& info) {
    const std::string n = std::to_string(info.index);
    const std::string connect = "connect" + n;
    info.elements = nc_.dim_or("num_el_in_blk" + n, 0);
    const auto v = nc_.var(connect);
    if (!v) {
      if (info.elements > 0)
        nc_.fail("missing variable " + connect + " for the " + std::to_string(info.elements) + " elements of block " +
                 std::to_string(info.id));
      return;  // a null block
    }
    const auto per = nc_.dim("num_nod_per_el" + n);
    if (!per) nc_.fail("missing dimension num_nod_per_el" + n + " of variable " + connect);
    nc_.expect_shape(*v, connect, {info.elements, *per}, "(num_el_in_blk" + n + ", num_nod_per_el" + n + ")");
    info.elem_type = nc_.text_attribute(*v, "elem_type").value_or("");
    const ElementKind kind = classify(info.elem_type);
    if (kind.kind == ElementKind::Refuse) {
      nc_.fail("variable " + connect + " (block " + std::to_string(info.id) + "): element type '" + info.elem_type +
               "' is not supported (volume types: HEX, TETRA, WEDGE, PYRAMID; NSIDED/NFACED polyhedra are not read)");
    }
    if (kind.kind == ElementKind::Drop) return;
    if (*per < kind.corners) {
      nc_.fail("variable " + connect + ": element type " + info.elem_type + " needs at least " +
               std::to_string(kind.corners) + " nodes per element, the block has " + std::to_string(*per));
    }
    info.kept = true;
    info.first_cell = cells_;
    cells_ += info.elements;
    // The rows of this block in the cell range read (all of them in a whole read).
    const uint64_t lo = range_ ? std::clamp(range_->first, info.first_cell, cells_) : info.first_cell;
    const uint64_t hi = range_ ? std::clamp(range_->first + range_->count, lo, cells_) : cells_;
    info.row_first = lo - info.first_cell;
    info.rows = hi - lo;
    info.out_first = out_cells_;
    out_cells_ += info.rows;
    if (layout_only_ || info.rows == 0) return;
    const std::vector<long long> ids = nc_.read<long long>(*v, connect, {info.row_first, 0}, {info.rows, *per});
    mesh_.reserve(mesh_.cell_count() + info.rows, mesh_.connectivity.size() + info.rows * kind.corners);
    std::array<uint32_t, 8> corners{};
    for (uint64_t e = 0; e < info.rows; ++e) {
      // Every node the element stores is checked, also the mid-edge ones of a higher-order element that only its
      // corners are kept from: an id out of range anywhere means the connectivity cannot be trusted.
      for (uint64_t k = 0; k < *per; ++k) {
        const long long id = ids[size_t(e * *per + k)];
        if (id < 1 || uint64_t(id) > nodes_) {
          nc_.fail("variable " + connect + ": element " + std::to_string(info.row_first + e + 1) + " node " +
                   std::to_string(k + 1) + " is " + std::to_string(id) + ", outside 1.." + std::to_string(nodes_));
        }
        if (k < kind.corners) corners[k] = uint32_t(id - 1);
      }
      if (kind.type == CellType::Wedge) {
        // Exodus (like Gmsh and most FE codes) orders the wedge's first triangle with its normal towards the second
        // one; VTK's points away from it. Swapping nodes 1<->2 and 4<->5 turns one into the other.
        std::swap(corners[1], corners[2]);
        std::swap(corners[4], corners[5]);
      }
      mesh_.add_cell(kind.type, std::span<const uint32_t>(corners.data(), kind.corners));
    }
  }

  void choose_time_step() {
    const uint64_t steps = nc_.dim_or("time_step", 0);
    if (steps > 0 && times_.size() != steps) {  // read once for a reader kept open over steps
      const int v = nc_.require_var("time_whole", "the time values");
      nc_.expect_shape(v, "time_whole", {steps}, "(time_step)");
      times_ = nc_.read_all<double>(v, "time_whole");
    }
    if (requested_step_ == -1) {
      if (steps > 0) step_ = steps - 1;
      return;
    }
    if (requested_step_ < 0 || uint64_t(requested_step_) >= steps) {
      std::string list;
      for (size_t i = 0; i < times_.size() && i < 32; ++i) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%s%g", i ? " " : "", times_[i]);
        list += buf;
      }
      if (times_.size() > 32) list += " ...";
      nc_.fail("time step " + std::to_string(requested_step_) + " does not exist: the file has " +
               std::to_string(steps) + " time steps (0.." + std::to_string(steps ? steps - 1 : 0) + ")" +
               (steps ? ", times " + list : std::string()));
    }
    step_ = uint64_t(requested_step_);
  }

  std::string time_text() const {
    if (!step_) return times_.empty() ? ", no time steps" : "";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", times_[size_t(*step_)]);
    return ", time step " + std::to_string(*step_) + " of " + std::to_string(times_.size()) + " (t = " + buf + ")";
  }

  void add_block_ids(FieldSet& fields) const {
    std::vector<int32_t> ids;
    ids.reserve(size_t(out_cells_));
    for (const BlockInfo& b : blocks_)
      if (b.kept) ids.insert(ids.end(), size_t(b.rows), b.id);
    fields.add(Field("block_id", Association::Cell, DataArray::from(std::move(ids), 1)));
  }

  // One time step of variable v of shape (time_step, ..., n) where the trailing n values start at `start`.
  // One time step of a nodal variable over the nodes read; `start` / `count` are its leading indices.
  Values read_node_values(int v, const std::string& var_name, const std::vector<size_t>& start,
                          const std::vector<size_t>& count) const {
    Values out;
    out.is_double = nc_.var_type(v, var_name) != NC_FLOAT;
    if (out.is_double) {
      out.d = read_nodes<double>(v, var_name, start, count);
    } else {
      out.f = read_nodes<float>(v, var_name, start, count);
    }
    return out;
  }

  std::vector<std::string> variable_names(const char* count_dim, const char* names_var) const {
    const uint64_t n = nc_.dim_or(count_dim, 0);
    if (n == 0) return {};
    if (n > kMaxVariables) nc_.fail(std::string(count_dim) + " = " + std::to_string(n) + " is over the limit");
    return nc_.read_names(names_var, n);
  }

  void add_nodal_variables(FieldSet& fields) const {
    const std::vector<std::string> names = variable_names("num_nod_var", "name_nod_var");
    if (names.empty()) return;
    const uint64_t steps = times_.size();
    std::vector<Values> values;
    const auto combined = nc_.var("vals_nod_var");
    for (size_t i = 0; i < names.size(); ++i) {
      Values val;
      if (combined) {
        if (i == 0) {
          nc_.expect_shape(*combined, "vals_nod_var", {steps, names.size(), nodes_},
                           "(time_step, num_nod_var, num_nodes)");
        }
        val = read_node_values(*combined, "vals_nod_var", {size_t(*step_), i}, {1, 1});
      } else {
        const std::string var_name = "vals_nod_var" + std::to_string(i + 1);
        const int v = nc_.require_var(var_name, "values of nodal variable " + names[i]);
        nc_.expect_shape(v, var_name, {steps, nodes_}, "(time_step, num_nodes)");
        val = read_node_values(v, var_name, {size_t(*step_)}, {1});
      }
      val.name = names[i].empty() ? "nodal_" + std::to_string(i + 1) : names[i];
      values.push_back(std::move(val));
    }
    add_fields(fields, Association::Vertex, std::move(values));
  }

  void add_element_variables(FieldSet& fields) {
    const std::vector<std::string> names = variable_names("num_elem_var", "name_elem_var");
    if (names.empty()) return;
    const uint64_t steps = times_.size();
    std::vector<int> table;
    if (const auto t = nc_.var("elem_var_tab")) {
      nc_.expect_shape(*t, "elem_var_tab", {blocks_.size(), names.size()}, "(num_el_blk, num_elem_var)");
      table = nc_.read_all<int>(*t, "elem_var_tab");
    }
    std::vector<Values> values;
    for (size_t i = 0; i < names.size(); ++i) {
      Values val;
      val.name = names[i].empty() ? "element_" + std::to_string(i + 1) : names[i];
      std::vector<double> merged(size_t(out_cells_), 0.0);
      bool any_float = false, any_double = false;
      std::string missing;
      for (size_t b = 0; b < blocks_.size(); ++b) {
        const BlockInfo& blk = blocks_[b];
        if (!blk.kept) continue;
        const std::string var_name = "vals_elem_var" + std::to_string(i + 1) + "eb" + std::to_string(blk.index);
        const auto v = nc_.var(var_name);
        const bool in_table = table.empty() || table[b * names.size() + i] != 0;
        if (!in_table || !v) {
          if (in_table && blk.elements > 0)
            nc_.fail("missing variable " + var_name + " (the truth table elem_var_tab lists it)");
          missing += (missing.empty() ? "" : ", ") + std::to_string(blk.id);
          continue;
        }
        nc_.expect_shape(*v, var_name, {steps, blk.elements},
                         "(time_step, num_el_in_blk" + std::to_string(blk.index) + ")");
        // Every kept block decides the variable's type and whether it exists (a part read gives the whole read's
        // fields), only the rows read are read.
        const std::vector<double> d = nc_.read<double>(*v, var_name, {size_t(*step_), blk.row_first}, {1, blk.rows});
        std::copy(d.begin(), d.end(), merged.begin() + ptrdiff_t(blk.out_first));
        (nc_.var_type(*v, var_name) == NC_FLOAT ? any_float : any_double) = true;
      }
      if (!any_float && !any_double) {
        warnings_.push_back(nc_.path() + ": element variable '" + val.name +
                            "' is defined on no volume block; skipped");
        continue;
      }
      if (!missing.empty()) {
        warnings_.push_back(nc_.path() + ": element variable '" + val.name + "' is not defined on block(s) " + missing +
                            "; those cells get 0");
      }
      // Doubles hold float values exactly, so converting back keeps float32 variables bit-identical.
      val.is_double = any_double;
      if (val.is_double) {
        val.d = std::move(merged);
      } else {
        val.f.assign(merged.begin(), merged.end());
      }
      values.push_back(std::move(val));
    }
    add_fields(fields, Association::Cell, std::move(values));
  }

  // The base name if `name` is BASE + [_]X/Y/Z-suffix `axis` ('X', 'Y', 'Z'), else nullopt.
  static std::optional<std::string> vector_base(const std::string& name, char axis) {
    if (name.size() < 2 || std::toupper(static_cast<unsigned char>(name.back())) != axis) return std::nullopt;
    std::string base = name.substr(0, name.size() - 1);
    if (base.size() > 1 && base.back() == '_') base.pop_back();
    return base;
  }

  static void add_fields(FieldSet& fields, Association association, std::vector<Values> values) {
    for (size_t i = 0; i < values.size(); ++i) {
      if (i + 2 < values.size()) {
        const auto bx = vector_base(values[i].name, 'X');
        const auto by = vector_base(values[i + 1].name, 'Y');
        const auto bz = vector_base(values[i + 2].name, 'Z');
        const bool same_type =
            values[i].is_double == values[i + 1].is_double && values[i].is_double == values[i + 2].is_double;
        if (bx && by && bz && *bx == *by && *bx == *bz && same_type) {
          fields.add(Field(*bx, association, interleave(values[i], values[i + 1], values[i + 2])));
          i += 2;
          continue;
        }
      }
      Values& v = values[i];
      fields.add(Field(v.name, association,
                       v.is_double ? DataArray::from(std::move(v.d), 1) : DataArray::from(std::move(v.f), 1)));
    }
  }

  static DataArray interleave(const Values& x, const Values& y, const Values& z) {
    auto mix = [](const auto& a, const auto& b, const auto& c) {
      std::vector<typename std::decay_t<decltype(a)>::value_type> out(a.size() * 3);
      for (size_t k = 0; k < a.size(); ++k) {
        out[3 * k] = a[k];
        out[3 * k + 1] = b[k];
        out[3 * k + 2] = c[k];
      }
      return DataArray::from(std::move(out), 3);
    };
    return x.is_double ? mix(x.d, y.d, z.d) : mix(x.f, y.f, z.f);
  }

  NcFile nc_;
  int64_t requested_step_;
  uint64_t nodes_ = 0;
  std::vector<std::pair<uint64_t, uint64_t>> node_runs_;  // the nodes read as (first, count): all but in a part read
  uint64_t node_count_ = 0;                               // the nodes in the runs
  uint64_t cells_ = 0;                                    // the kept blocks' elements: a whole read's cells
  uint64_t out_cells_ = 0;                                // the cells read (cells_ but in a part read)
  std::optional<ExodusCellRange> range_;                  // a part read's cells
  bool layout_only_ = false;
  UnstructuredMesh mesh_;
  std::vector<BlockInfo> blocks_;
  std::vector<double> times_;
  std::optional<uint64_t> step_;
  std::vector<std::string> warnings_;
};

}  // namespace

Dataset read_exodus(const std::string& path, int64_t time_step) { return ExodusReader(path, time_step).read(); }

ExodusLayout read_exodus_layout(const std::string& path) {
  ExodusReader reader(path, -1);
  reader.read_layout();
  return reader.layout();
}

std::vector<ExodusCellRange> exodus_cell_ranges(const ExodusLayout& layout, uint64_t pieces) {
  const uint64_t n = std::clamp<uint64_t>(pieces, 1, std::max<uint64_t>(layout.cells, 1));
  const uint64_t snap = layout.cells / n / 8;  // how far a cut moves to fall between blocks
  std::vector<uint64_t> cuts{0};
  for (uint64_t k = 1; k < n; ++k) {
    const uint64_t even = layout.cells * k / n;
    // The block start nearest the even cut, when it is near enough and keeps the ranges in order.
    uint64_t cut = even, distance = snap + 1;
    const auto next = std::lower_bound(layout.block_starts.begin(), layout.block_starts.end(), even);
    for (const auto it : {next, next == layout.block_starts.begin() ? next : std::prev(next)}) {
      if (it == layout.block_starts.end()) continue;
      const uint64_t d = *it > even ? *it - even : even - *it;
      if (d<distance&& * it> cuts.back() && *it < layout.cells * (k + 1) / n) cut = *it, distance = d;
    }
    cuts.push_back(cut);
  }
  cuts.push_back(layout.cells);
  std::vector<ExodusCellRange> out;
  for (size_t k = 0; k + 1 < cuts.size(); ++k)
    if (cuts[k + 1] > cuts[k]) out.push_back({cuts[k], cuts[k + 1] - cuts[k]});
  if (!out.empty()) out.front().from_first_node = out.back().to_last_node = true;
  return out;
}

Dataset read_exodus_cells(const std::string& path, int64_t time_step, const ExodusCellRange& range,
                          std::vector<uint32_t>* node_numbers) {
  ExodusReader reader(path, time_step, range);
  Dataset ds = reader.read();
  if (node_numbers) *node_numbers = reader.node_numbers();
  return ds;
}

struct ExodusFieldReader::Impl {
  explicit Impl(const std::string& path) : reader(path, -1) { reader.read_layout(); }
  ExodusReader reader;
};

ExodusFieldReader::ExodusFieldReader(const std::string& path) : impl_(std::make_unique<Impl>(path)) {}
ExodusFieldReader::~ExodusFieldReader() = default;

FieldSet ExodusFieldReader::read(uint64_t step, std::string& format, std::vector<std::string>& warnings) {
  return impl_->reader.fields_at(step, format, warnings);
}

std::vector<double> list_exodus_times(const std::string& path) {
  const NcFile nc(path);
  const uint64_t steps = nc.dim_or("time_step", 0);
  if (steps == 0) return {};
  const int v = nc.require_var("time_whole", "the time values");
  nc.expect_shape(v, "time_whole", {steps}, "(time_step)");
  return nc.read_all<double>(v, "time_whole");
}

std::optional<GridCounts> exodus_header_counts(const std::string& path) {
  const NcFile nc(path);
  const std::optional<uint64_t> points = nc.dim("num_nodes"), cells = nc.dim("num_elem");
  if (!points || !cells) return std::nullopt;
  return GridCounts{*points, *cells};
}

}  // namespace ugvr
