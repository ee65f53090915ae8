// The markup of a VTK XML file without its data, small enough to hand to an XML parser whatever the file's size.
//
// A VTK XML file is markup around numbers: inline arrays keep theirs as element text (ascii or base64), appended
// files keep them as raw bytes after "<AppendedData encoding=...>_", which is not XML at all. The scanner streams
// through the file once and keeps only the tags:
//  - every start and end tag is copied verbatim (attributes included);
//  - every text run that is not blank is replaced by a processing instruction <?ugvr-text OFFSET LENGTH?> giving where
//    it lies in the file, so arrays are decoded later straight from the file, chunk by chunk;
//  - comments, processing instructions and DOCTYPEs of the file are dropped (so a file cannot forge a ugvr-text);
//  - at <AppendedData ...> the scanner checks for the '_' marker, records where the data begins, closes the open
//    elements itself and stops: the appended bytes are never scanned.
// Tags keep their nesting (the scanner checks it), so the result is a well-formed document for pugixml.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ugvr/core/file.h"

namespace ugvr {

inline constexpr const char* kXmlTextMarker = "ugvr-text";

struct XmlSkeleton {
  std::string markup;
  // File offset of the first byte after the '_' that starts the appended data, if the file has <AppendedData>.
  std::optional<uint64_t> appended_data;
  // (markup offset, file offset) of each copied tag, sorted, to report parser positions as file offsets.
  std::vector<std::pair<uint64_t, uint64_t>> origins;

  // File offset of the markup at `markup_offset` (the start of the tag containing it).
  uint64_t file_offset(uint64_t markup_offset) const;
};

// Throws ugvr::Error (file and byte offset) for malformed markup: unterminated tags or comments, mismatched end
// tags, a missing '_' after <AppendedData>, CDATA sections, nesting deeper than 256 or markup above 64 MiB.
XmlSkeleton scan_xml_skeleton(const InputFile& file);

}  // namespace ugvr
