// DataArray: a typed, tuple-organised array of numbers kept in the type it was stored in (a float32 field stays
// float32; an int8 flag array stays int8). Layout: `tuples` x `components` values, tuple-major (the components of a
// tuple are adjacent), exactly as in VTK files, so readers fill it with one copy.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <variant>
#include <vector>

namespace ugvr {

enum class ScalarType : uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64 };

size_t scalar_size(ScalarType t);
// VTK XML names: "Int8" ... "Float64".
std::string_view scalar_type_name(ScalarType t);
// Accepts the VTK XML names plus legacy VTK names ("float", "double", "int", "unsigned_char", "vtktypeint64", ...).
std::optional<ScalarType> parse_scalar_type(std::string_view name);

template <class T>
constexpr ScalarType scalar_type_of();

class DataArray {
 public:
  DataArray() = default;
  // Zero-filled array.
  DataArray(ScalarType type, int components, uint64_t tuples);
  template <class T>
  static DataArray from(std::vector<T> values, int components) {
    DataArray a;
    a.components_ = components;
    a.tuples_ = components ? values.size() / uint64_t(components) : 0;
    a.storage_ = std::move(values);
    return a;
  }

  ScalarType type() const { return ScalarType(storage_.index()); }
  int components() const { return components_; }
  uint64_t tuples() const { return tuples_; }
  uint64_t value_count() const { return tuples_ * uint64_t(components_); }
  uint64_t byte_size() const { return value_count() * scalar_size(type()); }
  std::byte* bytes();
  const std::byte* bytes() const;

  // Typed access; the requested type must match type().
  template <class T>
  std::span<T> values() {
    return std::get<std::vector<T>>(storage_);
  }
  template <class T>
  std::span<const T> values() const {
    return std::get<std::vector<T>>(storage_);
  }
  // Calls f(std::span<const T>) with the array's own element type.
  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit([&](const auto& v) { return f(std::span(v)); }, storage_);
  }
  template <class F>
  decltype(auto) visit(F&& f) {
    return std::visit([&](auto& v) { return f(std::span(v)); }, storage_);
  }

  // Generic element access (slow path: tests, I/O of small arrays).
  double get(uint64_t tuple, int component) const;
  void set(uint64_t tuple, int component, double value);

  // Keeps only the listed tuples, in the given order.
  DataArray gather(std::span<const uint64_t> tuple_ids) const;
  // Element-wise equality of type, shape and values (NaNs compare equal bitwise).
  bool operator==(const DataArray& other) const;

 private:
  using Storage = std::variant<std::vector<int8_t>, std::vector<uint8_t>, std::vector<int16_t>, std::vector<uint16_t>,
                               std::vector<int32_t>, std::vector<uint32_t>, std::vector<int64_t>, std::vector<uint64_t>,
                               std::vector<float>, std::vector<double>>;
  Storage storage_;
  int components_ = 1;
  uint64_t tuples_ = 0;
};

template <class T>
constexpr ScalarType scalar_type_of() {
  if constexpr (std::is_same_v<T, int8_t>)
    return ScalarType::Int8;
  else if constexpr (std::is_same_v<T, uint8_t>)
    return ScalarType::UInt8;
  else if constexpr (std::is_same_v<T, int16_t>)
    return ScalarType::Int16;
  else if constexpr (std::is_same_v<T, uint16_t>)
    return ScalarType::UInt16;
  else if constexpr (std::is_same_v<T, int32_t>)
    return ScalarType::Int32;
  else if constexpr (std::is_same_v<T, uint32_t>)
    return ScalarType::UInt32;
  else if constexpr (std::is_same_v<T, int64_t>)
    return ScalarType::Int64;
  else if constexpr (std::is_same_v<T, uint64_t>)
    return ScalarType::UInt64;
  else if constexpr (std::is_same_v<T, float>)
    return ScalarType::Float32;
  else if constexpr (std::is_same_v<T, double>)
    return ScalarType::Float64;
  else
    static_assert(sizeof(T) == 0, "unsupported scalar type");
}

}  // namespace ugvr
