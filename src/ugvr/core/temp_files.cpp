#include "ugvr/core/temp_files.h"

#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/memory.h"

namespace ugvr {
namespace {

// A slot's life: Free -> Writing (a thread copies the path in) -> Live -> Free (the owner is done with it), or
// Live -> Cleaning (the signal handler took it; the process is about to die, nobody frees it).
enum SlotState : int { kFree = 0, kWriting = 1, kLive = 2, kCleaning = 3 };
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler reads the slots' states");

struct Slot {
  std::atomic<int> state{kFree};
  bool directory = false;
  char path[kMaxTempPath] = {};
};

Slot g_slots[kMaxLiveTemporaries];
// Set once a temporary could not be registered: from then on a name with this process's PID that is not in the
// registry may still be this process's own, so it is not taken for a stale one.
std::atomic<bool> g_overflowed{false};
std::atomic<bool> g_installed{false};

// The record getdents64 fills (linux/dirent.h, not exported by glibc's headers under this name).
struct LinuxDirent64 {
  uint64_t d_ino;
  int64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[1];
};

// Empties the open directory `fd`, recursing `depth` levels into sub-folders. Async-signal-safe: system calls only,
// no allocation. Entries are deleted while the directory is listed, which may skip some, so the listing restarts
// until a pass finds nothing (or gives up after a bounded number, the process being about to die).
void empty_directory(int fd, int depth) {
  alignas(8) char buf[2048];
  for (int pass = 0; pass < 64; ++pass) {
    if (::lseek(fd, 0, SEEK_SET) != 0) return;
    bool found = false;
    for (;;) {
      const long n = ::syscall(SYS_getdents64, fd, buf, sizeof buf);
      if (n <= 0) break;
      for (long at = 0; at < n;) {
        const auto* d = reinterpret_cast<const LinuxDirent64*>(buf + at);
        at += d->d_reclen;
        const char* name = d->d_name;
        if (name[0] == '.' && (name[1] == 0 || (name[1] == '.' && name[2] == 0))) continue;
        found = true;
        if (::unlinkat(fd, name, 0) == 0 || (errno != EISDIR && errno != EPERM) || depth <= 0) continue;
        const int sub = ::openat(fd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (sub >= 0) {
          empty_directory(sub, depth - 1);
          ::close(sub);
        }
        ::unlinkat(fd, name, AT_REMOVEDIR);
      }
    }
    if (!found) return;
  }
}

// Removes a registered temporary from the signal handler. A folder is emptied and removed, again while other threads
// (still running until the signal's default action ends the process) add files to it; once rmdir succeeds nothing
// can be created in it any more.
void remove_signal_safe(const Slot& s) {
  if (!s.directory) {
    ::unlink(s.path);
    return;
  }
  for (int tries = 0; tries < 16; ++tries) {
    const int fd = ::open(s.path, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return;
    empty_directory(fd, 4);
    ::close(fd);
    if (::rmdir(s.path) == 0 || errno != ENOTEMPTY) return;
  }
}

extern "C" void on_fatal_signal(int sig) {
  const int saved_errno = errno;
  for (Slot& s : g_slots) {
    int live = kLive;
    if (s.state.compare_exchange_strong(live, kCleaning)) remove_signal_safe(s);
  }
  // The default action, so that the process ends as killed by `sig` (exit status 128 + sig in a shell): the signal is
  // blocked while this handler runs and is delivered again as soon as it returns.
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  ::sigaction(sig, &dfl, nullptr);
  ::raise(sig);
  errno = saved_errno;
}

bool is_registered(const std::string& path) {
  for (const Slot& s : g_slots) {
    if (s.state.load(std::memory_order_acquire) == kLive && path == s.path) return true;
  }
  return false;
}

// A temporary with `pid` in its name is stale if that process is gone, or if it is this process's PID (reused after
// a killed run, common in containers) but not one of this process's registered temporaries.
bool stale_owner(pid_t pid, const std::string& path) {
  if (pid <= 0) return false;
  if (pid == ::getpid()) return !g_overflowed.load() && !is_registered(path);
  return !process_exists(pid);
}

// Parses the decimal digits of s from `at` up to `end_char` (or the end); false on anything else.
bool parse_pid(std::string_view s, size_t at, char end_char, pid_t& pid, size_t& next) {
  uint64_t v = 0;
  size_t i = at;
  while (i < s.size() && s[i] >= '0' && s[i] <= '9' && i - at < 10) v = v * 10 + uint64_t(s[i++] - '0');
  if (i == at || v > uint64_t(INT32_MAX)) return false;
  if (end_char ? (i >= s.size() || s[i] != end_char) : i != s.size()) return false;
  pid = pid_t(v);
  next = i + 1;
  return true;
}

uint64_t bytes_under(const std::filesystem::path& p) {
  std::error_code ec;
  if (!std::filesystem::is_directory(std::filesystem::symlink_status(p, ec))) {
    const auto n = std::filesystem::file_size(p, ec);
    return ec ? 0 : uint64_t(n);
  }
  uint64_t total = 0;
  for (auto it = std::filesystem::recursive_directory_iterator(p, ec); !ec && it != decltype(it)(); it.increment(ec)) {
    std::error_code e2;
    if (it->is_regular_file(e2)) total += uint64_t(it->file_size(e2));
  }
  return total;
}

// Removes a stale temporary and says so; false (also said) when it cannot be removed.
bool remove_stale(const std::filesystem::path& p, pid_t pid) {
  const uint64_t bytes = bytes_under(p);
  std::error_code ec;
  std::filesystem::remove_all(p, ec);
  if (ec) {
    std::fprintf(stderr, "ugvr: warning: cannot remove %s, left by process %d, which is no longer running: %s\n",
                 p.c_str(), int(pid), ec.message().c_str());
    return false;
  }
  // This process's own id: an earlier process had it (ids are reused, quickly in a container).
  std::fprintf(stderr, "ugvr: removed %s (%s), left by process %d, which is no longer running%s\n", p.c_str(),
               format_bytes(bytes).c_str(), int(pid), pid == ::getpid() ? " (an earlier process with this id)" : "");
  return true;
}

}  // namespace

void install_temp_cleanup_on_signals() {
  if (g_installed.exchange(true)) return;
  struct sigaction sa {};
  sa.sa_handler = on_fatal_signal;
  sigemptyset(&sa.sa_mask);
  // One handler at a time: a second signal waits until the first has cleaned up and re-raised.
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&sa.sa_mask, sig);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    ::sigaction(sig, &sa, nullptr);
  }
}

TempRegistration::TempRegistration(const std::string& path, bool directory) {
  if (path.size() >= kMaxTempPath) {
    g_overflowed = true;
    return;
  }
  for (size_t i = 0; i < kMaxLiveTemporaries; ++i) {
    Slot& s = g_slots[i];
    int free = kFree;
    if (!s.state.compare_exchange_strong(free, kWriting)) continue;
    std::memcpy(s.path, path.c_str(), path.size() + 1);
    s.directory = directory;
    s.state.store(kLive, std::memory_order_release);
    slot_ = int(i);
    return;
  }
  g_overflowed = true;
}

TempRegistration& TempRegistration::operator=(TempRegistration&& other) noexcept {
  if (this != &other) {
    release();
    slot_ = other.slot_;
    other.slot_ = -1;
  }
  return *this;
}

void TempRegistration::release() {
  if (slot_ < 0) return;
  int live = kLive;
  // Cleaning: the handler has it and the process is ending; the slot stays taken.
  g_slots[slot_].state.compare_exchange_strong(live, kFree);
  slot_ = -1;
}

bool process_exists(pid_t pid) { return pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM); }

std::vector<std::string> remove_stale_temporaries(const std::string& output) {
  std::vector<std::string> removed;
  std::string dir = dir_name(output);
  const std::string base = base_name(output);
  if (base.empty()) return removed;
  const std::string tmp_prefix = base + ".tmp-", cells_prefix = base + ".cells-";
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator(dir.empty() ? "." : dir, ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    pid_t pid = 0;
    size_t next = 0;
    if (name.starts_with(tmp_prefix)) {
      // "<base>.tmp-<pid>-<n>"
      pid_t n = 0;
      size_t end = 0;
      if (!parse_pid(name, tmp_prefix.size(), '-', pid, next) || !parse_pid(name, next, 0, n, end)) continue;
    } else if (name.starts_with(cells_prefix)) {
      // "<base>.cells-<pid>", the scratch folder's name before it was "<base>.cells"
      if (!parse_pid(name, cells_prefix.size(), 0, pid, next)) continue;
    } else {
      continue;
    }
    const std::string path = dir + name;
    if (stale_owner(pid, path) && remove_stale(it->path(), pid)) removed.push_back(path);
  }
  return removed;
}

ScratchFolder::ScratchFolder(const std::string& output) : path_(output + ".cells") {
  namespace fs = std::filesystem;
  remove_stale_temporaries(output);
  std::error_code ec;
  if (fs::exists(fs::symlink_status(path_, ec))) {
    pid_t owner = 0;
    {
      std::ifstream in(path_ + "/owner");
      long v = 0;
      if (in >> v && v > 0 && v <= INT32_MAX) owner = pid_t(v);
    }
    const bool ours = owner == ::getpid();
    if (owner > 0 && process_exists(owner) && (!ours || is_registered(path_))) {
      fail_in(path_, "scratch folder in use by process " + std::to_string(owner) +
                         ": another build of the same output is running (if that process is not ugvr, remove the "
                         "folder)");
    }
    const uint64_t bytes = bytes_under(path_);
    fs::remove_all(path_, ec);
    if (ec) fail_in(path_, "cannot remove the stale scratch folder: " + ec.message());
    std::fprintf(stderr, "ugvr: removed %s (%s), left by %s, which is no longer running\n", path_.c_str(),
                 format_bytes(bytes).c_str(),
                 owner > 0 ? ("process " + std::to_string(owner)).c_str() : "a build killed as it started");
  }
  // Registered before it exists, so that a signal from here on removes it.
  registration_ = TempRegistration(path_, true);
  if (!fs::create_directory(path_, ec) || ec) {
    fail_in(path_, "cannot create the scratch folder: " + (ec ? ec.message() : std::string("it exists")));
  }
  std::ofstream out(path_ + "/owner");
  out << ::getpid() << "\n";
  if (!out.flush()) {
    fs::remove_all(path_, ec);  // the destructor will not run
    fail_in(path_, "cannot write the scratch folder's owner file");
  }
}

ScratchFolder::~ScratchFolder() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
  registration_.release();
}

}  // namespace ugvr
