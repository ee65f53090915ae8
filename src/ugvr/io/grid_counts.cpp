// grid_counts_from_headers (reader.h): what each format's header says of its size, read without the data.
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/io/header_counts.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/saturating_size.h"

namespace ugvr {
namespace {

namespace fs = std::filesystem;

// The first `bytes` of a file (fewer when it is shorter).
std::string file_head(const std::string& path, size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail_in(path, "cannot open");
  std::string head(bytes, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  return head;
}

// The value of `name="N"` in `tag`, or nullopt.
std::optional<uint64_t> attribute(std::string_view tag, const std::string& name) {
  const size_t at = tag.find(" " + name + "=\"");
  if (at == std::string::npos) return std::nullopt;
  const std::string digits(tag.substr(at + name.size() + 3, 24));
  const char* begin = digits.c_str();
  char* end = nullptr;
  const unsigned long long v = std::strtoull(begin, &end, 10);
  if (end == begin || *end != '"') return std::nullopt;
  return uint64_t(v);
}

// A .vtu's counts from its <Piece> tags in its first 64 KiB (every file ugvr and VTK write has them there: the
// appended data comes after the XML), summed over the pieces.
std::optional<GridCounts> vtu_counts(const std::string& path) {
  const std::string head = file_head(path, 64 * 1024);
  GridCounts counts;
  bool any = false;
  for (size_t piece = head.find("<Piece "); piece != std::string::npos; piece = head.find("<Piece ", piece + 1)) {
    const size_t close = head.find('>', piece);
    if (close == std::string::npos) return std::nullopt;  // cut at 64 KiB: not all pieces are known
    const std::string_view tag(head.data() + piece, close - piece);
    const auto points = attribute(tag, "NumberOfPoints"), cells = attribute(tag, "NumberOfCells");
    if (!points || !cells) return std::nullopt;
    counts.points = sat_add(counts.points, *points), counts.cells = sat_add(counts.cells, *cells);
    any = true;
  }
  if (!any) return std::nullopt;
  return counts;
}

// A .pvtu's counts: its pieces' (their Source paths are relative to the .pvtu).
std::optional<GridCounts> pvtu_counts(const std::string& path) {
  constexpr size_t kMaxIndex = 16 << 20;  // a .pvtu lists its pieces in a few KiB; more is not one
  const std::string text = file_head(path, kMaxIndex);
  GridCounts counts;
  bool any = false;
  for (size_t piece = text.find("<Piece "); piece != std::string::npos; piece = text.find("<Piece ", piece + 1)) {
    const size_t close = text.find('>', piece);
    if (close == std::string::npos) return std::nullopt;
    const std::string_view tag(text.data() + piece, close - piece);
    const size_t at = tag.find(" Source=\"");
    if (at == std::string::npos) return std::nullopt;
    const size_t end = tag.find('"', at + 9);
    if (end == std::string::npos) return std::nullopt;
    const fs::path source(std::string(tag.substr(at + 9, end - at - 9)));
    const fs::path file = source.is_absolute() ? source : fs::path(path).parent_path() / source;
    const std::optional<GridCounts> c = vtu_counts(file.string());
    if (!c) return std::nullopt;
    counts.points = sat_add(counts.points, c->points), counts.cells = sat_add(counts.cells, c->cells);
    any = true;
  }
  if (!any) return std::nullopt;
  return counts;
}

}  // namespace

std::optional<GridCounts> grid_counts_from_headers(std::span<const std::string> paths) {
  if (paths.size() != 1) return std::nullopt;  // PLOT3D's grid and solution: not counted
  const std::string& path = paths[0];
  switch (detect_format(paths)) {
    case InputFormat::VtkXml: {
      const std::string ext = fs::path(path).extension().string();
      if (ext == ".vtu") return vtu_counts(path);
      if (ext == ".pvtu") return pvtu_counts(path);
      return std::nullopt;
    }
    case InputFormat::Exodus: return exodus_header_counts(path);
    case InputFormat::Cgns: return cgns_header_counts(path);
    case InputFormat::OpenFoam: return openfoam_header_counts(path);
    default: return std::nullopt;
  }
}

}  // namespace ugvr
