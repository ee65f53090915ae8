// Process memory figures for reports and benchmarks (Linux).
#pragma once

#include <cstdint>
#include <string>

namespace ugvr {

// Peak resident set size of this process so far (getrusage ru_maxrss).
uint64_t peak_rss_bytes();
// Current resident set size (/proc/self/statm).
uint64_t current_rss_bytes();
// The machine's physical memory (sysconf); UINT64_MAX when the system does not say. Readers check what they would
// hold against it before allocating.
uint64_t physical_memory_bytes();
// "12.3 MiB"
std::string format_bytes(uint64_t bytes);

}  // namespace ugvr
