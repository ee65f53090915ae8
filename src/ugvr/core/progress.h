// Progress reporting for long work, on stderr: a redrawn bar when stderr is a terminal, a line every ~10% (at most one
// every 2 s) otherwise, nothing when disabled. Thread-safe: add() may be called from worker threads.
// An observer (set_observer) also sees every progress, at most ~10 times a second per Progress, whether or not output
// is enabled: `ugvr view` shows a background build's progress in the page.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace ugvr {

class Progress {
 public:
  // Globally silences all progress output (tests, --quiet).
  static void set_enabled(bool enabled);
  static bool enabled();
  // Called with (label, fraction done in [0, 1]) from whichever thread reports; must be cheap and thread-safe.
  using Observer = std::function<void(const std::string& label, double fraction)>;
  static void set_observer(Observer observer);  // empty: none

  Progress(std::string label, uint64_t total);
  // The same, also reporting to `observer` (this object's own, beside the process-wide one): a build run for one
  // caller (the viewer's background build, the public API's build_store) reports to that caller alone.
  Progress(std::string label, uint64_t total, Observer observer);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void add(uint64_t amount);
  void set(uint64_t done);
  void finish();

 private:
  void report(bool final);

  std::string label_;
  uint64_t total_;
  Observer own_observer_;
  std::atomic<uint64_t> done_{0};
  std::chrono::steady_clock::time_point start_, last_report_, last_observed_;
  int last_decile_ = -1;
  bool tty_;
  bool finished_ = false;
  std::mutex mutex_;
};

}  // namespace ugvr
