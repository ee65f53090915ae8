// PLOT3D reader: the two real datasets (checked against their published ranges), every layout the reader detects
// written synthetically and read back value by value, and malformed files that must fail with ugvr::Error naming the
// file. Fields-only steps (io/step_fields.h): a series' later steps read their .q file alone, bit for bit the whole
// read.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "step_fields_checks.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/render/exact/exact_renderer.h"

namespace ugvr {
namespace {

using test::ScratchDir;

// ---- A small PLOT3D writer for synthetic files ----

struct Spec {
  bool big = true;
  bool fortran = false;
  bool multi = false;
  int precision = 4;
  bool iblank = false;
};

struct SynthBlock {
  std::array<int32_t, 3> dims{};
  std::vector<double> x, y, z;
  std::vector<int32_t> iblank;
  std::array<double, 4> qheader{};  // fsmach alpha re time
  std::vector<double> rho, mx, my, mz, energy;
  size_t n() const { return x.size(); }
};

// Values exactly representable in float32, so that float and double files read back exactly.
SynthBlock make_block(std::array<int32_t, 3> dims, int seed) {
  SynthBlock b;
  b.dims = dims;
  const size_t n = size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]);
  for (size_t i = 0; i < n; ++i) {
    const double d = double(i);
    b.x.push_back(d * 0.5 + seed);
    b.y.push_back(-d * 0.25);
    b.z.push_back(seed * 10.0 + d);
    b.iblank.push_back(int32_t(i % 3) - 1);  // -1, 0, 1
    b.rho.push_back(1.0 + double(i % 4) * 0.5);
    b.mx.push_back(d * 0.125);
    b.my.push_back(-0.5 * seed);
    b.mz.push_back(2.0 - d * 0.0625);
    b.energy.push_back(10.0 + d * 0.25);
  }
  b.qheader = {2.5 + seed, 0.5, 1000.0 * (seed + 1), 7.25};
  return b;
}

class Bytes {
 public:
  explicit Bytes(bool big) : big_(big) {}
  void i32(int32_t v) { put(uint32_t(v)); }
  void real(double v, int precision) {
    if (precision == 4) {
      put(std::bit_cast<uint32_t>(float(v)));
    } else {
      put(std::bit_cast<uint64_t>(v));
    }
  }
  // Writes payload() as one record: enclosed in int32 byte counts when `fortran`.
  template <class F>
  void record(bool fortran, F&& payload) {
    const size_t marker = s_.size();
    if (fortran) i32(0);
    const size_t start = s_.size();
    payload();
    if (!fortran) return;
    const int32_t len = int32_t(s_.size() - start);
    Bytes m(big_);
    m.i32(len);
    s_.replace(marker, 4, m.str());
    i32(len);
  }
  const std::string& str() const { return s_; }

 private:
  template <class U>
  void put(U u) {
    for (size_t k = 0; k < sizeof(U); ++k) {
      const size_t shift = 8 * (big_ ? sizeof(U) - 1 - k : k);
      s_.push_back(char((u >> shift) & 0xff));
    }
  }
  bool big_;
  std::string s_;
};

void write_header(Bytes& out, const Spec& s, const std::vector<SynthBlock>& blocks) {
  if (s.multi) out.record(s.fortran, [&] { out.i32(int32_t(blocks.size())); });
  out.record(s.fortran, [&] {
    for (const SynthBlock& b : blocks)
      for (int32_t d : b.dims) out.i32(d);
  });
}

std::string grid_bytes(const Spec& s, const std::vector<SynthBlock>& blocks) {
  Bytes out(s.big);
  write_header(out, s, blocks);
  for (const SynthBlock& b : blocks) {
    out.record(s.fortran, [&] {
      for (const auto* a : {&b.x, &b.y, &b.z})
        for (double v : *a) out.real(v, s.precision);
      if (s.iblank)
        for (int32_t v : b.iblank) out.i32(v);
    });
  }
  return out.str();
}

std::string q_bytes(const Spec& s, const std::vector<SynthBlock>& blocks) {
  Bytes out(s.big);
  write_header(out, s, blocks);
  for (const SynthBlock& b : blocks) {
    out.record(s.fortran, [&] {
      for (double v : b.qheader) out.real(v, s.precision);
    });
    out.record(s.fortran, [&] {
      for (const auto* a : {&b.rho, &b.mx, &b.my, &b.mz, &b.energy})
        for (double v : *a) out.real(v, s.precision);
    });
  }
  return out.str();
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), std::streamsize(bytes.size()));
  ASSERT_TRUE(f.good()) << path;
}

// The message of the ugvr::Error that f() throws, or "" (and a test failure) if it does not throw one.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected ugvr::Error";
  return {};
}

const Field& field(const Block& b, const char* name) {
  const Field* f = b.fields.find(name);
  if (!f) throw std::runtime_error(std::string("no field ") + name);
  return *f;
}

const StructuredGrid& grid(const Block& b) { return std::get<StructuredGrid>(b.grid); }

// ---- Real data ----

TEST(Plot3dReader, BluntFin) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  const Dataset ds = read_plot3d(relative_data_path, test::data_path("blunt-fin/bluntfinq.bin"));
  EXPECT_EQ(ds.format,
            "PLOT3D (big-endian, C binary, single block, no IBLANK, float32); "
            "q: fsmach=2.95 alpha=0 re=2.1e+06 time=1.3911");
  ASSERT_EQ(ds.blocks.size(), 1u);
  const Block& b = ds.blocks[0];
  EXPECT_EQ(b.name, "block 0");
  const StructuredGrid& g = grid(b);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{40, 32, 32}));
  EXPECT_EQ(ds.point_count(), 40960u);
  EXPECT_EQ(ds.cell_count(), 37479u);
  EXPECT_FALSE(g.has_iblank());
  const Bounds bb = ds.bounds();
  EXPECT_NEAR(bb.lo.x, -7.816, 1e-3);
  EXPECT_NEAR(bb.hi.x, 14.362, 1e-3);
  EXPECT_NEAR(bb.hi.y, 8.328, 1e-3);
  EXPECT_NEAR(bb.hi.z, 5.724, 1e-3);

  ASSERT_EQ(b.fields.size(), 7u);
  EXPECT_EQ(field(b, "Density").data().type(), ScalarType::Float32);
  const Range density = field(b, "Density").range();
  EXPECT_NEAR(density.min, 0.193, 0.001);
  EXPECT_NEAR(density.max, 4.98, 0.005);
  const Range pressure = field(b, "Pressure").range();
  EXPECT_NEAR(pressure.min, 0.26, 0.005);
  EXPECT_NEAR(pressure.max, 10.0, 0.02);
  const Range speed = field(b, "VelocityMagnitude").range();
  EXPECT_NEAR(speed.min, 0.0, 1e-6);
  EXPECT_NEAR(speed.max, 3.12, 0.005);
  EXPECT_EQ(speed.nan_count, 0u);
  // The vector and its own magnitude field agree.
  EXPECT_NEAR(field(b, "Velocity").range(kMagnitude).max, speed.max, 1e-5);
  EXPECT_EQ(field(b, "Momentum").components(), 3);
  // bluntfinq.bin is zero-padded to 819712 bytes (1601 x 512) after its 819228 bytes of data.
  ASSERT_EQ(ds.warnings.size(), 1u);
  EXPECT_NE(ds.warnings[0].find("484 trailing bytes"), std::string::npos) << ds.warnings[0];
  EXPECT_NE(ds.warnings[0].find("all zero"), std::string::npos) << ds.warnings[0];
}

TEST(Plot3dReader, BluntFinThroughReadDataset) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  const std::vector<std::string> paths{relative_data_path, test::data_path("blunt-fin/bluntfinq.bin")};
  EXPECT_EQ(detect_format(paths), InputFormat::Plot3d);
  const Dataset ds = read_dataset(paths);
  EXPECT_EQ(ds.point_count(), 40960u);
  EXPECT_EQ(ds.sources, paths);
  ASSERT_NE(ds.blocks[0].fields.find("Temperature"), nullptr);
}

TEST(Plot3dReader, BluntFinGeometryOnly) {
  UGVR_REQUIRE_DATA("blunt-fin/bluntfinxyz.bin");
  const Dataset ds = read_plot3d(relative_data_path, "");
  EXPECT_EQ(ds.format, "PLOT3D (big-endian, C binary, single block, no IBLANK, float32)");
  EXPECT_EQ(ds.sources.size(), 1u);
  ASSERT_EQ(ds.blocks.size(), 1u);
  EXPECT_TRUE(ds.blocks[0].fields.empty());
  EXPECT_EQ(ds.point_count(), 40960u);
  EXPECT_TRUE(ds.warnings.empty());
}

TEST(Plot3dReader, LoxPostWithIblank) {
  UGVR_REQUIRE_DATA("lox-post/postxyz.bin");
  const Dataset ds = read_plot3d(relative_data_path, test::data_path("lox-post/postq.bin"));
  EXPECT_EQ(ds.format,
            "PLOT3D (big-endian, C binary, single block, IBLANK, float32); q: fsmach=1 alpha=1 re=1000 time=46");
  ASSERT_EQ(ds.blocks.size(), 1u);
  const Block& b = ds.blocks[0];
  const StructuredGrid& g = grid(b);
  EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{38, 76, 38}));
  EXPECT_EQ(ds.point_count(), 109744u);
  EXPECT_EQ(ds.cell_count(), 102675u);
  ASSERT_EQ(g.iblank.size(), 109744u);
  // Measured: the file holds only 1 (105,412 points) and -1 (4,332 points, overset fringe), no 0; so although
  // SOURCE.txt speaks of {-1, 0, 1}, no point is blanked, as in VTK (which hides only IBLANK 0).
  std::map<int32_t, uint64_t> histogram;
  for (int32_t v : g.iblank) ++histogram[v];
  EXPECT_EQ(histogram, (std::map<int32_t, uint64_t>{{-1, 4332}, {1, 105412}}));

  const Range density = field(b, "Density").range();
  EXPECT_EQ(density.min, 1.0);
  EXPECT_EQ(density.max, 1.0);
  const Range energy = field(b, "StagnationEnergy").range();
  EXPECT_NEAR(energy.min, -0.54, 0.005);
  EXPECT_NEAR(energy.max, 4.40, 0.005);
  const Range speed = field(b, "VelocityMagnitude").range();
  EXPECT_NEAR(speed.min, 0.0, 1e-6);
  EXPECT_NEAR(speed.max, 1.39, 0.005);
  // SOURCE.txt's Momentum [-0.68, 1.36] is over all three components.
  const Field& momentum = field(b, "Momentum");
  double lo = 1e9, hi = -1e9;
  for (int c = 0; c < 3; ++c) {
    lo = std::min(lo, momentum.range(c).min);
    hi = std::max(hi, momentum.range(c).max);
  }
  EXPECT_NEAR(lo, -0.68, 0.005);
  EXPECT_NEAR(hi, 1.36, 0.005);
  EXPECT_TRUE(ds.warnings.empty());
}

// ---- Every layout, synthetic ----

using LayoutParam = std::tuple<bool, bool, bool, int, bool>;  // big, fortran, multi, precision, iblank

class Plot3dLayout : public ::testing::TestWithParam<LayoutParam> {
 protected:
  Spec spec() const {
    const auto [big, fortran, multi, precision, iblank] = GetParam();
    return {big, fortran, multi, precision, iblank};
  }
  std::vector<SynthBlock> blocks() const {
    if (!spec().multi) return {make_block({3, 2, 2}, 0)};
    return {make_block({3, 2, 2}, 0), make_block({2, 3, 4}, 1)};
  }
};

template <class T>
void expect_q_fields(const Block& b, const SynthBlock& want) {
  const size_t n = want.n();
  for (const char* name :
       {"Density", "Momentum", "StagnationEnergy", "Pressure", "Temperature", "Velocity", "VelocityMagnitude"}) {
    EXPECT_EQ(field(b, name).data().type(), scalar_type_of<T>()) << name;
    EXPECT_EQ(field(b, name).tuples(), n) << name;
  }
  const auto density = field(b, "Density").data().values<T>();
  const auto momentum = field(b, "Momentum").data().values<T>();
  const auto energy = field(b, "StagnationEnergy").data().values<T>();
  const auto pressure = field(b, "Pressure").data().values<T>();
  const auto temperature = field(b, "Temperature").data().values<T>();
  const auto velocity = field(b, "Velocity").data().values<T>();
  const auto speed = field(b, "VelocityMagnitude").data().values<T>();
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(density[i], T(want.rho[i])) << i;
    ASSERT_EQ(momentum[3 * i], T(want.mx[i])) << i;
    ASSERT_EQ(momentum[3 * i + 1], T(want.my[i])) << i;
    ASSERT_EQ(momentum[3 * i + 2], T(want.mz[i])) << i;
    ASSERT_EQ(energy[i], T(want.energy[i])) << i;
    const double r = want.rho[i], u = want.mx[i] / r, v = want.my[i] / r, w = want.mz[i] / r;
    const double p = 0.4 * (want.energy[i] - 0.5 * r * (u * u + v * v + w * w));
    const double tol = 1e-5 * (1 + std::abs(p));
    ASSERT_NEAR(pressure[i], p, tol) << i;
    ASSERT_NEAR(temperature[i], p / r, tol) << i;
    ASSERT_NEAR(velocity[3 * i], u, 1e-6) << i;
    ASSERT_NEAR(velocity[3 * i + 1], v, 1e-6) << i;
    ASSERT_NEAR(velocity[3 * i + 2], w, 1e-6) << i;
    ASSERT_NEAR(speed[i], std::sqrt(u * u + v * v + w * w), 1e-5) << i;
  }
}

TEST_P(Plot3dLayout, ReadsBackWhatWasWritten) {
  const Spec s = spec();
  const std::vector<SynthBlock> want = blocks();
  ScratchDir dir;
  const std::string xyz = dir.file("grid.xyz"), q = dir.file("sol.q");
  write_file(xyz, grid_bytes(s, want));
  write_file(q, q_bytes(s, want));

  const Dataset ds = read_plot3d(xyz, q);
  std::string layout = std::string(s.big ? "big-endian" : "little-endian") +
                       (s.fortran ? ", Fortran records" : ", C binary") +
                       (s.multi ? ", multi-block (2 blocks)" : ", single block") +
                       (s.iblank ? ", IBLANK" : ", no IBLANK") + (s.precision == 4 ? ", float32" : ", float64");
  char header[128];
  std::snprintf(header, sizeof header, "; q: fsmach=%g alpha=%g re=%g time=%g", want[0].qheader[0], want[0].qheader[1],
                want[0].qheader[2], want[0].qheader[3]);
  EXPECT_EQ(ds.format, "PLOT3D (" + layout + ")" + header);
  EXPECT_EQ(ds.sources, (std::vector<std::string>{xyz, q}));
  ASSERT_EQ(ds.blocks.size(), want.size());
  for (size_t bi = 0; bi < want.size(); ++bi) {
    SCOPED_TRACE("block " + std::to_string(bi));
    const Block& b = ds.blocks[bi];
    const SynthBlock& w = want[bi];
    EXPECT_EQ(b.name, "block " + std::to_string(bi));
    const StructuredGrid& g = grid(b);
    EXPECT_EQ(g.dims.points, (std::array<uint32_t, 3>{uint32_t(w.dims[0]), uint32_t(w.dims[1]), uint32_t(w.dims[2])}));
    ASSERT_EQ(g.points.size(), w.n());
    for (size_t i = 0; i < w.n(); ++i) {
      ASSERT_EQ(g.points[i], (Vec3f{float(w.x[i]), float(w.y[i]), float(w.z[i])})) << i;
    }
    if (s.iblank) {
      EXPECT_EQ(g.iblank, w.iblank);
    } else {
      EXPECT_FALSE(g.has_iblank());
    }
    if (s.precision == 4) {
      expect_q_fields<float>(b, w);
    } else {
      expect_q_fields<double>(b, w);
    }
  }
  // Block 1 of the multi-block files has its own Q header, which the format line cannot show.
  EXPECT_EQ(ds.warnings.size(), s.multi ? 1u : 0u);
}

TEST_P(Plot3dLayout, GridOnly) {
  const Spec s = spec();
  const std::vector<SynthBlock> want = blocks();
  ScratchDir dir;
  const std::string xyz = dir.file("grid.xyz");
  write_file(xyz, grid_bytes(s, want));
  const Dataset ds = read_plot3d(xyz, "");
  EXPECT_EQ(ds.format.find("; q:"), std::string::npos);
  ASSERT_EQ(ds.blocks.size(), want.size());
  for (size_t bi = 0; bi < want.size(); ++bi) {
    EXPECT_TRUE(ds.blocks[bi].fields.empty());
    EXPECT_EQ(grid(ds.blocks[bi]).points.back(),
              (Vec3f{float(want[bi].x.back()), float(want[bi].y.back()), float(want[bi].z.back())}));
    EXPECT_EQ(grid(ds.blocks[bi]).has_iblank(), s.iblank);
  }
}

// A grid file cut short anywhere fails cleanly, except where the prefix is itself a complete file of another layout
// (a C file cut after Z reads as the same grid without IBLANK, a multi-block C file cut after a few hundred bytes as a
// single block of dims nblocks x ni x nj): sizes are all PLOT3D has. It never reads as the layout it was written in,
// and a Fortran file, whose header markers mark it as Fortran, is never taken for a C file.
TEST_P(Plot3dLayout, EveryTruncatedGridFails) {
  const Spec s = spec();
  const std::string full = grid_bytes(s, blocks());
  ScratchDir dir;
  const std::string xyz = dir.file("cut.xyz");
  write_file(xyz, full);
  const std::string full_format = read_plot3d(xyz, "").format;
  size_t failures = 0;
  for (size_t len = 0; len < full.size(); ++len) {
    write_file(xyz, full.substr(0, len));
    try {
      const Dataset ds = read_plot3d(xyz, "");
      EXPECT_FALSE(s.fortran) << "prefix of " << len << " bytes read as " << ds.format;
      EXPECT_NE(ds.format, full_format) << len;
    } catch (const Error& e) {
      ++failures;
      ASSERT_NE(std::string(e.what()).find("cut.xyz"), std::string::npos) << e.what();
    }
  }
  // At most one coincidental reading per other C layout (7).
  EXPECT_GE(failures, full.size() - (s.fortran ? 0 : 7));
}

std::string layout_param_name(const ::testing::TestParamInfo<LayoutParam>& info) {
  const auto [big, fortran, multi, precision, iblank] = info.param;
  return std::string(big ? "Big" : "Little") + (fortran ? "Fortran" : "Raw") + (multi ? "Multi" : "Single") +
         (precision == 4 ? "F32" : "F64") + (iblank ? "Iblank" : "NoIblank");
}

INSTANTIATE_TEST_SUITE_P(AllLayouts, Plot3dLayout,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool(), ::testing::Bool(),
                                            ::testing::Values(4, 8), ::testing::Bool()),
                         layout_param_name);

// ---- Derived values ----

TEST(Plot3dReader, ZeroDensityGivesZeroDerivedValuesNotNaN) {
  SynthBlock b = make_block({2, 2, 2}, 0);
  b.rho[3] = 0;
  b.mx[3] = 1;  // momentum without mass: VTK would divide by a substituted density of 1
  const Spec s;
  ScratchDir dir;
  write_file(dir.file("g.xyz"), grid_bytes(s, {b}));
  write_file(dir.file("g.q"), q_bytes(s, {b}));
  const Dataset ds = read_plot3d(dir.file("g.xyz"), dir.file("g.q"));
  const Block& blk = ds.blocks[0];
  for (const char* name : {"Pressure", "Temperature", "Velocity", "VelocityMagnitude"}) {
    const Field& f = field(blk, name);
    EXPECT_EQ(f.range(f.components() > 1 ? 0 : kMagnitude).nan_count, 0u) << name;
    for (int c = 0; c < f.components(); ++c) EXPECT_EQ(f.data().get(3, c), 0.0) << name;
  }
  EXPECT_EQ(field(blk, "Momentum").data().get(3, 0), 1.0);
  EXPECT_NE(field(blk, "Pressure").data().get(2, 0), 0.0);  // its neighbours are computed
}

TEST(Plot3dReader, KnownDerivedValues) {
  SynthBlock b = make_block({1, 1, 2}, 0);
  // rho 2, m (2, 4, 4) -> v (1, 2, 2), |v| 3; E 20 -> p = 0.4 (20 - 0.5 * 2 * 9) = 4.4, T = 2.2.
  b.rho = {2, 2};
  b.mx = {2, 2};
  b.my = {4, 4};
  b.mz = {4, 4};
  b.energy = {20, 20};
  const Spec s{.big = false, .precision = 8};
  ScratchDir dir;
  write_file(dir.file("g.xyz"), grid_bytes(s, {b}));
  write_file(dir.file("g.q"), q_bytes(s, {b}));
  const Block blk = read_plot3d(dir.file("g.xyz"), dir.file("g.q")).blocks[0];
  EXPECT_DOUBLE_EQ(field(blk, "Pressure").data().get(0, 0), 4.4);
  EXPECT_DOUBLE_EQ(field(blk, "Temperature").data().get(0, 0), 2.2);
  EXPECT_DOUBLE_EQ(field(blk, "VelocityMagnitude").data().get(1, 0), 3.0);
  EXPECT_DOUBLE_EQ(field(blk, "Velocity").data().get(1, 2), 2.0);
}

// ---- Padding, ambiguity ----

TEST(Plot3dReader, TrailingBytesAfterSolutionAreWarned) {
  const std::vector<SynthBlock> bs{make_block({2, 3, 2}, 0)};
  const Spec s;
  ScratchDir dir;
  write_file(dir.file("g.xyz"), grid_bytes(s, bs));
  write_file(dir.file("g.q"), q_bytes(s, bs) + std::string(100, '\0') + "x");
  const Dataset ds = read_plot3d(dir.file("g.xyz"), dir.file("g.q"));
  ASSERT_EQ(ds.warnings.size(), 1u);
  EXPECT_NE(ds.warnings[0].find("101 trailing bytes"), std::string::npos) << ds.warnings[0];
  EXPECT_NE(ds.warnings[0].find("not all zero"), std::string::npos) << ds.warnings[0];
  EXPECT_EQ(field(ds.blocks[0], "Density").data().get(11, 0), bs[0].rho[11]);
}

// A 1x1x1 multi-block float32 grid (28 bytes: 1 | 1 1 1 | x y z) is byte for byte also a valid single-block grid of
// dims 1x1x1 with IBLANK (1 1 1 | x y z iblank). Alone it is refused; the solution file settles it.
TEST(Plot3dReader, AmbiguousTinyGridNeedsTheSolutionFile) {
  const std::vector<SynthBlock> bs{make_block({1, 1, 1}, 0)};
  const Spec multi{.multi = true};
  ScratchDir dir;
  write_file(dir.file("tiny.xyz"), grid_bytes(multi, bs));
  ASSERT_EQ(grid_bytes(multi, bs).size(), 28u);
  const std::string msg = error_of([&] { read_plot3d(dir.file("tiny.xyz"), ""); });
  EXPECT_NE(msg.find("tiny.xyz"), std::string::npos) << msg;
  EXPECT_NE(msg.find("ambiguous"), std::string::npos) << msg;
  EXPECT_NE(msg.find("multi-block (1 block)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("single block, IBLANK"), std::string::npos) << msg;

  write_file(dir.file("tiny.q"), q_bytes(multi, bs));
  const Dataset ds = read_plot3d(dir.file("tiny.xyz"), dir.file("tiny.q"));
  EXPECT_NE(ds.format.find("multi-block (1 block), no IBLANK"), std::string::npos) << ds.format;
  EXPECT_EQ(field(ds.blocks[0], "StagnationEnergy").data().get(0, 0), bs[0].energy[0]);
}

// ---- Malformed input ----

class Plot3dMalformed : public ::testing::Test {
 protected:
  void SetUp() override {
    blocks_ = {make_block({3, 4, 2}, 0), make_block({2, 2, 3}, 1)};
    write_file(xyz(), grid_bytes(spec_, blocks_));
    write_file(q(), q_bytes(spec_, blocks_));
  }
  std::string xyz() const { return dir_.file("grid.xyz"); }
  std::string q() const { return dir_.file("sol.q"); }
  // Error message of reading (xyz, q); also checks it names the file it blames.
  std::string fails(const std::string& blamed) {
    const std::string msg = error_of([&] { read_plot3d(xyz(), q()); });
    EXPECT_NE(msg.find(blamed), std::string::npos) << msg;
    return msg;
  }

  ScratchDir dir_;
  Spec spec_{.fortran = true, .multi = true};
  std::vector<SynthBlock> blocks_;
};

TEST_F(Plot3dMalformed, ValidFilesRead) { EXPECT_EQ(read_plot3d(xyz(), q()).point_count(), 24u + 12u); }

TEST_F(Plot3dMalformed, TruncatedGrid) {
  write_file(xyz(), grid_bytes(spec_, blocks_).substr(0, 200));
  const std::string msg = fails("grid.xyz");
  EXPECT_NE(msg.find("no binary layout implies its size of 200 bytes"), std::string::npos) << msg;
  // It says what the header implied.
  EXPECT_NE(msg.find("big-endian, Fortran records, multi-block: 2 blocks with 36 points"), std::string::npos) << msg;
}

TEST_F(Plot3dMalformed, TruncatedSolution) {
  const std::string full = q_bytes(spec_, blocks_);
  write_file(q(), full.substr(0, full.size() - 10));
  const std::string msg = fails("sol.q");
  EXPECT_NE(msg.find("byte "), std::string::npos) << msg;
  EXPECT_NE(msg.find("the file ends"), std::string::npos) << msg;
}

TEST_F(Plot3dMalformed, SolutionDimsDifferFromGrid) {
  std::vector<SynthBlock> other = blocks_;
  other[1] = make_block({2, 2, 4}, 1);
  write_file(q(), q_bytes(spec_, other));
  const std::string msg = fails("sol.q");
  EXPECT_NE(msg.find("grid.xyz"), std::string::npos) << msg;
  EXPECT_NE(msg.find("block 1 has dimensions 2x2x4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("2x2x3"), std::string::npos) << msg;
}

TEST_F(Plot3dMalformed, SolutionBlockCountDiffers) {
  write_file(q(), q_bytes(spec_, {blocks_[0]}));
  const std::string msg = fails("sol.q");
  EXPECT_NE(msg.find("block count 1, but grid file grid.xyz has 2"), std::string::npos) << msg;
}

TEST_F(Plot3dMalformed, SolutionInAnotherByteOrder) {
  Spec little = spec_;
  little.big = false;
  write_file(q(), q_bytes(little, blocks_));
  const std::string msg = fails("sol.q");
  EXPECT_NE(msg.find("Fortran record marker"), std::string::npos) << msg;
}

TEST_F(Plot3dMalformed, CorruptGridRecordMarker) {
  std::string bytes = grid_bytes(spec_, blocks_);
  bytes[bytes.size() - 1] ^= 1;  // the closing marker of the last block
  write_file(xyz(), bytes);
  const std::string msg = fails("grid.xyz");
  EXPECT_NE(msg.find("the size matches but Fortran record marker at byte " + std::to_string(bytes.size() - 4)),
            std::string::npos)
      << msg;
}

TEST_F(Plot3dMalformed, CorruptSolutionRecordMarker) {
  std::string bytes = q_bytes(spec_, blocks_);
  const size_t at = 4 + 4 + 4 + 4 + 24 + 4;  // block 0's header record marker, after [2] and [dims]
  bytes[at + 3] ^= 8;
  write_file(q(), bytes);
  const std::string msg = fails("sol.q");
  EXPECT_NE(msg.find("byte " + std::to_string(at) + ": Fortran record marker is 24, expected 16"), std::string::npos)
      << msg;
}

TEST_F(Plot3dMalformed, AbsurdDimensions) {
  Bytes b(true);
  for (int32_t d : {100000, 100000, 100000}) b.i32(d);
  for (int i = 0; i < 64; ++i) b.real(1.0, 4);
  write_file(xyz(), b.str());
  const std::string msg = fails("grid.xyz");
  EXPECT_NE(msg.find("dims 100000x100000x100000"), std::string::npos) << msg;

  Bytes huge(false);  // 2^31-1 cubed overflows 64 bits
  for (int i = 0; i < 3; ++i) huge.i32(INT32_MAX);
  huge.i32(0);
  write_file(xyz(), huge.str());
  EXPECT_NE(fails("grid.xyz").find("more than 2^64"), std::string::npos);
}

TEST_F(Plot3dMalformed, NegativeDimensions) {
  Bytes b(true);
  for (int32_t d : {4, -3, 2}) b.i32(d);
  for (int i = 0; i < 24 * 3; ++i) b.real(0.5, 4);
  write_file(xyz(), b.str());
  const std::string msg = fails("grid.xyz");
  EXPECT_NE(msg.find("block 0 dimension j = -3 at byte 4 is not positive"), std::string::npos) << msg;
}

TEST_F(Plot3dMalformed, AbsurdBlockCount) {
  Bytes b(true);
  b.i32(1 << 30);
  for (int i = 0; i < 30; ++i) b.i32(2);
  write_file(xyz(), b.str());
  const std::string msg = fails("grid.xyz");
  EXPECT_NE(msg.find("block count 1073741824 at byte 0 is impossible"), std::string::npos) << msg;

  // Possible by size (a sparse 30 MB file), but past the cap on blocks that bounds per-block overhead.
  Bytes many(true);
  many.i32((1 << 20) + 1);
  write_file(xyz(), many.str());
  std::filesystem::resize_file(xyz(), 30u << 20);
  const std::string capped = fails("grid.xyz");
  EXPECT_NE(capped.find("block count 1048577 at byte 0 is over the limit"), std::string::npos) << capped;
}

TEST_F(Plot3dMalformed, Garbage) {
  std::mt19937 rng(12345);
  std::string bytes(4096, '\0');
  for (char& c : bytes) c = char(rng());
  write_file(xyz(), bytes);
  fails("grid.xyz");
  write_file(xyz(), grid_bytes(spec_, blocks_));
  write_file(q(), bytes);
  fails("sol.q");
}

TEST_F(Plot3dMalformed, EmptyAndMissingFiles) {
  write_file(xyz(), "");
  EXPECT_NE(fails("grid.xyz").find("size of 0 bytes"), std::string::npos);
  std::filesystem::remove(xyz());
  EXPECT_NE(fails("grid.xyz").find("cannot open"), std::string::npos);
}

// ---- Fields-only steps

using test::expect_same_bits;
using test::expect_whole_read;

// A series of `count` steps on one grid (`blocks`): step k's solution has its density, energy and time raised by k, so
// every step's values differ; step 1's block 1 has its own Q header (a warning) and step 2 trailing padding (another).
std::shared_ptr<const TimeSeries> write_series(const ScratchDir& dir, const Spec& s, std::vector<SynthBlock> blocks,
                                               int count) {
  std::vector<std::string> inputs{dir.file("grid.xyz")};
  write_file(inputs[0], grid_bytes(s, blocks));
  for (int k = 0; k < count; ++k) {
    std::vector<SynthBlock> step = blocks;
    for (SynthBlock& b : step) {
      for (double& v : b.rho) v += k;
      for (double& v : b.energy) v += 2.0 * k;
      b.qheader = {2.5, 0.5, 1000.0, 7.25 + k};  // one header for every block
    }
    if (k == 1 && step.size() > 1) step[1].qheader[0] += 1;
    inputs.push_back(dir.file("sol_" + std::to_string(k) + ".q"));
    write_file(inputs.back(), q_bytes(s, step) + (k == 2 ? std::string(64, '\0') : std::string()));
  }
  return std::make_shared<const TimeSeries>(list_time_steps(inputs));
}

// A grid rewritten as garbage of its own size, its time stamp put back: its mesh key stays, a whole read fails.
void spoil_keeping_size_and_time(const std::string& path) {
  const auto stamp = std::filesystem::last_write_time(path);
  write_file(path, std::string(std::filesystem::file_size(path), 'x'));
  std::filesystem::last_write_time(path, stamp);
}

// Multi-block series in two layouts (float32 C binary with IBLANK, big-endian; float64 Fortran records, little-endian):
// each step's solution read alone equals the whole read bit for bit (fields, format with the step's Q header, sources,
// warnings). The grid file is then overwritten with garbage of its size and its time stamp put back: the fields-only
// reads still give the same fields (the grid is never opened) while a whole read fails on it.
TEST(Plot3dSteps, LaterStepsReadTheirSolutionAloneBitForBit) {
  for (const Spec& s : {Spec{.big = true, .multi = true, .iblank = true},
                        Spec{.big = false, .fortran = true, .multi = true, .precision = 8}}) {
    SCOPED_TRACE(s.precision == 4 ? "float32 C IBLANK" : "float64 Fortran");
    ScratchDir dir;
    const auto series = write_series(dir, s, {make_block({3, 4, 2}, 0), make_block({2, 3, 5}, 1)}, 3);
    ASSERT_EQ(series->kind, SeriesKind::Plot3d);
    StepFieldReader reader(series);
    reader.read_whole(0);
    const auto k0 = reader.geometry_keys(0);
    ASSERT_TRUE(k0.has_value());
    EXPECT_EQ(reader.geometry_keys(2), k0);
    EXPECT_TRUE(reader.has_mesh_of(2, 0));
    for (size_t k : {2u, 1u, 0u}) expect_whole_read(*series, reader.read(k), k);
    EXPECT_EQ(reader.read(1).warnings.size(), 1u) << "block 1's own Q header";
    EXPECT_EQ(reader.read(2).warnings.size(), 1u) << "the padding";

    std::vector<StepFields> before;
    for (size_t k = 0; k < 3; ++k) before.push_back(reader.read(k));
    spoil_keeping_size_and_time(series->source);
    EXPECT_EQ(reader.geometry_keys(1), k0);
    for (size_t k = 0; k < 3; ++k) {
      const StepFields after = reader.read(k);
      ASSERT_EQ(after.blocks.size(), 2u);
      for (size_t b = 0; b < 2; ++b) expect_same_bits(after.blocks[b], before[k].blocks[b]);
      EXPECT_EQ(after.format, before[k].format);
    }
    EXPECT_NE(error_of([&] { read_time_step(*series, 1); }).find("grid.xyz"), std::string::npos)
        << "the whole read opens the grid";
  }
}

// Through the exact scene: every switch swaps the fields on the walk mesh built once, the values those of a scene made
// from the step alone; a prefetched step too.
TEST(Plot3dSteps, TheSceneSwitchesStepsFieldsOnly) {
  ScratchDir dir;
  const auto series = write_series(dir, Spec{.multi = true}, {make_block({4, 3, 3}, 0), make_block({3, 3, 4}, 1)}, 3);
  ExactScene scene(series, 0);
  scene.bind("Density");
  for (uint32_t k : {2u, 1u}) {
    scene.set_step(k);
    ExactScene fresh(std::make_shared<const Dataset>(read_time_step(*series, k)));
    fresh.bind("Density");
    EXPECT_EQ(scene.engine.bound_values(), fresh.engine.bound_values()) << k;
  }
  scene.prefetch(0);
  scene.set_step(0);
  EXPECT_EQ(scene.fields_only, 3u);
  EXPECT_EQ(scene.rebuilds, 0u);
}

// A truncated .q file: the fields-only read fails with the whole read's error (naming the file and the offset), and a
// switch to it leaves the scene on its step. A tiny grid whose layout only the solution decided keeps no layout: its
// steps are read whole (a spoiled grid then fails them).
TEST(Plot3dSteps, ATruncatedSolutionFailsAsTheWholeReadAndAnAmbiguousGridReadsWhole) {
  ScratchDir dir;
  const auto series = write_series(dir, Spec{.fortran = true, .multi = true}, {make_block({3, 2, 2}, 0)}, 3);
  const std::string q1 = series->steps[1].files[1];
  StepFieldReader reader(series);
  reader.read_whole(0);
  std::filesystem::resize_file(q1, std::filesystem::file_size(q1) - 10);
  const std::string whole = error_of([&] { read_time_step(*series, 1); });
  EXPECT_NE(whole.find("sol_1.q"), std::string::npos) << whole;
  EXPECT_EQ(error_of([&] { reader.read(1); }), whole);
  ExactScene scene(series, 0);
  EXPECT_EQ(error_of([&] { scene.set_step(1); }), whole);
  EXPECT_EQ(scene.step, 0u);
  scene.set_step(2);
  EXPECT_EQ(scene.fields_only, 1u);

  ScratchDir tiny_dir;
  const auto tiny = write_series(tiny_dir, Spec{.multi = true}, {make_block({1, 1, 1}, 0)}, 2);
  StepFieldReader tiny_reader(tiny);
  tiny_reader.read_whole(0);
  expect_whole_read(*tiny, tiny_reader.read(1), 1);
  spoil_keeping_size_and_time(tiny->source);
  EXPECT_NE(error_of([&] { tiny_reader.read(1); }).find("grid.xyz"), std::string::npos);
}

}  // namespace
}  // namespace ugvr
