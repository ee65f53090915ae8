#include "ugvr/core/progress.h"

#include <unistd.h>

#include <cstdio>
#include <exception>
#include <memory>

namespace ugvr {

namespace {
std::atomic<bool> g_enabled{true};
std::mutex g_observer_mutex;
std::shared_ptr<const Progress::Observer> g_observer;  // read under the mutex, called outside it

std::shared_ptr<const Progress::Observer> observer() {
  std::lock_guard lock(g_observer_mutex);
  return g_observer;
}
}  // namespace

void Progress::set_observer(Observer o) {
  std::lock_guard lock(g_observer_mutex);
  g_observer = o ? std::make_shared<const Observer>(std::move(o)) : nullptr;
}

void Progress::set_enabled(bool enabled) { g_enabled = enabled; }
bool Progress::enabled() { return g_enabled; }

Progress::Progress(std::string label, uint64_t total)
    : label_(std::move(label)),
      total_(total),
      start_(std::chrono::steady_clock::now()),
      last_report_(start_),
      tty_(isatty(STDERR_FILENO) != 0) {}

Progress::Progress(std::string label, uint64_t total, Observer observer) : Progress(std::move(label), total) {
  own_observer_ = std::move(observer);
}

Progress::~Progress() {
  // Unwinding (a failed or cancelled step): the work did not finish, so no "100%".
  if (std::uncaught_exceptions() == 0) finish();
}

void Progress::add(uint64_t amount) {
  done_ += amount;
  report(false);
}

void Progress::set(uint64_t done) {
  done_ = done;
  report(false);
}

void Progress::finish() {
  if (finished_) return;
  done_ = total_;
  report(true);
  finished_ = true;
}

void Progress::report(bool final) {
  const auto now = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() && !final) return;  // another thread is reporting; skip rather than wait
  if (!lock.owns_lock()) lock.lock();
  const double fraction = total_ ? std::min(1.0, double(done_) / double(total_)) : 1.0;
  if (final || now - last_observed_ > std::chrono::milliseconds(100)) {
    if (const auto o = observer()) (*o)(label_, fraction);
    if (own_observer_) own_observer_(label_, fraction);
    last_observed_ = now;
  }
  if (!g_enabled) return;
  const double seconds = std::chrono::duration<double>(now - start_).count();
  const double since = std::chrono::duration<double>(now - last_report_).count();
  if (tty_) {
    if (!final && since < 0.1) return;
    constexpr int kWidth = 30;
    const int filled = int(fraction * kWidth);
    std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%% %6.1fs", label_.c_str(), filled,
                 "==============================", kWidth - filled, "", fraction * 100.0, seconds);
    if (final) std::fputc('\n', stderr);
  } else {
    const int decile = int(fraction * 10);
    if (!final && (decile == last_decile_ || since < 2.0)) return;
    if (final && seconds < 1.0) return;  // quick work stays silent in logs
    last_decile_ = decile;
    std::fprintf(stderr, "%s: %.0f%% (%.1fs)\n", label_.c_str(), fraction * 100.0, seconds);
  }
  std::fflush(stderr);
  last_report_ = now;
}

}  // namespace ugvr
