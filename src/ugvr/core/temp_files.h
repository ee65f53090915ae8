// Temporaries that are never left behind (issue 23): an interrupted `generate`, `convert` or out-of-core `build` used
// to leave "<out>.tmp-<pid>-<n>" files and "<out>.cells-<pid>/" folders of gigabytes, piling up with each PID.
//
//  - A registry of the live temporaries (files and folders), which a SIGINT / SIGTERM / SIGHUP handler removes with
//    async-signal-safe calls only (unlink, open, getdents64, unlinkat, rmdir) before re-raising the signal with its
//    default action, so the exit status still says "killed by SIGINT". Exceptions need nothing from it: the owners
//    (AtomicOutputFile, ScratchFolder) remove their temporaries in their destructors.
//  - SIGKILL cannot be caught: what it leaves is removed the next time the same output is written. A temporary's name
//    carries the PID of the process that made it, and one whose process is gone (kill(pid, 0) fails with ESRCH) is
//    stale (remove_stale_temporaries).
//  - A build's scratch folder has one predictable name, "<out>.cells", with the owner's PID in "<out>.cells/owner".
//
// The registry holds kMaxLiveTemporaries paths of up to kMaxTempPath bytes in static storage (no allocation in the
// handler); a temporary beyond either limit is not registered, and only the next run's stale cleanup removes it.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ugvr {

inline constexpr size_t kMaxLiveTemporaries = 64;
inline constexpr size_t kMaxTempPath = 1024;

// Installs the handler for SIGINT, SIGTERM and SIGHUP (once; later calls do nothing). A signal that was ignored when
// the process started (nohup, a background job of a non-interactive shell) stays ignored. The CLI calls it first
// thing; a library user may call it too (it replaces the default action of those signals only).
void install_temp_cleanup_on_signals();

// One registered temporary: removed by the signal handler while registered. The owner removes it itself on the
// normal path (commit or destructor) and then lets the registration go. Moving transfers the slot.
class TempRegistration {
 public:
  TempRegistration() = default;
  TempRegistration(const std::string& path, bool directory);
  ~TempRegistration() { release(); }
  TempRegistration(TempRegistration&& other) noexcept : slot_(other.slot_) { other.slot_ = -1; }
  TempRegistration& operator=(TempRegistration&& other) noexcept;
  TempRegistration(const TempRegistration&) = delete;
  TempRegistration& operator=(const TempRegistration&) = delete;

  // Unregisters (without removing anything).
  void release();
  bool registered() const { return slot_ >= 0; }

 private:
  int slot_ = -1;
};

// Whether a process with this id exists (kill(pid, 0) succeeds or fails with EPERM: another user's).
bool process_exists(pid_t pid);

// Temporaries of `output` left by processes that no longer exist, in output's directory: files
// "<output>.tmp-<pid>-<n>" (AtomicOutputFile), folders "<output>.cells-<pid>" (out-of-core builds before the scratch
// folder had one name). Each is removed and reported on stderr ("ugvr: removed ..., left by process P, which is no
// longer running"); those of live processes are left alone. Returns the paths removed. Never throws: a temporary that
// cannot be removed is reported and skipped.
std::vector<std::string> remove_stale_temporaries(const std::string& output);

// A build's scratch folder "<output>.cells": claimed for this process (its PID in "owner"), registered for the signal
// handler, and removed by the destructor. A folder left by a dead process is removed (and reported) first; one owned
// by a live process other than this one is refused with a ugvr::Error naming the folder and the process (two builds
// of one output at once would also race for the output itself).
class ScratchFolder {
 public:
  explicit ScratchFolder(const std::string& output);
  ~ScratchFolder();
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  TempRegistration registration_;
};

}  // namespace ugvr
