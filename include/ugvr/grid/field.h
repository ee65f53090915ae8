// Named fields. A Field is a DataArray attached to the vertices or the cells of one grid, kept in its stored type.
// Renderers consume scalars: a 1-component field is its own scalar; an n-component field offers each component and
// the Euclidean magnitude ("NAME" means the magnitude of a vector, "NAME:k" or "NAME:x|y|z" a component,
// "NAME:magnitude" explicitly). Value ranges are computed once per component and cached (thread-safe).
// Geometry and values are separate: a grid never owns its fields; a Block pairs them (dataset.h).
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/grid/data_array.h"

namespace ugvr {

enum class Association : uint8_t { Vertex, Cell };
std::string_view association_name(Association a);

struct Range {
  double min = 0, max = 0;
  uint64_t nan_count = 0;  // NaN values are skipped and counted
  bool operator==(const Range&) const = default;
};

inline constexpr int kMagnitude = -1;

class Field {
 public:
  Field(std::string name, Association association, DataArray data);
  Field(const Field& other);
  Field(Field&&) noexcept = default;
  Field& operator=(Field other) noexcept;
  ~Field() = default;

  const std::string& name() const { return name_; }
  Association association() const { return association_; }
  const DataArray& data() const { return data_; }
  // Mutable access drops cached ranges.
  DataArray& mutable_data();
  int components() const { return data_.components(); }
  uint64_t tuples() const { return data_.tuples(); }

  // Scalar view: component c in [0, components) or kMagnitude (for 1 component, the value itself).
  double scalar(uint64_t tuple, int component) const;
  // Range of a scalar view over all tuples; computed in parallel on first use, then cached.
  Range range(int component = kMagnitude) const;

 private:
  struct RangeCache {
    std::mutex mutex;
    std::vector<std::optional<Range>> ranges;  // index component+1 (0 = magnitude)
  };
  Range compute_range(int component) const;

  std::string name_;
  Association association_;
  DataArray data_;
  std::unique_ptr<RangeCache> cache_;
};

// A reference to one scalar of a FieldSet, parsed from "NAME", "NAME:k", "NAME:x|y|z" or "NAME:magnitude".
struct ScalarRef {
  const Field* field = nullptr;
  int component = kMagnitude;
};

class FieldSet {
 public:
  void add(Field f);
  size_t size() const { return fields_.size(); }
  bool empty() const { return fields_.empty(); }
  const Field& operator[](size_t i) const { return fields_[i]; }
  Field& operator[](size_t i) { return fields_[i]; }
  auto begin() const { return fields_.begin(); }
  auto end() const { return fields_.end(); }
  auto begin() { return fields_.begin(); }
  auto end() { return fields_.end(); }

  // First field of that name (vertex fields before cell fields when both exist), or nullptr.
  const Field* find(std::string_view name) const;
  const Field* find(std::string_view name, Association a) const;
  // Resolves a scalar selector; throws ugvr::Error listing the available names when it does not match.
  ScalarRef scalar(std::string_view selector) const;
  bool operator==(const FieldSet& other) const;

 private:
  std::vector<Field> fields_;
};

}  // namespace ugvr
