// PLOT3D reader: binary 3-D grid (XYZ) file plus an optional solution (Q) file, whole layout auto-detected.
//
// Layouts read. Integers are int32, reals float32 or float64, one byte order for the whole file; n = ni*nj*nk and
// every array is stored i fastest. IBLANK is int32 even in float64 files (as vtkMultiBlockPLOT3DReader reads it).
//
//   grid, C binary ("raw"), single block:  ni nj nk | X[n] Y[n] Z[n] [IBLANK[n]]
//   grid, C binary, multi block:           nblocks | ni nj nk x nblocks | per block: X Y Z [IBLANK]
//   grid, Fortran sequential:              the same values, but every record is enclosed by int32 byte counts,
//                                          "[len] payload [len]"; records are [nblocks] (multi only), [all dims],
//                                          then one [X Y Z IBLANK?] record per block
//   Q, C binary:                           [nblocks] ni nj nk x nblocks | per block: fsmach alpha re time (reals),
//                                          density[n] mx[n] my[n] mz[n] energy[n]
//   Q, Fortran sequential:                 records [nblocks] (multi only), [all dims], then per block
//                                          [fsmach alpha re time] and [density mx my mz energy]
//
// Detection, like vtkMultiBlockPLOT3DReader::AutoDetectFormat but exhaustive and deterministic: for every byte order x
// record style x single/multi block, parse the grid header; for every precision x IBLANK, compute the exact size that
// layout implies. The layout whose size equals the grid file's size (and whose Fortran record markers all agree) is
// the one. A header framed by agreeing Fortran record markers is never read as C (see grid_candidates). Several
// layouts can match only for tiny files; then the Q file, which must use the same byte order, records, blocking and
// precision, decides (fitting at all, then fitting exactly), and if it cannot the read fails rather than guess.
// Sizes are all PLOT3D has: a file cut exactly where a smaller layout would end (a float32+IBLANK grid cut after Z)
// is indistinguishable from a complete file of that layout.
// The Q file is checked against the grid (block count, dims) and its own size; trailing bytes after its data are
// allowed with a warning, because real files are padded (bluntfinq.bin is zero-padded to a multiple of 512 bytes).
//
// Not read: ASCII PLOT3D, 2-D files (no Z, two dims), Fortran subrecords (records over 2 GiB), 8-byte record
// markers, OVERFLOW-style Q files with extra variables, function (.f) files.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/plot3d_fields.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/saturating_size.h"

namespace ugvr {
namespace {

constexpr double kGamma = 1.4;        // ratio of specific heats, VTK's default
constexpr double kGasConstant = 1.0;  // R, VTK's default
// A Fortran record longer than this cannot be described by a 4-byte signed marker (compilers then split it into
// subrecords, which this reader does not follow).
constexpr uint64_t kMaxRecord = uint64_t(std::numeric_limits<int32_t>::max());
// More blocks than any real overset system has. Each block costs a few hundred bytes of bookkeeping beyond its data,
// so without a cap a file of millions of 1-point blocks would cost many times its size in memory.
constexpr uint64_t kMaxBlocks = uint64_t(1) << 20;

enum class Order { Big, Little };

struct Layout {
  Order order = Order::Big;
  bool fortran = false;
  bool multi = false;
  int precision = 4;  // bytes per real
  bool iblank = false;
};

std::string order_name(Order o) { return o == Order::Big ? "big-endian" : "little-endian"; }

// "big-endian, Fortran records, multi-block" (what the header parse depends on).
std::string header_layout_name(Order order, bool fortran, bool multi) {
  return order_name(order) + (fortran ? ", Fortran records" : ", C binary") +
         (multi ? ", multi-block" : ", single block");
}

std::string layout_name(const Layout& l, size_t blocks) {
  std::string s = order_name(l.order) + (l.fortran ? ", Fortran records" : ", C binary");
  s += l.multi ? ", multi-block (" + std::to_string(blocks) + (blocks == 1 ? " block)" : " blocks)") : ", single block";
  s += l.iblank ? ", IBLANK" : ", no IBLANK";
  s += l.precision == 4 ? ", float32" : ", float64";
  return s;
}

// Decodes int32 / float32 / float64 values of one byte order from positional reads. Arrays are read in bounded
// chunks so that the temporary buffer never exceeds a fixed size, whatever the array length.
class Decoder {
 public:
  Decoder(const InputFile& file, Order order)
      : file_(file), swap_((order == Order::Big) != (std::endian::native == std::endian::big)) {}

  const InputFile& file() const { return file_; }

  int32_t i32(uint64_t offset) const {
    uint32_t u;
    file_.read_at(offset, &u, 4);
    return int32_t(fix(u));
  }
  double real(uint64_t offset, int precision) const {
    double v = 0;
    reals(offset, 1, precision, [&](uint64_t, double x) { v = x; });
    return v;
  }

  // Calls sink(index, value) for `count` reals of `precision` bytes starting at `offset`.
  template <class Sink>
  void reals(uint64_t offset, uint64_t count, int precision, Sink&& sink) const {
    if (precision == 4) {
      values<uint32_t>(offset, count, [&](uint64_t i, uint32_t u) { sink(i, double(std::bit_cast<float>(u))); });
    } else {
      values<uint64_t>(offset, count, [&](uint64_t i, uint64_t u) { sink(i, std::bit_cast<double>(u)); });
    }
  }
  template <class Sink>
  void ints(uint64_t offset, uint64_t count, Sink&& sink) const {
    values<uint32_t>(offset, count, [&](uint64_t i, uint32_t u) { sink(i, int32_t(u)); });
  }

 private:
  uint32_t fix(uint32_t u) const { return swap_ ? __builtin_bswap32(u) : u; }
  uint64_t fix(uint64_t u) const { return swap_ ? __builtin_bswap64(u) : u; }

  template <class Raw, class Sink>
  void values(uint64_t offset, uint64_t count, Sink&& sink) const {
    constexpr uint64_t kChunk = uint64_t(1) << 16;
    std::vector<Raw> buffer(size_t(std::min(count, kChunk)));
    for (uint64_t done = 0; done < count;) {
      const uint64_t n = std::min(count - done, kChunk);
      file_.read_at(offset + done * sizeof(Raw), buffer.data(), size_t(n * sizeof(Raw)));
      for (uint64_t k = 0; k < n; ++k) sink(done + k, fix(buffer[size_t(k)]));
      done += n;
    }
  }

  const InputFile& file_;
  bool swap_;
};

// Block dimensions as stored at the start of both files.
struct DimsHeader {
  std::vector<std::array<uint32_t, 3>> dims;
  std::vector<uint64_t> points;  // per block, ni*nj*nk
  uint64_t dims_offset = 0;      // where the first block's ni is
  uint64_t data_offset = 0;      // first byte after the header (and its Fortran records)
};

std::string dims_text(const std::array<uint32_t, 3>& d) {
  return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

// Parses the block count and dimensions for one header interpretation without throwing on a mismatch: a layout that
// does not fit is not an error yet, only a rejected candidate, and `why` says (with the byte offset) what did not fit.
// Still throws if the file cannot be read at all.
std::optional<DimsHeader> parse_dims(const Decoder& d, bool fortran, bool multi, std::string& why) {
  const uint64_t size = d.file().size();
  uint64_t off = 0;
  // Reads the int32 at `at` if it lies within the file.
  auto int_at = [&](uint64_t at, int32_t& v) {
    if (at > size || size - at < 4) {
      why = "the file ends at byte " + std::to_string(size) + ", before the header value at byte " + std::to_string(at);
      return false;
    }
    v = d.i32(at);
    return true;
  };
  auto marker_at = [&](uint64_t at, uint64_t want) {
    int32_t v;
    if (!int_at(at, v)) return false;
    if (uint64_t(uint32_t(v)) != want) {
      why = "Fortran record marker at byte " + std::to_string(at) + " is " + std::to_string(v) + ", expected " +
            std::to_string(want);
      return false;
    }
    return true;
  };

  uint64_t nblocks = 1;
  if (multi) {
    if (fortran) {
      if (!marker_at(off, 4)) return std::nullopt;
      off += 4;
    }
    int32_t n;
    if (!int_at(off, n)) return std::nullopt;
    // Each block needs at least its 12 bytes of dims and 12 bytes of coordinates for one point.
    if (n < 1 || uint64_t(n) > size / 24 || uint64_t(n) > kMaxBlocks) {
      why = "block count " + std::to_string(n) + " at byte " + std::to_string(off);
      if (n < 1) {
        why += " is not positive";
      } else if (uint64_t(n) > size / 24) {
        why += " is impossible in a file of " + std::to_string(size) + " bytes";
      } else {
        why += " is over the limit of " + std::to_string(kMaxBlocks) + " blocks";
      }
      return std::nullopt;
    }
    nblocks = uint64_t(n);
    off += 4;
    if (fortran) {
      if (!marker_at(off, 4)) return std::nullopt;
      off += 4;
    }
  }
  const uint64_t dims_bytes = 12 * nblocks;
  if (fortran) {
    if (!marker_at(off, dims_bytes)) return std::nullopt;
    off += 4;
  }
  if (off > size || size - off < dims_bytes) {
    why = "the file ends at byte " + std::to_string(size) + ", before the " + std::to_string(dims_bytes) +
          " bytes of block dimensions at byte " + std::to_string(off);
    return std::nullopt;
  }
  DimsHeader h;
  h.dims_offset = off;
  std::vector<int32_t> raw(size_t(3 * nblocks));
  d.ints(off, 3 * nblocks, [&](uint64_t i, int32_t v) { raw[size_t(i)] = v; });
  h.dims.resize(size_t(nblocks));
  h.points.resize(size_t(nblocks));
  for (uint64_t b = 0; b < nblocks; ++b) {
    uint64_t points = 1;
    for (int k = 0; k < 3; ++k) {
      const int32_t v = raw[size_t(3 * b + uint64_t(k))];
      if (v < 1) {
        why = "block " + std::to_string(b) + " dimension " + "ijk"[k] + " = " + std::to_string(v) + " at byte " +
              std::to_string(off + 12 * b + 4 * uint64_t(k)) + " is not positive";
        return std::nullopt;
      }
      h.dims[size_t(b)][size_t(k)] = uint32_t(v);
      points = sat_mul(points, uint64_t(v));  // three factors below 2^31 each can exceed 2^64
    }
    h.points[size_t(b)] = points;
  }
  off += dims_bytes;
  if (fortran) {
    if (!marker_at(off, dims_bytes)) return std::nullopt;
    off += 4;
  }
  h.data_offset = off;
  return h;
}

std::string header_summary(const DimsHeader& h) {
  if (h.dims.size() == 1) return "dims " + dims_text(h.dims[0]) + " at byte " + std::to_string(h.dims_offset);
  uint64_t total = 0;
  for (uint64_t n : h.points) total = sat_add(total, n);
  return std::to_string(h.dims.size()) + " blocks with " + size_text(total) + " points in all (dims at byte " +
         std::to_string(h.dims_offset) + ")";
}

// ---- Grid layout detection ----

// A grid layout that fits the grid file exactly.
struct GridCandidate {
  Layout layout;
  DimsHeader header;
  bool told_by_solution = false;  // several layouts fit the grid: the solution file chose this one
};

uint64_t grid_block_bytes(uint64_t points, const Layout& l) {
  return sat_mul(points, uint64_t(3 * l.precision + (l.iblank ? 4 : 0)));
}

// The total grid file size a layout implies.
uint64_t grid_file_size(const DimsHeader& h, const Layout& l) {
  uint64_t total = h.data_offset;
  for (uint64_t n : h.points) total = sat_add(sat_add(total, grid_block_bytes(n, l)), l.fortran ? 8 : 0);
  return total;
}

// For a Fortran layout whose total size already equals the file size (so every read below is inside the file):
// checks the markers around every block's coordinate record.
bool grid_markers_agree(const Decoder& d, const DimsHeader& h, const Layout& l, std::string& why) {
  uint64_t off = h.data_offset;
  for (size_t b = 0; b < h.points.size(); ++b) {
    const uint64_t record = grid_block_bytes(h.points[b], l);
    if (record > kMaxRecord) {
      why = "block " + std::to_string(b) + "'s record of " + std::to_string(record) +
            " bytes is too long for 4-byte record markers";
      return false;
    }
    for (const uint64_t at : {off, off + 4 + record}) {
      const int32_t m = d.i32(at);
      if (uint64_t(uint32_t(m)) != record) {
        why = "Fortran record marker at byte " + std::to_string(at) + " is " + std::to_string(m) + ", expected " +
              std::to_string(record);
        return false;
      }
    }
    off += record + 8;
  }
  return true;
}

// Every layout whose implied size equals the grid file's size; `tried` gets one line per header interpretation
// saying why it does not fit (for the error message when nothing does).
//
// Fortran framing takes precedence, as in VTK (which looks for record markers first): when a byte order's header is
// enclosed by agreeing Fortran record markers, C readings of that byte order are not accepted. Such a header read as
// C starts with dims (4, nblocks, 4) or (12, ni, nj), which can equal the size of a Fortran file cut short; whereas a
// genuine C file whose first values happen to form agreeing markers is practically impossible.
std::vector<GridCandidate> grid_candidates(const InputFile& f, std::vector<std::string>& tried) {
  std::vector<GridCandidate> found;
  for (const Order order : {Order::Big, Order::Little}) {
    const Decoder d(f, order);
    bool fortran_framed = false;
    for (const bool fortran : {true, false}) {
      for (const bool multi : {false, true}) {
        const std::string name = header_layout_name(order, fortran, multi);
        std::string why;
        const std::optional<DimsHeader> h = parse_dims(d, fortran, multi, why);
        if (!h) {
          tried.push_back(name + ": " + why);
          continue;
        }
        fortran_framed = fortran_framed || fortran;
        std::string sizes;
        bool all_saturated = true;
        for (const int precision : {4, 8}) {
          for (const bool iblank : {false, true}) {
            const Layout l{order, fortran, multi, precision, iblank};
            const uint64_t want = grid_file_size(*h, l);
            all_saturated = all_saturated && want == kSaturated;
            sizes += (sizes.empty() ? "" : ", ") + size_text(want) + (precision == 4 ? " (float32" : " (float64") +
                     (iblank ? "+IBLANK)" : ")");
            if (want != f.size()) continue;
            if (fortran && !grid_markers_agree(d, *h, l, why)) continue;
            if (!fortran && fortran_framed) {
              why = "the header is framed by Fortran record markers (a truncated Fortran file?)";
              continue;
            }
            found.push_back({l, *h});
          }
        }
        if (all_saturated) sizes = "more than 2^64";
        tried.push_back(name + ": " + header_summary(*h) + " imply " + sizes + " bytes" +
                        (why.empty() ? "" : "; the size matches but " + why));
      }
    }
  }
  return found;
}

// ---- Solution (Q) file ----

struct QBlockPlan {
  uint64_t header_offset = 0;  // fsmach alpha re time
  uint64_t data_offset = 0;    // density, mx, my, mz, energy
};

struct QPlan {
  std::vector<QBlockPlan> blocks;
  uint64_t end = 0;  // first byte after the last block
};

// Checks the Q file against the grid's layout and dimensions (the grid file named `grid_name` in messages) and locates
// every block's values; throws ugvr::Error naming the Q file, the byte offset and what was expected there.
QPlan plan_q(const InputFile& q, const std::string& grid_name, const GridCandidate& g) {
  const Layout& l = g.layout;
  const size_t nblocks = g.header.dims.size();
  const Decoder d(q, l.order);
  std::string why;
  const std::optional<DimsHeader> h = parse_dims(d, l.fortran, l.multi, why);
  if (!h) {
    fail_in(q.path(), "not a PLOT3D solution file in the layout of grid file " + grid_name + " (" +
                          layout_name(l, nblocks) + "): " + why);
  }
  if (h->dims.size() != nblocks) {
    fail_at_offset(q.path(), l.fortran ? 4 : 0,
                   "block count " + std::to_string(h->dims.size()) + ", but grid file " + grid_name + " has " +
                       std::to_string(nblocks));
  }
  for (size_t b = 0; b < nblocks; ++b) {
    if (h->dims[b] != g.header.dims[b]) {
      fail_at_offset(q.path(), h->dims_offset + 12 * b,
                     "block " + std::to_string(b) + " has dimensions " + dims_text(h->dims[b]) + ", but grid file " +
                         grid_name + " has " + dims_text(g.header.dims[b]) + " for it");
    }
  }

  const uint64_t size = q.size(), precision = uint64_t(l.precision);
  uint64_t off = h->data_offset;
  auto need = [&](uint64_t bytes, const std::string& what) {
    if (off > size || size - off < bytes) {
      fail_at_offset(q.path(), off,
                     "the file ends at byte " + std::to_string(size) + ", but " + size_text(bytes) + " bytes of " +
                         what + " should start here");
    }
  };
  auto marker = [&](uint64_t want, const std::string& what) {
    if (want > kMaxRecord) {
      fail_at_offset(q.path(), off,
                     what + " is " + size_text(want) + " bytes, too long for 4-byte Fortran record markers");
    }
    need(4, "the Fortran record marker of " + what);
    const int32_t m = d.i32(off);
    if (uint64_t(uint32_t(m)) != want) {
      fail_at_offset(q.path(), off,
                     "Fortran record marker is " + std::to_string(m) + ", expected " + std::to_string(want) +
                         " (the length of " + what + ")");
    }
    off += 4;
  };

  QPlan plan;
  for (size_t b = 0; b < nblocks; ++b) {
    const std::string block = "block " + std::to_string(b);
    const std::string header = block + "'s header record (fsmach, alpha, re, time)";
    const std::string values = block + "'s solution record (density, momentum x, y, z, energy: 5 x " +
                               std::to_string(h->points[b]) + " values)";
    const uint64_t header_bytes = 4 * precision;
    const uint64_t value_bytes = sat_mul(h->points[b], 5 * precision);
    QBlockPlan p;
    if (l.fortran) marker(header_bytes, header);
    p.header_offset = off;
    need(header_bytes, header);
    off += header_bytes;
    if (l.fortran) {
      marker(header_bytes, header);
      marker(value_bytes, values);
    }
    p.data_offset = off;
    need(value_bytes, values);
    off += value_bytes;
    if (l.fortran) marker(value_bytes, values);
    plan.blocks.push_back(p);
  }
  plan.end = off;
  return plan;
}

struct QHeader {
  double fsmach = 0, alpha = 0, re = 0, time = 0;
};

std::string q_header_text(const QHeader& h) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "fsmach=%g alpha=%g re=%g time=%g", h.fsmach, h.alpha, h.re, h.time);
  return buf;
}

// ---- Choosing the layout ----

std::string bullet_list(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& line : lines) s += "\n  - " + line;
  return s;
}

GridCandidate detect_layout(const InputFile& xyz, const InputFile* q) {
  std::vector<std::string> tried;
  std::vector<GridCandidate> found = grid_candidates(xyz, tried);
  if (found.size() == 1) return found.front();
  if (found.empty()) {
    fail_in(xyz.path(), "not a PLOT3D grid file: no binary layout implies its size of " + std::to_string(xyz.size()) +
                            " bytes. Tried:" + bullet_list(tried));
  }
  std::vector<std::string> names;
  for (const GridCandidate& c : found) names.push_back(layout_name(c.layout, c.header.dims.size()));
  const std::string ambiguous = "ambiguous PLOT3D grid file: " + std::to_string(found.size()) +
                                " layouts imply its size of " + std::to_string(xyz.size()) +
                                " bytes:" + bullet_list(names);
  if (!q) fail_in(xyz.path(), ambiguous + "\nGive the solution file as well to tell them apart.");
  // The solution file must follow the grid's layout, so it can rule candidates out.
  std::vector<GridCandidate> fit;
  for (const GridCandidate& c : found) {
    try {
      plan_q(*q, xyz.name(), c);
      fit.push_back(c);
    } catch (const Error&) {
      // this candidate does not explain the solution file: not the layout
    }
  }
  for (GridCandidate& c : fit) c.told_by_solution = true;
  if (fit.size() == 1) return fit.front();
  // The solution file may carry padding after its data; one that fits a candidate exactly is the stronger evidence.
  std::vector<GridCandidate> exact;
  for (const GridCandidate& c : fit) {
    if (plan_q(*q, xyz.name(), c).end == q->size()) exact.push_back(c);
  }
  if (exact.size() == 1) return exact.front();
  fail_in(xyz.path(), ambiguous + "\nand the solution file " + q->name() + " fits " +
                          (fit.empty() ? "none" : std::to_string(fit.size())) + " of them.");
}

// ---- Reading ----

StructuredGrid read_grid_block(const Decoder& d, const Layout& l, const std::array<uint32_t, 3>& dims, uint64_t n,
                               size_t block, uint64_t& off) {
  const InputFile& f = d.file();
  const uint64_t precision = uint64_t(l.precision);
  if (l.fortran) off += 4;
  // The layout's size matched the file already; this guards the allocations on their own all the same.
  check_count_fits(f.path(), off, "block " + std::to_string(block) + " point", n, 3 * precision + (l.iblank ? 4 : 0),
                   f.size() - std::min(off, f.size()));
  StructuredGrid g;
  g.dims.points = dims;
  g.points.resize(size_t(n));
  d.reals(off, n, l.precision, [&](uint64_t i, double v) { g.points[size_t(i)].x = float(v); });
  off += n * precision;
  d.reals(off, n, l.precision, [&](uint64_t i, double v) { g.points[size_t(i)].y = float(v); });
  off += n * precision;
  d.reals(off, n, l.precision, [&](uint64_t i, double v) { g.points[size_t(i)].z = float(v); });
  off += n * precision;
  if (l.iblank) {
    g.iblank.resize(size_t(n));
    d.ints(off, n, [&](uint64_t i, int32_t v) { g.iblank[size_t(i)] = v; });
    off += n * 4;
  }
  if (l.fortran) off += 4;
  return g;
}

template <class T>
Field vertex_field(const char* name, std::vector<T> values, int components) {
  return Field(name, Association::Vertex, DataArray::from(std::move(values), components));
}

// Reads one block's Q variables in the file's precision T and derives Pressure, Temperature, Velocity and
// VelocityMagnitude as vtkMultiBlockPLOT3DReader does (gamma 1.4, R 1). VTK substitutes density 1 where it is 0;
// here the derived values are 0 there instead, so that a zero-density point (a vacuum, or a blanked point left at
// 0) shows up as nothing rather than as momentum-sized garbage, and nothing is ever NaN from a division.
template <class T>
FieldSet read_q_block(const Decoder& d, int precision, uint64_t data_offset, uint64_t n) {
  const InputFile& f = d.file();
  check_count_fits(f.path(), data_offset, "solution point", n, 5 * uint64_t(precision),
                   f.size() - std::min(data_offset, f.size()));
  const uint64_t stride = n * uint64_t(precision);
  const size_t count = size_t(n);
  std::vector<T> density(count), momentum(3 * count), energy(count);
  d.reals(data_offset, n, precision, [&](uint64_t i, double v) { density[size_t(i)] = T(v); });
  for (uint64_t c = 0; c < 3; ++c) {
    d.reals(data_offset + (1 + c) * stride, n, precision,
            [&](uint64_t i, double v) { momentum[size_t(3 * i + c)] = T(v); });
  }
  d.reals(data_offset + 4 * stride, n, precision, [&](uint64_t i, double v) { energy[size_t(i)] = T(v); });

  std::vector<T> pressure(count), temperature(count), velocity(3 * count), speed(count);
  for (size_t i = 0; i < count; ++i) {
    const double rho = double(density[i]);
    if (rho == 0) continue;  // derived values stay 0
    const double vx = double(momentum[3 * i]) / rho, vy = double(momentum[3 * i + 1]) / rho,
                 vz = double(momentum[3 * i + 2]) / rho;
    const double v2 = vx * vx + vy * vy + vz * vz;
    const double p = (kGamma - 1) * (double(energy[i]) - 0.5 * rho * v2);
    pressure[i] = T(p);
    temperature[i] = T(p / (rho * kGasConstant));
    velocity[3 * i] = T(vx);
    velocity[3 * i + 1] = T(vy);
    velocity[3 * i + 2] = T(vz);
    speed[i] = T(std::sqrt(v2));
  }

  FieldSet fields;
  fields.add(vertex_field("Density", std::move(density), 1));
  fields.add(vertex_field("Momentum", std::move(momentum), 3));
  fields.add(vertex_field("StagnationEnergy", std::move(energy), 1));
  fields.add(vertex_field("Pressure", std::move(pressure), 1));
  fields.add(vertex_field("Temperature", std::move(temperature), 1));
  fields.add(vertex_field("Velocity", std::move(velocity), 3));
  fields.add(vertex_field("VelocityMagnitude", std::move(speed), 1));
  return fields;
}

QHeader read_q_header(const Decoder& d, int precision, uint64_t offset) {
  const uint64_t p = uint64_t(precision);
  return {d.real(offset, precision), d.real(offset + p, precision), d.real(offset + 2 * p, precision),
          d.real(offset + 3 * p, precision)};
}

// True if bytes [from, end of file) are all zero (read in bounded chunks).
bool all_zero_from(const InputFile& f, uint64_t from) {
  std::vector<char> buffer(size_t(1) << 16);
  for (uint64_t off = from; off < f.size();) {
    const size_t n = size_t(std::min<uint64_t>(buffer.size(), f.size() - off));
    f.read_at(off, buffer.data(), n);
    if (std::any_of(buffer.begin(), buffer.begin() + std::ptrdiff_t(n), [](char c) { return c != 0; })) return false;
    off += n;
  }
  return true;
}

// What the solution file adds to the dataset: each block's fields, the format line's "; q: ..." and the warnings.
struct Solution {
  std::vector<FieldSet> blocks;
  std::string format;
  std::vector<std::string> warnings;
};

// The solution file's blocks on grid layout `g`, located by `plan` (plan_q): the decoding both the whole read and the
// fields-only read of a series' step go through.
Solution read_solution(const InputFile& q, const GridCandidate& g, const QPlan& plan) {
  const Layout& l = g.layout;
  const size_t nblocks = g.header.dims.size();
  const Decoder q_decoder(q, l.order);
  Solution out;
  std::vector<QHeader> headers;
  for (size_t b = 0; b < nblocks; ++b) {
    const QBlockPlan& p = plan.blocks[b];
    headers.push_back(read_q_header(q_decoder, l.precision, p.header_offset));
    const uint64_t n = g.header.points[b];
    out.blocks.push_back(l.precision == 4 ? read_q_block<float>(q_decoder, l.precision, p.data_offset, n)
                                          : read_q_block<double>(q_decoder, l.precision, p.data_offset, n));
  }
  out.format = "; q: " + q_header_text(headers.front());
  // One warning, not one per block: a hostile file may have a million blocks.
  size_t differing = 0, first = 0;
  for (size_t b = nblocks; b-- > 1;) {
    if (q_header_text(headers[b]) != q_header_text(headers.front())) {  // as shown; NaN == NaN here
      ++differing;
      first = b;
    }
  }
  if (differing > 0) {
    out.warnings.push_back(q.name() + ": " + std::to_string(differing) + " block(s) have a Q header other than block " +
                           "0's shown in the format line, first block " + std::to_string(first) + ": " +
                           q_header_text(headers[first]));
  }
  if (plan.end < q.size()) {
    out.warnings.push_back(q.name() + ": ignored " + std::to_string(q.size() - plan.end) +
                           " trailing bytes after the last block, from byte " + std::to_string(plan.end) +
                           (all_zero_from(q, plan.end) ? " (all zero: padding)" : " (not all zero)"));
  }
  return out;
}

std::string grid_format(const GridCandidate& g) {
  return "PLOT3D (" + layout_name(g.layout, g.header.dims.size()) + ")";
}

}  // namespace

// What a step's solution needs of the grid, kept from the grid's read (plot3d_fields.h).
struct Plot3dLayout {
  std::optional<uint64_t> mesh_key;  // plot3d_mesh_key of the grid when read; none where the solution chose the layout
  std::string xyz_path;              // the dataset's first source
  std::string xyz_name;              // the grid as the solution's messages name it
  GridCandidate grid;
};

namespace {

// The grid and its solution (if any) as one dataset; where `kept` is given, the layout detected from the grid.
Dataset read_grid_and_solution(const std::string& xyz_path, const std::string& q_path, Plot3dLayout* kept) {
  const InputFile xyz(xyz_path);
  std::optional<InputFile> q;
  if (!q_path.empty()) q.emplace(q_path);

  const GridCandidate g = detect_layout(xyz, q ? &*q : nullptr);
  const Layout& l = g.layout;
  const size_t nblocks = g.header.dims.size();
  std::optional<QPlan> plan;
  if (q) plan = plan_q(*q, xyz.name(), g);
  if (kept) {
    kept->xyz_path = xyz_path;
    kept->xyz_name = xyz.name();
    kept->grid = g;
  }

  Dataset ds;
  ds.format = grid_format(g);
  ds.sources.push_back(xyz_path);
  if (q) ds.sources.push_back(q_path);

  const Decoder grid_decoder(xyz, l.order);
  uint64_t off = g.header.data_offset;
  for (size_t b = 0; b < nblocks; ++b) {
    Block block;
    block.name = "block " + std::to_string(b);
    block.grid = read_grid_block(grid_decoder, l, g.header.dims[b], g.header.points[b], b, off);
    ds.blocks.push_back(std::move(block));
  }
  if (!q) return ds;

  Solution solution = read_solution(*q, g, *plan);
  for (size_t b = 0; b < nblocks; ++b) {
    ds.blocks[b].fields = std::move(solution.blocks[b]);
    ds.blocks[b].validate_fields(q->path());
  }
  ds.format += solution.format;
  ds.warnings = std::move(solution.warnings);
  return ds;
}

}  // namespace

Dataset read_plot3d(const std::string& xyz_path, const std::string& q_path) {
  return read_grid_and_solution(xyz_path, q_path, nullptr);
}

uint64_t plot3d_mesh_key(const std::string& xyz_path) {
  return hash_file_stamp(hash_mix(kFnvOffset, 0x706c3364), xyz_path);  // "pl3d"
}

Dataset read_plot3d(const std::string& xyz_path, const std::string& q_path, std::shared_ptr<const Plot3dLayout>* kept) {
  if (!kept) return read_plot3d(xyz_path, q_path);
  // Taken before the grid is read: a grid rewritten during the read gives another key than the one kept.
  const uint64_t key = plot3d_mesh_key(xyz_path);
  auto layout = std::make_shared<Plot3dLayout>();
  Dataset ds = read_grid_and_solution(xyz_path, q_path, layout.get());
  if (!layout->grid.told_by_solution) layout->mesh_key = key;
  *kept = std::move(layout);
  return ds;
}

const std::optional<uint64_t>& plot3d_layout_mesh_key(const Plot3dLayout& layout) { return layout.mesh_key; }

std::vector<FieldSet> read_plot3d_fields(const Plot3dLayout& layout, const std::string& q_path, std::string& format,
                                         std::vector<std::string>& sources, std::vector<std::string>& warnings) {
  const InputFile q(q_path);
  const QPlan plan = plan_q(q, layout.xyz_name, layout.grid);
  Solution solution = read_solution(q, layout.grid, plan);
  format = grid_format(layout.grid) + solution.format;
  sources = {layout.xyz_path, q_path};
  warnings.insert(warnings.end(), solution.warnings.begin(), solution.warnings.end());
  return std::move(solution.blocks);
}

}  // namespace ugvr
