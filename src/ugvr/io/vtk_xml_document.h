// The markup of one VTK XML file, parsed, and what its readers look up there alike: attribute numbers, the encoding
// <VTKFile> and <AppendedData> declare, and where each <DataArray>'s values lie (read them with XmlArrayReader,
// vtk_xml_array.h). Shared by the VTK XML reader and by the out-of-core octree build, which streams the arrays of a
// .vtu itself. Errors throw ugvr::Error naming the file and the byte offset of the element.
#pragma once

#include <charconv>
#include <cstdint>
#include <memory>
#include <optional>
#include <pugixml.hpp>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "ugvr/io/vtk_xml_array.h"
#include "ugvr/io/vtk_xml_skeleton.h"

namespace ugvr::vtk_xml {

inline constexpr int kMaxComponents = 1 << 20;

// s without the white space around it.
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\n' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\n' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

// An attribute's number, white space around it and a leading '+' allowed; nullopt unless it is one whole T.
template <class T>
std::optional<T> parse_number(std::string_view s) {
  s = trim(s);
  if (s.starts_with('+')) s.remove_prefix(1);
  T v{};
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// Whitespace-separated numbers of an attribute; nullopt unless there are exactly `n` of them.
template <class T>
std::optional<std::vector<T>> parse_numbers(std::string_view s, size_t n) {
  std::vector<T> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::string_view(" \t\r\n").find(s[i]) != std::string_view::npos) ++i;
    size_t e = i;
    while (e < s.size() && std::string_view(" \t\r\n").find(s[e]) == std::string_view::npos) ++e;
    if (e > i) {
      const auto v = parse_number<T>(s.substr(i, e - i));
      if (!v || out.size() == n) return std::nullopt;
      out.push_back(*v);
    }
    i = e;
  }
  if (out.size() != n) return std::nullopt;
  return out;
}

// Parsed markup of one file.
struct XmlDoc {
  std::string path;
  uint64_t file_size = 0;
  pugi::xml_document doc;
  XmlSkeleton skeleton;  // markup released after parsing; origins kept for messages
  XmlEncoding encoding;
  pugi::xml_node root;  // <VTKFile>
  std::string type;     // VTKFile's type attribute

  // File offset of the element's tag.
  uint64_t offset(pugi::xml_node n) const {
    const ptrdiff_t o = n.offset_debug();
    return o < 0 ? 0 : skeleton.file_offset(uint64_t(o));
  }
  // Fails at the element's tag.
  [[noreturn]] void fail(pugi::xml_node n, const std::string& message) const;
};

// Scans and parses the markup of the file at `path` (the markup itself is then released, its origins kept for
// messages) and reads its encoding; fails unless the root is <VTKFile>.
std::unique_ptr<XmlDoc> load_doc(const std::string& path);

// "<Name>", for messages.
std::string element_name(pugi::xml_node n);
// A non-negative integer attribute, which must be there.
uint64_t count_attribute(const XmlDoc& d, pugi::xml_node n, const char* name);

// Why an array was not described: its type has no place in the model (skipped with a warning), or it is malformed.
struct Unsupported {
  std::string reason;
};

// The layout of one <DataArray>: its type, components and where its values lie.
std::variant<XmlArray, Unsupported> describe_array(const XmlDoc& d, pugi::xml_node n, const std::string& label);
// The first <DataArray> child (Points, Coordinates) or the one with the given Name (Cells).
pugi::xml_node data_array(pugi::xml_node parent, std::string_view name = {});
// The <tag> child of `parent` (null when there is none); fails when there are several: a repeated <Points>, <Cells>,
// <PointData>, ... would otherwise be silently ignored, the first one winning.
pugi::xml_node single_child(const XmlDoc& d, pugi::xml_node parent, const char* tag);
// data_array, failing when several <DataArray>s match (a second one under <Points>, or a second 'connectivity').
pugi::xml_node single_data_array(const XmlDoc& d, pugi::xml_node parent, std::string_view name = {});
// describe_array, failing for an unsupported type.
XmlArray required_array(const XmlDoc& d, pugi::xml_node n, const std::string& label);

}  // namespace ugvr::vtk_xml
