#include "ugvr/mpi/mpi_part_read.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <span>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"
#include "ugvr/mpi/mesh_part.h"
#include "ugvr/mpi/mpi_session.h"

namespace ugvr::mpi {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

const Block& piece_block(const Dataset& ds, const std::string& file) {
  if (ds.blocks.size() != 1 || !std::holds_alternative<UnstructuredMesh>(ds.blocks[0].grid))
    fail_in(file, "a piece read by parts must be one unstructured grid");
  return ds.blocks[0];
}

bool meets(const Bounds& a, const Bounds& box) {
  return !a.empty() && a.lo.x <= box.hi.x && a.hi.x >= box.lo.x && a.lo.y <= box.hi.y && a.hi.y >= box.lo.y &&
         a.lo.z <= box.hi.z && a.hi.z >= box.lo.z;
}

// Minima and maxima reduced in one call: maxima travel negated.
struct MinMax {
  std::vector<double> lo, neg_hi;
  explicit MinMax(size_t n) : lo(n, kInf), neg_hi(n, kInf) {}
  void add(size_t i, double l, double h) { lo[i] = std::min(lo[i], l), neg_hi[i] = std::min(neg_hi[i], -h); }
  double hi(size_t i) const { return -neg_hi[i]; }
  void reduce() {
    MPI_Allreduce(MPI_IN_PLACE, lo.data(), int(lo.size()), MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, neg_hi.data(), int(neg_hi.size()), MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  }
};

std::string broadcast_text(std::string text, int root) {
  uint64_t n = text.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, root, MPI_COMM_WORLD);
  text.resize(size_t(n));
  MPI_Bcast(text.data(), int(n), MPI_CHAR, root, MPI_COMM_WORLD);
  return text;
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  for (size_t at = 0; at < text.size();) {
    const size_t end = text.find('\n', at);
    out.push_back(text.substr(at, end - at));
    at = end + 1;
  }
  return out;
}

// Every rank's samples, in rank order (the same vector on every rank, so the same tree).
std::vector<Vec3d> gather_samples(const std::vector<Vec3d>& mine) {
  const int n = size();
  int count = int(mine.size() * 3);
  std::vector<int> counts(static_cast<size_t>(n)), displs(static_cast<size_t>(n));
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  int total = 0;
  for (int r = 0; r < n; ++r) displs[size_t(r)] = total, total += counts[size_t(r)];
  std::vector<double> flat, all(static_cast<size_t>(total));
  flat.reserve(size_t(count));
  for (const Vec3d& p : mine) flat.insert(flat.end(), {p.x, p.y, p.z});
  MPI_Allgatherv(flat.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  std::vector<Vec3d> out(all.size() / 3);
  for (size_t i = 0; i < out.size(); ++i) out[i] = {all[3 * i], all[3 * i + 1], all[3 * i + 2]};
  return out;
}

// Every rank's bytes for every other (MPI_Alltoallv), what this rank receives concatenated in sender order. MPI counts
// bytes in int: a message or a rank's total beyond 2 GiB is refused with advice rather than truncated.
std::vector<std::byte> exchange_parts(const std::vector<std::vector<std::byte>>& outgoing, const std::string& path) {
  const int n = size();
  constexpr uint64_t kMaxMessage = uint64_t(std::numeric_limits<int>::max());
  std::vector<int> send_counts(static_cast<size_t>(n)), send_displs(static_cast<size_t>(n));
  std::vector<int> recv_counts(static_cast<size_t>(n)), recv_displs(static_cast<size_t>(n));
  std::vector<std::byte> send;
  for (int r = 0; r < n; ++r) {
    const std::vector<std::byte>& to = outgoing[size_t(r)];
    if (send.size() + to.size() > kMaxMessage)
      fail_in(path,
              "a rank's parts for the others exceed 2 GiB, more than one MPI exchange carries: run more ranks "
              "(or UGVR_MPI_WHOLE_MESH=1)");
    send_displs[size_t(r)] = int(send.size());
    send_counts[size_t(r)] = int(to.size());
    send.insert(send.end(), to.begin(), to.end());
  }
  MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  uint64_t total = 0;
  for (int r = 0; r < n; ++r)
    recv_displs[size_t(r)] = int(std::min(total, kMaxMessage)), total += uint64_t(recv_counts[size_t(r)]);
  if (total > kMaxMessage)
    fail_in(path, "rank " + std::to_string(rank()) +
                      "'s part exceeds 2 GiB, more than one MPI exchange carries: run "
                      "more ranks (or UGVR_MPI_WHOLE_MESH=1)");
  std::vector<std::byte> received(total);
  MPI_Alltoallv(send.data(), send_counts.data(), send_displs.data(), MPI_BYTE, received.data(), recv_counts.data(),
                recv_displs.data(), MPI_BYTE, MPI_COMM_WORLD);
  return received;
}

// What default_field_names (octree/input.h) picks, from the whole mesh's magnitude ranges.
std::vector<std::string> default_fields(const std::vector<std::string>& names, const std::vector<bool>& vertex,
                                        const MinMax& magnitude, size_t max_fields) {
  std::vector<std::string> varying;
  const std::string* first = nullptr;
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == "IBLANK" && vertex[i]) continue;
    if (!first) first = &names[i];
    if (varying.size() == max_fields) break;
    if (magnitude.hi(i) > magnitude.lo[i] && std::find(varying.begin(), varying.end(), names[i]) == varying.end())
      varying.push_back(names[i]);
  }
  if (varying.empty() && first) varying.push_back(*first);
  return varying;
}

// The range of the values the exact engine binds for `selector` (float, NaN skipped), added into `into` at `i`.
void add_engine_range(const Block& block, const std::string& selector, MinMax& into, size_t i) {
  const ScalarRef ref = block.fields.scalar(selector);
  double lo = kInf, hi = -kInf;
  for (uint64_t t = 0; t < ref.field->tuples(); ++t) {
    const float v = float(ref.field->scalar(t, ref.component));
    if (!std::isnan(v)) lo = std::min(lo, double(v)), hi = std::max(hi, double(v));
  }
  into.add(i, lo, hi);
}

}  // namespace

PartRead read_part(const PartSource& source, const std::string& selector, size_t max_fields) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string& path = source.path();
  const size_t pieces = source.pieces();
  const int me = rank(), ranks = size();
  const auto owner = [&](size_t k) { return int(k % size_t(ranks)); };
  PartRead out;
  out.source = source.kind();
  out.pieces_total = uint32_t(pieces);

  // Each rank reads the pieces it owns, once, and keeps them until they are dealt out.
  const std::optional<uint64_t> header_cells = source.cells_from_headers();
  const uint64_t stride = header_cells ? split_sample_stride(*header_cells) : 1;
  MinMax piece_bounds(3 * pieces);
  std::vector<uint64_t> piece_cells(pieces, 0);
  std::vector<Vec3d> samples;
  std::vector<std::string> piece_fields(pieces);  // per owned piece: "v|c" + name + "\n" per field
  std::vector<std::pair<size_t, Dataset>> owned;
  for (size_t k = 0; k < pieces; ++k) {
    if (owner(k) != me) continue;
    Dataset ds = source.read_piece(k);
    const Block& block = piece_block(ds, source.piece_file(k));
    const Bounds b = block_point_bounds(block);
    if (!b.empty())
      for (int a = 0; a < 3; ++a) piece_bounds.add(3 * k + size_t(a), (&b.lo.x)[a], (&b.hi.x)[a]);
    piece_cells[k] = std::get<UnstructuredMesh>(block.grid).cell_count();
    const std::vector<Vec3d> s = sampled_cell_centroids(block, 0, stride);
    samples.insert(samples.end(), s.begin(), s.end());
    for (const Field& f : block.fields)
      if (f.name() != kPartPointIdField)  // the source's point numbers, no field of the data
        piece_fields[k] += (f.association() == Association::Vertex ? "v" : "c") + f.name() + "\n";
    out.cells_read += piece_cells[k];
    ++out.pieces_read;
    owned.emplace_back(k, std::move(ds));
  }
  piece_bounds.reduce();
  MPI_Allreduce(MPI_IN_PLACE, piece_cells.data(), int(pieces), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  for (uint64_t c : piece_cells) out.cells_total += c;
  const auto first = std::find_if(piece_cells.begin(), piece_cells.end(), [](uint64_t c) { return c > 0; });
  if (first == piece_cells.end()) fail_in(path, "its pieces hold no volume cells");
  // The fields of the first piece with cells, as a whole read takes them (every piece must have them).
  const size_t first_piece = size_t(first - piece_cells.begin());
  std::vector<std::string> names;
  std::vector<bool> vertex;
  for (const std::string& line : split_lines(broadcast_text(piece_fields[first_piece], owner(first_piece)))) {
    vertex.push_back(line[0] == 'v');
    names.push_back(line.substr(1));
  }
  const auto piece_box = [&](size_t k) {
    Bounds b;
    if (piece_bounds.lo[3 * k] <= piece_bounds.hi(3 * k)) {
      b.add(Vec3d{piece_bounds.lo[3 * k], piece_bounds.lo[3 * k + 1], piece_bounds.lo[3 * k + 2]});
      b.add(Vec3d{piece_bounds.hi(3 * k), piece_bounds.hi(3 * k + 1), piece_bounds.hi(3 * k + 2)});
    }
    return b;
  };
  // Every piece's points, with cells or not, as a whole read's walk mesh counts them.
  for (size_t k = 0; k < pieces; ++k) out.bounds.add(piece_box(k));
  std::vector<Vec3d> all_samples = gather_samples(samples);
  samples = {};
  out.split_samples = all_samples.size();
  out.tree = build_kd_tree(std::move(all_samples), ranks);

  // The fields' ranges over the owned pieces, whole: every piece once, so the reduction is the whole mesh's.
  std::vector<std::string> selectors = names;
  if (!selector.empty() && std::find(names.begin(), names.end(), selector) == names.end())
    selectors.push_back(selector);
  MinMax magnitude(names.size()), engine(selectors.size());
  for (const auto& [k, ds] : owned) {
    if (piece_cells[k] == 0) continue;
    const Block& block = ds.blocks[0];
    for (size_t i = 0; i < names.size(); ++i) {
      const Field* f = block.fields.find(names[i], vertex[i] ? Association::Vertex : Association::Cell);
      if (!f)
        fail_in(source.piece_file(k), std::string("lacks the ") + (vertex[i] ? "point" : "cell") + " array '" +
                                          names[i] + "' of the first piece with cells (" +
                                          source.piece_file(first_piece) + ")");
      const Range r = f->range(kMagnitude);
      if (r.nan_count < f->tuples()) magnitude.add(i, r.min, r.max);
    }
    for (size_t i = 0; i < selectors.size(); ++i) add_engine_range(block, selectors[i], engine, i);
  }
  magnitude.reduce();
  engine.reduce();

  // The cuts dealt out: each owner cuts its pieces to every box they meet, dropping each piece once cut (so the owned
  // pieces shrink as the outgoing bytes grow), and sends every rank its cuts. Per destination, in piece order.
  auto part = std::make_shared<Dataset>();
  part->format = source.format();
  part->sources.push_back(path);
  std::vector<std::vector<std::byte>> outgoing(static_cast<size_t>(ranks));
  for (auto& [k, ds] : owned) {
    for (int r = 0; r < ranks && piece_cells[k] > 0; ++r) {
      if (!meets(piece_box(k), out.tree.boxes[size_t(r)])) continue;
      const Block cut = cells_meeting_box(ds.blocks[0], out.tree.boxes[size_t(r)]);
      if (std::get<UnstructuredMesh>(cut.grid).cell_count() == 0) continue;
      std::vector<std::byte>& to = outgoing[size_t(r)];
      const uint64_t piece = k;
      to.insert(to.end(), reinterpret_cast<const std::byte*>(&piece), reinterpret_cast<const std::byte*>(&piece + 1));
      append_block_bytes(cut, to);
    }
    for (std::string& w : ds.warnings)  // pieces of one file may warn alike
      if (std::find(part->warnings.begin(), part->warnings.end(), w) == part->warnings.end())
        part->warnings.push_back(std::move(w));
    ds = Dataset{};
  }
  owned = {};
  const std::vector<std::byte> incoming = exchange_parts(outgoing, path);
  outgoing = {};
  // The cuts arrive by sender; the part lists them in piece order (the order a whole read numbers cells in).
  std::map<uint64_t, Block> cuts;
  for (std::span<const std::byte> rest(incoming); !rest.empty();) {
    uint64_t piece = 0;
    if (rest.size() < sizeof piece) fail_in(path, "a part's bytes end early");
    std::memcpy(&piece, rest.data(), sizeof piece);
    rest = rest.subspan(sizeof piece);
    if (piece >= pieces) fail_in(path, "a part names a piece out of range");
    cuts.emplace(piece, read_block_bytes(rest, source.piece_file(size_t(piece))));
  }
  for (auto& [k, block] : cuts) {
    out.cells_kept += std::get<UnstructuredMesh>(block.grid).cell_count();
    if (std::find(part->sources.begin(), part->sources.end(), source.piece_file(k)) == part->sources.end())
      part->sources.push_back(source.piece_file(k));
    part->blocks.push_back(std::move(block));
  }
  // Pieces that number points as the input does are joined into one block: the walk mesh matches faces by vertex
  // number, so cells of two pieces meet as in the whole read's (separate blocks would leave a boundary between them,
  // which rays leave and re-enter: slower, and not the whole read's walk). A .pvtu's pieces stay apart, as its
  // whole read leaves them.
  if (!part->blocks.empty() && part->blocks[0].fields.find(kPartPointIdField, Association::Vertex)) {
    Block joined = join_blocks(std::move(part->blocks), kPartPointIdField, path);
    part->blocks.clear();
    part->blocks.push_back(std::move(joined));
  }
  if (part->blocks.empty())
    fail_in(path, "rank " + std::to_string(me) + " of " + std::to_string(ranks) +
                      ": its kd box meets no cell (fewer cells than ranks?)");
  out.dataset = std::move(part);
  out.fields = default_fields(names, vertex, magnitude, max_fields);
  for (size_t i = 0; i < selectors.size(); ++i)
    if (engine.lo[i] <= engine.hi(i))
      out.ranges[selectors[i]] = {engine.lo[i], engine.hi(i)};
    else
      out.ranges[selectors[i]] = {0, 0};  // all NaN, as the engine reports it
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace ugvr::mpi
