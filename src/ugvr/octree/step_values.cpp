#include "ugvr/octree/step_values.h"

#include <algorithm>

#include "ugvr/core/error.h"

namespace ugvr {
namespace {

// The distinct ids of a batch of records in ascending order, and each id's index among them: through a table over
// their range when it is not much larger than the references (the ids of a node of an ordered mesh: linear time), else
// by sorting (as weld_soup_records does).
template <class T>
class DistinctIds {
 public:
  explicit DistinctIds(std::vector<T> refs) : ids_(std::move(refs)) {
    if (ids_.empty()) return;
    const auto [lo, hi] = std::minmax_element(ids_.begin(), ids_.end());
    first_ = *lo;
    const uint64_t range = uint64_t(*hi) - uint64_t(*lo) + 1;
    if (range <= 4 * uint64_t(ids_.size())) {
      local_of_.assign(range, 0);
      for (T id : ids_) local_of_[id - first_] = 1;
      ids_.clear();
      for (uint64_t r = 0; r < range; ++r)
        if (local_of_[r]) local_of_[r] = uint32_t(ids_.size()), ids_.push_back(T(first_ + r));
      return;
    }
    std::sort(ids_.begin(), ids_.end());
    ids_.erase(std::unique(ids_.begin(), ids_.end()), ids_.end());
  }
  const std::vector<T>& ids() const { return ids_; }
  size_t index(T id) const {
    return local_of_.empty() ? size_t(std::lower_bound(ids_.begin(), ids_.end(), id) - ids_.begin())
                             : local_of_[id - first_];
  }

 private:
  std::vector<T> ids_;
  std::vector<uint32_t> local_of_;
  T first_ = 0;
};

// The values at `ids` (ascending, distinct, each below the file's length) of a value file, read in runs: ids at most
// kGap apart share a read (reading through a small gap is cheaper than another call), up to kRun values a read.
template <class T>
void gather(const InputFile& file, std::span<const T> ids, float* out) {
  constexpr uint64_t kGap = 1024, kRun = uint64_t(1) << 16;
  std::vector<float> run;
  for (size_t s = 0; s < ids.size();) {
    size_t e = s + 1;
    while (e < ids.size() && uint64_t(ids[e] - ids[e - 1]) <= kGap && uint64_t(ids[e] - ids[s]) < kRun) ++e;
    const uint64_t first = ids[s], count = uint64_t(ids[e - 1] - ids[s]) + 1;
    run.resize(size_t(count));
    file.read_at(first * sizeof(float), run.data(), size_t(count) * sizeof(float));
    for (size_t j = s; j < e; ++j) out[j] = run[size_t(ids[j] - first)];
    s = e;
  }
}

template <class T>
void check_below(const std::string& path, const std::vector<T>& ids, uint64_t count, const char* what) {
  if (!ids.empty() && uint64_t(ids.back()) >= count)
    fail_in(path, std::string("a record names ") + what + " " + std::to_string(ids.back()) + ", beyond the step's " +
                      std::to_string(count) + ": the records are not of this step's mesh");
}

// Reads the values of `files` (one per field) at the distinct ids of `refs` (one per record, or per corner) and
// writes them into the records through `put(record, cell, ref index within the record, field, value)`.
template <class T, class Visit, class Put>
void fill(const SoupLayout& layout, std::span<std::byte> records, std::span<const size_t> offsets,
          const std::vector<InputFile>& files, uint64_t count, const char* what, Visit&& ids_of, Put&& put) {
  std::vector<T> refs;
  for (size_t at : offsets) ids_of(SoupCell(records.data() + at, layout), refs);
  const DistinctIds<T> distinct(std::move(refs));
  const std::vector<T>& ids = distinct.ids();
  check_below(files[0].path(), ids, count, what);
  const size_t F = files.size();
  std::vector<float> values(F * ids.size());
  for (size_t f = 0; f < F; ++f) gather<T>(files[f], ids, values.data() + f * ids.size());
  std::vector<T> mine;
  for (size_t at : offsets) {
    std::byte* record = records.data() + at;
    const SoupCell cell(record, layout);
    mine.clear();
    ids_of(cell, mine);
    for (size_t i = 0; i < mine.size(); ++i) {
      const size_t local = distinct.index(mine[i]);
      for (size_t f = 0; f < F; ++f) put(record, cell, i, uint32_t(f), values[f * ids.size() + local]);
    }
  }
}

}  // namespace

std::string step_vertex_values_path(const std::string& prefix, uint32_t field) {
  return prefix + "v" + std::to_string(field);
}

std::string step_cell_values_path(const std::string& prefix, uint32_t field) {
  return prefix + "c" + std::to_string(field);
}

void append_record_geometry(const SoupCell& cell, const SoupLayout& layout, std::vector<std::byte>& out) {
  const int n = cell.vertex_count();
  const size_t geometry = layout.vertex_value_offset(n, 0, 0);  // header, vertex ids and positions: 16 + 16 n
  if (cell.layout() == layout) {
    out.insert(out.end(), cell.data(), cell.data() + cell.bytes());
    return;
  }
  out.insert(out.end(), cell.data(), cell.data() + geometry);
  out.resize(out.size() + layout.record_bytes(n) - geometry, std::byte{0});
}

void ValueFileWriter::append_zeros(uint64_t count) {
  const float zero = 0.0f;
  for (uint64_t i = 0; i < count; ++i) append(&zero, 1);
}

InputFile StepValues::open_values(const std::string& path, uint64_t count) {
  InputFile file(path);
  if (file.size() != count * sizeof(float))
    fail_in(path, "the temporary value file holds " + std::to_string(file.size() / sizeof(float)) + " values, not " +
                      std::to_string(count));
  return file;
}

StepValues::StepValues(const std::string& prefix, const SoupLayout& layout, uint64_t points, uint64_t cells)
    : layout_(layout), points_(points), cells_(cells) {
  for (uint32_t f = 0; f < layout.vertex_fields; ++f)
    vertex_files_.push_back(open_values(step_vertex_values_path(prefix, f), points));
  for (uint32_t f = 0; f < layout.cell_fields; ++f)
    cell_files_.push_back(open_values(step_cell_values_path(prefix, f), cells));
}

StepValues::~StepValues() = default;

void StepValues::put_into(std::span<std::byte> records) const {
  std::vector<size_t> offsets;
  for (size_t at = 0; at < records.size(); at += SoupCell(records.data() + at, layout_).bytes()) offsets.push_back(at);
  if (!vertex_files_.empty())
    fill<uint32_t>(
        layout_, records, offsets, vertex_files_, points_, "point",
        [](const SoupCell& cell, std::vector<uint32_t>& out) {
          for (int i = 0; i < cell.vertex_count(); ++i) out.push_back(cell.vertex(i));
        },
        [&](std::byte* record, const SoupCell& cell, size_t corner, uint32_t f, float v) {
          std::memcpy(record + layout_.vertex_value_offset(cell.vertex_count(), f, int(corner)), &v, sizeof(float));
        });
  if (!cell_files_.empty())
    fill<uint64_t>(
        layout_, records, offsets, cell_files_, cells_, "cell",
        [](const SoupCell& cell, std::vector<uint64_t>& out) { out.push_back(cell.id()); },
        [&](std::byte* record, const SoupCell& cell, size_t, uint32_t f, float v) {
          std::memcpy(record + layout_.cell_value_offset(cell.vertex_count(), f), &v, sizeof(float));
        });
}

}  // namespace ugvr
