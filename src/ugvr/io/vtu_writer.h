// Writing VTK XML UnstructuredGrid (.vtu) files, streaming, in bounded memory.
//
// File layout (one Piece, appended binary data, header_type="UInt64", byte_order="LittleEndian"):
//
//   <?xml version="1.0"?>
//   <VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64"
//            [compressor="vtkZLibDataCompressor" | "vtkLZ4DataCompressor"]>
//     <UnstructuredGrid>
//       <Piece NumberOfPoints="N" NumberOfCells="C">
//         <PointData> <DataArray type=".." Name=".." NumberOfComponents=".." format="appended" offset=".."/> ...
//         <CellData>  ...
//         <Points>    <DataArray type="Float32" Name="Points" NumberOfComponents="3" .../>
//         <Cells>     connectivity, offsets (C end offsets), types (UInt8 VTK cell ids)
//       </Piece>
//     </UnstructuredGrid>
//     <AppendedData encoding="raw">
//      _<array 0><array 1>...
//     </AppendedData>
//   </VTKFile>
//
// Each array's `offset` counts bytes from the first byte after the '_'. The arrays lie in the appended section in the
// order they were declared (which need not be the XML order). An array is stored as
//   - uncompressed: UInt64 byte count, then the values;
//   - compressed:   UInt64 header [number of blocks, block size, size of a partial last block (0 if the last block is
//                   full), compressed size of each block], then the compressed blocks (each block compressed on its
//                   own, as vtkZLibDataCompressor / vtkLZ4DataCompressor do).
//
// Streaming: the caller declares the piece and every array up front, then streams the values of each array in
// declaration order, in chunks of any size. Uncompressed, every offset is known from the declarations, so the XML
// header is written first and the values go straight to the file. Compressed sizes are known only afterwards, so the
// appended section is built in an anonymous temporary file beside the output (unlinked at once, so nothing is left
// behind even on a crash) and copied after the header at the end. Either way memory stays bounded by a few block
// buffers, never by the size of the mesh, and the output goes through AtomicOutputFile: the target path only ever
// holds a complete file.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/codec.h"

namespace ugvr {

enum class VtuSection : uint8_t { Points, Cells, PointData, CellData };

// One DataArray of the piece. For Cells the name must be "connectivity", "offsets" or "types".
struct VtuArraySpec {
  std::string name;
  ScalarType type = ScalarType::Float32;
  int components = 1;
  uint64_t tuples = 0;
  VtuSection section = VtuSection::PointData;

  uint64_t byte_size() const { return tuples * uint64_t(components) * scalar_size(type); }
};

struct VtuStreamOptions {
  Codec codec = Codec::None;
  int level = 0;                            // codec level (see compress()); <= 0 picks the codec's default
  uint64_t block_size = uint64_t(1) << 20;  // uncompressed bytes per compressed block (VTK readers accept any size)
};

// Streams one UnstructuredGrid piece to `path`. Declared arrays must include exactly one Points array (3 components,
// Float32 or Float64, one tuple per point) and the three Cells arrays (connectivity of any integer type, offsets
// with one tuple per cell, types UInt8 with one tuple per cell); PointData / CellData arrays need one tuple per point /
// cell. Throws ugvr::Error on a bad declaration, on values that do not fit the current array, and on I/O failure.
// If commit() is not reached (exception, early return), nothing appears at `path`.
class VtuStreamWriter {
 public:
  VtuStreamWriter(const std::string& path, uint64_t points, uint64_t cells, std::vector<VtuArraySpec> arrays,
                  const VtuStreamOptions& options = {});
  ~VtuStreamWriter();
  VtuStreamWriter(const VtuStreamWriter&) = delete;
  VtuStreamWriter& operator=(const VtuStreamWriter&) = delete;

  // Appends raw little-endian values to the current array, moving on to the next array when one is complete. A
  // chunk may span the end of one array and the start of the next.
  void write_bytes(std::span<const std::byte> bytes);
  // Typed append: T must be the current array's type (checked).
  template <class T>
  void write(std::span<const T> values) {
    check_type(scalar_type_of<T>());
    write_bytes(std::as_bytes(values));
  }

  // Index of the array now being written (== number of arrays once all are complete).
  size_t current_array() const;
  const std::vector<VtuArraySpec>& arrays() const;
  // Checks every array was written in full, finishes the file and renames it into place. Returns the file size.
  uint64_t commit();

 private:
  void check_type(ScalarType t) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Convenience declarations of the mandatory arrays.
VtuArraySpec vtu_points_spec(uint64_t points, ScalarType type = ScalarType::Float32);
VtuArraySpec vtu_connectivity_spec(uint64_t indices, ScalarType type);
VtuArraySpec vtu_offsets_spec(uint64_t cells);
VtuArraySpec vtu_types_spec(uint64_t cells);
// Int32 when every point index fits in an Int32, else Int64.
ScalarType vtu_connectivity_type(uint64_t points);

struct VtuWriteOptions {
  Codec codec = Codec::None;
  int level = 0;
};

// Writes the dataset as a single UnstructuredGrid piece. Unstructured blocks are written as they are; structured,
// uniform and rectilinear blocks become hexahedra (to_unstructured_block; IBLANK becomes an Int32 vertex field and
// blanked cells are dropped). Several blocks are concatenated into one mesh (point ids offset), which requires every
// block to have the same fields (name, association, type, components); otherwise ugvr::Error. Points are Float32,
// connectivity Int32 (Int64 above INT32_MAX points), offsets Int64, types UInt8, fields in their own type.
// Returns the size of the file written.
uint64_t write_vtu(const Dataset& ds, const std::string& path, const VtuWriteOptions& options = {});

}  // namespace ugvr
