// IdMap: a file's arbitrary node ids -> dense vertex indices, in the order the nodes were added. Files nearly always
// number consecutively, which costs an offset; any other numbering falls back to a hash map.
#pragma once

#include <cstdint>
#include <optional>
#include <unordered_map>

namespace ugvr {

class IdMap {
 public:
  // Adds the next index for `id`; false if the id is already there.
  bool add(int64_t id) {
    if (!hashed_) {
      if (size_ == 0) first_ = id;
      if (uint64_t(id) - uint64_t(first_) == size_) {
        ++size_;
        return true;
      }
      hashed_ = true;
      map_.reserve(size_ * 2);
      for (uint64_t i = 0; i < size_; ++i) map_.emplace(int64_t(uint64_t(first_) + i), uint32_t(i));
    }
    if (!map_.emplace(id, uint32_t(size_)).second) return false;
    ++size_;
    return true;
  }
  std::optional<uint32_t> find(int64_t id) const {
    if (!hashed_) {
      const uint64_t d = uint64_t(id) - uint64_t(first_);
      if (d < size_) return uint32_t(d);
      return std::nullopt;
    }
    const auto it = map_.find(id);
    if (it == map_.end()) return std::nullopt;
    return it->second;
  }
  uint64_t size() const { return size_; }

 private:
  bool hashed_ = false;
  int64_t first_ = 0;
  uint64_t size_ = 0;
  std::unordered_map<int64_t, uint32_t> map_;
};

}  // namespace ugvr
