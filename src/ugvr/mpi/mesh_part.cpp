#include "ugvr/mpi/mesh_part.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <numeric>
#include <unordered_map>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/mpi/kd_partition.h"

namespace ugvr {
namespace {

const UnstructuredMesh& unstructured(const Block& block, std::string_view what) {
  const auto* mesh = std::get_if<UnstructuredMesh>(&block.grid);
  if (!mesh)
    fail_in(what, "a part is cut from an unstructured block only, not a " + std::string(grid_kind_name(block.grid)));
  return *mesh;
}

bool closed_overlap(const Bounds& a, const Bounds& box) {
  return a.lo.x <= box.hi.x && a.hi.x >= box.lo.x && a.lo.y <= box.hi.y && a.hi.y >= box.lo.y && a.lo.z <= box.hi.z &&
         a.hi.z >= box.lo.z;
}

std::string pvtu_type_attributes(ScalarType type, int components) {
  return " type=\"" + std::string(scalar_type_name(type)) + "\" NumberOfComponents=\"" + std::to_string(components) +
         "\"";
}

}  // namespace

Bounds cell_bounds(const UnstructuredMesh& mesh, uint64_t c) {
  Bounds b;
  for (uint32_t v : mesh.cell(c)) b.add(to_double(mesh.points[v]));
  return b;
}

Vec3d cell_centroid(const UnstructuredMesh& mesh, uint64_t c) {
  const auto v = mesh.cell(c);
  return mean_of_corners(int(v.size()), [&](int i) { return mesh.points[v[size_t(i)]]; });
}

Block block_subset(const Block& block, std::span<const uint8_t> keep) {
  const UnstructuredMesh& mesh = unstructured(block, "block_subset");
  if (keep.size() != mesh.cell_count()) fail_in("block_subset", "one keep flag per cell expected");
  constexpr uint32_t kUnused = ~uint32_t(0);
  std::vector<uint32_t> new_id(mesh.point_count(), kUnused);
  std::vector<uint64_t> cells, points;
  for (uint64_t c = 0; c < mesh.cell_count(); ++c)
    if (keep[c]) {
      cells.push_back(c);
      for (uint32_t v : mesh.cell(c)) new_id[v] = 0;
    }
  for (uint64_t p = 0; p < mesh.point_count(); ++p)
    if (new_id[p] != kUnused) new_id[p] = uint32_t(points.size()), points.push_back(p);

  UnstructuredMesh part;
  part.points.reserve(points.size());
  for (uint64_t p : points) part.points.push_back(mesh.points[p]);
  uint64_t indices = 0;
  for (uint64_t c : cells) indices += mesh.cell(c).size();
  part.reserve(cells.size(), indices);
  std::vector<uint32_t> v;
  for (uint64_t c : cells) {
    v.clear();
    for (uint32_t i : mesh.cell(c)) v.push_back(new_id[i]);
    part.add_cell(mesh.cell_types[c], v);
  }
  Block out;
  out.name = block.name;
  for (const Field& f : block.fields)
    out.fields.add(
        Field(f.name(), f.association(), f.data().gather(f.association() == Association::Vertex ? points : cells)));
  out.grid = std::move(part);
  return out;
}

Block join_blocks(std::vector<Block> blocks, const std::string& id_field, const std::string& source) {
  if (blocks.empty()) return Block{};
  // Concatenated first (points and cells of block b after those of the blocks before), then welded.
  UnstructuredMesh all;
  std::vector<std::vector<const DataArray*>> arrays(blocks[0].fields.size());
  uint64_t points = 0, cells = 0, indices = 0;
  for (const Block& b : blocks) {
    const UnstructuredMesh& m = unstructured(b, source);
    points += m.point_count(), cells += m.cell_count(), indices += m.connectivity.size();
    if (b.fields.size() != blocks[0].fields.size()) fail_in(source, "the parts' blocks have different fields");
    for (size_t f = 0; f < b.fields.size(); ++f) {
      const Field& want = blocks[0].fields[f];
      const Field* got = b.fields.find(want.name(), want.association());
      if (!got || got->data().type() != want.data().type() || got->components() != want.components())
        fail_in(source, "the parts' blocks differ in field '" + want.name() + "'");
      arrays[f].push_back(&got->data());
    }
  }
  size_t id_index = blocks[0].fields.size();
  for (size_t f = 0; f < blocks[0].fields.size(); ++f)
    if (blocks[0].fields[f].name() == id_field && blocks[0].fields[f].association() == Association::Vertex)
      id_index = f;
  if (id_index == blocks[0].fields.size())
    fail_in(source, "the parts' blocks lack the point numbers '" + id_field + "'");
  std::vector<uint64_t> ids;
  ids.reserve(points);
  for (const DataArray* a : arrays[id_index])
    for (uint64_t p = 0; p < a->tuples(); ++p) ids.push_back(uint64_t(a->get(p, 0)));
  // Each point's index in the joined block: its number's first occurrence.
  std::unordered_map<uint64_t, uint32_t> first;
  first.reserve(size_t(points));
  std::vector<uint32_t> joined(static_cast<size_t>(points));
  std::vector<uint64_t> kept;  // the concatenation's points kept
  for (uint64_t p = 0; p < points; ++p) {
    const auto [it, added] = first.try_emplace(ids[p], uint32_t(kept.size()));
    if (added) kept.push_back(p);
    joined[p] = it->second;
  }
  all.reserve(cells, indices);
  uint64_t base = 0;
  std::vector<uint32_t> v;
  for (const Block& b : blocks) {
    const UnstructuredMesh& m = std::get<UnstructuredMesh>(b.grid);
    for (uint64_t c = 0; c < m.cell_count(); ++c) {
      v.clear();
      for (const uint32_t i : m.cell(c)) v.push_back(joined[base + i]);
      all.add_cell(m.cell_types[c], v);
    }
    base += m.point_count();
  }
  all.points.resize(kept.size());
  {
    std::vector<Vec3f> concatenated;
    concatenated.reserve(size_t(points));
    for (const Block& b : blocks) {
      const auto& pts = std::get<UnstructuredMesh>(b.grid).points;
      concatenated.insert(concatenated.end(), pts.begin(), pts.end());
    }
    for (size_t i = 0; i < kept.size(); ++i) all.points[i] = concatenated[kept[i]];
  }
  Block out;
  out.name = blocks[0].name;
  for (size_t f = 0; f < arrays.size(); ++f) {
    if (f == id_index) continue;
    const Field& spec = blocks[0].fields[f];
    const bool vertex = spec.association() == Association::Vertex;
    DataArray cat(spec.data().type(), spec.components(), vertex ? points : cells);
    uint64_t at = 0;
    for (const DataArray* a : arrays[f]) {
      std::memcpy(cat.bytes() + at, a->bytes(), size_t(a->byte_size()));
      at += a->byte_size();
    }
    out.fields.add(Field(spec.name(), spec.association(), vertex ? cat.gather(kept) : std::move(cat)));
  }
  out.grid = std::move(all);
  return out;
}

Block cells_meeting_box(const Block& block, const Bounds& box) {
  const UnstructuredMesh& mesh = unstructured(block, "cells_meeting_box");
  std::vector<uint8_t> keep(mesh.cell_count());
  for (uint64_t c = 0; c < mesh.cell_count(); ++c) keep[c] = closed_overlap(cell_bounds(mesh, c), box);
  return block_subset(block, keep);
}

Bounds block_point_bounds(const Block& block) {
  Bounds b;
  for (const Vec3f& p : unstructured(block, "block_point_bounds").points) b.add(to_double(p));
  return b;
}

std::vector<Vec3d> sampled_cell_centroids(const Block& block, uint64_t first, uint64_t stride) {
  const UnstructuredMesh& mesh = unstructured(block, "sampled_cell_centroids");
  std::vector<Vec3d> out;
  for (uint64_t c = first; c < mesh.cell_count(); c += std::max<uint64_t>(stride, 1))
    out.push_back(cell_centroid(mesh, c));
  return out;
}

namespace {

template <class T>
void put(std::vector<std::byte>& out, std::span<const T> values) {
  const auto bytes = std::as_bytes(values);
  out.insert(out.end(), bytes.begin(), bytes.end());
}
void put_u64(std::vector<std::byte>& out, uint64_t v) { put(out, std::span<const uint64_t>(&v, 1)); }

// Copies the next n bytes of `in` to `to`.
void take(std::span<const std::byte>& in, void* to, uint64_t n, std::string_view source) {
  if (n > in.size()) fail_in(source, "a part's bytes end early");
  if (n > 0) std::memcpy(to, in.data(), size_t(n));
  in = in.subspan(size_t(n));
}
uint64_t take_u64(std::span<const std::byte>& in, std::string_view source) {
  uint64_t v = 0;
  take(in, &v, sizeof v, source);
  return v;
}
// A count whose bytes (count x size) must fit in what is left: checked before anything is allocated.
uint64_t take_count(std::span<const std::byte>& in, uint64_t size, std::string_view source) {
  const uint64_t n = take_u64(in, source);
  if (size > 0 && n > in.size() / size) fail_in(source, "a part's counts exceed its bytes");
  return n;
}

}  // namespace

void append_block_bytes(const Block& block, std::vector<std::byte>& out) {
  const UnstructuredMesh& mesh = unstructured(block, "append_block_bytes");
  put_u64(out, mesh.point_count());
  put_u64(out, mesh.cell_count());
  put_u64(out, mesh.connectivity.size());
  put_u64(out, block.fields.size());
  put(out, std::span<const Vec3f>(mesh.points));
  put(out, std::span<const CellType>(mesh.cell_types));
  put(out, std::span<const uint64_t>(mesh.cell_offsets));
  put(out, std::span<const uint32_t>(mesh.connectivity));
  for (const Field& f : block.fields) {
    put_u64(out, f.name().size());
    put(out, std::span<const char>(f.name()));
    const uint8_t kind[2] = {uint8_t(f.association()), uint8_t(f.data().type())};
    put(out, std::span<const uint8_t>(kind));
    put_u64(out, uint64_t(f.components()));
    put_u64(out, f.tuples());
    put(out, std::span<const std::byte>(f.data().bytes(), size_t(f.data().byte_size())));
  }
}

Block read_block_bytes(std::span<const std::byte>& bytes, std::string_view source) {
  UnstructuredMesh mesh;
  const uint64_t points = take_count(bytes, sizeof(Vec3f), source);
  const uint64_t cells = take_count(bytes, 1, source);
  const uint64_t indices = take_count(bytes, sizeof(uint32_t), source);
  const uint64_t fields = take_count(bytes, 1, source);
  mesh.points.resize(points);
  take(bytes, mesh.points.data(), points * sizeof(Vec3f), source);
  mesh.cell_types.resize(cells);
  take(bytes, mesh.cell_types.data(), cells, source);
  if (cells + 1 > bytes.size() / sizeof(uint64_t)) fail_in(source, "a part's counts exceed its bytes");
  mesh.cell_offsets.resize(cells + 1);
  take(bytes, mesh.cell_offsets.data(), (cells + 1) * sizeof(uint64_t), source);
  mesh.connectivity.resize(indices);
  take(bytes, mesh.connectivity.data(), indices * sizeof(uint32_t), source);
  mesh.validate(source);
  Block block;
  for (uint64_t i = 0; i < fields; ++i) {
    std::string name(take_count(bytes, 1, source), '\0');
    take(bytes, name.data(), name.size(), source);
    uint8_t kind[2] = {};
    take(bytes, kind, 2, source);
    if (kind[0] > uint8_t(Association::Cell) || kind[1] > uint8_t(ScalarType::Float64))
      fail_in(source, "a part's field '" + name + "' has a bad association or type");
    const ScalarType type = ScalarType(kind[1]);
    const uint64_t components = take_u64(bytes, source);
    const uint64_t tuples = take_count(bytes, scalar_size(type) * std::max<uint64_t>(components, 1), source);
    if (components < 1 || components > 64) fail_in(source, "a part's field '" + name + "' has a bad component count");
    DataArray data(type, int(components), tuples);
    take(bytes, data.bytes(), data.byte_size(), source);
    block.fields.add(Field(std::move(name), Association(kind[0]), std::move(data)));
  }
  block.grid = std::move(mesh);
  block.validate_fields(source);
  return block;
}

std::vector<uint32_t> slab_pieces(const Block& block, uint32_t pieces, int axis) {
  const UnstructuredMesh& mesh = unstructured(block, "slab_pieces");
  std::vector<double> key(mesh.cell_count());
  for (uint64_t c = 0; c < key.size(); ++c) key[c] = cell_centroid(mesh, c)[axis];
  std::vector<uint64_t> order(key.size());
  std::iota(order.begin(), order.end(), uint64_t(0));
  std::stable_sort(order.begin(), order.end(), [&](uint64_t a, uint64_t b) { return key[a] < key[b]; });
  std::vector<uint32_t> out(key.size());
  for (uint64_t i = 0; i < order.size(); ++i)
    out[order[i]] = uint32_t(i * pieces / std::max<uint64_t>(order.size(), 1));
  return out;
}

std::vector<uint32_t> kd_pieces(const Block& block, uint32_t pieces) {
  const UnstructuredMesh& mesh = unstructured(block, "kd_pieces");
  const KdTree tree = build_kd_tree(sampled_cell_centroids(block, 0, 1), int(pieces));
  std::vector<uint32_t> out(mesh.cell_count());
  for (uint64_t c = 0; c < out.size(); ++c) out[c] = uint32_t(tree.part_of(cell_centroid(mesh, c)));
  return out;
}

std::vector<std::string> write_pvtu(const Block& block, const std::string& path,
                                    std::span<const uint32_t> piece_of_cell, uint32_t pieces) {
  const UnstructuredMesh& mesh = unstructured(block, path);
  if (piece_of_cell.size() != mesh.cell_count()) fail_in(path, "one piece number per cell expected");
  std::string stem = base_name(path);
  if (const size_t dot = stem.rfind('.'); dot != std::string::npos) stem.resize(dot);
  std::vector<std::string> files;
  std::vector<uint8_t> keep(mesh.cell_count());
  for (uint32_t k = 0; k < pieces; ++k) {
    for (uint64_t c = 0; c < keep.size(); ++c) keep[c] = piece_of_cell[c] == k;
    Dataset piece;
    piece.blocks.push_back(block_subset(block, keep));
    files.push_back(stem + "_" + std::to_string(k) + ".vtu");
    write_vtu(piece, dir_name(path) + files.back());
  }
  // The index: the arrays every piece has (the pieces' own headers say the rest) and the pieces, relative to it.
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n  <PUnstructuredGrid GhostLevel=\"0\">\n";
  for (const Association assoc : {Association::Vertex, Association::Cell}) {
    out << (assoc == Association::Vertex ? "    <PPointData>\n" : "    <PCellData>\n");
    for (const Field& f : block.fields)
      if (f.association() == assoc)
        out << "      <PDataArray" << pvtu_type_attributes(f.data().type(), f.components()) << " Name=\"" << f.name()
            << "\"/>\n";
    out << (assoc == Association::Vertex ? "    </PPointData>\n" : "    </PCellData>\n");
  }
  out << "    <PPoints>\n      <PDataArray" << pvtu_type_attributes(ScalarType::Float32, 3)
      << " Name=\"Points\"/>\n    </PPoints>\n";
  for (const std::string& f : files) out << "    <Piece Source=\"" << f << "\"/>\n";
  out << "  </PUnstructuredGrid>\n</VTKFile>\n";
  if (!out.flush()) fail_in(path, "could not write the .pvtu");
  std::vector<std::string> paths;
  for (const std::string& f : files) paths.push_back(dir_name(path) + f);
  return paths;
}

void write_vtu_pieces(const Block& block, const std::string& path, std::span<const uint32_t> piece_of_cell,
                      uint32_t pieces) {
  const UnstructuredMesh& mesh = unstructured(block, path);
  if (piece_of_cell.size() != mesh.cell_count()) fail_in(path, "one piece number per cell expected");
  // Each piece is written by write_vtu (one <Piece>, raw appended data) to a scratch file, whose <Piece> markup and
  // appended bytes are then joined: offsets moved by the appended bytes of the pieces before.
  constexpr std::string_view kOpen = "<AppendedData encoding=\"raw\">\n   _", kClose = "\n  </AppendedData>";
  const std::string scratch = path + ".piece-scratch.vtu";
  std::string head, markup, appended;
  std::vector<uint8_t> keep(mesh.cell_count());
  for (uint32_t k = 0; k < pieces; ++k) {
    for (uint64_t c = 0; c < keep.size(); ++c) keep[c] = piece_of_cell[c] == k;
    Dataset piece;
    piece.blocks.push_back(block_subset(block, keep));
    write_vtu(piece, scratch);
    const std::string bytes = InputFile(scratch).read_all(uint64_t(1) << 32);
    const size_t begin = bytes.find("<Piece"), end = bytes.find("</Piece>"), data = bytes.find(kOpen);
    const size_t data_end = bytes.rfind(kClose);
    if (begin == std::string::npos || end == std::string::npos || data == std::string::npos ||
        data_end == std::string::npos || data_end < data + kOpen.size())
      fail_in(scratch, "not the layout write_vtu writes");
    if (k == 0) head = bytes.substr(0, begin);
    std::string piece_markup = bytes.substr(begin, end + std::string_view("</Piece>\n").size() - begin);
    for (size_t at = 0; (at = piece_markup.find("offset=\"", at)) != std::string::npos;) {
      at += std::string_view("offset=\"").size();
      const size_t stop = piece_markup.find('"', at);
      const uint64_t offset = std::stoull(piece_markup.substr(at, stop - at)) + appended.size();
      piece_markup.replace(at, stop - at, std::to_string(offset));
    }
    markup += "    " + piece_markup;
    appended.append(bytes, data + kOpen.size(), data_end - data - kOpen.size());
  }
  std::remove(scratch.c_str());
  AtomicOutputFile out(path);
  out.write(head);
  out.write(markup);
  out.write("  </UnstructuredGrid>\n  ");
  out.write(kOpen);
  out.write(appended);
  out.write(kClose);
  out.write("\n</VTKFile>\n");
  out.commit();
}

}  // namespace ugvr
