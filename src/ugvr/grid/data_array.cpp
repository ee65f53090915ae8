#include "ugvr/grid/data_array.h"

#include <cstring>
#include <string>

namespace ugvr {

size_t scalar_size(ScalarType t) {
  switch (t) {
    case ScalarType::Int8:
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16: return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32: return 4;
    case ScalarType::Int64:
    case ScalarType::UInt64:
    case ScalarType::Float64: return 8;
  }
  return 0;
}

std::string_view scalar_type_name(ScalarType t) {
  static constexpr std::string_view names[] = {"Int8",   "UInt8", "Int16",  "UInt16",  "Int32",
                                               "UInt32", "Int64", "UInt64", "Float32", "Float64"};
  return names[size_t(t)];
}

std::optional<ScalarType> parse_scalar_type(std::string_view n) {
  for (int i = 0; i <= int(ScalarType::Float64); ++i) {
    if (n == scalar_type_name(ScalarType(i))) return ScalarType(i);
  }
  // Legacy VTK names.
  if (n == "bit") return std::nullopt;
  if (n == "char" || n == "signed_char") return ScalarType::Int8;
  if (n == "unsigned_char") return ScalarType::UInt8;
  if (n == "short") return ScalarType::Int16;
  if (n == "unsigned_short") return ScalarType::UInt16;
  if (n == "int") return ScalarType::Int32;
  if (n == "unsigned_int") return ScalarType::UInt32;
  if (n == "long" || n == "vtktypeint64" || n == "vtkIdType") return ScalarType::Int64;
  if (n == "unsigned_long" || n == "vtktypeuint64") return ScalarType::UInt64;
  if (n == "float") return ScalarType::Float32;
  if (n == "double") return ScalarType::Float64;
  // VTK XML aliases.
  if (n == "Char") return ScalarType::Int8;
  if (n == "UChar") return ScalarType::UInt8;
  return std::nullopt;
}

DataArray::DataArray(ScalarType type, int components, uint64_t tuples) : components_(components), tuples_(tuples) {
  const uint64_t n = tuples * uint64_t(components);
  switch (type) {
    case ScalarType::Int8: storage_ = std::vector<int8_t>(n); break;
    case ScalarType::UInt8: storage_ = std::vector<uint8_t>(n); break;
    case ScalarType::Int16: storage_ = std::vector<int16_t>(n); break;
    case ScalarType::UInt16: storage_ = std::vector<uint16_t>(n); break;
    case ScalarType::Int32: storage_ = std::vector<int32_t>(n); break;
    case ScalarType::UInt32: storage_ = std::vector<uint32_t>(n); break;
    case ScalarType::Int64: storage_ = std::vector<int64_t>(n); break;
    case ScalarType::UInt64: storage_ = std::vector<uint64_t>(n); break;
    case ScalarType::Float32: storage_ = std::vector<float>(n); break;
    case ScalarType::Float64: storage_ = std::vector<double>(n); break;
  }
}

std::byte* DataArray::bytes() {
  return std::visit([](auto& v) { return reinterpret_cast<std::byte*>(v.data()); }, storage_);
}

const std::byte* DataArray::bytes() const {
  return std::visit([](const auto& v) { return reinterpret_cast<const std::byte*>(v.data()); }, storage_);
}

double DataArray::get(uint64_t tuple, int component) const {
  const uint64_t i = tuple * uint64_t(components_) + uint64_t(component);
  return std::visit([i](const auto& v) { return double(v[i]); }, storage_);
}

void DataArray::set(uint64_t tuple, int component, double value) {
  const uint64_t i = tuple * uint64_t(components_) + uint64_t(component);
  std::visit(
      [i, value](auto& v) {
        using T = typename std::decay_t<decltype(v)>::value_type;
        v[i] = T(value);
      },
      storage_);
}

DataArray DataArray::gather(std::span<const uint64_t> ids) const {
  DataArray out;
  out.components_ = components_;
  out.tuples_ = ids.size();
  const size_t nc = size_t(components_);
  out.storage_ = std::visit(
      [&](const auto& v) -> Storage {
        std::decay_t<decltype(v)> g(ids.size() * nc);
        for (size_t t = 0; t < ids.size(); ++t) {
          for (size_t c = 0; c < nc; ++c) g[t * nc + c] = v[ids[t] * nc + c];
        }
        return g;
      },
      storage_);
  return out;
}

bool DataArray::operator==(const DataArray& o) const {
  return type() == o.type() && components_ == o.components_ && tuples_ == o.tuples_ &&
         (byte_size() == 0 || std::memcmp(bytes(), o.bytes(), byte_size()) == 0);
}

}  // namespace ugvr
