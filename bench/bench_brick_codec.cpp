// Brick codec candidates on realistic bricks: compression ratio, encode and decode speed, accuracy.
//   bench_brick_codec [R=32] [BRICKS_PER_SET=60] [--json] [--only=SUBSTRING] [--store=FLOAT32_STORE.ugvr]
// Four sets of R³ bricks are synthesized from a flow-like field on [0, 1]³ (a shear layer, vortex cores, six octaves
// of Kolmogorov-scaled waves), at octree levels 3 to 7 like the nodes of an adaptive tree:
//   smooth   the analytic field sampled exactly;
//   mesh-8   the field as a voxelizer sees it: the piecewise-linear interpolant of values on a lattice of "cells"
//            8 voxels wide (kinks at every cell face, as a mesh's linear interpolant has). Typical of the paper's
//            trees: the blunt fin's 22,208 nodes of 32³ hold 727M voxels for 40,960 grid points, so most bricks
//            over-resolve the mesh by far;
//   mesh-1.5 the same with cells of 1.5 voxels: a brick at the mesh's own resolution, the hard case;
//   noisy    mesh-1.5 + white noise of 1e-4 of the field range (unresolved fluctuations, solver noise): pessimistic;
//   partial  mesh-1.5 bricks straddling the surface of a body (a sphere, no data inside), masked.
// Each candidate encoding is run over every set: ratio = float32 bytes / block bytes (headers included), speeds in
// MB/s of float32 samples per second of the thread's CPU time (single thread, fastest of 5 timed runs), max error
// relative to the field's range.
// Then the chosen default is timed through the store (BrickStoreReader::read_brick: pread + crc32 + decode).
// With --store, the bricks are a real store's instead (build it with `ugvr build ... --float32` so they are the
// voxelizer's exact samples; BRICKS_PER_SET of them, evenly spread, go through the candidates), and the whole store
// is rewritten with the default encoding to give its size per node.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ugvr/store/brick_codec.h"
#include "ugvr/store/brick_store.h"

using namespace ugvr;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Wave {
  Vec3d k;
  double phase, amp;
};

// The flow-like field: O(1) large-scale structure and features down to ~1/500 of the domain.
class FlowField {
 public:
  explicit FlowField(uint32_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (int octave = 0; octave < 6; ++octave) {
      for (int w = 0; w < 4; ++w) {
        const double z = 2 * u(rng) - 1, phi = 2 * kPi * u(rng), s = std::sqrt(1 - z * z);
        const double k = 2 * kPi * 3 * std::pow(2.0, octave);
        waves_.push_back({{k * s * std::cos(phi), k * s * std::sin(phi), k * z},
                          2 * kPi * u(rng),
                          0.08 * std::pow(2.0, -octave / 3.0)});
      }
    }
    for (int v = 0; v < 12; ++v) cores_.push_back({u(rng), u(rng), u(rng)});
  }
  double operator()(const Vec3d& p) const {
    double f = std::tanh(6 * (p.y - 0.5 - 0.1 * std::sin(2 * kPi * p.x))) + 0.3 * p.x;
    for (const Vec3d& c : cores_) {
      const Vec3d d = p - c;
      f -= 0.8 * std::exp(-dot(d, d) / (2 * 0.03 * 0.03));
    }
    for (const Wave& w : waves_) f += w.amp * std::sin(dot(w.k, p) + w.phase);
    return f;
  }

 private:
  std::vector<Wave> waves_;
  std::vector<Vec3d> cores_;
};

struct Brick {
  std::vector<float> samples;
  std::vector<uint8_t> mask;  // empty: all valid
};

struct Set {
  std::string name;
  std::vector<Brick> bricks;
};

const Vec3d kBody{0.5, 0.5, 0.5};
constexpr double kBodyRadius = 0.3;

// One brick of node (level, i, j, k): exact, or piecewise linear over a lattice of `lattice` voxels.
Brick make_brick(const FlowField& f, uint32_t r, int level, Vec3d lo, double lattice, double noise, bool masked,
                 std::mt19937_64& rng) {
  const double cell = std::ldexp(1.0, -level), h = cell / (r - 1);
  Brick b;
  b.samples.resize(size_t(r) * r * r);
  std::normal_distribution<double> gauss(0, noise);
  const double off = std::uniform_real_distribution<double>(0, 1)(rng);  // lattice not aligned with the voxels
  auto lattice_value = [&](int64_t a, int64_t bb, int64_t c) {
    const double hl = h * lattice;
    return f(Vec3d{(double(a) + off) * hl, (double(bb) + off) * hl, (double(c) + off) * hl});
  };
  size_t s = 0;
  for (uint32_t z = 0; z < r; ++z) {
    for (uint32_t y = 0; y < r; ++y) {
      for (uint32_t x = 0; x < r; ++x, ++s) {
        const Vec3d p = lo + Vec3d{x * h, y * h, z * h};
        double v;
        if (lattice <= 0) {
          v = f(p);
        } else {
          const double hl = h * lattice;
          const Vec3d g{p.x / hl - off, p.y / hl - off, p.z / hl - off};
          const int64_t a = int64_t(std::floor(g.x)), bb = int64_t(std::floor(g.y)), c = int64_t(std::floor(g.z));
          const double tx = g.x - a, ty = g.y - bb, tz = g.z - c;
          v = 0;
          for (int corner = 0; corner < 8; ++corner) {
            const int dx = corner & 1, dy = corner >> 1 & 1, dz = corner >> 2 & 1;
            v += (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz) * lattice_value(a + dx, bb + dy, c + dz);
          }
        }
        if (noise > 0) v += gauss(rng);
        b.samples[s] = float(v);
      }
    }
  }
  if (masked) {
    b.mask.resize(b.samples.size());
    s = 0;
    for (uint32_t z = 0; z < r; ++z) {
      for (uint32_t y = 0; y < r; ++y) {
        for (uint32_t x = 0; x < r; ++x, ++s) {
          b.mask[s] = length(lo + Vec3d{x * h, y * h, z * h} - kBody) >= kBodyRadius;
        }
      }
    }
  }
  return b;
}

std::vector<Set> make_sets(uint32_t r, int per_set, double field_range) {
  const FlowField f(7);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Set> sets = {{"smooth", {}}, {"mesh-8", {}}, {"mesh-1.5", {}}, {"noisy", {}}, {"partial", {}}};
  for (int n = 0; n < per_set; ++n) {
    const int level = 3 + n % 5;
    const double cell = std::ldexp(1.0, -level);
    const int64_t cells = int64_t(1) << level;
    auto random_corner = [&] {
      return Vec3d{double(int64_t(u(rng) * cells)) * cell, double(int64_t(u(rng) * cells)) * cell,
                   double(int64_t(u(rng) * cells)) * cell};
    };
    sets[0].bricks.push_back(make_brick(f, r, level, random_corner(), 0, 0, false, rng));
    sets[1].bricks.push_back(make_brick(f, r, level, random_corner(), 8, 0, false, rng));
    sets[2].bricks.push_back(make_brick(f, r, level, random_corner(), 1.5, 0, false, rng));
    sets[3].bricks.push_back(make_brick(f, r, level, random_corner(), 1.5, 1e-4 * field_range, false, rng));
    // A cell the body's surface crosses: from a random point on the sphere.
    Vec3d lo;
    for (;;) {
      const double z = 2 * u(rng) - 1, phi = 2 * kPi * u(rng), s = std::sqrt(1 - z * z);
      const Vec3d p = kBody + Vec3d{s * std::cos(phi), s * std::sin(phi), z} * kBodyRadius;
      lo = Vec3d{std::floor(p.x / cell) * cell, std::floor(p.y / cell) * cell, std::floor(p.z / cell) * cell};
      Brick b = make_brick(f, r, level, lo, 1.5, 0, true, rng);
      const size_t valid = size_t(std::count(b.mask.begin(), b.mask.end(), 1));
      if (valid > 0 && valid < b.mask.size()) {
        sets[4].bricks.push_back(std::move(b));
        break;
      }
    }
  }
  return sets;
}

struct Candidate {
  std::string name;
  BrickEncoding enc;
  bool brick_range = false;  // Quant16 against each brick's own range instead of the field's
};

// The calling thread's CPU time: the machines are shared, and wall time would count other processes' turns.
double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// CPU seconds per pass of fn over all bricks: the fastest of 5 timed runs of at least 0.1 s each.
template <class F>
double time_passes(F&& fn) {
  double best = INFINITY;
  for (int rep = 0; rep < 5; ++rep) {
    int passes = 0;
    const double t0 = thread_seconds();
    do {
      fn();
      ++passes;
    } while (thread_seconds() - t0 < 0.1);
    best = std::min(best, (thread_seconds() - t0) / passes);
  }
  return best;
}

struct Result {
  double ratio, bytes_per_brick, encode_mbs, decode_mbs, max_rel_error;
};

Result run(const Candidate& c, const Set& set, uint32_t r, double field_min, double field_range) {
  const size_t n = size_t(r) * r * r;
  const double step = c.brick_range ? 0.0 : 2 * kQuant16Tolerance * field_range;
  std::vector<EncodedBlock> blocks(set.bricks.size());
  const double enc_s = time_passes([&] {
    for (size_t b = 0; b < set.bricks.size(); ++b) {
      const Brick& br = set.bricks[b];
      blocks[b] =
          encode_brick(c.enc, r, br.samples.data(), br.mask.empty() ? nullptr : br.mask.data(), step, field_min);
    }
  });
  std::vector<float> out(n);
  std::vector<uint8_t> mask(n);
  const double dec_s = time_passes([&] {
    for (const EncodedBlock& b : blocks) decode_brick(b.bytes, r, out.data(), mask.data(), "bench", 0);
  });
  double bytes = 0, worst = 0;
  for (size_t b = 0; b < blocks.size(); ++b) {
    bytes += double(blocks[b].bytes.size());
    decode_brick(blocks[b].bytes, r, out.data(), nullptr, "bench", 0);
    const Brick& br = set.bricks[b];
    for (size_t s = 0; s < n; ++s) {
      if (br.mask.empty() || br.mask[s]) worst = std::max(worst, std::abs(double(out[s]) - br.samples[s]));
    }
  }
  const double raw = double(n) * 4 * double(blocks.size());
  return {raw / bytes, bytes / double(blocks.size()), raw / enc_s / 1e6, raw / dec_s / 1e6, worst / field_range};
}

// A real store's bricks (field 0) as a set: `ugvr build ... --float32` keeps the voxelizer's exact samples. At most
// max_bricks of them, evenly spread over the node ids, so the candidates' passes fit in memory.
Set load_store_set(const BrickStoreReader& store, size_t max_bricks) {
  std::vector<uint64_t> ids;
  for (uint64_t id = 0; id < store.node_count(); ++id) {
    if (store.node(id).has_brick()) ids.push_back(id);
  }
  const size_t stride = std::max<size_t>(1, (ids.size() + max_bricks - 1) / max_bricks);
  const size_t n = size_t(store.resolution()) * store.resolution() * store.resolution();
  Set set{std::filesystem::path(store.path()).stem().string(), {}};
  for (size_t i = 0; i < ids.size(); i += stride) {
    Brick b;
    b.samples.resize(n);
    b.mask.resize(n);
    store.read_brick(ids[i], 0, b.samples.data(), b.mask.data());
    if (std::all_of(b.mask.begin(), b.mask.end(), [](uint8_t m) { return m != 0; })) b.mask.clear();
    set.bricks.push_back(std::move(b));
  }
  return set;
}

// Times read_brick (pread + crc32 + decode) over every node of a store in the page cache and prints its size per
// node against the paper's.
void report_store(const std::string& path, const std::string& what, bool json) {
  const BrickStoreReader store(path);
  const uint32_t r = store.resolution();
  std::vector<float> out(size_t(r) * r * r);
  std::vector<uint8_t> mask(out.size());
  uint64_t bricks = 0;
  for (uint64_t id = 0; id < store.node_count(); ++id) bricks += store.node(id).has_brick();
  const double s = time_passes([&] {
    for (uint64_t id = 0; id < store.node_count(); ++id) {
      if (store.node(id).has_brick()) store.read_brick(id, 0, out.data(), mask.data());
    }
  });
  const double per_node = double(store.file_size()) / double(store.node_count());
  const double paper = 3002e6 / 22208;  // Leven et al. 2002, blunt fin: 3,002 MB for 22,208 nodes of 32³
  const double mbs = double(out.size()) * 4 * double(bricks) / s / 1e6;
  if (json) {
    std::printf(
        "{\"bench\":\"brick_store_read\",\"store\":\"%s\",\"r\":%u,\"nodes\":%llu,\"file_bytes\":%llu,"
        "\"bytes_per_node\":%.0f,\"read_brick_mbs\":%.1f,\"read_brick_us\":%.1f,\"paper_bytes_per_node\":%.0f}\n",
        what.c_str(), r, (unsigned long long)store.node_count(), (unsigned long long)store.file_size(), per_node, mbs,
        s / double(bricks) * 1e6, paper);
  } else {
    std::printf(
        "\nstore (%s, default encoding, %llu nodes): %.0f bytes/node incl. header and node table; read_brick %.0f MB/s "
        "= %.1f us/brick (single thread, page cache)\npaper: %.0f bytes/node -> %.1fx smaller\n",
        what.c_str(), (unsigned long long)store.node_count(), per_node, mbs, s / double(bricks) * 1e6, paper,
        paper / per_node);
  }
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t r = 32;
  int per_set = 60;
  bool json = false;
  std::string only;   // run the candidates whose name contains it
  std::string input;  // a float32 store to take the bricks from instead of the synthetic sets
  int positional = 0;
  for (int a = 1; a < argc; ++a) {
    if (std::strcmp(argv[a], "--json") == 0) {
      json = true;
    } else if (std::strncmp(argv[a], "--only=", 7) == 0) {
      only = argv[a] + 7;
    } else if (std::strncmp(argv[a], "--store=", 8) == 0) {
      input = argv[a] + 8;
    } else if (positional++ == 0) {
      r = uint32_t(std::strtoul(argv[a], nullptr, 10));
    } else {
      per_set = std::atoi(argv[a]);
    }
  }

  std::vector<Set> sets;
  double fmin = INFINITY, fmax = -INFINITY, range = 0;
  std::unique_ptr<BrickStoreReader> source;
  if (!input.empty()) {
    source = std::make_unique<BrickStoreReader>(input);
    r = source->resolution();
    fmin = source->layout().fields[0].min;
    range = source->layout().fields[0].max - fmin;
    sets.push_back(load_store_set(*source, size_t(per_set)));
  } else {
    // The field's global range, from a dense sampling of the domain (the builder takes it from the dataset).
    const FlowField f(7);
    for (int z = 0; z <= 96; ++z) {
      for (int y = 0; y <= 96; ++y) {
        for (int x = 0; x <= 96; ++x) {
          const double v = f(Vec3d{x / 96.0, y / 96.0, z / 96.0});
          fmin = std::min(fmin, v);
          fmax = std::max(fmax, v);
        }
      }
    }
    range = (fmax - fmin) * 1.05;  // margin: the sampling above misses the sharpest extremes
    fmin -= 0.025 * (fmax - fmin);
    sets = make_sets(r, per_set, range);
  }

  using E = SampleEncoding;
  using P = Predictor;
  using C = BrickCodec;
  const std::vector<Candidate> candidates = {
      {"float32 raw", {E::Float32, P::None, false, C::Stored, 0}},
      {"float32 shuffle zstd3", {E::Float32, P::None, true, C::Zstd, 3}},
      {"float32 lorenzo shuffle lz4", {E::Float32, P::Lorenzo, true, C::Lz4, 0}},
      {"float32 lorenzo shuffle zstd3", {E::Float32, P::Lorenzo, true, C::Zstd, 3}},
      {"q16 none shuffle zstd3", {E::Quant16, P::None, true, C::Zstd, 3}},
      {"q16 delta-x shuffle zstd3", {E::Quant16, P::DeltaX, true, C::Zstd, 3}},
      {"q16 lorenzo zstd3 (no shuffle)", {E::Quant16, P::Lorenzo, false, C::Zstd, 3}},
      {"q16 lorenzo shuffle lz4", {E::Quant16, P::Lorenzo, true, C::Lz4, 0}},
      {"q16 lorenzo shuffle lz4hc9", {E::Quant16, P::Lorenzo, true, C::Lz4, 9}},
      {"q16 lorenzo shuffle zstd1", {E::Quant16, P::Lorenzo, true, C::Zstd, 1}},
      {"q16 lorenzo shuffle zstd3", {E::Quant16, P::Lorenzo, true, C::Zstd, 3}},
      {"q16 lorenzo shuffle zstd9", {E::Quant16, P::Lorenzo, true, C::Zstd, 9}},
      {"q16 lorenzo shuffle zstd19", {E::Quant16, P::Lorenzo, true, C::Zstd, 19}},
      {"q16/brick-range lorenzo shuffle zstd3", {E::Quant16, P::Lorenzo, true, C::Zstd, 3}, true},
  };

  if (!json) {
    if (source) {
      std::printf("%s: %zu of its bricks (field %s), R = %u, field range %.4g; ratio vs float32, MB/s of float32\n\n",
                  input.c_str(), sets[0].bricks.size(), source->layout().fields[0].name.c_str(), r, range);
    } else {
      std::printf("R = %u, %d bricks per set (levels 3-7), field range %.4g; ratio vs float32, MB/s of float32\n\n", r,
                  per_set, range);
    }
    std::printf("| candidate |");
    for (const Set& s : sets) std::printf(" %s ratio | %s dec MB/s |", s.name.c_str(), s.name.c_str());
    std::printf(" enc MB/s (%s) | max error / range |\n|---|", sets[std::min<size_t>(2, sets.size() - 1)].name.c_str());
    for (size_t i = 0; i < sets.size(); ++i) std::printf("---|---|");
    std::printf("---|---|\n");
  }
  for (const Candidate& c : candidates) {
    if (c.name.find(only) == std::string::npos) continue;
    std::vector<Result> res;
    for (const Set& s : sets) res.push_back(run(c, s, r, fmin, range));
    double worst = 0;
    for (const Result& x : res) worst = std::max(worst, x.max_rel_error);
    if (json) {
      for (size_t i = 0; i < sets.size(); ++i) {
        std::printf(
            "{\"bench\":\"brick_codec\",\"r\":%u,\"candidate\":\"%s\",\"set\":\"%s\",\"ratio\":%.3f,"
            "\"bytes_per_brick\":%.0f,\"encode_mbs\":%.1f,\"decode_mbs\":%.1f,\"max_rel_error\":%.3g}\n",
            r, c.name.c_str(), sets[i].name.c_str(), res[i].ratio, res[i].bytes_per_brick, res[i].encode_mbs,
            res[i].decode_mbs, res[i].max_rel_error);
      }
    } else {
      std::printf("| %s |", c.name.c_str());
      for (const Result& x : res)
        std::printf(" %.2f (%.1f KB) | %.0f |", x.ratio, x.bytes_per_brick / 1e3, x.decode_mbs);
      std::printf(" %.0f | %.2g |\n", res[std::min<size_t>(2, res.size() - 1)].encode_mbs, worst);
    }
    std::fflush(stdout);
  }

  const std::string path = std::filesystem::temp_directory_path() / ("bench_brick_codec_" + std::to_string(getpid()));
  if (source) {
    // The same tree and bricks, rewritten with the default encoding.
    BrickStoreLayout layout = source->layout();
    layout.fields.resize(1);
    layout.encoding = BrickEncoding{};
    layout.tolerance = kQuant16Tolerance;
    std::vector<OctreeNode> nodes(source->nodes().begin(), source->nodes().end());
    std::vector<FieldError> errors;
    {
      BrickStoreWriter w(path, layout);
      const size_t n = size_t(r) * r * r;
      std::vector<float> samples(n);
      std::vector<uint8_t> mask(n);
      for (uint64_t id = 0; id < source->node_count(); ++id) {
        errors.push_back({source->stats(id, 0).error_max, source->stats(id, 0).error_rms});
        if (!source->node(id).has_brick()) continue;
        source->read_brick(id, 0, samples.data(), mask.data());
        const float* fields[1] = {samples.data()};
        w.add_brick(id, fields, mask.data());
      }
      w.commit(nodes, errors);
    }
    report_store(path, sets[0].name, json);
  } else {
    // Every set's bricks as the nodes of a tree (breadth first, 8 children a node, one field), read back with
    // read_brick.
    BrickStoreLayout layout;
    layout.resolution = r;
    layout.root = Bounds{{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
    layout.data = layout.root;
    layout.fields = {{"flow", Association::Vertex, fmin, fmin + range}};
    std::vector<const Brick*> all;
    for (const Set& s : sets) {
      for (const Brick& b : s.bricks) all.push_back(&b);
    }
    std::vector<OctreeNode> nodes(1);
    for (size_t id = 0; nodes.size() < all.size(); ++id) {
      nodes[id].first_child = nodes.size();
      for (int o = 0; o < 8 && nodes.size() < all.size(); ++o) {
        OctreeNode c;
        c.parent = id;
        c.level = uint8_t(nodes[id].level + 1);
        c.i = 2 * nodes[id].i + (o & 1);
        c.j = 2 * nodes[id].j + (o >> 1 & 1);
        c.k = 2 * nodes[id].k + (o >> 2 & 1);
        nodes[id].child_mask |= uint8_t(1u << o);
        nodes.push_back(c);
      }
    }
    {
      BrickStoreWriter w(path, layout);
      for (size_t id = 0; id < all.size(); ++id) {
        const float* fields[1] = {all[id]->samples.data()};
        w.add_brick(id, fields, all[id]->mask.empty() ? nullptr : all[id]->mask.data());
      }
      w.commit(nodes);
    }
    report_store(path, "synthetic sets", json);
  }
  std::filesystem::remove(path);
  return 0;
}
