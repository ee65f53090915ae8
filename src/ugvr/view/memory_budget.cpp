#include "ugvr/view/memory_budget.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "ugvr/core/error.h"
#include "ugvr/core/memory.h"
#include "ugvr/io/reader.h"

namespace ugvr::view {
namespace {

namespace fs = std::filesystem;

uint64_t size_on_disk(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    uint64_t total = 0;
    for (auto it = fs::recursive_directory_iterator(path, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec))
      if (it->is_regular_file(ec)) total += it->file_size(ec);
    return total;
  }
  const uint64_t size = fs::file_size(path, ec);
  if (ec) fail_in(path, "cannot read its size: " + ec.message());
  return size;
}

}  // namespace

InCoreEstimate estimate_in_core(const std::vector<std::string>& inputs) {
  InCoreEstimate e;
  for (const std::string& path : inputs) e.input_bytes += size_on_disk(path);
  std::optional<GridCounts> counts;
  try {
    counts = grid_counts_from_headers(inputs);
  } catch (const Error&) {
    // A file the header walk cannot make sense of: its read will say why, in the page and the terminal (the viewer
    // serves first); the estimate falls back to its size.
  }
  if (counts) {
    e.points = counts->points, e.cells = counts->cells;
    e.bytes = uint64_t(kViewFixedBytes + double(e.cells) * kViewBytesPerCell + double(e.points) * kViewBytesPerPoint);
    e.basis = std::to_string(e.cells) + " cells, " + std::to_string(e.points) + " points";
    return e;
  }
  e.bytes = uint64_t(kViewFixedBytes + double(e.input_bytes) * kViewBytesPerInputByte);
  e.basis = format_bytes(e.input_bytes) + " on disk";
  return e;
}

uint64_t parse_byte_size(const std::string& text, const std::string& what) {
  const auto bad = [&] {
    fail_in(what, "\"" + text + "\" is not a byte size (a number of bytes, or with a unit: 512MiB, 12GiB, 800MB)");
  };
  size_t i = 0;
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  const char* begin = text.c_str() + i;
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end == begin || !std::isfinite(v) || v < 0) bad();
  std::string unit;
  for (const char* c = end; *c; ++c)
    if (!std::isspace(static_cast<unsigned char>(*c))) unit += char(std::tolower(static_cast<unsigned char>(*c)));
  static const std::pair<const char*, double> units[] = {{"", 1},
                                                         {"b", 1},
                                                         {"k", 1e3},
                                                         {"kb", 1e3},
                                                         {"kib", 1024.0},
                                                         {"m", 1e6},
                                                         {"mb", 1e6},
                                                         {"mib", 1048576.0},
                                                         {"g", 1e9},
                                                         {"gb", 1e9},
                                                         {"gib", 1073741824.0},
                                                         {"t", 1e12},
                                                         {"tb", 1e12},
                                                         {"tib", 1099511627776.0}};
  for (const auto& [name, scale] : units)
    if (unit == name) {
      const double bytes = v * scale;
      if (bytes >= 18e18) bad();
      return uint64_t(bytes);
    }
  bad();
  return 0;
}

uint64_t view_memory_budget(std::optional<uint64_t> flag, std::string* source) {
  if (flag) {
    if (source) *source = "--memory-budget";
    return *flag;
  }
  if (const char* env = std::getenv(kViewMemoryBudgetEnv); env && *env) {
    if (source) *source = kViewMemoryBudgetEnv;
    return parse_byte_size(env, kViewMemoryBudgetEnv);
  }
  const uint64_t ram = physical_memory_bytes();
  if (ram == UINT64_MAX) {
    if (source) *source = "no budget (the system does not say its memory size)";
    return UINT64_MAX;
  }
  if (source) *source = "half of the machine's " + format_bytes(ram);
  return uint64_t(double(ram) * kViewMemoryFraction);
}

std::string over_budget_reason(const InCoreEstimate& need, uint64_t budget, const std::string& source) {
  return "the grid would take about " + format_bytes(need.bytes) + " in memory (" + need.basis +
         "), over the memory budget of " + format_bytes(budget) + " (" + source + ")";
}

void require_out_of_core_input(const std::vector<std::string>& inputs, const std::string& why,
                               const std::string& raise) {
  if (inputs.size() == 1 && fs::path(inputs[0]).extension() == ".vtu") return;
  fail_in(inputs.empty() ? std::string("input") : inputs[0],
          why +
              "; only a .vtu file is built out of core: convert it (`ugvr convert`) on a larger machine, or raise "
              "the budget with " +
              raise);
}

}  // namespace ugvr::view
