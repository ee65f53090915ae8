#include "ugvr/io/vtk_xml_document.h"

#include <algorithm>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"

namespace ugvr::vtk_xml {

namespace {

XmlEncoding parse_encoding(const XmlDoc& d) {
  XmlEncoding e;
  const std::string order = d.root.attribute("byte_order").value();
  if (order == "BigEndian")
    e.big_endian = true;
  else if (!order.empty() && order != "LittleEndian")
    d.fail(d.root, "byte_order=\"" + order.substr(0, 40) + "\" is neither LittleEndian nor BigEndian");
  const std::string header = d.root.attribute("header_type").value();
  if (header == "UInt64")
    e.header_uint64 = true;
  else if (!header.empty() && header != "UInt32")
    d.fail(d.root, "header_type=\"" + header.substr(0, 40) + "\" is neither UInt32 nor UInt64");
  const std::string compressor = d.root.attribute("compressor").value();
  if (const std::optional<Codec> codec = codec_of_vtk_compressor(compressor))
    e.codec = *codec;
  else
    d.fail(d.root, "compressor \"" + compressor.substr(0, 60) +
                       "\" is not supported (vtkZLibDataCompressor and vtkLZ4DataCompressor are)");
  if (const pugi::xml_node app = d.root.child("AppendedData")) {
    const std::string enc = app.attribute("encoding").value();
    if (enc == "base64")
      e.appended_base64 = true;
    else if (!enc.empty() && enc != "raw")
      d.fail(app, "<AppendedData> encoding=\"" + enc.substr(0, 40) + "\" is neither raw nor base64");
    e.appended_data = d.skeleton.appended_data;
  }
  return e;
}

}  // namespace

void XmlDoc::fail(pugi::xml_node n, const std::string& message) const { fail_at_offset(path, offset(n), message); }

std::unique_ptr<XmlDoc> load_doc(const std::string& path) {
  auto d = std::make_unique<XmlDoc>();
  d->path = path;
  {
    const InputFile file(path);
    d->file_size = file.size();
    d->skeleton = scan_xml_skeleton(file);
  }
  const pugi::xml_parse_result r = d->doc.load_buffer(d->skeleton.markup.data(), d->skeleton.markup.size(),
                                                      pugi::parse_default | pugi::parse_pi, pugi::encoding_utf8);
  if (!r) {
    fail_at_offset(path, d->skeleton.file_offset(uint64_t(std::max<ptrdiff_t>(r.offset, 0))),
                   std::string("malformed XML: ") + r.description());
  }
  std::string().swap(d->skeleton.markup);
  d->root = d->doc.child("VTKFile");
  if (!d->root) fail_in(path, "no <VTKFile> root element: not a VTK XML file");
  d->type = d->root.attribute("type").value();
  d->encoding = parse_encoding(*d);
  return d;
}

std::string element_name(pugi::xml_node n) { return "<" + std::string(n.name()) + ">"; }

uint64_t count_attribute(const XmlDoc& d, pugi::xml_node n, const char* name) {
  const pugi::xml_attribute a = n.attribute(name);
  if (a.empty()) d.fail(n, element_name(n) + " has no " + name + " attribute");
  const auto v = parse_number<uint64_t>(a.value());
  if (!v) {
    d.fail(n, element_name(n) + " attribute " + name + "=\"" + std::string(a.value()).substr(0, 40) +
                  "\" is not a non-negative integer");
  }
  return *v;
}

std::variant<XmlArray, Unsupported> describe_array(const XmlDoc& d, pugi::xml_node n, const std::string& label) {
  XmlArray a;
  a.element_offset = d.offset(n);
  a.name = n.attribute("Name").value();
  a.label = label;
  const std::string type = n.attribute("type").value();
  const auto st = parse_scalar_type(type);
  if (!st) return Unsupported{"type \"" + type.substr(0, 40) + "\""};
  a.type = *st;
  if (const pugi::xml_attribute c = n.attribute("NumberOfComponents")) {
    const auto v = parse_number<int64_t>(c.value());
    if (!v || *v < 1 || *v > kMaxComponents) {
      d.fail(n, label + ": NumberOfComponents=\"" + std::string(c.value()).substr(0, 40) + "\" is not in 1.." +
                    std::to_string(kMaxComponents));
    }
    a.components = int(*v);
  }
  const std::string format = n.attribute("format").value();
  if (format == "appended") {
    a.format = XmlArrayFormat::Appended;
    if (!d.encoding.appended_data) d.fail(n, label + ": format=\"appended\" but the file has no <AppendedData>");
    const uint64_t off = count_attribute(d, n, "offset");
    const uint64_t start = *d.encoding.appended_data;
    if (off > d.file_size - std::min(start, d.file_size)) {
      d.fail(n, label + ": offset " + std::to_string(off) +
                    " points past the end of the file (appended data starts at byte " + std::to_string(start) +
                    ", the file has " + std::to_string(d.file_size) + " bytes)");
    }
    a.begin = start + off;
    a.end = d.file_size;
    return a;
  }
  if (format == "ascii")
    a.format = XmlArrayFormat::Ascii;
  else if (format == "binary")
    a.format = XmlArrayFormat::Binary;
  else
    d.fail(n, label + ": format=\"" + format.substr(0, 40) + "\" is not ascii, binary or appended");
  // The element's text was replaced by a marker with its file range; no marker means no text.
  a.begin = a.end = a.element_offset;
  int markers = 0;
  for (pugi::xml_node c : n.children()) {
    if (c.type() != pugi::node_pi || std::string_view(c.name()) != kXmlTextMarker) continue;
    const auto range = parse_numbers<uint64_t>(c.value(), 2);
    if (!range || ++markers > 1) d.fail(n, label + ": data text interrupted by child elements");
    a.begin = (*range)[0];
    a.end = (*range)[0] + (*range)[1];
  }
  return a;
}

pugi::xml_node data_array(pugi::xml_node parent, std::string_view name) {
  for (pugi::xml_node c : parent.children("DataArray")) {
    if (name.empty() || name == c.attribute("Name").value()) return c;
  }
  return {};
}

pugi::xml_node single_child(const XmlDoc& d, pugi::xml_node parent, const char* tag) {
  const pugi::xml_node first = parent.child(tag);
  if (const pugi::xml_node second = first.next_sibling(tag)) {
    d.fail(second, element_name(parent) + " has more than one <" + tag + "> element");
  }
  return first;
}

pugi::xml_node single_data_array(const XmlDoc& d, pugi::xml_node parent, std::string_view name) {
  pugi::xml_node found;
  for (pugi::xml_node c : parent.children("DataArray")) {
    if (!name.empty() && name != c.attribute("Name").value()) continue;
    if (found) {
      d.fail(c, element_name(parent) + " has more than one <DataArray>" +
                    (name.empty() ? std::string() : " named '" + std::string(name) + "'"));
    }
    found = c;
  }
  return found;
}

XmlArray required_array(const XmlDoc& d, pugi::xml_node n, const std::string& label) {
  auto v = describe_array(d, n, label);
  if (auto* u = std::get_if<Unsupported>(&v)) d.fail(n, label + ": unsupported " + u->reason);
  return std::get<XmlArray>(std::move(v));
}

}  // namespace ugvr::vtk_xml
