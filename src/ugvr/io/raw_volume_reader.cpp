// Headerless raw voxel volume: `header_bytes` bytes skipped, then NX*NY*NZ values of one type, x fastest, in one
// byte order. The layout is not in the file (it comes from RawVolumeOptions, i.e. the command line), so the only
// check the file allows is its size, and that check is exact: a file of any other size than header + NX*NY*NZ *
// type size means the layout given is wrong, and reading it anyway would show a scrambled volume.
// Result: an ImageGrid (dims are point dims) with one vertex field "values" in the stored type.
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/io/byte_swap.h"
#include "ugvr/io/reader.h"

namespace ugvr {
namespace {

std::optional<ScalarType> raw_type(const std::string& name) {
  static constexpr std::pair<const char*, ScalarType> kNames[] = {
      {"int8", ScalarType::Int8},       {"uint8", ScalarType::UInt8},   {"int16", ScalarType::Int16},
      {"uint16", ScalarType::UInt16},   {"int32", ScalarType::Int32},   {"uint32", ScalarType::UInt32},
      {"int64", ScalarType::Int64},     {"uint64", ScalarType::UInt64}, {"float32", ScalarType::Float32},
      {"float64", ScalarType::Float64}, {"float", ScalarType::Float32}, {"double", ScalarType::Float64},
  };
  for (const auto& [n, t] : kNames)
    if (name == n) return t;
  return std::nullopt;
}

}  // namespace

Dataset read_raw_volume(const std::string& path, const RawVolumeOptions& options) {
  InputFile file(path);
  const std::optional<ScalarType> type = raw_type(options.type);
  if (!type) {
    fail_in(path, "unknown raw value type '" + options.type +
                      "' (expected int8 uint8 int16 uint16 int32 uint32 int64 uint64 float32 float64)");
  }
  const auto& d = options.dims;
  if (d[0] < 1 || d[1] < 1 || d[2] < 1) {
    fail_in(path, "raw volume dimensions " + std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " +
                      std::to_string(d[2]) + " must all be at least 1 (give them with --raw-dims NX NY NZ)");
  }
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(options.spacing[a]) || options.spacing[a] <= 0 || !std::isfinite(options.origin[a])) {
      fail_in(path, "raw volume spacing must be positive and finite, origin finite");
    }
  }
  const size_t value_size = scalar_size(*type);
  uint64_t count = 0, bytes = 0, expected = 0;
  if (__builtin_mul_overflow(uint64_t(d[0]) * d[1], uint64_t(d[2]), &count) ||
      __builtin_mul_overflow(count, uint64_t(value_size), &bytes) ||
      __builtin_add_overflow(bytes, options.header_bytes, &expected)) {
    fail_in(path, "raw volume of " + std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " +
                      std::to_string(d[2]) + " " + options.type + " values is larger than 2^64 bytes");
  }
  if (file.size() != expected) {
    fail_in(path, "file size is " + std::to_string(file.size()) + " bytes, but " + std::to_string(d[0]) + " x " +
                      std::to_string(d[1]) + " x " + std::to_string(d[2]) + " " + options.type + " values after a " +
                      std::to_string(options.header_bytes) + "-byte header need exactly " + std::to_string(expected) +
                      " bytes");
  }

  // Straight into the final array: the file size equals the array size, so no guard beyond that is needed.
  DataArray values(*type, 1, count);
  file.read_at(options.header_bytes, values.bytes(), size_t(bytes));
  if (options.big_endian != (std::endian::native == std::endian::big)) swap_bytes(values.bytes(), count, value_size);

  ImageGrid grid;
  grid.dims.points = d;
  grid.origin = {options.origin[0], options.origin[1], options.origin[2]};
  grid.spacing = {options.spacing[0], options.spacing[1], options.spacing[2]};
  Block block;
  block.name = base_name(path);
  block.grid = grid;
  block.fields.add(Field("values", Association::Vertex, std::move(values)));
  Dataset ds;
  ds.format = "raw volume (" + options.type + ", " + (options.big_endian ? "big" : "little") + "-endian, " +
              std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]) +
              (options.header_bytes ? ", " + std::to_string(options.header_bytes) + "-byte header" : "") + ")";
  ds.sources.push_back(path);
  ds.blocks.push_back(std::move(block));
  return ds;
}

}  // namespace ugvr
