// Block compression codecs used by VTK XML files (vtkZLibDataCompressor, vtkLZ4DataCompressor) and, later, by the
// brick store. Thin wrappers over zlib and liblz4 that fail with the file and offset of a corrupt block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace ugvr {

enum class Codec : uint8_t { None, Zlib, Lz4 };

// The compressor attribute of a VTK XML file naming a codec: "vtkZLibDataCompressor", "vtkLZ4DataCompressor", and ""
// (no attribute) for None.
std::string_view vtk_compressor_name(Codec codec);
// The codec a compressor attribute names; nullopt for a compressor that is not supported.
std::optional<Codec> codec_of_vtk_compressor(std::string_view name);

// Decompresses `src` into exactly dst.size() bytes. `file` and `offset` (of the block in the file) name a corrupt
// block in the error.
void decompress(Codec codec, std::span<const std::byte> src, std::span<std::byte> dst, std::string_view file,
                uint64_t offset);
// Compresses `src`; level is the codec's own (zlib 1..9, lz4 acceleration >= 1; <= 0 picks the default).
std::vector<std::byte> compress(Codec codec, std::span<const std::byte> src, int level = 0);

}  // namespace ugvr
