#include "ugvr/octree/coarse_preview.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <optional>

#include "ugvr/core/error.h"
#include "ugvr/grid/cell_interpolation.h"
#include "ugvr/octree/build_parts.h"
#include "ugvr/octree/cell_box_overlap.h"
#include "ugvr/octree/downsample.h"
#include "ugvr/store/brick_pad.h"

namespace ugvr {

std::unique_ptr<WeldedSoup> weld_soup_records(std::span<const std::byte> records, const SoupLayout& layout,
                                              std::span<const VtuCellSource::Slot> slots,
                                              std::span<const BrickStoreField> fields) {
  std::vector<size_t> offsets;
  std::vector<uint32_t> ids;
  for (size_t at = 0; at < records.size();) {
    const SoupCell cell(records.data() + at, layout);
    offsets.push_back(at);
    for (int i = 0; i < cell.vertex_count(); ++i) ids.push_back(cell.vertex(i));
    at += cell.bytes();
  }
  auto by_id = [&](size_t a, size_t b) {
    return SoupCell(records.data() + a, layout).id() < SoupCell(records.data() + b, layout).id();
  };
  if (!std::is_sorted(offsets.begin(), offsets.end(), by_id)) std::sort(offsets.begin(), offsets.end(), by_id);
  // The vertex ids in ascending order, and each one's local index: through a table over their range when the range
  // is not much larger than the references (a chunk of an ordered mesh: linear time), else by sorting.
  std::vector<uint32_t> local_of;
  uint32_t first = 0;
  if (!ids.empty()) {
    const auto [lo, hi] = std::minmax_element(ids.begin(), ids.end());
    first = *lo;
    const uint64_t range = uint64_t(*hi) - *lo + 1;
    if (range <= 4 * uint64_t(ids.size())) {
      local_of.assign(range, 0);
      for (uint32_t id : ids) local_of[id - first] = 1;
      ids.clear();
      for (uint64_t r = 0; r < range; ++r)
        if (local_of[r]) local_of[r] = uint32_t(ids.size()), ids.push_back(uint32_t(first + r));
    }
  }
  if (local_of.empty()) {
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  }
  auto local_index = [&](uint32_t id) {
    return local_of.empty() ? uint32_t(std::lower_bound(ids.begin(), ids.end(), id) - ids.begin())
                            : local_of[id - first];
  };
  auto out = std::make_unique<WeldedSoup>();
  UnstructuredMesh& mesh = out->mesh;
  mesh.points.resize(ids.size());
  std::vector<std::vector<float>> vertex_values(layout.vertex_fields, std::vector<float>(ids.size()));
  std::vector<std::vector<float>> cell_values(layout.cell_fields);
  uint32_t v[kMaxCellVertices];
  out->ids.reserve(offsets.size());
  for (size_t at : offsets) {
    const SoupCell cell(records.data() + at, layout);
    const int n = cell.vertex_count();
    for (int i = 0; i < n; ++i) {
      v[i] = local_index(cell.vertex(i));
      mesh.points[v[i]] = cell.position(i);
      for (uint32_t f = 0; f < layout.vertex_fields; ++f) vertex_values[f][v[i]] = cell.vertex_value(f, i);
    }
    mesh.add_cell(cell.type(), std::span<const uint32_t>(v, size_t(n)));
    for (uint32_t f = 0; f < layout.cell_fields; ++f) cell_values[f].push_back(cell.cell_value(f));
    out->ids.push_back(cell.id());
  }
  for (size_t f = 0; f < fields.size(); ++f) {
    const VtuCellSource::Slot& s = slots[f];
    std::vector<float>& values = s.association == Association::Vertex ? vertex_values[s.index] : cell_values[s.index];
    // A copy: two store fields may name the same scalar.
    out->fields.add(Field(fields[f].name, s.association, DataArray::from(std::vector<float>(values), 1)));
  }
  for (size_t f = 0; f < fields.size(); ++f) out->refs.push_back({&out->fields[f], kMagnitude});
  out->cells.resize(mesh.cell_count());
  std::iota(out->cells.begin(), out->cells.end(), uint64_t(0));
  return out;
}

uint64_t coarse_preview_brick_bytes(int depth, uint32_t resolution, uint32_t fields) {
  const uint64_t brick = uint64_t(resolution) * resolution * resolution * (4 * uint64_t(fields) + 1);
  uint64_t nodes = 0;
  for (int l = 0; l <= depth; ++l) nodes += uint64_t(1) << (3 * l);
  return nodes * brick;
}

int coarse_preview_depth_for(uint64_t memory_budget, uint32_t resolution, uint32_t fields) {
  int depth = 0;
  for (int d = 1; d <= 3; ++d)
    if (coarse_preview_brick_bytes(d, resolution, fields) <= memory_budget / 8) depth = d;
  return depth;
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// The level-K node range [lo, hi] (per axis) whose boxes, widened by `margin`, may meet [a, b] along `axis`: one node
// more on each side than the division says, so that rounding never drops one (extra nodes only cost a box test).
std::pair<uint32_t, uint32_t> node_range(const BrickLattice& lattice, int level, int axis, double a, double b) {
  const double lo = lattice.root.lo[axis], size = lattice.root.hi[axis] - lattice.root.lo[axis];
  const double n = double(uint64_t(1) << level);
  auto place = [&](double x) {
    const double t = size > 0 ? (x - lo) / size * n : 0.0;
    return std::clamp(std::floor(t), 0.0, n - 1);
  };
  return {uint32_t(std::max(place(a) - 1, 0.0)), uint32_t(std::min(place(b) + 1, n - 1))};
}

}  // namespace

uint64_t write_level_store(std::vector<std::unique_ptr<BrickSamples>> deepest, int K, const BrickStoreLayout& layout,
                           const std::string& path) {
  const uint32_t R = layout.resolution, F = uint32_t(layout.fields.size());
  const size_t level_nodes = size_t(1) << (3 * K);
  if (K < 1 || K > kMaxPreviewDepth || deepest.size() != level_nodes)
    throw Error("level store: " + std::to_string(deepest.size()) + " bricks for level " + std::to_string(K));
  // The tree: a level-K node with data, and every ancestor of one. Ids breadth first (children contiguous after
  // their parent, in octant order, as the store wants).
  std::vector<std::vector<uint8_t>> exists(size_t(K) + 1);
  for (int l = 0; l <= K; ++l) exists[size_t(l)].assign(size_t(1) << (3 * l), 0);
  auto place = [](int level, uint32_t i, uint32_t j, uint32_t k) {
    const size_t s = size_t(1) << level;
    return i + s * (j + s * k);
  };
  for (size_t n = 0; n < level_nodes; ++n) exists[size_t(K)][n] = deepest[n] != nullptr;
  for (int l = K - 1; l >= 0; --l) {
    const uint32_t s = uint32_t(1) << l;
    for (uint32_t k = 0; k < s; ++k)
      for (uint32_t j = 0; j < s; ++j)
        for (uint32_t i = 0; i < s; ++i)
          for (uint32_t o = 0; o < 8; ++o)
            exists[size_t(l)][place(l, i, j, k)] |=
                exists[size_t(l) + 1][place(l + 1, 2 * i + (o & 1), 2 * j + ((o >> 1) & 1), 2 * k + ((o >> 2) & 1))];
  }
  // A mesh with no sample at all still gets a store: its root, without brick.
  std::vector<OctreeNode> nodes(1);
  std::vector<std::vector<uint64_t>> id_of(size_t(K) + 1);
  for (int l = 0; l <= K; ++l) id_of[size_t(l)].assign(size_t(1) << (3 * l), kNoNode);
  id_of[0][0] = 0;
  if (exists[0][0]) {
    for (size_t at = 0; at < nodes.size(); ++at) {  // breadth first: nodes grows behind `at`
      const OctreeNode n = nodes[at];
      if (n.level == K) continue;
      uint8_t mask = 0;
      for (uint32_t o = 0; o < 8; ++o) {
        const uint32_t i = 2 * n.i + (o & 1), j = 2 * n.j + ((o >> 1) & 1), k = 2 * n.k + ((o >> 2) & 1);
        if (!exists[size_t(n.level) + 1][place(n.level + 1, i, j, k)]) continue;
        if (!mask) nodes[at].first_child = nodes.size();
        mask |= uint8_t(1u << o);
        OctreeNode c;
        c.parent = at, c.level = uint8_t(n.level + 1), c.i = i, c.j = j, c.k = k;
        id_of[size_t(c.level)][place(c.level, i, j, k)] = nodes.size();
        nodes.push_back(c);
      }
      nodes[at].child_mask = mask;
    }
  }

  // Bricks bottom-up, exactly as the builder makes them (a leaf padded before its parent subsamples it), written as
  // they are made; a level's bricks are dropped once the next level up has them.
  BrickStoreWriter writer(path, layout);
  std::vector<std::unique_ptr<BrickSamples>> level = std::move(deepest);
  for (size_t n = 0; n < level.size(); ++n) {
    if (!level[n]) continue;
    pad_brick(R, F, level[n]->values.data(), level[n]->mask.data());
    write_node_brick(writer, id_of[size_t(K)][n], *level[n], F);
  }
  for (int l = K - 1; l >= 0; --l) {
    const uint32_t s = uint32_t(1) << l;
    std::vector<std::unique_ptr<BrickSamples>> up(size_t(s) * s * s);
    tbb::parallel_for(size_t(0), up.size(), [&](size_t n) {
      if (!exists[size_t(l)][n]) return;
      const uint32_t i = uint32_t(n % s), j = uint32_t((n / s) % s), k = uint32_t(n / (size_t(s) * s));
      std::array<const BrickSamples*, 8> kids{};
      for (uint32_t o = 0; o < 8; ++o)
        kids[o] = level[place(l + 1, 2 * i + (o & 1), 2 * j + ((o >> 1) & 1), 2 * k + ((o >> 2) & 1))].get();
      auto b = std::make_unique<BrickSamples>();
      downsample_children(R, F, kids, *b);
      pad_brick(R, F, b->values.data(), b->mask.data());
      write_node_brick(writer, id_of[size_t(l)][n], *b, F);
      up[n] = std::move(b);
    });
    level = std::move(up);
  }
  // Errors: unknown, so the field's whole range (see the header comment).
  std::vector<FieldError> errors;
  errors.reserve(nodes.size() * F);
  for (size_t n = 0; n < nodes.size(); ++n)
    for (const BrickStoreField& f : layout.fields) {
      const float range = float(f.max - f.min);
      errors.push_back({range, range});
    }
  writer.commit(nodes, errors);
  return nodes.size();
}

CoarsePreviewStats write_coarse_preview(const std::string& soup_path, const SoupLayout& soup_layout,
                                        std::span<const VtuCellSource::Slot> slots, const BrickLattice& lattice,
                                        const BrickStoreLayout& layout, const CoarsePreviewOptions& options,
                                        const std::string& path) {
  const int K = options.depth;
  if (K < 1 || K > kMaxPreviewDepth)
    throw Error("coarse preview depth " + std::to_string(K) + " is out of range 1.." +
                std::to_string(kMaxPreviewDepth));
  if (slots.size() != layout.fields.size())
    throw Error("coarse preview: " + std::to_string(slots.size()) + " field slots for " +
                std::to_string(layout.fields.size()) + " store fields");
  const auto start = std::chrono::steady_clock::now();
  std::optional<tbb::global_control> threads;
  if (options.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));
  const uint32_t R = lattice.resolution, F = uint32_t(layout.fields.size());
  const size_t per_brick = size_t(R) * R * R;
  const uint32_t side = uint32_t(1) << K;
  const size_t level_nodes = size_t(side) * side * side;
  CoarsePreviewStats stats;
  stats.depth = K;

  // The level-K bricks, made as the first chunk reaching each node finds data there.
  std::vector<std::unique_ptr<BrickSamples>> deepest(level_nodes);
  auto new_brick = [&] {
    auto b = std::make_unique<BrickSamples>();
    b->resolution = R, b->field_count = F;
    b->values.assign(F * per_brick, 0.0f);
    b->mask.assign(per_brick, 0);
    return b;
  };
  std::atomic<uint64_t> shared{0};
  tbb::enumerable_thread_specific<BrickScratch> scratch;
  tbb::enumerable_thread_specific<BrickSamples> pieces;
  {
    // Total: the soup's records, from its size (records of one layout vary with the vertex count only: the count
    // by bytes is exact for tetrahedra, an estimate otherwise; the last report says 1 anyway).
    Progress progress("coarse preview", 1000, options.progress);
    SoupReader reader(soup_path, soup_layout);
    const std::byte* rec = nullptr;
    bool more = reader.next(rec);
    uint64_t last_id = 0;
    std::vector<std::byte> chunk;
    std::vector<std::pair<uint32_t, uint32_t>> pairs;  // (level-K node, welded cell)
    std::vector<uint32_t> offsets, entries, counts;
    // The level-K node boxes, as BrickLattice::node_box gives them (it computes lattice lines: costly per cell).
    std::vector<Bounds> node_boxes(level_nodes);
    for (uint32_t k = 0; k < side; ++k)
      for (uint32_t j = 0; j < side; ++j)
        for (uint32_t i = 0; i < side; ++i)
          node_boxes[i + size_t(side) * (j + size_t(side) * k)] = lattice.node_box(K, {i, j, k});
    uint64_t file_bytes = 0;
    {
      std::error_code ec;
      file_bytes = uint64_t(std::filesystem::file_size(soup_path, ec));
    }
    uint64_t done_bytes = 0;
    while (more) {
      chunk.clear();
      do {
        const SoupCell cell(rec, soup_layout);
        if (stats.cells > 0 && cell.id() < last_id)
          throw Error(soup_path + ": cell " + std::to_string(cell.id()) + " comes after cell " +
                      std::to_string(last_id) + ": the coarse preview needs the cells in id order");
        last_id = cell.id();
        ++stats.cells;
        chunk.insert(chunk.end(), rec, rec + cell.bytes());
        more = reader.next(rec);
      } while (more && chunk.size() + SoupCell(rec, soup_layout).bytes() <= options.chunk_bytes);
      ++stats.chunks;
      const std::unique_ptr<WeldedSoup> local = weld_soup_records(chunk, soup_layout, slots, layout.fields);
      done_bytes += chunk.size();

      // Each cell to the level-K nodes its widened box meets (the sampler's candidates: a superset is fine), then
      // grouped by node with a counting sort, which keeps each node's cells in id order.
      pairs.clear();
      const UnstructuredMesh& mesh = local->mesh;
      for (uint32_t c = 0; c < uint32_t(mesh.cell_count()); ++c) {
        Bounds bb;
        for (uint32_t v : mesh.cell(c)) bb.add(to_double(mesh.points[v]));
        const double margin = kOverlapMargin * length(bb.size());
        std::array<std::pair<uint32_t, uint32_t>, 3> r;
        for (int a = 0; a < 3; ++a) r[size_t(a)] = node_range(lattice, K, a, bb.lo[a] - margin, bb.hi[a] + margin);
        for (uint32_t k = r[2].first; k <= r[2].second; ++k)
          for (uint32_t j = r[1].first; j <= r[1].second; ++j)
            for (uint32_t i = r[0].first; i <= r[0].second; ++i) {
              const uint32_t node = uint32_t(i + size_t(side) * (j + size_t(side) * k));
              const Bounds e = expanded(node_boxes[node], margin);
              if (bb.lo.x > e.hi.x || bb.lo.y > e.hi.y || bb.lo.z > e.hi.z || bb.hi.x < e.lo.x || bb.hi.y < e.lo.y ||
                  bb.hi.z < e.lo.z)
                continue;
              pairs.emplace_back(node, c);
            }
      }
      counts.assign(level_nodes + 1, 0);
      for (const auto& pr : pairs) ++counts[pr.first + 1];
      for (size_t n = 0; n < level_nodes; ++n) counts[n + 1] += counts[n];
      offsets.clear(), entries.clear();
      for (size_t n = 0; n < level_nodes; ++n)
        if (counts[n + 1] > counts[n]) offsets.push_back(counts[n]), entries.push_back(uint32_t(n));
      offsets.push_back(uint32_t(pairs.size()));
      std::vector<uint64_t> cells(pairs.size());
      for (const auto& pr : pairs) cells[counts[pr.first]++] = pr.second;
      stats.sampled += entries.size();

      // The nodes in parallel: each is one task's alone, so its brick needs no lock.
      const BrickSampler sampler(mesh, local->refs, options.sampler);
      tbb::parallel_for(size_t(0), entries.size(), [&](size_t e) {
        const uint32_t node = entries[e];
        const std::array<uint32_t, 3> ijk{node % side, (node / side) % side, uint32_t(node / (size_t(side) * side))};
        BrickSamples& piece = pieces.local();
        sampler.sample(lattice, K, ijk,
                       std::span<const uint64_t>(cells.data() + offsets[e], offsets[e + 1] - offsets[e]),
                       scratch.local(), piece);
        if (piece.valid == 0) return;
        std::unique_ptr<BrickSamples>& b = deepest[node];
        if (!b) b = new_brick();
        uint64_t both = 0;
        for (size_t s = 0; s < per_brick; ++s) {
          if (!piece.mask[s]) continue;
          if (b->mask[s]) {  // an earlier chunk (lower ids) found it first: its cell wins
            ++both;
            continue;
          }
          b->mask[s] = 1;
          ++b->valid;
          for (uint32_t f = 0; f < F; ++f) b->values[f * per_brick + s] = piece.values[f * per_brick + s];
        }
        if (both) shared += both;
      });
      if (file_bytes > 0) progress.set(std::min<uint64_t>(999, done_bytes * 1000 / file_bytes));
    }
    progress.finish();
  }
  stats.shared_samples = shared;

  stats.nodes = write_level_store(std::move(deepest), K, layout, path);
  stats.store_bytes = std::filesystem::file_size(path);
  const BrickStoreReader store(path);
  for (uint64_t id = 0; id < store.node_count(); ++id) stats.bricks += store.node(id).has_brick();
  stats.seconds = seconds_since(start);
  return stats;
}

}  // namespace ugvr
