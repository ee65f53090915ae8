// VTK XML UnstructuredGrid writer; the file layout is documented in vtu_writer.h.
#include "ugvr/io/vtu_writer.h"

#include <fcntl.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <climits>
#include <cstring>
#include <optional>
#include <string_view>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/progress.h"
#include "ugvr/grid/structured_cells.h"

namespace ugvr {

static_assert(std::endian::native == std::endian::little, "the writer declares byte_order=\"LittleEndian\"");

namespace {

// Largest piece handed to AtomicOutputFile at once: it buffers up to 4 MiB and would otherwise copy a larger write
// into a buffer as large as the write.
constexpr size_t kMaxWritePiece = size_t(1) << 20;

std::string_view section_name(VtuSection s) {
  switch (s) {
    case VtuSection::Points: return "Points";
    case VtuSection::Cells: return "Cells";
    case VtuSection::PointData: return "PointData";
    case VtuSection::CellData: return "CellData";
  }
  return "?";
}

bool is_integer(ScalarType t) { return t != ScalarType::Float32 && t != ScalarType::Float64; }

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Checks the declarations against the piece so that a file we write is always one a reader accepts.
void validate_specs(const std::string& path, uint64_t points, uint64_t cells, const std::vector<VtuArraySpec>& arrays) {
  int n_points = 0;
  bool seen_conn = false, seen_offsets = false, seen_types = false;
  for (size_t a = 0; a < arrays.size(); ++a) {
    const VtuArraySpec& s = arrays[a];
    const std::string what = "array '" + s.name + "' (" + std::string(section_name(s.section)) + ")";
    if (s.components < 1) fail_in(path, what + " has " + std::to_string(s.components) + " components");
    if (s.name.empty()) fail_in(path, "an array in " + std::string(section_name(s.section)) + " has no name");
    for (size_t b = 0; b < a; ++b) {
      if (arrays[b].section == s.section && arrays[b].name == s.name) fail_in(path, what + " is declared twice");
    }
    auto expect_tuples = [&](uint64_t want) {
      if (s.tuples != want) {
        fail_in(path, what + " has " + std::to_string(s.tuples) + " tuples, expected " + std::to_string(want));
      }
    };
    switch (s.section) {
      case VtuSection::Points:
        ++n_points;
        if (s.components != 3 || is_integer(s.type)) fail_in(path, what + " must be 3-component Float32 or Float64");
        expect_tuples(points);
        break;
      case VtuSection::Cells:
        if (s.components != 1 || !is_integer(s.type)) fail_in(path, what + " must be a 1-component integer array");
        if (s.name == "connectivity") {
          seen_conn = true;
        } else if (s.name == "offsets") {
          seen_offsets = true;
          expect_tuples(cells);
        } else if (s.name == "types") {
          seen_types = true;
          if (s.type != ScalarType::UInt8) fail_in(path, what + " must be UInt8");
          expect_tuples(cells);
        } else {
          fail_in(path, what + ": Cells arrays are connectivity, offsets and types");
        }
        break;
      case VtuSection::PointData: expect_tuples(points); break;
      case VtuSection::CellData: expect_tuples(cells); break;
    }
  }
  if (n_points != 1) fail_in(path, "a piece needs exactly one Points array, got " + std::to_string(n_points));
  if (!seen_conn || !seen_offsets || !seen_types) fail_in(path, "a piece needs connectivity, offsets and types arrays");
}

// The XML before the appended data, ending with the '_' that marks its start.
std::string xml_header(uint64_t points, uint64_t cells, const std::vector<VtuArraySpec>& arrays,
                       const std::vector<uint64_t>& offsets, Codec codec) {
  std::string x = "<?xml version=\"1.0\"?>\n";
  x += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"";
  if (codec != Codec::None) x += " compressor=\"" + std::string(vtk_compressor_name(codec)) + "\"";
  x += ">\n  <UnstructuredGrid>\n";
  x +=
      "    <Piece NumberOfPoints=\"" + std::to_string(points) + "\" NumberOfCells=\"" + std::to_string(cells) + "\">\n";
  // VTK's own order of the sections inside a piece.
  for (VtuSection section : {VtuSection::PointData, VtuSection::CellData, VtuSection::Points, VtuSection::Cells}) {
    x += "      <" + std::string(section_name(section)) + ">\n";
    for (size_t a = 0; a < arrays.size(); ++a) {
      const VtuArraySpec& s = arrays[a];
      if (s.section != section) continue;
      x += "        <DataArray type=\"" + std::string(scalar_type_name(s.type)) + "\" Name=\"" + xml_escape(s.name) +
           "\"";
      if (s.components != 1) x += " NumberOfComponents=\"" + std::to_string(s.components) + "\"";
      x += " format=\"appended\" offset=\"" + std::to_string(offsets[a]) + "\"/>\n";
    }
    x += "      </" + std::string(section_name(section)) + ">\n";
  }
  x += "    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
  return x;
}

constexpr std::string_view kTrailer = "\n  </AppendedData>\n</VTKFile>\n";

// An anonymous scratch file in the output's directory (same file system, so no surprise about space elsewhere). It is
// unlinked as soon as it is created: the data disappears with the descriptor whatever happens.
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& near_path) {
    std::string dir = dir_name(near_path);
    if (dir.empty()) dir = "./";
    std::string templ = dir + ".ugvr-appended-XXXXXX";
    fd_ = ::mkstemp(templ.data());
    if (fd_ < 0) fail_in(near_path, std::string("cannot create scratch file: ") + std::strerror(errno));
    ::unlink(templ.c_str());
  }
  ~ScratchFile() { ::close(fd_); }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  void write_at(uint64_t offset, const void* data, size_t n, const std::string& name) const {
    pwrite_all(fd_, offset, data, n, name + " (scratch file)");
  }
  size_t read_at(uint64_t offset, void* data, size_t n, const std::string& name) const {
    for (;;) {
      const ssize_t r = ::pread(fd_, data, n, off_t(offset));
      if (r >= 0) return size_t(r);
      if (errno != EINTR) fail_in(name, std::string("scratch read failed: ") + std::strerror(errno));
    }
  }

 private:
  int fd_ = -1;
};

}  // namespace

struct VtuStreamWriter::Impl {
  std::string path;
  uint64_t points = 0, cells = 0;
  std::vector<VtuArraySpec> arrays;
  VtuStreamOptions options;
  AtomicOutputFile out;
  std::vector<uint64_t> offsets;  // per array, from the start of the appended data
  size_t current = 0;             // array being written
  uint64_t done_in_current = 0;   // its bytes received so far
  bool started_current = false;

  // Compressed mode only.
  std::optional<ScratchFile> scratch;
  uint64_t scratch_end = 0;           // bytes of appended data in the scratch file
  uint64_t header_at = 0;             // where the current array's block header goes
  std::vector<uint64_t> block_sizes;  // compressed sizes of the current array's blocks so far
  std::vector<std::byte> pending;     // uncompressed bytes waiting to be compressed (a batch of blocks)
  size_t batch_blocks = 1;

  Impl(const std::string& p, uint64_t np, uint64_t nc, std::vector<VtuArraySpec> a, const VtuStreamOptions& o)
      : path(p), points(np), cells(nc), arrays(std::move(a)), options(o), out(p) {}

  bool compressed() const { return options.codec != Codec::None; }

  void write_out(const std::byte* p, size_t n) {
    while (n > 0) {
      const size_t piece = std::min(n, kMaxWritePiece);
      out.write(p, piece);
      p += piece;
      n -= piece;
    }
  }

  void begin_array() {
    started_current = true;
    done_in_current = 0;
    const uint64_t bytes = arrays[current].byte_size();
    if (!compressed()) {
      out.write(&bytes, sizeof bytes);
      return;
    }
    offsets[current] = scratch_end;
    header_at = scratch_end;
    const uint64_t nblocks = (bytes + options.block_size - 1) / options.block_size;
    scratch_end += (3 + nblocks) * sizeof(uint64_t);  // filled in by end_array()
    block_sizes.clear();
    pending.clear();
  }

  // Compresses the pending bytes (whole blocks, plus the partial last block when `final`) in parallel and appends
  // them to the scratch file in order.
  void flush_blocks(bool final) {
    const size_t bs = size_t(options.block_size);
    const size_t n = final ? (pending.size() + bs - 1) / bs : pending.size() / bs;
    if (n == 0) return;
    std::vector<std::vector<std::byte>> packed(n);
    tbb::parallel_for(size_t(0), n, [&](size_t b) {
      const size_t begin = b * bs, len = std::min(bs, pending.size() - begin);
      packed[b] = compress(options.codec, std::span(pending).subspan(begin, len), options.level);
    });
    for (const auto& p : packed) {
      scratch->write_at(scratch_end, p.data(), p.size(), path);
      scratch_end += p.size();
      block_sizes.push_back(p.size());
    }
    pending.erase(pending.begin(), pending.begin() + ptrdiff_t(std::min(pending.size(), n * bs)));
  }

  void end_array() {
    if (compressed()) {
      flush_blocks(true);
      const uint64_t bytes = arrays[current].byte_size();
      std::vector<uint64_t> header = {block_sizes.size(), options.block_size, bytes % options.block_size};
      header.insert(header.end(), block_sizes.begin(), block_sizes.end());
      scratch->write_at(header_at, header.data(), header.size() * sizeof(uint64_t), path);
    }
    ++current;
    started_current = false;
  }

  void append(const std::byte* p, size_t n) {
    if (!compressed()) {
      write_out(p, n);
      return;
    }
    const size_t batch_bytes = batch_blocks * size_t(options.block_size);
    while (n > 0) {
      const size_t take = std::min(n, batch_bytes - pending.size());
      pending.insert(pending.end(), p, p + take);
      p += take;
      n -= take;
      if (pending.size() == batch_bytes) flush_blocks(false);
    }
  }

  // Arrays of zero bytes complete as soon as they are reached.
  void skip_empty_arrays() {
    while (current < arrays.size() && arrays[current].byte_size() == 0) {
      if (!started_current) begin_array();
      end_array();
    }
  }
};

VtuStreamWriter::VtuStreamWriter(const std::string& path, uint64_t points, uint64_t cells,
                                 std::vector<VtuArraySpec> arrays, const VtuStreamOptions& options) {
  validate_specs(path, points, cells, arrays);
  if (options.block_size == 0 || options.block_size > (uint64_t(1) << 30)) {
    fail_in(path, "compression block size must be between 1 byte and 1 GiB");
  }
  impl_ = std::make_unique<Impl>(path, points, cells, std::move(arrays), options);
  Impl& m = *impl_;
  m.offsets.assign(m.arrays.size(), 0);
  if (m.compressed()) {
    m.scratch.emplace(path);
    // Enough blocks per batch to keep every core compressing, few enough to keep memory small.
    m.batch_blocks = size_t(std::clamp(tbb::this_task_arena::max_concurrency(), 1, 8));
    m.pending.reserve(m.batch_blocks * size_t(options.block_size));
  } else {
    uint64_t at = 0;
    for (size_t a = 0; a < m.arrays.size(); ++a) {
      m.offsets[a] = at;
      at += sizeof(uint64_t) + m.arrays[a].byte_size();
    }
    m.out.write(xml_header(points, cells, m.arrays, m.offsets, Codec::None));
  }
  m.skip_empty_arrays();
}

VtuStreamWriter::~VtuStreamWriter() = default;

size_t VtuStreamWriter::current_array() const { return impl_->current; }
const std::vector<VtuArraySpec>& VtuStreamWriter::arrays() const { return impl_->arrays; }

void VtuStreamWriter::check_type(ScalarType t) const {
  const Impl& m = *impl_;
  if (m.current >= m.arrays.size()) fail_in(m.path, "values written after the last array was complete");
  if (m.arrays[m.current].type != t) {
    fail_in(m.path, "array '" + m.arrays[m.current].name + "' is " +
                        std::string(scalar_type_name(m.arrays[m.current].type)) + ", got " +
                        std::string(scalar_type_name(t)) + " values");
  }
}

void VtuStreamWriter::write_bytes(std::span<const std::byte> bytes) {
  Impl& m = *impl_;
  const std::byte* p = bytes.data();
  size_t n = bytes.size();
  while (n > 0) {
    if (m.current >= m.arrays.size()) {
      fail_in(m.path, std::to_string(n) + " bytes written after the last array was complete");
    }
    if (!m.started_current) m.begin_array();
    const uint64_t left = m.arrays[m.current].byte_size() - m.done_in_current;
    const size_t take = size_t(std::min<uint64_t>(left, n));
    m.append(p, take);
    m.done_in_current += take;
    p += take;
    n -= take;
    if (m.done_in_current == m.arrays[m.current].byte_size()) {
      m.end_array();
      m.skip_empty_arrays();
    }
  }
}

uint64_t VtuStreamWriter::commit() {
  Impl& m = *impl_;
  if (m.current < m.arrays.size()) {
    const VtuArraySpec& s = m.arrays[m.current];
    fail_in(m.path, "array '" + s.name + "' is incomplete: " + std::to_string(m.done_in_current) + " of " +
                        std::to_string(s.byte_size()) + " bytes written");
  }
  if (m.compressed()) {
    m.out.write(xml_header(m.points, m.cells, m.arrays, m.offsets, m.options.codec));
    std::vector<std::byte> buf(kMaxWritePiece);
    for (uint64_t at = 0; at < m.scratch_end;) {
      const size_t want = size_t(std::min<uint64_t>(buf.size(), m.scratch_end - at));
      const size_t got = m.scratch->read_at(at, buf.data(), want, m.path);
      if (got == 0) fail_in(m.path, "scratch file ended early");
      m.out.write(buf.data(), got);
      at += got;
    }
  }
  m.out.write(kTrailer);
  const uint64_t size = m.out.position();
  m.out.commit();
  return size;
}

VtuArraySpec vtu_points_spec(uint64_t points, ScalarType type) {
  return {"Points", type, 3, points, VtuSection::Points};
}
VtuArraySpec vtu_connectivity_spec(uint64_t indices, ScalarType type) {
  return {"connectivity", type, 1, indices, VtuSection::Cells};
}
VtuArraySpec vtu_offsets_spec(uint64_t cells) { return {"offsets", ScalarType::Int64, 1, cells, VtuSection::Cells}; }
VtuArraySpec vtu_types_spec(uint64_t cells) { return {"types", ScalarType::UInt8, 1, cells, VtuSection::Cells}; }
ScalarType vtu_connectivity_type(uint64_t points) {
  return points > uint64_t(INT32_MAX) ? ScalarType::Int64 : ScalarType::Int32;
}

// ---------------------------------------------------------------------------------------------------------------------
// write_vtu: a Dataset already in memory, streamed through VtuStreamWriter.

namespace {

constexpr size_t kConvertChunk = size_t(1) << 16;  // values converted per step (connectivity, offsets)

// `values` shifted by `base` (a block's point ids or connectivity offsets, placed after the blocks before it), in the
// file's type Out, a chunk at a time.
template <class Out, class In, class Put>
void write_shifted(Put& put, std::span<const In> values, uint64_t base) {
  std::vector<Out> buf;
  buf.reserve(kConvertChunk);
  for (size_t at = 0; at < values.size(); at += kConvertChunk) {
    const size_t end = std::min(values.size(), at + kConvertChunk);
    buf.clear();
    for (size_t i = at; i < end; ++i) buf.push_back(Out(base + values[i]));
    put(std::as_bytes(std::span(buf)));
  }
}

// The fields of the first block, each of which every other block must have with the same type and components.
std::vector<const Field*> common_fields(const std::vector<const Block*>& blocks, const std::string& path) {
  std::vector<const Field*> fields;
  for (const Field& f : blocks[0]->fields) fields.push_back(&f);
  for (size_t b = 1; b < blocks.size(); ++b) {
    const FieldSet& fs = blocks[b]->fields;
    bool same = fs.size() == fields.size();
    for (const Field* f : fields) {
      const Field* g = fs.find(f->name(), f->association());
      same = same && g && g->data().type() == f->data().type() && g->components() == f->components();
    }
    if (!same) {
      fail_in(path, "cannot write blocks '" + blocks[0]->name + "' and '" + blocks[b]->name +
                        "' as one piece: their fields differ (names, types or components)");
    }
  }
  return fields;
}

}  // namespace

uint64_t write_vtu(const Dataset& ds, const std::string& path, const VtuWriteOptions& options) {
  if (ds.blocks.empty()) fail_in(path, "nothing to write: the dataset has no blocks");

  // Unstructured blocks are used in place; the others get explicit hexahedra.
  std::vector<Block> converted;
  converted.reserve(ds.blocks.size());
  std::vector<const Block*> blocks;
  for (const Block& b : ds.blocks) {
    b.validate_fields(path);
    if (std::holds_alternative<UnstructuredMesh>(b.grid)) {
      blocks.push_back(&b);
    } else {
      converted.push_back(to_unstructured_block(b, StructuredCellShape::Hexahedra));
      blocks.push_back(&converted.back());
    }
  }
  const std::vector<const Field*> fields = common_fields(blocks, path);

  auto mesh_of = [](const Block* b) -> const UnstructuredMesh& { return std::get<UnstructuredMesh>(b->grid); };
  uint64_t points = 0, cells = 0, indices = 0;
  for (const Block* b : blocks) {
    points += mesh_of(b).point_count();
    cells += mesh_of(b).cell_count();
    indices += mesh_of(b).connectivity.size();
  }
  const ScalarType index_type = vtu_connectivity_type(points);

  std::vector<VtuArraySpec> specs = {vtu_points_spec(points), vtu_connectivity_spec(indices, index_type),
                                     vtu_offsets_spec(cells), vtu_types_spec(cells)};
  for (const Field* f : fields) {
    const bool vertex = f->association() == Association::Vertex;
    specs.push_back({f->name(), f->data().type(), f->components(), vertex ? points : cells,
                     vertex ? VtuSection::PointData : VtuSection::CellData});
  }

  uint64_t total_bytes = 0;
  for (const VtuArraySpec& s : specs) total_bytes += s.byte_size();
  VtuStreamWriter w(path, points, cells, std::move(specs), {options.codec, options.level});
  Progress progress("write " + base_name(path), total_bytes);
  auto put = [&](std::span<const std::byte> bytes) {
    w.write_bytes(bytes);
    progress.add(bytes.size());
  };
  for (const Block* b : blocks) put(std::as_bytes(std::span(mesh_of(b).points)));
  uint64_t base = 0;
  for (const Block* b : blocks) {
    const std::span<const uint32_t> ids(mesh_of(b).connectivity);
    if (index_type == ScalarType::Int32)
      write_shifted<int32_t>(put, ids, base);
    else
      write_shifted<int64_t>(put, ids, base);
    base += mesh_of(b).point_count();
  }
  base = 0;
  for (const Block* b : blocks) {
    const std::span<const uint64_t> offsets(mesh_of(b).cell_offsets);  // the file holds where each cell ends
    write_shifted<int64_t>(put, offsets.subspan(std::min<size_t>(1, offsets.size())), base);
    base += mesh_of(b).connectivity.size();
  }
  for (const Block* b : blocks) put(std::as_bytes(std::span(mesh_of(b).cell_types)));
  for (const Field* f : fields) {
    for (const Block* b : blocks) {
      const DataArray& data = b->fields.find(f->name(), f->association())->data();
      put(std::span<const std::byte>(data.bytes(), size_t(data.byte_size())));
    }
  }
  const uint64_t size = w.commit();
  progress.finish();
  return size;
}

}  // namespace ugvr
